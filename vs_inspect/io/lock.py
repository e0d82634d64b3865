"""One run at a time into one place: a lock beside every output a command writes.

A run takes `.NAME.lock` beside its --out folder (and beside its recording, its mosaic, ...): an
open file holding the run's pid, start time and command line, locked with flock. A second run into
the same place while the first is alive refuses at once, naming the first; the kernel releases the
lock when its process ends in any way (SIGKILL and power loss included), so a lock left by a dead
process is simply taken over. The file is removed when the run ends.
"""

from __future__ import annotations

import fcntl
import json
import os
import shlex
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

from .. import signals
from ..errors import InputError, OutputBusy


_HELD: set[str] = set()  # lock files this process holds


def lock_path(path: str | os.PathLike) -> Path:
    """`.NAME.lock` beside path."""
    path = Path(os.path.abspath(path))
    return path.with_name(f".{path.name}.lock")


def _holder(fd: int) -> str:
    """'pid 123, started 2026-12-02 10:03:01 UTC: vs-inspect sync ...' from a lock file."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        info = json.loads(os.read(fd, 65536).decode("utf-8", "replace") or "{}")
    except (OSError, ValueError):
        info = {}
    if not isinstance(info, dict) or "pid" not in info:
        return "another run (just starting)"
    text = f"pid {info.get('pid')}"
    if info.get("started"):
        text += f", started {info['started']}"
    if info.get("command"):
        text += f": {info['command']}"
    return text


@contextmanager
def output_lock(path: str | os.PathLike, option: str = "--out") -> Iterator[Path]:
    """Hold the lock of `path` for the block; OutputBusy (exit 2) if another live run holds it.

    The folders leading to path are made if needed (and removed again if the block leaves them
    empty). path is also named in the line printed if the command is interrupted."""
    target = Path(path)
    lp = lock_path(target)
    key = os.fspath(lp)
    if key in _HELD:  # this process holds it already (an outer block): nothing more to do
        yield lp
        return
    made = []
    for parent in reversed(lp.parents):
        if not parent.exists():
            made.append(parent)
        elif not parent.is_dir():
            raise InputError(f"{option} {target}: {parent} is a file, not a folder")
    for d in made:
        signals.register_made_dir(d)
    try:
        lp.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # named by the output, as the write would have been
        raise OSError(exc.errno, exc.strerror, os.fspath(target)) from None
    try:
        while True:
            try:
                fd = os.open(lp, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:  # a read-only or unwritable folder: named by the output
                raise OSError(exc.errno, exc.strerror, os.fspath(target)) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                who = _holder(fd)
                os.close(fd)
                raise OutputBusy(f"{option} {target} is being written by another run ({who}); "
                                 "wait for it to finish or choose another place") from None
            # the previous holder may have removed the file between our open and our lock
            try:
                same = os.stat(lp).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        try:
            started = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
            info = {"pid": os.getpid(), "started": started,
                    "command": " ".join(shlex.quote(a) for a in ["vs-inspect", *sys.argv[1:]])}
            os.ftruncate(fd, 0)
            os.write(fd, json.dumps(info).encode())
            signals.register_output(target)
            signals.register_temporary(lp)  # removed too if the process is ended from the watchdog
            _HELD.add(key)
            yield lp
        finally:
            _HELD.discard(key)
            signals.unregister_temporary(lp)
            try:
                os.unlink(lp)  # while still holding the lock: see the inode check above
            except OSError:
                pass
            os.close(fd)
    finally:
        for d in reversed(made):  # the deepest first
            signals.register_made_dir(d, made=False)
            try:
                d.rmdir()
            except OSError:
                pass


def lock_outputs(stack: ExitStack, *outputs: tuple[str | os.PathLike | None, str]) -> None:
    """Lock every (path, option) given (None paths are skipped) on stack, in a fixed order."""
    seen = set()
    for path, option in outputs:
        if path is None:
            continue
        key = os.path.abspath(path)
        if key in seen:
            continue
        seen.add(key)
        stack.enter_context(output_lock(path, option))


# the options that name what a command writes, locked for every command (export's positional
# `out` is its input run folder, not an output)
OUTPUT_OPTIONS = {"out": "--out", "mosaic": "--mosaic", "json": "--json", "jsonl": "--jsonl",
                  "workdir": "--workdir"}
INPUT_OUT = frozenset({"export"})


def command_outputs(args) -> list[tuple[Path, str]]:
    """(path, option) of every output a parsed command line names."""
    out = []
    for attr, option in OUTPUT_OPTIONS.items():
        if attr == "out" and getattr(args, "command", None) in INPUT_OUT:
            continue
        value = getattr(args, attr, None)
        if isinstance(value, (str, os.PathLike)):
            out.append((Path(value), option))
    return out
