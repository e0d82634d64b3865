"""Clock drift on the cue-level synthetic scenes: every non-reference video's clock
runs ± drift_ppm off, and `sync --drift` is compared with the constant-offset model (the ablation)
on the same bundles. Errors are the project's one definition (eval.metrics.offset_errors_ms,
offsets at each video's local time 0) and, with drift, the error at the end of each video.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..eval.metrics import offset_errors_ms, time_errors
from ..pipeline.stage12 import sync_bundle
from ..sync.config import DriftConfig, SyncConfig
from .datasets import cue_scene


@dataclass(frozen=True)
class DriftSceneRow:
    scene: str
    model: str  # "drift" | "constant"
    errors_ms: dict[str, float | None]  # per non-reference video, |offset error| at local time 0
    end_errors_ms: dict[str, float | None]  # |error| of the global time of the video's last frame
    drift_err_ppm: dict[str, float | None]  # estimated - true rate relative to the reference
    wall_s: float


def end_errors(res, bundle) -> tuple[dict, dict]:
    """Per non-reference video: |error| (ms) of the global time of its last frame, and its drift
    error (ppm, relative to the reference); None where unresolved (eval.metrics.time_errors)."""
    gd = bundle.gt_drift_ppm or dict.fromkeys(bundle.gt_offsets_s, 0.0)  # a truth without drift: 0
    span = {v.name: (float(v.timestamps_s[0]), float(v.timestamps_s[-1])) for v in bundle.videos}
    te = time_errors(res.offsets_s, bundle.gt_offsets_s, res.reference, None, res.drift_ppm, gd, span)
    te.pop(res.reference, None)
    return ({n: None if e is None else abs(e.end_err_s) * 1e3 for n, e in te.items()},
            {n: None if e is None else e.drift_err_ppm for n, e in te.items()})


def run_drift_cues(difficulty: str = "default", seeds: tuple[int, ...] = (0, 1, 2, 3, 4),
                   drift_ppm: float = 200.0, seconds: float | None = None) -> list[DriftSceneRow]:
    rows = []
    for seed in seeds:
        data = cue_scene(difficulty, seed, drift_ppm=drift_ppm, seconds=seconds)
        b = data.bundle
        for model, cfg in (("drift", SyncConfig(drift=DriftConfig(enabled=True))), ("constant", SyncConfig())):
            t0 = time.perf_counter()
            res = sync_bundle(b, cfg, progress=False)
            wall = time.perf_counter() - t0
            err = offset_errors_ms(res.offsets_s, b.gt_offsets_s, res.reference)
            err.pop(res.reference, None)
            ends, derr = end_errors(res, b)
            rows.append(DriftSceneRow(data.name, model, err, ends, derr, wall))
    return rows


def summarize(rows: list[DriftSceneRow]) -> str:
    lines = [f"{'model':9} {'videos':>6} {'median ms':>9} {'mean ms':>8} {'max ms':>7} {'end median ms':>13} "
             f"{'end max ms':>10} {'|drift err| median ppm':>22} {'unresolved':>10} {'wall s':>7}"]
    for model in ("drift", "constant"):
        mine = [r for r in rows if r.model == model]
        e = [x for r in mine for x in r.errors_ms.values() if x is not None]
        end = [x for r in mine for x in r.end_errors_ms.values() if x is not None]
        d = [abs(x) for r in mine for x in r.drift_err_ppm.values() if x is not None]
        un = sum(1 for r in mine for x in r.errors_ms.values() if x is None)
        f = (lambda xs, fn: f"{fn(xs):.2f}" if xs else "nan")  # noqa: E731
        lines.append(f"{model:9} {len(e):6d} {f(e, np.median):>9} {f(e, np.mean):>8} {f(e, np.max):>7} "
                     f"{f(end, np.median):>13} {f(end, np.max):>10} {f(d, np.median):>22} {un:10d} "
                     f"{sum(r.wall_s for r in mine):7.1f}")
    return "\n".join(lines)


def per_scene(rows: list[DriftSceneRow]) -> str:
    out = []
    for r in rows:
        cells = ", ".join(f"{v} {'-' if e is None else f'{e:.1f}'}" + (
            "" if r.drift_err_ppm.get(v) is None or r.model == "constant" else f" ({r.drift_err_ppm[v]:+.0f} ppm)")
            for v, e in r.errors_ms.items())
        out.append(f"  {r.scene} {r.model:8}: {cells} ms")
    return "\n".join(out) if out else ""


__all__ = ["DriftSceneRow", "end_errors", "per_scene", "run_drift_cues", "summarize"]
