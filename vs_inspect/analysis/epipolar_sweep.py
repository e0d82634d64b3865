"""The epipolar offset sweep of a pair: one frame of a, and for many candidate offsets the
epipolar lines of b's paired points at τ_a − Δ. The lines pass through a's points only near the
right Δ, which is what the recording lets a person scrub through. Numbers only (no rerun).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.epipolar import clip_lines, epipolar_lines, fundamental_from_cameras, line_distance
from ..geometry.sampling import camera_at_frames, sample_video
from ..types import CueBundle


@dataclass(frozen=True)
class EpipolarSweep:
    """One frame of a with b's track points turned into epipolar lines, for many offsets."""

    a: str
    b: str
    frame_a: int  # frame index of a that is shown
    time_a_s: float  # its local time
    points_a: np.ndarray  # (L,2) px, a's paired track points at frame_a
    instance: np.ndarray  # (L,) int, instance of each track pair (-1 unknown)
    offsets_s: np.ndarray  # (D,) Δ_ab candidates
    segments: np.ndarray  # (D,L,2,2) px, epipolar line of b's point (at τ_a − Δ) clipped to a's image
    distance_px: np.ndarray  # (D,L) px, distance of a's point to its line (NaN: b not seen)


def epipolar_sweep(bundle: CueBundle, a: str, b: str, offsets_s: np.ndarray, best_offset_s: float,
                   max_lines: int, seed: int = 0,
                   prefer_frames: set[int] | None = None) -> EpipolarSweep | None:
    """Pick a frame of a with many paired tracks visible (at the chosen offset when known), and
    compute for each offset the epipolar lines in a of b's paired points at τ_a − Δ.

    prefer_frames: frames of a that have an image; the best of them is taken when it shows at
    least half as many paired tracks as the best frame overall.
    """
    tp = bundle.pair(a, b)
    if tp is None or len(tp.index) == 0 or len(offsets_s) == 0:
        return None
    va, vb = bundle.video(a), bundle.video(b)
    cam_a, cam_b = bundle.cameras[a], bundle.cameras[b]
    xa, xb = bundle.tracks[a].xy, bundle.tracks[b].xy
    ia, ib = tp.index[:, 0], tp.index[:, 1]
    frames_a = np.arange(va.num_frames)
    seen_a = np.isfinite(xa[ia, :, 0]) & camera_at_frames(cam_a, frames_a).valid[None]  # (P,Ta)
    score = seen_a.sum(0).astype(float)
    if np.isfinite(best_offset_s):
        pb = sample_video(vb.timestamps_s, cam_b, xb, va.timestamps_s - best_offset_s, rows=ib).xy
        score = (seen_a & np.isfinite(pb[..., 0])).sum(0).astype(float)
    if score.max() <= 0:
        return None
    k = int(np.argmax(score))
    if prefer_frames:
        cand = np.array(sorted(f for f in prefer_frames if 0 <= f < len(score)), dtype=int)
        if len(cand) and score[cand].max() >= 0.5 * score[k]:
            k = int(cand[np.argmax(score[cand])])
    tau = float(va.timestamps_s[k])
    rows = np.flatnonzero(seen_a[:, k])
    if len(rows) > max_lines:
        rows = np.sort(np.random.default_rng(seed).choice(rows, max_lines, replace=False))
    pts_a = xa[ia[rows], k].astype(float)
    at_a = camera_at_frames(cam_a, np.array([k]))
    at_b = sample_video(vb.timestamps_s, cam_b, xb, tau - np.asarray(offsets_s, float), rows=ib[rows])
    with np.errstate(invalid="ignore", divide="ignore"):
        F = fundamental_from_cameras(at_a.K, at_a.cam_from_world, at_b.K, at_b.cam_from_world)  # (D,3,3)
    lines = epipolar_lines(F[:, None], np.swapaxes(at_b.xy, 0, 1))  # (D,L,3)
    dist = line_distance(lines, pts_a[None])
    inst = bundle.tracks[a].instance
    inst = inst[ia[rows]] if inst is not None else np.full(len(rows), -1)
    return EpipolarSweep(a, b, k, tau, pts_a, np.asarray(inst), np.asarray(offsets_s, float),
                         clip_lines(lines, va.width, va.height), dist)
