"""result.json (DESIGN.md): written atomically, read back with its keys checked."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..types import PairLandscape, SyncResult


def _num(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def pair_to_dict(p: PairLandscape, with_landscape: bool = True) -> dict[str, Any]:
    d = p.decision
    out: dict[str, Any] = {
        "a": p.a, "b": p.b,
        "offset_s": _num(p.best_offset_s) if d.accepted or math.isfinite(p.best_offset_s) else None,
        "accepted": bool(d.accepted),
        "reason": d.reason,
        "uncertainty_s": _num(p.uncertainty_s),
        "best_energy": _num(p.best_energy),
        "contrast": d.contrast,
        "second_depth_ratio": d.second_depth_ratio,
        "num_minima": d.num_minima,
        "num_pareto_minima": d.num_pareto_minima,
        "at_range_edge": d.at_range_edge,
        "inlier_fraction": _num(d.inlier_fraction),
        "inlier_tau_px": _num(d.inlier_tau_px),
        "num_track_pairs": p.num_track_pairs,
        "residual": p.residual,
        "robust_scale": _num(p.robust_scale),
        "minima_offsets_s": [float(p.offsets_s[i]) for i in p.minima_idx],
        "minima_energy": [_num(float(p.energy[i])) for i in p.minima_idx],
    }
    if with_landscape:
        out["landscape"] = {
            "offsets_s": [float(x) for x in p.offsets_s],
            "energy": [_num(float(x)) for x in p.energy],
            "support": [int(x) for x in p.support],
        }
    return out


def result_to_dict(result: SyncResult, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {
        "format": "vs-inspect-result", "version": 1,
        "reference": result.reference,
        "offsets_s": {k: _num(v) if v is not None else None for k, v in result.offsets_s.items()},
        "uncertainty_s": {k: _num(v) if v is not None else None for k, v in result.uncertainty_s.items()},
        "unresolved": result.unresolved_reason,
        "pairs": [pair_to_dict(p) for p in result.pairs],
        "solve": {
            "solver": result.solver,
            "pairs": [list(p) for p in result.solve_pairs],
            "iterations": [{"residual_s": [float(r) for r in it.residual_s],
                            "weight": [float(w) for w in it.weight]} for it in result.iterations],
        },
        "timings_s": {k: round(v, 4) for k, v in result.timings_s.items()},
    }
    if extra:
        out.update(extra)
    return out


def write_json_atomic(data: dict[str, Any], path: str | os.PathLike) -> Path:
    """Write JSON to a temporary sibling, then rename: no half-written file is ever visible."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1, default=_default)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"cannot write {type(o).__name__} to JSON")


def read_result(path: str | os.PathLike) -> dict[str, Any]:
    path = Path(path)
    if path.is_dir():
        path = path / "result.json"
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: missing file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("offsets_s"), dict) or "reference" not in data:
        raise InputError(f"{path}: not a vs-inspect result (needs 'reference' and 'offsets_s')")
    return data
