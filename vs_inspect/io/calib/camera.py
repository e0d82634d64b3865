"""A camera as calibration files give it, validated: every bad field is an InputError naming
where it was found."""

from __future__ import annotations

import numpy as np

from ...errors import InputError
from ...types import CameraCalibration

DIST_LENGTHS = (0, 4, 5, 8, 12, 14)  # OpenCV accepts these numbers of distortion coefficients


def make_camera(where: str, K, dist, cam_from_world, size) -> CameraCalibration:
    """Build a CameraCalibration, raising InputError naming `where` for every bad field."""
    try:
        K = np.asarray(K, dtype=np.float64)
        dist = np.asarray([] if dist is None else dist, dtype=np.float64).reshape(-1)
        T = np.asarray(cam_from_world, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: calibration values are not numbers ({exc})") from None
    if K.shape != (3, 3):
        raise InputError(f"{where}: K must be 3x3, got shape {K.shape}")
    if T.shape[-2:] == (3, 4):
        bottom = np.broadcast_to([0.0, 0, 0, 1], T.shape[:-2] + (1, 4))
        T = np.concatenate([T, bottom], axis=-2)
    if T.shape[-2:] != (4, 4) or T.ndim not in (2, 3) or (T.ndim == 3 and len(T) == 0):
        raise InputError(f"{where}: cam_from_world must be 4x4 or a list of 4x4 (one per frame), "
                         f"got shape {T.shape}")
    for name, a in (("K", K), ("distortion", dist), ("cam_from_world", T)):
        if not np.all(np.isfinite(a)):
            raise InputError(f"{where}: {name} has NaN or inf values")
    if abs(np.linalg.det(K)) < 1e-9 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"{where}: K is singular or has a non-positive focal length: {K.tolist()}")
    if not np.allclose(K[2], [0, 0, 1], atol=1e-9):
        raise InputError(f"{where}: the last row of K must be [0, 0, 1], got {K[2].tolist()}")
    if dist.size not in DIST_LENGTHS:
        raise InputError(
            f"{where}: {dist.size} distortion coefficients; OpenCV takes {DIST_LENGTHS[1:]}"
        )
    if dist.size == 0:
        dist = np.zeros(5)
    R = T[..., :3, :3]
    err = np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(3)).max()
    if err > 1e-4 or np.any(np.linalg.det(R) <= 0) or not np.allclose(T[..., 3, :], [0, 0, 0, 1]):
        raise InputError(f"{where}: cam_from_world is not a rigid transform (|RRᵀ-I| = {err:.2g})")
    if size is not None:
        try:
            w, h = (int(s) for s in size)
        except (TypeError, ValueError):
            raise InputError(f"{where}: size must be [width, height], got {size!r}") from None
        if w < 1 or h < 1:
            raise InputError(f"{where}: size must be positive, got {size!r}")
        size = (w, h)
    return CameraCalibration(K, dist, T, size)


def rt_matrix(R, t) -> np.ndarray:
    """(4,4) world -> camera transform from R (3,3) and t (3,)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return T


def scaled_translation(T: np.ndarray, s: float) -> np.ndarray:
    """cam_from_world (4,4) or (T,4,4) with its translation times s (a change of length unit)."""
    T = T.copy()
    T[..., :3, 3] *= s
    return T
