"""Two-view geometry from correspondences, in one place: the fundamental matrix by robust
estimation (OpenCV's USAC MAGSAC or RANSAC), a focal length from F, the nearest calibrated F, the
relative pose of an essential matrix (OpenCV's cheirality test), and Sampson distances.

One convention throughout, geometry.epipolar's: F_ab with x_aᵀ F_ab x_b = 0 for pixel points x_a
of camera a and x_b of camera b, K_a and K_b their (3,3) intrinsics, and the pose b_from_a (4,4)
with x_b = R x_a + t in camera coordinates. OpenCV's own order (points2ᵀ F points1 = 0) is turned
into it here and nowhere else. Pure numpy/OpenCV, no I/O.
"""

from __future__ import annotations

import cv2
import numpy as np

from ._shapes import check_shape
from .epipolar import epipolar_residual

ROBUST_METHODS = {"magsac": cv2.USAC_MAGSAC, "ransac": cv2.FM_RANSAC}


def fundamental_ransac(x_a: np.ndarray, x_b: np.ndarray, threshold_px: float, confidence: float = 0.999,
                       max_iters: int = 2000, method: str = "magsac"
                       ) -> tuple[np.ndarray | None, np.ndarray]:
    """(F_ab (3,3) or None, inliers (M,) bool) robustly fitted to x_a, x_b (M,2) px: method
    "magsac" (OpenCV's USAC_MAGSAC) or "ransac" (FM_RANSAC), threshold_px its inlier distance.
    None (and no inlier) when OpenCV finds no single F or fails on a degenerate sample."""
    x_a = np.asarray(x_a, dtype=np.float64)
    x_b = np.asarray(x_b, dtype=np.float64)
    check_shape("x_a", x_a, (None, 2), batched=False)
    check_shape("x_b", x_b, (len(x_a), 2), batched=False)
    none = (None, np.zeros(len(x_a), bool))
    if method not in ROBUST_METHODS:
        raise ValueError(f"unknown robust method {method!r}; choose one of {sorted(ROBUST_METHODS)}")
    try:
        F, mask = cv2.findFundamentalMat(x_a, x_b, ROBUST_METHODS[method], threshold_px, confidence, max_iters)
    except cv2.error:  # OpenCV 5's USAC asserts on some degenerate samples instead of failing softly
        return none
    if F is None or F.shape != (3, 3):
        return none
    inliers = np.zeros(len(x_a), bool) if mask is None else mask.ravel().astype(bool)
    return F.T, inliers  # OpenCV's F has x_bᵀ F x_a = 0


def focal_from_fundamental(F_ab: np.ndarray, pp_a: np.ndarray, pp_b: np.ndarray, size_px: float,
                           lo: float = 0.3, hi: float = 5.0, num: int = 160) -> float:
    """The focal length (px) shared by both cameras, principal points pp_a, pp_b (2,) px, that
    makes K_aᵀ F_ab K_b closest to an essential matrix (two equal singular values), searched on
    num geometric steps between lo and hi times size_px."""
    F_ab = np.asarray(F_ab, dtype=np.float64)
    check_shape("F_ab", F_ab, (3, 3), batched=False)
    best, best_f = np.inf, size_px
    for f in np.geomspace(lo * size_px, hi * size_px, num):
        K_a = np.array([[f, 0, pp_a[0]], [0, f, pp_a[1]], [0, 0, 1]])
        K_b = np.array([[f, 0, pp_b[0]], [0, f, pp_b[1]], [0, 0, 1]])
        s = np.linalg.svd(K_a.T @ F_ab @ K_b, compute_uv=False)
        cost = (s[0] - s[1]) / (s[0] + s[1])
        if cost < best:
            best, best_f = cost, f
    return float(best_f)


def essential_from_fundamental(F_ab: np.ndarray, K_a: np.ndarray, K_b: np.ndarray) -> np.ndarray:
    """(3,3) E_ab = K_aᵀ F_ab K_b: x̂_aᵀ E_ab x̂_b = 0 in normalized coordinates x̂ = K⁻¹ x."""
    for name, M in (("F_ab", F_ab), ("K_a", K_a), ("K_b", K_b)):
        check_shape(name, np.asarray(M), (3, 3), batched=False)
    return np.asarray(K_a, np.float64).T @ np.asarray(F_ab, np.float64) @ np.asarray(K_b, np.float64)


def nearest_calibrated_fundamental(F_ab: np.ndarray, K_a: np.ndarray, K_b: np.ndarray) -> np.ndarray:
    """(3,3) the F_ab whose essential matrix is the one nearest to F_ab's (singular values set to
    1, 1, 0): a calibrated camera pair's F closest to an uncalibrated fit."""
    U, _, Vt = np.linalg.svd(essential_from_fundamental(F_ab, K_a, K_b))
    return np.linalg.inv(K_a).T @ (U @ np.diag([1.0, 1.0, 0.0]) @ Vt) @ np.linalg.inv(K_b)


def normalized_points(x: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(M,2) pixel points x (M,2) in normalized camera coordinates K⁻¹ x (no lens distortion)."""
    x = np.asarray(x, dtype=np.float64)
    check_shape("x", x, (None, 2), batched=False)
    check_shape("K", np.asarray(K), (3, 3), batched=False)
    if not len(x):
        return np.zeros((0, 2))
    return cv2.undistortPoints(x.reshape(-1, 1, 2), np.asarray(K, np.float64), None).reshape(-1, 2)


def pose_from_essential(E_ab: np.ndarray, n_a: np.ndarray, n_b: np.ndarray,
                        mask: np.ndarray | None = None) -> np.ndarray:
    """(4,4) b_from_a (t of unit length) of E_ab and normalized points n_a, n_b (M,2): of the
    four decompositions, the one that puts most points in front of both cameras (OpenCV's
    recoverPose); mask (M,) restricts the test to those points."""
    check_shape("E_ab", np.asarray(E_ab), (3, 3), batched=False)
    E_cv = np.asarray(E_ab, np.float64).T  # OpenCV: x̂_bᵀ E x̂_a = 0
    kw = {} if mask is None else {"mask": np.asarray(mask, np.uint8).reshape(-1, 1)}
    _, R, t, _ = cv2.recoverPose(E_cv, np.asarray(n_a, np.float64), np.asarray(n_b, np.float64), np.eye(3), **kw)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t.ravel()
    return T


def pose_from_fundamental(F_ab: np.ndarray, K_a: np.ndarray, K_b: np.ndarray, x_a: np.ndarray,
                          x_b: np.ndarray) -> np.ndarray:
    """(4,4) b_from_a (unit t) of F_ab for cameras K_a, K_b, chosen by cheirality on the pixel
    correspondences x_a, x_b (M,2)."""
    return pose_from_essential(essential_from_fundamental(F_ab, K_a, K_b), normalized_points(x_a, K_a),
                               normalized_points(x_b, K_b))


def essential_ransac(n_a: np.ndarray, n_b: np.ndarray, threshold: float, confidence: float = 0.9999
                     ) -> tuple[np.ndarray | None, np.ndarray]:
    """(E_ab (3,3) or None, inliers (M,) bool) fitted by RANSAC to normalized points n_a, n_b
    (M,2); threshold in normalized units (pixels / focal)."""
    n_a = np.asarray(n_a, dtype=np.float64)
    n_b = np.asarray(n_b, dtype=np.float64)
    check_shape("n_a", n_a, (None, 2), batched=False)
    check_shape("n_b", n_b, (len(n_a), 2), batched=False)
    E, mask = cv2.findEssentialMat(n_a, n_b, np.eye(3), cv2.RANSAC, confidence, threshold)
    if E is None or E.shape != (3, 3):
        return None, np.zeros(len(n_a), bool)
    return E.T, mask.ravel().astype(bool)  # OpenCV's E has x̂_bᵀ E x̂_a = 0


def sampson_px(F_ab: np.ndarray, x_a: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """(...,) Sampson distance (px, not squared) of x_aᵀ F_ab x_b = 0; x_a, x_b (...,2), F_ab
    (3,3) or (...,3,3); NaN where a point is NaN or the distance is undefined."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(epipolar_residual(F_ab, x_a, x_b, "sampson"))


def signed_sampson_px(F_ab: np.ndarray, h_a: np.ndarray, h_b: np.ndarray) -> np.ndarray:
    """(P,) signed Sampson distance (px) of x_aᵀ F_ab x_b = 0 for homogeneous h_a, h_b (P,3)
    (last coordinate 1): the signed root of sampson_px, smooth at zero for least squares."""
    Fb, Fta = h_b @ F_ab.T, h_a @ F_ab
    num = np.sum(h_a * Fb, axis=1)
    return num / np.sqrt(Fb[:, 0] ** 2 + Fb[:, 1] ** 2 + Fta[:, 0] ** 2 + Fta[:, 1] ** 2 + 1e-300)


def _normalizing_transform(x: np.ndarray) -> np.ndarray:
    """(3,3) Hartley's similarity: centroid to 0, mean distance to √2."""
    c = x.mean(0)
    s = np.sqrt(2.0) / max(float(np.mean(np.linalg.norm(x - c, axis=1))), 1e-12)
    return np.array([[s, 0, -s * c[0]], [0, s, -s * c[1]], [0, 0, 1.0]])


def fundamental_irls(x_a: np.ndarray, x_b: np.ndarray, F0: np.ndarray, scale_px, iterations: int = 6
                     ) -> np.ndarray:
    """(3,3) F_ab that minimizes Σ ρ(Sampson distance / scale) over x_a, x_b (M,2) px, ρ Cauchy's
    with scale scale_px (a number, or (M,) px per correspondence): iteratively reweighted
    normalized 8-point from F0 (3,3), rank 2 each step. Deterministic and smooth in the points,
    unlike a RANSAC fit (for landscapes over a shift)."""
    x_a = np.asarray(x_a, dtype=np.float64)
    x_b = np.asarray(x_b, dtype=np.float64)
    check_shape("x_a", x_a, (None, 2), batched=False)
    check_shape("x_b", x_b, (len(x_a), 2), batched=False)
    check_shape("F0", np.asarray(F0), (3, 3), batched=False)
    if len(x_a) < 8:
        raise ValueError(f"fundamental_irls needs at least 8 correspondences, got {len(x_a)}")
    scale2 = np.broadcast_to(np.asarray(scale_px, dtype=np.float64), (len(x_a),)) ** 2
    Ta, Tb = _normalizing_transform(x_a), _normalizing_transform(x_b)
    na = x_a * Ta[0, 0] + Ta[:2, 2]
    nb = x_b * Tb[0, 0] + Tb[:2, 2]
    ha = np.concatenate([na, np.ones((len(na), 1))], 1)
    hb = np.concatenate([nb, np.ones((len(nb), 1))], 1)
    A = (ha[:, :, None] * hb[:, None, :]).reshape(-1, 9)  # x_aᵀ F x_b = A vec(F), F row-major
    F = np.asarray(F0, np.float64)
    for _ in range(iterations):
        la = x_b @ F[:, :2].T + F[:, 2]  # F x_b
        lb = x_a @ F[:2] + F[2]  # Fᵀ x_a
        g2 = np.maximum(la[:, 0] ** 2 + la[:, 1] ** 2 + lb[:, 0] ** 2 + lb[:, 1] ** 2, 1e-300)
        r = x_a[:, 0] * la[:, 0] + x_a[:, 1] * la[:, 1] + la[:, 2]
        w = 1.0 / (g2 * (1.0 + r * r / g2 / scale2))
        # the normalized problem's algebraic residual is the pixel one times a constant
        _, vecs = np.linalg.eigh((A * w[:, None]).T @ A)
        U, S, Vt = np.linalg.svd(vecs[:, 0].reshape(3, 3))
        F = Ta.T @ (U @ np.diag([S[0], S[1], 0.0]) @ Vt) @ Tb
        F = F / np.linalg.norm(F)
    return F
