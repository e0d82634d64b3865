"""Two-view triangulation (DLT) with one filter for what is kept, vectorized (pure)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._shapes import check_shape
from .epipolar import camera_centers
from .sampling import camera_at_frames, sample_video

MAX_REPROJECTION_PX = 4.0  # a point is kept when it reprojects this close in both views
MIN_RAY_ANGLE_DEG = 3.0  # ... and when its two viewing rays meet at least at this angle


def projection_matrix(K: np.ndarray, cam_from_world: np.ndarray) -> np.ndarray:
    """(...,3,4) P = K [R | t] from (...,3,3) K and (...,4,4) cam_from_world."""
    check_shape("K", K, (3, 3))
    check_shape("cam_from_world", cam_from_world, (4, 4))
    return np.asarray(K, float) @ np.asarray(cam_from_world, float)[..., :3, :]


def triangulate_dlt(P_a: np.ndarray, P_b: np.ndarray, x_a: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """(...,3) world points from two views by the homogeneous DLT (Hartley & Zisserman 12.2).

    P_a, P_b: (...,3,4) projection matrices; x_a, x_b: (...,2) px. NaN in, NaN out.
    """
    P_a = check_shape("P_a", np.asarray(P_a, float), (3, 4))
    P_b = check_shape("P_b", np.asarray(P_b, float), (3, 4))
    x_a = check_shape("x_a", np.asarray(x_a, float), (2,))
    x_b = check_shape("x_b", np.asarray(x_b, float), (2,))
    shape = np.broadcast_shapes(P_a.shape[:-2], P_b.shape[:-2], x_a.shape[:-1], x_b.shape[:-1])
    P_a = np.broadcast_to(P_a, shape + (3, 4)).reshape(-1, 3, 4)
    P_b = np.broadcast_to(P_b, shape + (3, 4)).reshape(-1, 3, 4)
    x_a = np.broadcast_to(x_a, shape + (2,)).reshape(-1, 2)
    x_b = np.broadcast_to(x_b, shape + (2,)).reshape(-1, 2)
    out = np.full((len(x_a), 3), np.nan)
    ok = np.isfinite(x_a).all(1) & np.isfinite(x_b).all(1) & np.isfinite(P_a).all((1, 2)) \
        & np.isfinite(P_b).all((1, 2))
    if ok.any():
        Pa, Pb, xa, xb = P_a[ok], P_b[ok], x_a[ok], x_b[ok]
        A = np.stack([xa[:, 0:1] * Pa[:, 2] - Pa[:, 0], xa[:, 1:2] * Pa[:, 2] - Pa[:, 1],
                      xb[:, 0:1] * Pb[:, 2] - Pb[:, 0], xb[:, 1:2] * Pb[:, 2] - Pb[:, 1]], axis=1)
        # scale rows for conditioning; the null vector is unchanged
        A /= np.linalg.norm(A, axis=2, keepdims=True) + 1e-300
        _, _, Vt = np.linalg.svd(A)
        X = Vt[:, -1]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[ok] = X[:, :3] / X[:, 3:4]
    return out.reshape(shape + (3,))


def reprojection_error(P: np.ndarray, X: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(pixel distance (...), depth (...)) of world points X (...,3) seen by P (...,3,4) at x (...,2)."""
    check_shape("P", P, (3, 4))
    check_shape("X", X, (3,))
    check_shape("x", x, (2,))
    Xh = np.concatenate([np.asarray(X, float), np.ones(np.shape(X)[:-1] + (1,))], axis=-1)
    y = np.einsum("...ij,...j->...i", np.asarray(P, float), Xh)
    with np.errstate(invalid="ignore", divide="ignore"):
        uv = y[..., :2] / y[..., 2:3]
    return np.linalg.norm(uv - np.asarray(x, float), axis=-1), y[..., 2]


def triangulate_over_time(timestamps_a: np.ndarray, camera_a, xy_a: np.ndarray, offset_a_s: float,
                          timestamps_b: np.ndarray, camera_b, xy_b: np.ndarray, offset_b_s: float,
                          index: np.ndarray, at: str = "a") -> tuple[TwoViewPoints, np.ndarray]:
    """Track pairs index (P,2) (rows of xy_a (Na,Ta,2), of xy_b) triangulated at the frames of
    video `at` ("a" or "b"), the other read between its frames at the same global moment
    (sampling.sample_video); offset_*_s: each video's offset (global time of its local 0).
    Returns (points (P,T,3) with T the frames of `at`, NaN where a frame has no pose; (T,) the
    global time of those frames). camera_*: CameraTrack."""
    if at not in ("a", "b"):
        raise ValueError(f"at must be 'a' or 'b', got {at!r}")
    framed, other = (0, 1) if at == "a" else (1, 0)
    ts, offs = (timestamps_a, timestamps_b), (offset_a_s, offset_b_s)
    cams, xys = (camera_a, camera_b), (xy_a, xy_b)
    g = ts[framed] + offs[framed]
    here = camera_at_frames(cams[framed], np.arange(len(ts[framed])))
    x_here = np.asarray(xys[framed][index[:, framed]], dtype=np.float64)
    x_here[:, ~here.valid] = np.nan
    there = sample_video(ts[other], cams[other], xys[other], g - offs[other], rows=index[:, other])
    views = {framed: (here.K, here.cam_from_world, x_here), other: (there.K, there.cam_from_world, there.xy)}
    (K_a, T_a, x_a), (K_b, T_b, x_b) = views[0], views[1]
    return triangulate_track_pair(K_a[None], T_a[None], x_a, K_b[None], T_b[None], x_b), g


@dataclass(frozen=True)
class TwoViewPoints:
    """Triangulated points of two views, with the filter's verdict (leading shape S of the inputs)."""

    points_world: np.ndarray  # (*S,3) world units, NaN where not kept
    reprojection_px: np.ndarray  # (*S,) px, the larger of the two views' errors; NaN where not triangulated
    kept: np.ndarray  # (*S,) bool


def triangulate_track_pair(K_a: np.ndarray, a_from_world: np.ndarray, x_a: np.ndarray,
                           K_b: np.ndarray, b_from_world: np.ndarray, x_b: np.ndarray,
                           max_reprojection_px: float = MAX_REPROJECTION_PX,
                           min_ray_angle_deg: float = MIN_RAY_ANGLE_DEG) -> TwoViewPoints:
    """World points seen at x_a (...,2) px by camera a and at x_b (...,2) px by camera b (DLT),
    each camera at its own moment: K (...,3,3), *_from_world (...,4,4), all broadcast together.

    The one filter of the package: a point is kept when
    - its observations and both cameras are finite (NaN: not seen, camera unknown);
    - it lies in front of both cameras (cheirality);
    - it reprojects within max_reprojection_px in both views (wrong matches and a wrong offset
      make the rays miss each other);
    - its viewing rays meet at least at min_ray_angle_deg (near-parallel rays fix no depth).
    """
    P_a, P_b = projection_matrix(K_a, a_from_world), projection_matrix(K_b, b_from_world)
    X = triangulate_dlt(P_a, P_b, x_a, x_b)
    err_a, depth_a = reprojection_error(P_a, X, x_a)
    err_b, depth_b = reprojection_error(P_b, X, x_b)
    ray_a = X - camera_centers(a_from_world)
    ray_b = X - camera_centers(b_from_world)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.sum(ray_a * ray_b, -1) / (np.linalg.norm(ray_a, axis=-1) * np.linalg.norm(ray_b, axis=-1))
        angle_deg = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        kept = (depth_a > 0) & (depth_b > 0) & (err_a < max_reprojection_px) \
            & (err_b < max_reprojection_px) & (angle_deg >= min_ray_angle_deg)
    X = np.where(kept[..., None], X, np.nan)
    return TwoViewPoints(X, np.fmax(err_a, err_b), kept)
