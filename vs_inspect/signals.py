"""Ctrl-C (SIGINT) and SIGTERM end every command cleanly, whatever it is doing.

The handlers only record the signal. The main thread stops at the next safe point: checkpoint(),
called between frames, figures, files, pairs and stages and before and after native calls that
cannot be interrupted (pycolmap, PyAV, VTK, numba, torch), raises Interrupted there; the context
managers of io.atomic, io.lock, the recording and the SfM scratch folder remove what they had
started, and the CLI prints one line and exits 130 (SIGINT) or 143 (SIGTERM). An exception raised
by the handler itself would land anywhere: inside VTK's off-screen rendering, numba's thread pool
or an import, where the process can crash instead of stopping.

A watchdog thread wakes on the signal (the interpreter writes the signal's number to a pipe even
while the main thread is inside a native call) and, if the command has not stopped within
VS_INSPECT_STOP_GRACE_S seconds (default 10), removes the registered temporaries and ends the
process with the same line and exit code. A second signal ends it at once the same way.

pycolmap's glog installs its own SIGTERM handler when it is imported (it prints a stack trace and
kills the process, skipping every cleanup); import_pycolmap() puts ours back.

This module imports only the standard library: vs_inspect._entry installs the handlers before any
heavy import, so that a signal during `import torch` ends the command as cleanly as later.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
import threading
import time

GRACE_ENV = "VS_INSPECT_STOP_GRACE_S"
DEFAULT_GRACE_S = 10.0
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A recorded SIGINT or SIGTERM, raised by checkpoint() where it is safe to stop.

    A KeyboardInterrupt, so that every `except Exception` lets it through and every cleanup that
    handles Ctrl-C handles it."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal_name(signum))
        self.signum = int(signum)

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


class Terminated(Interrupted):
    """SIGTERM (a job scheduler, `kill`): exit 143."""

    def __init__(self, signum: int = signal.SIGTERM):
        super().__init__(signum)


def signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


class _State:
    def __init__(self) -> None:
        self.signum: int | None = None  # the first signal received
        self.count = 0  # signals seen by the watchdog
        self.installed = False
        self.command = "vs-inspect"
        self.outputs: list[tuple[str, bool]] = []  # (path, existed before the command)
        self.temporaries: dict[str, None] = {}  # paths to remove if the watchdog ends the process
        self.made_dirs: dict[str, None] = {}  # folders made for outputs: removed then if empty
        self.lock = threading.Lock()  # guards temporaries, outputs, announced
        self.commit = threading.RLock()  # held while a finished output is renamed into place
        self.announced = False
        self.finished = threading.Event()  # set when the command has returned
        self.wake_r = -1
        self.wake_w = -1
        self.generation = 0  # counts install(): a deadline of an earlier command is void
        self.committing = False  # the command is writing its finished outputs: checkpoints pass


_S = _State()


def _record(signum, frame) -> None:
    """The Python-level handler: record the first signal, nothing else."""
    if _S.signum is None:
        _S.signum = int(signum)


def install(command: str | None = None) -> tuple | None:
    """Record SIGINT and SIGTERM instead of raising, and start the watchdog (main thread only;
    elsewhere nothing happens, since Python sets handlers only there).

    Returns what restore() needs to put the previous handlers back, or None when the handlers
    were installed already (by vs_inspect._entry: a signal recorded since is kept)."""
    if command:
        _S.command = command
    if _S.installed or threading.current_thread() is not threading.main_thread():
        return None
    _S.signum, _S.count, _S.announced, _S.committing = None, 0, False, False
    _S.generation += 1
    _S.finished.clear()
    with _S.lock:
        _S.outputs.clear()
        _S.temporaries.clear()
        _S.made_dirs.clear()
    if _S.wake_r < 0:
        r, w = os.pipe()
        os.set_blocking(w, False)
        _S.wake_r, _S.wake_w = r, w
        threading.Thread(target=_watchdog, name="vs-inspect-stop", daemon=True).start()
    previous = tuple(signal.signal(s, _record) for s in SIGNALS)
    old_fd = signal.set_wakeup_fd(_S.wake_w, warn_on_full_buffer=False)
    _S.installed = True
    return previous, old_fd


def restore(previous: tuple | None) -> None:
    """Put back what install() replaced (nothing if it returned None)."""
    if previous is None or threading.current_thread() is not threading.main_thread():
        return
    handlers, old_fd = previous
    _S.finished.set()
    for s, h in zip(SIGNALS, handlers):
        signal.signal(s, h if h is not None else signal.SIG_DFL)
    signal.set_wakeup_fd(old_fd)
    _S.installed = False
    _S.signum = None  # the command that received it has returned: later calls are not stopped


def in_forked_worker() -> None:
    """In a forked worker process: SIGINT ignored (Ctrl-C reaches the whole process group; the
    parent stops the pool), SIGTERM's default action (the pool ends its workers with it), and no
    wake-up pipe shared with the parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        signal.set_wakeup_fd(-1)
    except ValueError:  # not the main thread of the worker
        pass


def requested() -> int | None:
    """The signal received so far (None: none)."""
    return _S.signum


def checkpoint() -> None:
    """Raise Interrupted (Terminated for SIGTERM) if a signal was received: call it where stopping
    is safe. Costs one attribute read otherwise. Passes once begin_commit() was called."""
    s = _S.signum
    if s is not None and not _S.committing:
        raise Terminated(s) if s == signal.SIGTERM else Interrupted(s)


def begin_commit() -> None:
    """The command's work is done and it now writes its finished outputs one after another (a
    recording, then result.json): a signal from here on no longer stops it halfway, which would
    leave some outputs new and others missing; it finishes (within the grace period) and the one
    line says the outputs are complete."""
    _S.committing = True


def set_command(command: str) -> None:
    """The name in the one line (`vs-inspect sync: interrupted by SIGINT; ...`)."""
    _S.command = command


def register_output(path: str | os.PathLike) -> None:
    """An output the command writes (its --out folder, its recording): named in the one line."""
    p = os.fspath(path)
    with _S.lock:
        if all(q != p for q, _ in _S.outputs):
            _S.outputs.append((p, os.path.lexists(p)))


def register_temporary(path: str | os.PathLike) -> None:
    with _S.lock:
        _S.temporaries[os.fspath(path)] = None


def unregister_temporary(path: str | os.PathLike) -> None:
    with _S.lock:
        _S.temporaries.pop(os.fspath(path), None)


def register_made_dir(path: str | os.PathLike, made: bool = True) -> None:
    """A folder made for an output (made=False: no longer to be removed): if the watchdog ends
    the process, it is removed when empty, as the output's context manager would."""
    with _S.lock:
        if made:
            _S.made_dirs[os.fspath(path)] = None
        else:
            _S.made_dirs.pop(os.fspath(path), None)


def commit_lock() -> threading.RLock:
    """Held while a finished output replaces the old one (two renames): the watchdog waits for it,
    so that it never ends the process between them."""
    return _S.commit


def stop_line(signum: int, finished: bool = False) -> str:
    """The one line: what stopped the command and what it leaves."""
    with _S.lock:
        outputs = list(_S.outputs)
    head = f"{_S.command}: interrupted by {signal_name(signum)}"
    if finished:
        return head + " after it had finished" + (
            f"; {', '.join(p for p, _ in outputs)} complete" if outputs else "")
    if not outputs:
        return head + "; temporary files removed"
    kept = [p for p, existed in outputs if existed]
    new = [p for p, existed in outputs if not existed]
    parts = ([f"nothing written to {', '.join(new)}"] if new else []) + \
            ([f"{', '.join(kept)} left as before"] if kept else [])
    return head + "; " + "; ".join(parts)


def announce(signum: int, finished: bool = False) -> bool:
    """Print the one line on stderr, once per process (False: it was already printed)."""
    with _S.lock:
        if _S.announced:
            return False
        _S.announced = True
    try:
        sys.stderr.write(stop_line(signum, finished) + "\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    return True


def mark_finished() -> None:
    """The command has returned: the watchdog no longer ends the process."""
    _S.finished.set()


def grace_s() -> float:
    try:
        g = float(os.environ.get(GRACE_ENV, DEFAULT_GRACE_S))
    except ValueError:
        return DEFAULT_GRACE_S
    return g if g >= 0 else DEFAULT_GRACE_S


def remove_temporaries() -> None:
    with _S.lock:
        paths = list(_S.temporaries)
        _S.temporaries.clear()
    for p in paths:
        try:
            if os.path.isdir(p) and not os.path.islink(p):
                shutil.rmtree(p, ignore_errors=True)
            else:
                os.unlink(p)
        except OSError:
            pass
    with _S.lock:
        dirs = sorted(_S.made_dirs, key=len, reverse=True)  # the deepest first
        _S.made_dirs.clear()
    for d in dirs:
        try:
            os.rmdir(d)
        except OSError:
            pass


def flush_output() -> None:
    """Flush stdout and stderr (what the command printed reaches its file or pipe now)."""
    for f in (sys.stdout, sys.stderr):
        try:
            f.flush()
        except (OSError, ValueError):
            pass


def hard_exit(code: int) -> None:
    """Flush stdout and stderr and end the process now (os._exit): interpreter shutdown with
    VTK/EGL, numba or rerun threads alive is where the crashes come from."""
    flush_output()
    os._exit(code)


def _watchdog() -> None:
    deadline = None
    generation = _S.generation
    while True:
        if generation != _S.generation:  # a new command (a call from Python): start afresh
            deadline, generation = None, _S.generation
        timeout = None if deadline is None else max(0.0, deadline - time.monotonic())
        got = _wait_readable(_S.wake_r, timeout)
        if got:
            try:
                data = os.read(_S.wake_r, 64)
            except OSError:
                data = b""
            for b in data:
                if b not in SIGNALS:
                    continue
                if _S.signum is None:  # the main thread is inside native code: record it here
                    _S.signum = int(b)
                _S.count += 1
            if _S.signum is not None and _S.count >= 1 and deadline is None:
                deadline = time.monotonic() + grace_s()
            if _S.count >= 2 and not _S.finished.is_set():
                _stop_now()
        elif deadline is not None and time.monotonic() >= deadline:
            if not _S.finished.is_set():
                _stop_now()
            deadline = None


def _wait_readable(fd: int, timeout: float | None) -> bool:
    import select
    try:
        r, _, _ = select.select([fd], [], [], timeout)
    except (OSError, ValueError):
        time.sleep(timeout or 0.1)
        return False
    return bool(r)


def _stop_now() -> None:
    """The command did not stop in time (or a second signal came): clean up and end here."""
    signum = _S.signum or signal.SIGINT
    # never between the two renames of a replacement; give up waiting after a few seconds
    _S.commit.acquire(timeout=5.0)  # held until the process ends
    try:
        remove_temporaries()
        announce(signum)
    finally:
        hard_exit(128 + signum)


def import_pycolmap():
    """`import pycolmap` that keeps our SIGTERM handler (glog replaces it at import)."""
    import numpy  # noqa: F401  (before pycolmap: see ENVIRONMENT.md)

    checkpoint()
    main = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGTERM) if main else None
    import pycolmap

    if main and handler is not None:
        signal.signal(signal.SIGTERM, handler)  # the C-level handler is glog's now: put Python's back
    checkpoint()
    return pycolmap
