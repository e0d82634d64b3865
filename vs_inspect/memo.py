"""Results of a run's expensive steps kept on disk under a digest of their inputs, so that a second
run that differs only in its decisions (e.g. a benchmark turning one acceptance rule off) computes
each video's cues, camera models, votes and landscapes once. A run without a folder keeps nothing
(NO_MEMO); results depend only on their inputs either way.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import pickle
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

T = TypeVar("T")
log = logging.getLogger(__name__)


def digest(*parts: Any) -> str:
    """A hex digest of parts: numbers, strings, arrays (shape, dtype and bytes), dataclasses (their
    fields), and tuples, lists and dicts of those."""
    h = hashlib.sha1()

    def feed(x: Any) -> None:
        if isinstance(x, np.ndarray):
            h.update(f"a{x.dtype}{x.shape}".encode())
            h.update(np.ascontiguousarray(x).tobytes())
        elif dataclasses.is_dataclass(x) and not isinstance(x, type):
            h.update(type(x).__name__.encode())
            # a settings record (every field has a default) counts by what differs from its
            # defaults, so that settings added, renamed or removed at their defaults keep the keys
            default = _defaults(type(x))
            for f in dataclasses.fields(x):
                v = getattr(x, f.name)
                if default is not None and _same(v, getattr(default, f.name)):
                    continue
                h.update(f.name.encode())
                feed(v)
        elif isinstance(x, dict):
            h.update(b"{")
            for k in sorted(x, key=repr):
                feed(k)
                feed(x[k])
            h.update(b"}")
        elif isinstance(x, (list, tuple, frozenset, set)):
            h.update(b"(")
            for v in (sorted(x, key=repr) if isinstance(x, (set, frozenset)) else x):
                feed(v)
            h.update(b")")
        else:
            h.update(repr(x).encode())

    for p in parts:
        feed(p)
    return h.hexdigest()


def _defaults(cls: type):
    """cls() when every field of the dataclass has a default, else None."""
    if all(f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
           for f in dataclasses.fields(cls)):
        return cls()
    return None


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b) and type(a) is type(b)
    except ValueError:  # arrays
        return False


class Memo:
    """get(key, compute): the value kept under key, else compute()'s, kept for next time (folder
    None: nothing is kept)."""

    def __init__(self, folder: str | os.PathLike | None):
        self.folder = None if folder is None else Path(folder)
        self.hits = self.misses = 0

    def get(self, key: str, compute: Callable[[], T]) -> T:
        if self.folder is None:
            return compute()
        path = self.folder / f"{key}.pkl"
        if path.exists():
            try:
                with path.open("rb") as f:
                    value = pickle.load(f)
                self.hits += 1
                return value
            except (pickle.UnpicklingError, EOFError, AttributeError, ImportError) as exc:
                # kept by another version of the package (a record since renamed or moved): computed again
                log.info("%s could not be read (%s): computed again", path, exc)
        self.misses += 1
        value = compute()
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".partial-")
        with os.fdopen(fd, "wb") as f:
            pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
        return value

    def call(self, name: str, fn: Callable[..., T], *args, **kwargs) -> T:
        """fn(*args, **kwargs), kept under name and a digest of the arguments."""
        if self.folder is None:
            return fn(*args, **kwargs)
        return self.get(f"{name}-{digest(args, kwargs)}", lambda: fn(*args, **kwargs))

    def has(self, key: str) -> bool:
        return self.folder is not None and (self.folder / f"{key}.pkl").exists()


NO_MEMO = Memo(None)
