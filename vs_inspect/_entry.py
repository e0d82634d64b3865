"""The `vs-inspect` console script: signal handling first, then the command line.

Nothing but the standard library is imported before vs_inspect.signals has installed its handlers
(the package's __init__ imports nothing), so Ctrl-C or SIGTERM at any moment, even during
`import torch`, ends the command with one line. The process ends with os._exit after flushing its output: interpreter shutdown with
VTK/EGL, numba or rerun threads alive is where crashes at exit come from.
"""

from __future__ import annotations

import signal
import sys


def main(argv: list[str] | None = None) -> None:
    from . import signals  # the standard library only

    args = sys.argv[1:] if argv is None else argv
    command = next((a for a in args if not a.startswith("-")), None)
    signals.install(f"vs-inspect {command}" if command else None)  # named in the line from the start
    code = 1
    try:
        from .cli import main as run_command
        from .progress import plain_lines_when_logged

        with plain_lines_when_logged():  # in a log: progress as plain lines, no carriage returns
            code = run_command(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except KeyboardInterrupt as exc:  # interrupted before the command started (an import)
        signum = getattr(exc, "signum", signals.requested() or signal.SIGINT)
        signals.remove_temporaries()
        signals.announce(signum)
        code = 128 + signum
    finally:
        signals.mark_finished()
    try:
        import logging
        logging.shutdown()
    except Exception:  # noqa: BLE001 - exiting anyway
        pass
    signals.flush_output()
    # the last check, after everything printed has been flushed: a signal recorded by now gets its
    # line (what the command wrote is complete); one that comes later finds the command ended
    signum = signals.requested()
    if signum is not None and code not in (128 + signal.SIGINT, 128 + signal.SIGTERM):
        signals.announce(signum, finished=True)
        code = 128 + signum
    signals.hard_exit(code)


if __name__ == "__main__":
    main(sys.argv[1:])
