"""The drone benchmark: pose-free pair sync with clock drift on the multi-view drone
tracking dataset, from detections alone, against the README's ground truth; the constant-offset
model is the ablation (same pairs, rate fixed at 1, its error shown).

It runs the product's path, `sync --drift --engine ray` on the pose-free bundle
(pipeline.stage12.sync_bundle: every pair's F, shift and rate from its tracks, the energy with
that F, as Ray tasks; Stage 2 with drift fixing camera 0), timed; then the constant-offset model
on the same pairs' estimates (energy at rate 1, one offset per camera), so that it differs only
in the time model. Errors per camera (eval.metrics.time_errors): the offset error in frames of
that camera (at its local time 0), the worst frame error over its recording (offset and drift
together), and the rate error in ppm.
"""

from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from ..engine import EngineConfig, open_engine
from ..eval.metrics import VideoTimeError, time_errors
from ..sync.config import DriftConfig, SyncConfig
from ..sync.drift import DriftSolution
from ..sync.posefree import PoseFreePair
from ..result_types import SyncResult
from ..types import CueBundle

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DroneBenchResult:
    drift: DriftSolution  # the product's --drift run (sync_bundle), as per-camera offset and drift
    constant: DriftSolution  # the same pairs' estimates, constant-offset model (drift 0)
    sync_drift: SyncResult
    sync_constant: SyncResult
    pairs: dict[tuple[str, str], PoseFreePair | None]  # what each pair's tracks gave (sync.posefree)
    errors_drift: dict[str, VideoTimeError | None]  # per camera against the README (eval.metrics.time_errors)
    errors_constant: dict[str, VideoTimeError | None]
    gt_drift_ppm: dict[str, float]  # the README's, per camera (camera 0: 0)
    wall_s: float  # the --drift run: pose-free pairs, energies, Stage 2
    wall_constant_s: float  # the ablation's energies and Stage 2 (its pairs' estimates reused)
    workers: int  # Ray CPUs (1: in this process)
    engine_start_s: float  # starting the embedded Ray (0 in this process), not in wall_s


def camera_errors(sol: DriftSolution, bundle: CueBundle, gt_offsets_s: dict[str, float],
                  gt_drift_ppm: dict[str, float]) -> dict[str, VideoTimeError | None]:
    """eval.metrics.time_errors of a solution, with each camera's frame rate and span (its first
    and last local times: the worst frame error over the recording is at one of them)."""
    fps = {v.name: v.fps or 1.0 / v.frame_interval_s for v in bundle.videos}
    span = {v.name: (float(v.timestamps_s[0]), float(v.timestamps_s[-1])) for v in bundle.videos}
    est = {v: sol.offsets_s.get(v) for v in bundle.names}
    return time_errors(est, gt_offsets_s, sol.reference, fps, sol.drift_ppm, gt_drift_ppm, span)


def _as_solution(res: SyncResult) -> DriftSolution:
    ok = [v for v, o in res.offsets_s.items() if o is not None]
    drift = res.drift_ppm or {}
    std = res.drift_std_ppm or {}
    return DriftSolution(res.reference, {v: float(res.offsets_s[v]) for v in ok},
                         {v: float(drift.get(v) or 0.0) for v in ok},
                         {v: float(res.uncertainty_s[v] or 0.0) for v in ok},
                         {v: float(std.get(v) or 0.0) for v in ok}, {}, res.drift_ppm is not None)


def run_drone_bench(bundle: CueBundle, gt_drift_ppm: dict[str, float], workers: int = 2) -> DroneBenchResult:
    """The product's path (pipeline.stage12.sync_bundle on the pose-free bundle) with --drift, then
    the constant-offset model on the same pairs' estimates (the ablation, timed apart).
    workers > 1: the pairs run as Ray tasks on an embedded Ray of that many CPUs (`sync --engine
    ray --ray-cpus N`), started before the clock does (its start is reported apart); 1: in this
    process."""
    from ..pipeline.stage12 import estimate_pose_free_pairs, sync_bundle

    if bundle.gt_offsets_s is None:
        raise ValueError("the bundle has no gt.json offsets")
    names = bundle.names
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:] if (a, b) in bundle.pairs]
    cfg_d = SyncConfig(drift=DriftConfig(enabled=True))
    t_start = time.perf_counter()
    with open_engine(EngineConfig("ray", ray_cpus=workers) if workers > 1 else EngineConfig()) as engine:
        start_s = time.perf_counter() - t_start
        t0 = time.perf_counter()
        est = estimate_pose_free_pairs(bundle, pairs, cfg_d, engine=engine)
        res_d = sync_bundle(bundle, cfg_d, progress=False, pose_free=est, engine=engine)
        wall = time.perf_counter() - t0
        t1 = time.perf_counter()
        res_c = sync_bundle(bundle, SyncConfig(), progress=False, pose_free=est, engine=engine)
        wall_c = time.perf_counter() - t1
    sol, sol_c = _as_solution(res_d), _as_solution(res_c)
    return DroneBenchResult(sol, sol_c, res_d, res_c, est,
                            camera_errors(sol, bundle, bundle.gt_offsets_s, gt_drift_ppm),
                            camera_errors(sol_c, bundle, bundle.gt_offsets_s, gt_drift_ppm), dict(gt_drift_ppm),
                            wall, wall_c, workers, start_s)


def format_table(res: DroneBenchResult, bundle: CueBundle) -> str:
    lines = [f"drone dataset: {len(bundle.videos)} cameras, {len(res.pairs)} pairs; `sync --drift` path "
             f"wall {res.wall_s:.1f} s on "
             + (f"{res.workers} Ray CPUs (the embedded Ray's start, {res.engine_start_s:.1f} s, not included)"
                if res.workers > 1 else "1 process")
             + f" (constant-offset ablation on the same pair estimates: {res.wall_constant_s:.1f} s more)",
             "", "per camera (reference " + res.drift.reference + "); frame errors in that camera's frames",
             f"{'camera':8} {'fps':>8} | {'drift model: offset err':>23} {'worst err':>10} {'est ppm':>9} "
             f"{'± ppm':>7} {'true ppm':>9} {'rate err ppm':>12} | {'constant offset: offset err':>27} "
             f"{'worst err':>10} {'rate err ppm':>12}"]
    std = res.sync_drift.drift_std_ppm or {}
    nan = math.nan
    for v in bundle.videos:
        n = v.name
        e, c = res.errors_drift.get(n), res.errors_constant.get(n)
        s = std.get(n)
        lines.append(f"{n:8} {v.fps or 1 / v.frame_interval_s:8.3f} | "
                     f"{e.offset_err_frames if e else nan:+23.2f} {e.worst_err_frames if e else nan:10.2f} "
                     f"{res.drift.drift_ppm.get(n, nan):+9.1f} {(s if s is not None else nan):7.1f} "
                     f"{res.gt_drift_ppm.get(n, nan):+9.1f} {e.drift_err_ppm if e else nan:+12.1f} | "
                     f"{c.offset_err_frames if c else nan:+27.2f} {c.worst_err_frames if c else nan:10.2f} "
                     f"{c.drift_err_ppm if c else nan:+12.1f}")
    gt, gd = bundle.gt_offsets_s or {}, bundle.gt_drift_ppm or {}
    lines += ["", "pairs: the tracks' estimate (sync.posefree: offset s, drift ppm ± std, inlier share), the "
                  "--drift pair (energy minimum at that rate), its error against the README, Stage 2 verdict"]
    for land in res.sync_drift.pairs:
        a, b = land.a, land.b
        p = res.pairs.get((a, b))
        p = p if isinstance(p, PoseFreePair) else None  # None or its task died
        head = (f"  {a}-{b}: tracks {p.offset_s:+10.4f} s {p.drift_ppm:+8.1f} ± {p.drift_std_ppm:6.1f} ppm "
                f"inliers {p.inlier_share:.2f} of {p.num_matches} ({p.median_sampson_px:.2f} px)"
                if p is not None else f"  {a}-{b}: tracks gave nothing")
        if land.decision.accepted and a in gt and b in gt:
            da, db = gd.get(a, 0.0) * 1e-6, gd.get(b, 0.0) * 1e-6
            t_off, t_ppm = (gt[b] - gt[a]) / (1 + da), ((1 + db) / (1 + da) - 1) * 1e6
            fps = bundle.video(b).fps or 1 / bundle.video(b).frame_interval_s
            head += (f" | pair {land.best_offset_s:+10.4f} s {(land.rate - 1) * 1e6:+8.1f} ppm, err "
                     f"{(land.best_offset_s - t_off) * fps:+.2f} frames {(land.rate - 1) * 1e6 - t_ppm:+.1f} ppm")
        elif not land.decision.accepted:
            head += f" | rejected: {land.decision.reason}"
        lines.append(head)
    return "\n".join(lines)


def load_drone_bundle(path: str | os.PathLike) -> tuple[CueBundle, dict[str, float]]:
    """A bundle folder written by import-drone, or the dataset folder itself (imported in memory)."""
    from ..io.bundle import read_bundle
    from ..io.drone import import_drone

    p = Path(path)
    if (p / "bundle.json").is_file():
        bundle = read_bundle(p)  # with gt.json's drift_ppm
        drift = bundle.gt_drift_ppm
    else:
        bundle, gt = import_drone(p)
        drift = gt.drift_ppm if gt is not None else None
    if drift is None or bundle.gt_offsets_s is None:
        raise ValueError(f"{p}: no ground truth (gt.json with offsets_s and drift_ppm, or README tables)")
    return bundle, drift
