"""Sampling a video's clock at arbitrary times: frame brackets and pose interpolation (pure)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ._shapes import check_shape
from .epipolar import camera_centers


def frame_brackets(timestamps_s: np.ndarray, query_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each query time, the frame k with t[k] <= q < t[k+1] and the weight w in [0,1).

    Returns (k, w) with k = -1 where q lies outside [t[0], t[-1]]. A query equal to the last
    timestamp maps to (T-2, 1.0) so that it still uses two frames.
    """
    t = check_shape("timestamps_s", np.asarray(timestamps_s, dtype=np.float64), (None,), batched=False)
    if len(t) == 0:
        raise ValueError("timestamps_s must have at least one frame, got (0,)")
    q = np.asarray(query_s, dtype=np.float64)
    if len(t) < 2:
        k = np.where(np.isclose(q, t[0], atol=1e-9), 0, -1)
        return k.astype(np.int64), np.zeros_like(q)
    k = np.searchsorted(t, q, side="right") - 1
    last = np.isclose(q, t[-1], rtol=0, atol=1e-9)
    k = np.where(last, len(t) - 2, k)
    inside = (k >= 0) & (k <= len(t) - 2) & np.isfinite(q)
    kc = np.clip(k, 0, len(t) - 2)
    w = (q - t[kc]) / (t[kc + 1] - t[kc])
    w = np.clip(np.where(inside, w, 0.0), 0.0, 1.0)
    return np.where(inside, kc, -1).astype(np.int64), w


def interpolate_poses(cam_from_world: np.ndarray, k: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(...,4,4) poses between frames k and k+1 (slerp for rotation, lerp for the camera centre).

    cam_from_world: (T,4,4). Entries with k == -1 come out as NaN.
    """
    T = check_shape("cam_from_world", np.asarray(cam_from_world, dtype=np.float64), (None, 4, 4),
                    batched=False)
    if np.shape(w) != np.shape(k):
        raise ValueError(f"k and w must have the same shape, got {np.shape(k)} and {np.shape(w)}")
    shape = np.shape(k)
    k = np.asarray(k).ravel()
    w = np.asarray(w, dtype=np.float64).ravel()
    out = np.full((len(k), 4, 4), np.nan)
    ok = k >= 0
    if ok.any():
        k0, ww = k[ok], w[ok]
        k1 = np.minimum(k0 + 1, len(T) - 1)
        R = Rotation.from_matrix(T[:, :3, :3])
        # Slerp over frame index as the "time" axis, then evaluate at k + w.
        slerp = Slerp(np.arange(len(T), dtype=np.float64), R) if len(T) > 1 else None
        Rq = slerp(np.clip(k0 + ww, 0, len(T) - 1)).as_matrix() if slerp else T[k0, :3, :3]
        C = camera_centers(T)
        Cq = (1 - ww)[:, None] * C[k0] + ww[:, None] * C[k1]
        out[ok] = 0.0
        out[ok, :3, :3] = Rq
        out[ok, :3, 3] = -np.einsum("nij,nj->ni", Rq, Cq)
        out[ok, 3, 3] = 1.0
    return out.reshape(shape + (4, 4))


def interpolate_intrinsics(K: np.ndarray, k: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(...,3,3) intrinsics between frames k and k+1 (K (3,3) is returned broadcast)."""
    K = check_shape("K", np.asarray(K, dtype=np.float64), (3, 3))
    if K.ndim > 3:
        raise ValueError(f"K must be (3,3) or (T,3,3), got {K.shape}")
    if K.ndim == 2:
        return np.broadcast_to(K, np.shape(k) + (3, 3)).copy()
    kc = np.clip(k, 0, len(K) - 1)
    k1 = np.clip(kc + 1, 0, len(K) - 1)
    ww = np.asarray(w)[..., None, None]
    return (1 - ww) * K[kc] + ww * K[k1]
