"""Shape checks at geometry's public functions: a ValueError that names the shape received."""

from __future__ import annotations

import numpy as np


def _fmt(trailing: tuple, batched: bool) -> str:
    dims = ",".join("N" if d is None else str(d) for d in trailing)
    if batched:
        return f"(...,{dims})" if dims else "(...)"
    return f"({dims},)" if len(trailing) == 1 else f"({dims})"


def check_shape(name: str, x: np.ndarray, trailing: tuple, batched: bool = True) -> np.ndarray:
    """x itself after checking that its last dims are `trailing` (None: any size).

    batched=False: x must have exactly these dims (no leading batch dims).
    """
    shape = np.shape(x)
    n = len(trailing)
    ok = len(shape) >= n if batched else len(shape) == n
    if ok and n:
        ok = all(t is None or s == t for s, t in zip(shape[len(shape) - n:], trailing))
    if not ok:
        raise ValueError(f"{name} must be {_fmt(trailing, batched)}, got {tuple(shape)}")
    return x
