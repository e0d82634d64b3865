"""Two-view linear triangulation (DLT) and reprojection checks, vectorized (pure)."""

from __future__ import annotations

import numpy as np


def projection_matrix(K: np.ndarray, cam_from_world: np.ndarray) -> np.ndarray:
    """(...,3,4) P = K [R | t] from (...,3,3) K and (...,4,4) cam_from_world."""
    return np.asarray(K, float) @ np.asarray(cam_from_world, float)[..., :3, :]


def triangulate_dlt(P_a: np.ndarray, P_b: np.ndarray, x_a: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """(...,3) world points from two views by the homogeneous DLT (Hartley & Zisserman 12.2).

    P_a, P_b: (...,3,4) projection matrices; x_a, x_b: (...,2) px. NaN in, NaN out.
    """
    P_a, P_b = np.asarray(P_a, float), np.asarray(P_b, float)
    x_a, x_b = np.asarray(x_a, float), np.asarray(x_b, float)
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
    Xh = np.concatenate([np.asarray(X, float), np.ones(np.shape(X)[:-1] + (1,))], axis=-1)
    y = np.einsum("...ij,...j->...i", np.asarray(P, float), Xh)
    with np.errstate(invalid="ignore", divide="ignore"):
        uv = y[..., :2] / y[..., 2:3]
    return np.linalg.norm(uv - np.asarray(x, float), axis=-1), y[..., 2]
