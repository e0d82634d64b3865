"""The drone benchmark (issue 22): pose-free pair sync with clock drift on the multi-view drone
tracking dataset, from detections alone, against the README's ground truth; the constant-offset
model is the ablation (same pairs, rate fixed at 1, its error shown).

Every pair of cameras is estimated (sync.posefree), in worker processes, then Stage 2 with drift
(sync.drift) fixes camera 0. The ablation reuses each pair's coarse landscape and starts from the
drift model's offset, so it differs only in the time model. Errors per camera: the offset error in frames of that camera (at its
local time 0), the worst frame error over its recording (offset and drift together), and the rate
error in ppm.
"""

from __future__ import annotations

import logging
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..sync.drift import DriftSolution, PairTiming, solve_offsets_drift
from ..sync.posefree import PoseFreeConfig, PoseFreePair, estimate_pair, fit_at_time_map
from ..types import CueBundle

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CameraError:
    name: str
    fps: float
    offset_err_frames: float  # (estimated - true offset_s) * fps
    worst_err_frames: float  # max over the camera's local times of the mapped-frame error
    drift_err_ppm: float
    est_drift_ppm: float
    true_drift_ppm: float


@dataclass(frozen=True)
class DroneBenchResult:
    drift: DriftSolution
    constant: DriftSolution
    pairs: dict[tuple[str, str], PoseFreePair | None]
    pairs_constant: dict[tuple[str, str], PoseFreePair | None]
    fit_at_truth: dict[tuple[str, str], tuple[float, float]]  # (median Sampson px, inlier share)
    errors_drift: list[CameraError]
    errors_constant: list[CameraError]
    wall_s: float
    workers: int


def _one_pair(args):
    (a, b, t_a, xy_a, K_a, t_b, xy_b, K_b, cfg) = args
    t0 = time.perf_counter()
    res = estimate_pair(t_a, xy_a, K_a, t_b, xy_b, K_b, cfg)
    res_c = None
    if res is not None:
        res_c = estimate_pair(t_a, xy_a, K_a, t_b, xy_b, K_b, replace(cfg, estimate_rate=False),
                              coarse=(res.coarse_offsets_s, res.coarse_score, res.coarse_score_F),
                              peaks_s=[res.offset_s])
    return a, b, res, res_c, time.perf_counter() - t0


def _truth_fit(args):
    (a, b, t_a, xy_a, K_a, t_b, xy_b, K_b, cfg, offset_s, rate) = args
    return (a, b), fit_at_time_map(t_a, xy_a, K_a, t_b, xy_b, K_b, offset_s, rate, cfg)


def estimate_all_pairs(bundle: CueBundle, cfg: PoseFreeConfig, workers: int):
    names = bundle.names
    jobs = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            va, vb = bundle.video(a), bundle.video(b)
            jobs.append((a, b, va.timestamps_s, bundle.tracks[a].xy[0], bundle.cameras[a].K,
                         vb.timestamps_s, bundle.tracks[b].xy[0], bundle.cameras[b].K, cfg))
    out, out_c = {}, {}
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as ex:
            results = list(ex.map(_one_pair, jobs))
    else:
        results = [_one_pair(j) for j in jobs]
    for a, b, res, res_c, dt in results:
        log.info("pair %s-%s: %.1f s", a, b, dt)
        out[(a, b)], out_c[(a, b)] = res, res_c
    return out, out_c


def fits_at_truth(bundle: CueBundle, gt_offsets_s: dict[str, float], gt_drift_ppm: dict[str, float],
                  cfg: PoseFreeConfig, workers: int) -> dict[tuple[str, str], tuple[float, float]]:
    """Per pair, how well the ground truth's time map explains the tracks (F refitted)."""
    names = bundle.names
    jobs = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            va, vb = bundle.video(a), bundle.video(b)
            da, db = gt_drift_ppm[a] * 1e-6, gt_drift_ppm[b] * 1e-6
            jobs.append((a, b, va.timestamps_s, bundle.tracks[a].xy[0], bundle.cameras[a].K,
                         vb.timestamps_s, bundle.tracks[b].xy[0], bundle.cameras[b].K, cfg,
                         (gt_offsets_s[b] - gt_offsets_s[a]) / (1 + da), (1 + db) / (1 + da)))
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as ex:
            return dict(ex.map(_truth_fit, jobs))
    return dict(_truth_fit(j) for j in jobs)


MIN_INLIER_SHARE = 0.5
"""A pair whose refined F explains fewer of its matches than this locked onto a wrong offset."""


def _timings(pairs: dict[tuple[str, str], PoseFreePair | None], with_rate: bool) -> list[PairTiming]:
    return [PairTiming(a, b, p.offset_s, math.log(p.rate) if with_rate else 0.0, p.offset_std_s,
                       p.log_rate_std if with_rate else 1.0)
            for (a, b), p in pairs.items() if p is not None and p.inlier_share >= MIN_INLIER_SHARE]


def camera_errors(sol: DriftSolution, bundle: CueBundle, gt_offsets_s: dict[str, float],
                  gt_drift_ppm: dict[str, float]) -> list[CameraError]:
    out = []
    for v in bundle.videos:
        n = v.name
        if n not in sol.offsets_s:
            out.append(CameraError(n, v.fps or 1 / v.frame_interval_s, math.nan, math.nan, math.nan,
                                   math.nan, gt_drift_ppm.get(n, math.nan)))
            continue
        fps = v.fps or 1.0 / v.frame_interval_s
        d_est, d_true = sol.drift_ppm[n] * 1e-6, gt_drift_ppm[n] * 1e-6
        # the global time the estimate gives a local time, minus the truth, at the ends of the
        # video; converted to this camera's frames
        ends = np.array([v.timestamps_s[0], v.timestamps_s[-1]])
        g_err = (sol.offsets_s[n] + (1 + d_est) * ends) - (gt_offsets_s[n] + (1 + d_true) * ends)
        out.append(CameraError(n, fps, (sol.offsets_s[n] - gt_offsets_s[n]) * fps,
                               float(np.max(np.abs(g_err)) * fps), (d_est - d_true) * 1e6,
                               d_est * 1e6, d_true * 1e6))
    return out


def run_drone_bench(bundle: CueBundle, gt_drift_ppm: dict[str, float], cfg: PoseFreeConfig = PoseFreeConfig(),
                    workers: int = 2) -> DroneBenchResult:
    if bundle.gt_offsets_s is None:
        raise ValueError("the bundle has no gt.json offsets")
    t0 = time.perf_counter()
    pairs, pairs_c = estimate_all_pairs(bundle, cfg, workers)
    ref = bundle.names[0]
    sol = solve_offsets_drift(ref, _timings(pairs, True), with_drift=True)
    sol_c = solve_offsets_drift(ref, _timings(pairs_c, False), with_drift=False)
    wall = time.perf_counter() - t0
    at_truth = fits_at_truth(bundle, bundle.gt_offsets_s, gt_drift_ppm, cfg, workers)  # not timed
    return DroneBenchResult(sol, sol_c, pairs, pairs_c, at_truth,
                            camera_errors(sol, bundle, bundle.gt_offsets_s, gt_drift_ppm),
                            camera_errors(sol_c, bundle, bundle.gt_offsets_s, gt_drift_ppm), wall, workers)


def format_table(res: DroneBenchResult, bundle: CueBundle) -> str:
    lines = [f"drone dataset: {len(bundle.videos)} cameras, {len(res.pairs)} pairs, "
             f"wall {res.wall_s:.1f} s on {res.workers} worker(s)",
             "", "per camera (reference " + res.drift.reference + "); frame errors in that camera's frames",
             f"{'camera':8} {'fps':>8} | {'drift model: offset err':>23} {'worst err':>10} {'est ppm':>9} "
             f"{'true ppm':>9} {'rate err ppm':>12} | {'constant offset: offset err':>27} {'worst err':>10} "
             f"{'rate err ppm':>12}"]
    for e, c in zip(res.errors_drift, res.errors_constant):
        lines.append(f"{e.name:8} {e.fps:8.3f} | {e.offset_err_frames:+23.2f} {e.worst_err_frames:10.2f} "
                     f"{e.est_drift_ppm:+9.1f} {e.true_drift_ppm:+9.1f} {e.drift_err_ppm:+12.1f} | "
                     f"{c.offset_err_frames:+27.2f} {c.worst_err_frames:10.2f} {c.drift_err_ppm:+12.1f}")
    lines += ["", "pairs (drift model): offset_s ± std, drift ppm ± std, inlier share, median Sampson px "
                  "(estimate; README truth with F refitted)"]
    for (a, b), p in res.pairs.items():
        if p is None:
            lines.append(f"  {a}-{b}: no estimate (overlap too small)")
            continue
        if (a, b) not in res.drift.pair_residuals:
            r = (math.nan, math.nan)
        else:
            r = res.drift.pair_residuals[(a, b)]
        lines.append(f"  {a}-{b}: {p.offset_s:+10.4f} ± {p.offset_std_s:.4f} s  {p.drift_ppm:+8.1f} ± "
                     f"{p.drift_std_ppm:6.1f} ppm  inliers {p.inlier_share:.2f} of {p.num_matches}  "
                     f"{p.median_sampson_px:.2f} px; truth {res.fit_at_truth[(a, b)][0]:.2f} px "
                     f"{res.fit_at_truth[(a, b)][1]:.2f}  | "
                     + (f"residual {r[0] * 1e3:+8.1f} ms {r[1] * 1e6:+8.1f} ppm" if math.isfinite(r[0])
                        else f"rejected (inlier share < {MIN_INLIER_SHARE})"))
    return "\n".join(lines)


def load_drone_bundle(path: str | os.PathLike) -> tuple[CueBundle, dict[str, float]]:
    """A bundle folder written by import-drone, or the dataset folder itself (imported in memory)."""
    from ..io.bundle import read_bundle
    from ..io.drone import import_drone, read_gt_drift_ppm

    p = Path(path)
    if (p / "bundle.json").is_file():
        drift = read_gt_drift_ppm(p)
        bundle = read_bundle(p)
    else:
        bundle, gt = import_drone(p)
        drift = gt.drift_ppm if gt is not None else None
    if drift is None or bundle.gt_offsets_s is None:
        raise ValueError(f"{p}: no ground truth (gt.json with offsets_s and drift_ppm, or README tables)")
    return bundle, drift
