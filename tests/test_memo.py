"""vs_inspect/memo.py: results kept under a digest of their inputs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vs_inspect.memo import NO_MEMO, Memo, digest


@dataclasses.dataclass(frozen=True)
class _Rec:
    a: np.ndarray
    b: str


def test_the_digest_follows_every_value_and_nothing_else():
    x = np.arange(6.0).reshape(2, 3)
    assert digest(x, {"k": 1, "j": (2, 3)}) == digest(x.copy(), {"j": (2, 3), "k": 1})  # dict order aside
    assert digest(x) != digest(x.reshape(3, 2)) != digest(x.astype(np.float32))  # shape and dtype count
    y = x.copy()
    y[1, 2] += 1e-12
    assert digest(x) != digest(y)
    assert digest(_Rec(x, "s")) == digest(_Rec(x.copy(), "s")) != digest(_Rec(x, "t"))
    assert digest(frozenset({"a", "b"})) == digest(frozenset({"b", "a"}))


@dataclasses.dataclass(frozen=True)
class _Settings:
    n: int = 3
    name: str = "x"


@dataclasses.dataclass(frozen=True)
class _Later:  # the same settings with one more field, as a later version would have them
    n: int = 3
    name: str = "x"
    added: float = 0.5


_Later.__name__ = _Settings.__name__


def test_settings_count_by_what_differs_from_their_defaults():
    """A settings record (every field defaulted) digests by the fields that differ from their
    defaults: a setting added (or removed) at its default keeps the keys; a changed one does not."""
    assert digest(_Settings()) == digest(_Settings(n=3)) == digest(_Later())
    assert digest(_Settings(n=4)) == digest(_Later(n=4)) != digest(_Settings())
    assert digest(_Later(added=0.7)) != digest(_Later())


def test_a_kept_value_is_computed_once(tmp_path):
    calls = []

    def f(v):
        calls.append(v)
        return {"v": np.full(3, v)}

    memo = Memo(tmp_path)
    first = memo.call("f", f, 2.0)
    again = memo.call("f", f, 2.0)
    other = Memo(tmp_path).call("f", f, 3.0)  # another process, another argument
    assert calls == [2.0, 3.0] and np.array_equal(first["v"], again["v"]) and other["v"][0] == 3.0
    assert memo.hits == 1 and memo.misses == 1
    assert not list(tmp_path.glob(".partial-*"))  # written whole or not at all
    NO_MEMO.call("f", f, 2.0)
    assert calls == [2.0, 3.0, 2.0] and NO_MEMO.folder is None  # nothing kept


def test_a_value_kept_by_another_version_is_computed_again(tmp_path):
    """A kept value naming a class this version no longer has (renamed or moved) is not an error:
    it is computed again and kept in its place."""
    import pickle
    import sys
    import types

    gone = types.ModuleType("vs_inspect_moved_away")
    gone.Gone = type("Gone", (), {"__module__": gone.__name__})
    sys.modules[gone.__name__] = gone
    try:
        (tmp_path / "k.pkl").write_bytes(pickle.dumps(gone.Gone()))
    finally:
        del sys.modules[gone.__name__]
    with pytest.raises(ImportError):
        pickle.loads((tmp_path / "k.pkl").read_bytes())
    memo = Memo(tmp_path)
    assert memo.get("k", lambda: 7) == 7 and memo.misses == 1
    assert Memo(tmp_path).get("k", lambda: 8) == 7  # kept in its place
