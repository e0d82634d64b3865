"""Views derived from a bundle and a result for the recording: the epipolar offset sweep of a pair
and triangulated 3D trajectories at the solved offsets. Numbers only (no rerun here), so that the
sink stays thin and these can be tested on their own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.epipolar import fundamental_from_cameras
from ..geometry.timing import frame_brackets, interpolate_intrinsics, interpolate_poses
from ..geometry.triangulate import projection_matrix, reprojection_error, triangulate_dlt
from ..types import CameraTrack, CueBundle


def sample_tracks(xy: np.ndarray, timestamps_s: np.ndarray, query_s: np.ndarray) -> np.ndarray:
    """(N,Q,2) track positions at local times query_s (Q,), linear between frames, NaN outside."""
    k, w = frame_brackets(timestamps_s, np.asarray(query_s, float))
    if xy.shape[1] < 2:
        out = np.repeat(xy[:, :1].astype(float), len(k), axis=1)
        out[:, k < 0] = np.nan
        return out
    kc = np.clip(k, 0, xy.shape[1] - 2)
    x0, x1 = xy[:, kc].astype(float), xy[:, kc + 1].astype(float)
    out = x0 + w[None, :, None] * (x1 - x0)
    out[:, k < 0] = np.nan
    return out


def camera_at(cam: CameraTrack, timestamps_s: np.ndarray, query_s: np.ndarray):
    """(K (Q,3,3), cam_from_world (Q,4,4)) at local times query_s; NaN where not defined."""
    q = np.asarray(query_s, float)
    k, w = frame_brackets(timestamps_s, q)
    K = interpolate_intrinsics(cam.K, np.maximum(k, 0), w)
    if cam.cam_from_world.ndim == 3:
        T = interpolate_poses(cam.cam_from_world, k, w)
    else:
        T = np.broadcast_to(cam.cam_from_world, (len(q), 4, 4)).copy()
    bad = k < 0
    if cam.valid is not None and len(cam.valid) > 1:
        kc = np.clip(k, 0, len(cam.valid) - 2)
        bad |= ~(cam.valid[kc] & cam.valid[kc + 1])
    T[bad] = np.nan
    K[bad] = np.nan
    return K, T


def clip_lines(lines: np.ndarray, width: int, height: int) -> np.ndarray:
    """(...,2,2) end points of lines a·x + b·y + c = 0 (...,3) inside [0,W-1]x[0,H-1]; NaN if outside."""
    l = np.asarray(lines, float)
    a, b, c = l[..., 0], l[..., 1], l[..., 2]
    W, H = width - 1.0, height - 1.0
    with np.errstate(invalid="ignore", divide="ignore"):
        cand = np.stack([
            np.stack([np.zeros_like(a), -c / b], -1),  # x = 0
            np.stack([np.full_like(a, W), -(c + a * W) / b], -1),  # x = W
            np.stack([-c / a, np.zeros_like(a)], -1),  # y = 0
            np.stack([-(c + b * H) / a, np.full_like(a, H)], -1),  # y = H
        ], -2)  # (...,4,2)
    eps = 1e-6
    inside = np.isfinite(cand).all(-1) & (cand[..., 0] >= -eps) & (cand[..., 0] <= W + eps) \
        & (cand[..., 1] >= -eps) & (cand[..., 1] <= H + eps)
    out = np.full(l.shape[:-1] + (2, 2), np.nan)
    flat_c, flat_in, flat_o = cand.reshape(-1, 4, 2), inside.reshape(-1, 4), out.reshape(-1, 2, 2)
    for i in np.flatnonzero(flat_in.sum(1) >= 2):
        pts = flat_c[i, flat_in[i]]
        d = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
        j, k = np.unravel_index(np.argmax(d), d.shape)
        if d[j, k] > 1e-6:
            flat_o[i] = pts[[j, k]]
    return out


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
    xa, xb = bundle.tracks[a].xy, bundle.tracks[b].xy
    ia, ib = tp.index[:, 0], tp.index[:, 1]
    seen_a = np.isfinite(xa[ia, :, 0])  # (P,Ta)
    score = seen_a.sum(0).astype(float)
    if np.isfinite(best_offset_s):
        pb = sample_tracks(xb[ib], vb.timestamps_s, va.timestamps_s - best_offset_s)
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
    q = tau - np.asarray(offsets_s, float)  # b's local time at each offset
    pb = sample_tracks(xb[ib[rows]], vb.timestamps_s, q)  # (L,D,2)
    Ka, Ta = camera_at(bundle.cameras[a], va.timestamps_s, np.array([tau]))
    Kb, Tb = camera_at(bundle.cameras[b], vb.timestamps_s, q)
    with np.errstate(invalid="ignore", divide="ignore"):
        F = fundamental_from_cameras(Ka, Ta, Kb, Tb)  # (D,3,3), x_aᵀ F x_b = 0
        xbh = np.concatenate([pb, np.ones(pb.shape[:-1] + (1,))], -1)  # (L,D,3)
        lines = np.einsum("dij,ldj->dli", F, xbh)  # (D,L,3)
        num = np.abs(lines[..., 0] * pts_a[None, :, 0] + lines[..., 1] * pts_a[None, :, 1] + lines[..., 2])
        dist = num / np.hypot(lines[..., 0], lines[..., 1])
    inst = bundle.tracks[a].instance
    inst = inst[ia[rows]] if inst is not None else np.full(len(rows), -1)
    return EpipolarSweep(a, b, k, tau, pts_a, np.asarray(inst), np.asarray(offsets_s, float),
                         clip_lines(lines, va.width, va.height), dist)


@dataclass(frozen=True)
class Trajectories:
    """3D positions of paired tracks of one accepted pair, triangulated at the solved offsets."""

    a: str
    b: str
    points_world: np.ndarray  # (P,Ta,3) m, NaN where not triangulated or rejected
    time_s: np.ndarray  # (Ta,) global time of a's frames (τ_a + offset_s[a])
    instance: np.ndarray  # (P,) int (-1 unknown)
    reprojection_px: float  # median reprojection error of the kept points


def triangulate_pair(bundle: CueBundle, a: str, b: str, offset_a_s: float, offset_b_s: float,
                     max_pairs: int, max_reprojection_px: float | None = None,
                     seed: int = 0) -> Trajectories | None:
    """Triangulate track pairs of (a, b) at a's frames with b sampled at the same global moment.

    Points behind a camera or reprojecting worse than max_reprojection_px (default 0.5 % of a's
    image diagonal, at least 4 px) in either view are dropped: wrong matches mostly vanish.
    """
    tp = bundle.pair(a, b)
    if tp is None or len(tp.index) == 0:
        return None
    va, vb = bundle.video(a), bundle.video(b)
    idx = tp.index
    if len(idx) > max_pairs:
        idx = idx[np.sort(np.random.default_rng(seed).choice(len(idx), max_pairs, replace=False))]
    g = va.timestamps_s + offset_a_s
    q = g - offset_b_s  # b's local time at a's frames
    xa = bundle.tracks[a].xy[idx[:, 0]].astype(float)  # (P,Ta,2)
    xb = sample_tracks(bundle.tracks[b].xy[idx[:, 1]], vb.timestamps_s, q)
    Ka, Ta = camera_at(bundle.cameras[a], va.timestamps_s, va.timestamps_s)
    Kb, Tb = camera_at(bundle.cameras[b], vb.timestamps_s, q)
    Pa, Pb = projection_matrix(Ka, Ta), projection_matrix(Kb, Tb)  # (Ta,3,4)
    X = triangulate_dlt(Pa[None], Pb[None], xa, xb)
    ea, da = reprojection_error(Pa[None], X, xa)
    eb, db = reprojection_error(Pb[None], X, xb)
    thr = max_reprojection_px or max(4.0, 0.005 * float(np.hypot(va.width, va.height)))
    with np.errstate(invalid="ignore"):
        keep = (ea < thr) & (eb < thr) & (da > 0) & (db > 0)
    X[~keep] = np.nan
    inst = bundle.tracks[a].instance
    inst = inst[idx[:, 0]] if inst is not None else np.full(len(idx), -1)
    med = float(np.median(np.concatenate([ea[keep], eb[keep]]))) if keep.any() else float("nan")
    return Trajectories(a, b, X, g, np.asarray(inst), med)
