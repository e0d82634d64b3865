"""The vs-inspect command line: glue only. Each subcommand lives in vs_inspect/commands/<name>.py
and registers itself with register(subparsers); this module lists them (COMMANDS), runs one, and
turns every failure into one clear line `vs-inspect COMMAND: error: ...` and an exit code, never
a traceback (-vv logs the traceback for debugging).

Exit codes: 0 done; 2 no result could be produced (bad input or option, an unreadable or
unwritable file, out of memory, another run writing the same output); 130 interrupted by Ctrl-C
(SIGINT); 143 terminated by SIGTERM. Both signals are only recorded when they arrive; the command
stops at its next safe point (vs_inspect.signals), every temporary output (io.atomic, the
recording's .partial, the SfM scratch folder) is removed, and one line says what was left.
"""

from __future__ import annotations

import argparse
import errno
import logging
import os
import signal
import sys
from contextlib import ExitStack

import numpy  # noqa: F401  (before anything that may import pycolmap; see ENVIRONMENT.md)

from . import __version__, signals
from .commands import (_help, bench, calib, calibrate_board, cues, demo, export, import_drone,
                       import_visualsync, inspect, report, sync, synth_cues, synth_video, view)
from .commands import eval as eval_command
from .errors import VsInspectError

log = logging.getLogger(__name__)

EXIT_FAILED = 2

# every command, in the order --help lists them
COMMANDS = (bench, calib, calibrate_board, cues, demo, eval_command, export, import_drone,
            import_visualsync, inspect, report, sync, synth_cues, synth_video, view)


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line too (`vs-inspect sync: error: argument --fps: ...`), exit 2."""

    def error(self, message: str):
        self.exit(EXIT_FAILED, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="vs-inspect",
        description="Synchronize videos of one dynamic scene from cameras that were never "
                    "synchronized, by the epipolar cue (VisualSync), and show why.",
        epilog="Run 'vs-inspect COMMAND --help' for the options of a command. Exit codes: 0 done, "
               "2 no result (bad input, an unreadable or unwritable file, another run writing the "
               "same output), 130 Ctrl-C, 143 SIGTERM (temporary outputs are removed in both "
               "cases; the command stops within VS_INSPECT_STOP_GRACE_S seconds, default 10).")
    parser.add_argument("--version", action="version", version=f"vs-inspect {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-v info, -vv debug, with tracebacks of errors)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        command.register(sub)
    for name, p in sub.choices.items():  # one --help style: defaults once, an Examples epilog
        _help.apply(p, name)
    return parser


def one_line(text: str) -> str:
    """Messages are one line: a newline in a file name or in a value cannot forge output lines."""
    return " ".join(str(text).split()) if ("\n" in str(text) or "\r" in str(text)) else str(text)


def describe_os_error(exc: OSError, fallback: object = None) -> str:
    """'<file>: <what went wrong>' for an OSError (the file from the error, else `fallback`)."""
    what = exc.strerror or exc.__class__.__name__
    if exc.errno == errno.ENOSPC:
        what = "no space left on device"
    elif exc.errno == errno.EROFS:
        what = "read-only file system"
    elif exc.errno == errno.ENOTDIR:
        what = "a part of this path is a file, not a folder"
    elif exc.errno == errno.EISDIR:
        what = "is a folder, expected a file"
    elif isinstance(exc, FileExistsError) and exc.filename is None:
        return str(exc)
    name = exc.filename if exc.filename is not None else fallback
    if name is None:
        return f"{what} ({exc})" if str(exc) != what else what
    return f"{os.fsdecode(name)}: {what}"


def _message(exc: BaseException, args: argparse.Namespace) -> str:
    out = getattr(args, "out", None)
    if isinstance(exc, VsInspectError):
        return str(exc)
    if isinstance(exc, OSError):
        return describe_os_error(exc, out)
    if isinstance(exc, MemoryError):
        return ("out of memory" + (f" ({exc})" if str(exc) else "") +
                ": the input or an option asks for more than this machine has")
    if isinstance(exc, RecursionError):
        return "input nested too deeply (recursion limit)"
    if isinstance(exc, ValueError):
        return str(exc)
    # a malformed input that no reader check caught: one line anyway (details with -vv)
    return f"unexpected input or internal error ({type(exc).__name__}: {exc})"


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns its exit code. Installs the signal handlers for the command's
    duration when vs_inspect._entry has not (a call from Python)."""
    previous = signals.install()
    try:
        return _main(argv)
    finally:
        signals.restore(previous)


def _main(argv: list[str] | None) -> int:
    args = None
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help, --version, or a usage error (one line, see _Parser)
            return exc.code if isinstance(exc.code, int) else EXIT_FAILED
        signals.set_command(f"vs-inspect {args.command}" if args.command else "vs-inspect")
        if args.verbose < 2:  # rerun's writer reports I/O errors on stderr too; ours is the one line
            os.environ.setdefault("RUST_LOG", "off")
        logging.basicConfig(level=[logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)],
                            format="%(levelname)s %(name)s: %(message)s")
        if not getattr(args, "func", None):
            parser.print_help()
            return EXIT_FAILED
        signals.checkpoint()
        from .io.lock import command_outputs, lock_outputs
        with ExitStack() as stack:  # one run at a time into each output the command names
            lock_outputs(stack, *command_outputs(args))
            return int(args.func(args) or 0)
    except KeyboardInterrupt as exc:  # a recorded signal (signals.Interrupted), or Ctrl-C itself
        return _stopped(getattr(exc, "signum", None) or signals.requested() or signal.SIGINT)
    except Exception as exc:  # the promise: one line, never a traceback
        if signals.requested() is not None:  # an error caused by stopping: the stop is the news
            log.debug("error while stopping", exc_info=True)
            return _stopped(signals.requested())
        log.debug("traceback of the error below", exc_info=True)
        code = exc.exit_code if isinstance(exc, VsInspectError) else EXIT_FAILED
        name = getattr(args, "command", None)
        print(f"vs-inspect{' ' + name if name else ''}: error: {one_line(_message(exc, args))}",
              file=sys.stderr)
        return code


def _stopped(signum: int) -> int:
    signals.remove_temporaries()  # what no context manager removed (normally nothing)
    signals.announce(signum)
    return 128 + signum  # 130 for SIGINT, 143 for SIGTERM

