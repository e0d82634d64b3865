"""`python -m vs_inspect ARGS`: the same as the vs-inspect command."""

from ._entry import main

main()
