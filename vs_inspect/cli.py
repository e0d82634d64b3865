"""The vs-inspect command line: glue only. Each subcommand lives in vs_inspect/commands/<name>.py
and registers itself with register(subparsers); this module finds them, runs one, and turns
input errors into one clear message and an exit code (2 = no result could be produced).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys

import numpy  # noqa: F401  (before anything that may import pycolmap; see ENVIRONMENT.md)

from . import __version__, commands
from .errors import VsInspectError


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vs-inspect",
        description="Synchronize videos of one dynamic scene from cameras that were never "
                    "synchronized, by the epipolar cue (VisualSync), and show why.",
        epilog="Run 'vs-inspect COMMAND --help' for the options of a command.")
    parser.add_argument("--version", action="version", version=f"vs-inspect {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-v info, -vv debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=[logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)],
                        format="%(levelname)s %(name)s: %(message)s")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except VsInspectError as exc:
        print(f"vs-inspect {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except (ValueError, FileExistsError) as exc:
        print(f"vs-inspect {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
