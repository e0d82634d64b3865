"""One module per command; each defines register(subparsers) and sets args.func. cli.COMMANDS
lists them; `bench` lists its sub-benchmarks the same way (commands/bench.py)."""
