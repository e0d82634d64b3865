"""SIGTERM takes Ctrl-C's cleanup path: a handler raises Terminated (a KeyboardInterrupt), so the
context managers of io.atomic, the recording and the SfM scratch folder remove their temporaries.

pycolmap's glog installs its own SIGTERM handler when it is imported (it prints a stack trace and
kills the process, skipping every cleanup); import_pycolmap() puts ours back.
"""

from __future__ import annotations

import signal
import threading


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is, so that cleanup runs as for Ctrl-C."""


def _raise_terminated(signum, frame) -> None:
    raise Terminated()


def install() -> object | None:
    """Handle SIGTERM by raising Terminated; returns the previous handler (None off the main
    thread, where Python cannot set handlers)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


def restore(previous) -> None:
    if previous is not None and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, previous)


def import_pycolmap():
    """`import pycolmap` that keeps Python's SIGTERM handler (glog replaces it at import)."""
    import numpy  # noqa: F401  (before pycolmap: see ENVIRONMENT.md)

    main = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGTERM) if main else None
    import pycolmap

    if main and handler is not None:
        signal.signal(signal.SIGTERM, handler)  # the C-level handler is glog's now: put Python's back
    return pycolmap
