"""Cameras from the moving points themselves, for static cameras whose background does not
reconstruct (wide baselines, textureless or repetitive walls).

For a reference video r and each other static video v: search the time offset whose aligned
track pairs (x_r(t + Δ), x_v(t)) give the most consistent fundamental matrix (RANSAC inlier
share, as in unsynchronized two-view geometry), self-calibrate one focal length per pair (the f
that makes K_vᵀ F K_r closest to an essential matrix, principal points at the image centres),
decompose into a relative pose, and fix the scale of every pair from points triangulated on the
reference's tracks. Pure functions of arrays; the coarse offsets found here are only used to
build the cameras, Stage 1 searches the offsets again.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from ..types import CameraTrack, TrackPairs, VideoInfo

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PairGeometry:
    offset_s: float  # coarse Δ_rv, seconds
    F: np.ndarray  # (3,3), x_v^T F x_r = 0 (full-resolution px)
    inlier_share: float
    num_correspondences: int
    focal_px: float


def aligned_correspondences(xy_a: np.ndarray, info_a: VideoInfo, xy_b: np.ndarray, info_b: VideoInfo,
                            index: np.ndarray, delta_s: float):
    """(P,2) x_a at local time τ_b + Δ (nearest frame within half a frame), (P,2) x_b, (P,) keys.

    keys = track index in a * T_a + frame of a (identifies the observation of a)."""
    ta, tb = info_a.timestamps_s, info_b.timestamps_s
    want = tb + delta_s
    ka = np.clip(np.searchsorted(ta, want), 1, len(ta) - 1)
    ka = np.where(np.abs(ta[ka - 1] - want) < np.abs(ta[ka] - want), ka - 1, ka)
    ok_t = np.abs(ta[ka] - want) <= 0.5 * info_a.frame_interval_s + 1e-9
    fb = np.nonzero(ok_t)[0]
    if not len(fb) or not len(index):
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64)
    fa = ka[fb]
    A = xy_a[index[:, 0]][:, fa]  # (P,F,2)
    B = xy_b[index[:, 1]][:, fb]
    ok = np.isfinite(A).all(-1) & np.isfinite(B).all(-1)
    pi, fi = np.nonzero(ok)
    keys = index[pi, 0].astype(np.int64) * len(ta) + fa[fi]
    return A[pi, fi], B[pi, fi], keys


def _focal_from_F(F: np.ndarray, ca: np.ndarray, cb: np.ndarray, size: float) -> float:
    """Focal (px) shared by both cameras that makes K_bᵀ F K_a most essential-like."""
    best, best_f = np.inf, size
    for f in np.geomspace(0.3 * size, 5.0 * size, 160):
        Ka = np.array([[f, 0, ca[0]], [0, f, ca[1]], [0, 0, 1]])
        Kb = np.array([[f, 0, cb[0]], [0, f, cb[1]], [0, 0, 1]])
        s = np.linalg.svd(Kb.T @ F @ Ka, compute_uv=False)
        cost = (s[0] - s[1]) / (s[0] + s[1])
        if cost < best:
            best, best_f = cost, f
    return float(best_f)


def search_pair(xy_r, info_r, xy_v, info_v, index, min_corr: int = 40, thresh_px: float = 2.0,
                max_corr: int = 2000, seed: int = 0,
                min_share_of_max: float = 0.35) -> PairGeometry | None:
    """Best coarse offset and F between r and v from their track pairs."""
    if len(index) < 8:
        return None
    step = min(info_r.frame_interval_s, info_v.frame_interval_s)
    lo = info_r.timestamps_s[0] - info_v.timestamps_s[-1]
    hi = info_r.timestamps_s[-1] - info_v.timestamps_s[0]
    rng = np.random.default_rng(seed)
    cands = []
    for d in np.arange(lo, hi + step / 2, step):
        A, B, _ = aligned_correspondences(xy_r, info_r, xy_v, info_v, index, d)
        if len(A) < min_corr:
            continue
        if len(A) > max_corr:
            sel = rng.choice(len(A), max_corr, replace=False)
            A, B = A[sel], B[sel]
        try:
            F, inl = cv2.findFundamentalMat(A.astype(np.float64), B.astype(np.float64), cv2.USAC_MAGSAC,
                                            thresh_px, 0.999, 2000)
        except cv2.error:  # OpenCV 5's USAC asserts on some degenerate samples instead of failing softly
            continue
        if F is None or F.shape != (3, 3):
            continue
        cands.append((float(inl.mean()), d, F, len(A)))
    if not cands:
        return None
    # a few correspondences fit any F: only offsets with a good part of the largest overlap count
    n_max = max(c[3] for c in cands)
    share, d, F, n = max((c for c in cands if c[3] >= min_share_of_max * n_max), key=lambda c: c[0])
    ca = np.array([(info_r.width - 1) / 2, (info_r.height - 1) / 2])
    cb = np.array([(info_v.width - 1) / 2, (info_v.height - 1) / 2])
    f = _focal_from_F(F, ca, cb, float(max(info_r.width, info_r.height, info_v.width, info_v.height)))
    return PairGeometry(float(d), F, share, n, f)


def cameras_from_tracks(ref: str, infos: dict[str, VideoInfo], xy: dict[str, np.ndarray],
                        pairs: dict[tuple[str, str], TrackPairs], moving: dict[str, bool]
                        ) -> tuple[dict[str, CameraTrack], dict[str, str], dict[str, dict]]:
    """Static cameras in the reference's camera frame: (cameras, unregistered reasons, details)."""
    cams: dict[str, CameraTrack] = {}
    reasons: dict[str, str] = {}
    details: dict[str, dict] = {}
    geo: dict[str, tuple] = {}
    info_r = infos[ref]
    for v in infos:
        if v == ref:
            continue
        if moving[v]:
            reasons[v] = "camera could not be registered: moving camera and no background reconstruction"
            continue
        tp = pairs.get((ref, v))
        idx = tp.index if tp is not None else None
        if tp is None and (v, ref) in pairs:
            idx = pairs[(v, ref)].index[:, ::-1]
        if idx is None or len(idx) < 8:
            reasons[v] = (f"camera could not be registered: background did not reconstruct and only "
                          f"{0 if idx is None else len(idx)} track pairs with {ref}")
            continue
        g = search_pair(xy[ref], info_r, xy[v], infos[v], idx)
        if g is None or g.inlier_share < 0.3:
            reasons[v] = ("camera could not be registered: no consistent two-view geometry from the "
                          f"moving points shared with {ref}")
            continue
        A, B, keys = aligned_correspondences(xy[ref], info_r, xy[v], infos[v], idx, g.offset_s)
        Ka = np.array([[g.focal_px, 0, (info_r.width - 1) / 2], [0, g.focal_px, (info_r.height - 1) / 2], [0, 0, 1]])
        Kb = np.array([[g.focal_px, 0, (infos[v].width - 1) / 2], [0, g.focal_px, (infos[v].height - 1) / 2], [0, 0, 1]])
        E = Kb.T @ g.F @ Ka
        na = cv2.undistortPoints(A.reshape(-1, 1, 2).astype(np.float64), Ka, None).reshape(-1, 2)
        nb = cv2.undistortPoints(B.reshape(-1, 1, 2).astype(np.float64), Kb, None).reshape(-1, 2)
        _, R, t, _ = cv2.recoverPose(E, na, nb, np.eye(3))
        P0 = np.hstack([np.eye(3), np.zeros((3, 1))])
        P1 = np.hstack([R, t.reshape(3, 1)])
        X = cv2.triangulatePoints(P0, P1, na.T, nb.T)
        X = (X[:3] / X[3]).T
        front = (X[:, 2] > 0) & ((X @ R.T + t.reshape(1, 3))[:, 2] > 0)
        geo[v] = (R, t.reshape(3), g, keys[front], X[front], Ka, Kb)
        details[v] = {"coarse_offset_s": round(g.offset_s, 4), "inlier_share": round(g.inlier_share, 3),
                      "correspondences": g.num_correspondences, "focal_px": round(g.focal_px, 1)}
    if not geo:
        return cams, reasons, details
    # common scale: points triangulated from different pairs on the same reference observation
    order = sorted(geo, key=lambda v: -len(geo[v][3]))
    scale = {order[0]: 1.0}
    for v in order[1:]:
        kv, Xv = geo[v][3], geo[v][4]
        ratios = []
        for u in scale:
            ku, Xu = geo[u][3], geo[u][4]
            common, iu, iv = np.intersect1d(ku, kv, return_indices=True)
            if len(common) >= 5:
                ratios.append(np.median(np.linalg.norm(Xu[iu], axis=1) / np.maximum(np.linalg.norm(Xv[iv], axis=1), 1e-9)) * scale[u])
        scale[v] = float(np.median(ratios)) if ratios else 1.0
        details[v]["scale_from_shared_points"] = bool(ratios)
    Kr = None
    for v, (R, t, g, _, _, Ka, Kb) in geo.items():
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, t * scale[v]
        cams[v] = CameraTrack(Kb, T)
        Kr = Ka if Kr is None else Kr
    f_ref = float(np.median([geo[v][2].focal_px for v in geo]))
    Kr = np.array([[f_ref, 0, (info_r.width - 1) / 2], [0, f_ref, (info_r.height - 1) / 2], [0, 0, 1]])
    cams[ref] = CameraTrack(Kr, np.eye(4))
    return cams, reasons, details
