"""One way to write a file or a folder so that a reader never sees it half-written.

Everything is written under a hidden temporary name beside the destination,
`.NAME.partial-PID-RANDOM`, and renamed into place only when complete (a rename within one file
system is atomic); a replaced destination is first renamed to `.NAME.old-PID`. On any error,
including an interrupt, the temporary is removed; if the process is killed (SIGKILL, power loss)
these names say what they are, no reader takes them for a result (readers list only the names
they expect, never dot-names), and the next writer into the same place removes the ones whose
process is no longer alive. Finished files get the usual mode (0666 minus the umask).
"""

from __future__ import annotations

import json
import os
import re
import secrets
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from .. import signals


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def temporary_name(path: Path, suffix: str = "") -> Path:
    """`.NAME.partial-PID-RANDOM<suffix>` beside path."""
    return path.with_name(f".{path.name}.partial-{os.getpid()}-{secrets.token_hex(4)}{suffix}")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def _remove(p: Path) -> None:
    try:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    except OSError:
        pass


def remove_leftovers(path: str | os.PathLike) -> list[Path]:
    """Remove what killed writers left beside path (`.NAME.partial-PID-*`, `.NAME.old-PID`)
    whose process is not alive. Returns what was removed."""
    path = Path(path)
    pattern = re.compile(re.escape(f".{path.name}.") + r"(?:partial-(\d+)-[0-9a-f]+.*|old-(\d+))")
    removed = []
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return removed
    for e in entries:
        m = pattern.fullmatch(e.name)
        if m is None:
            continue
        pid = int(m.group(1) or m.group(2))
        if not _alive(pid):
            _remove(Path(e.path))
            removed.append(Path(e.path))
    return removed


def _replace(tmp: Path, path: Path) -> None:
    """tmp becomes path; an existing path goes to .NAME.old-PID first and is then removed."""
    with signals.commit_lock():
        if tmp.is_dir() and os.path.lexists(path):  # a folder cannot replace in one rename
            old = path.with_name(f".{path.name}.old-{os.getpid()}")
            os.replace(path, old)
            os.replace(tmp, path)
            signals.unregister_temporary(tmp)
            _remove(old)
        else:
            os.replace(tmp, path)
            signals.unregister_temporary(tmp)


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a hidden temporary path next to `path`; rename it to `path` when the block succeeds.

    suffix: ending of the temporary name (some writers choose the format by it, e.g. ".mp4").
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    tmp = temporary_name(path, suffix)
    signals.register_temporary(tmp)
    try:
        os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
        yield tmp
        signals.checkpoint()  # an interrupted run replaces nothing
        os.chmod(tmp, 0o666 & ~_umask())
        _replace(tmp, path)
    except BaseException:
        _remove(tmp)
        signals.unregister_temporary(tmp)
        raise


@contextmanager
def atomic_dir(path: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Yield a hidden temporary folder next to `path`; it becomes `path` when the block succeeds.

    A file or a non-empty folder at `path` is replaced only with overwrite=True (else
    FileExistsError before any work).
    """
    path = Path(path)
    occupied = path.is_file() or (path.is_dir() and any(path.iterdir()))
    if occupied and not overwrite:
        raise FileExistsError(f"{path} exists and is not empty")
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    tmp = temporary_name(path)
    signals.register_temporary(tmp)
    try:
        tmp.mkdir(mode=0o700)
        yield tmp
        signals.checkpoint()  # an interrupted run replaces nothing
        os.chmod(tmp, 0o777 & ~_umask())
        _replace(tmp, path)
    except BaseException:
        _remove(tmp)
        signals.unregister_temporary(tmp)
        raise


def json_default(o: Any) -> Any:
    """json.dumps default= for numpy scalars and arrays and paths."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"cannot write {type(o).__name__} to JSON")


def write_json_atomic(data: Any, path: str | os.PathLike, indent: int | None = 1) -> Path:
    """JSON (numpy scalars and arrays allowed) written atomically. Returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=indent, default=json_default))
    return path


def write_text_atomic(text: str, path: str | os.PathLike) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return path
