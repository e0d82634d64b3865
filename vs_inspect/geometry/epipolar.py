"""Fundamental matrices between two cameras at two moments, and the paper's four residuals.

Convention: F_ab maps a point of b to its epipolar line in a, so x_aᵀ F_ab x_b = 0.
Everything is vectorized over leading dimensions.
"""

from __future__ import annotations

import numpy as np

from ._shapes import check_shape

RESIDUALS = ("sampson", "symmetric", "cosine", "algebraic")


def skew(v: np.ndarray) -> np.ndarray:
    """(...,3) -> (...,3,3) cross-product matrix [v]x."""
    v = check_shape("v", np.asarray(v, dtype=np.float64), (3,))
    z = np.zeros(v.shape[:-1])
    return np.stack([
        np.stack([z, -v[..., 2], v[..., 1]], -1),
        np.stack([v[..., 2], z, -v[..., 0]], -1),
        np.stack([-v[..., 1], v[..., 0], z], -1),
    ], -2)


def camera_centers(cam_from_world: np.ndarray) -> np.ndarray:
    """(...,3) camera centres in world coordinates, C = -Rᵀ t, of (...,4,4) cam_from_world."""
    T = check_shape("cam_from_world", np.asarray(cam_from_world, dtype=np.float64), (4, 4))
    return -np.einsum("...ji,...j->...i", T[..., :3, :3], T[..., :3, 3])


def relative_pose(a_from_world: np.ndarray, b_from_world: np.ndarray) -> np.ndarray:
    """(...,4,4) a_from_b = a_from_world · inverse(b_from_world)."""
    check_shape("a_from_world", a_from_world, (4, 4))
    check_shape("b_from_world", b_from_world, (4, 4))
    R_b, t_b = b_from_world[..., :3, :3], b_from_world[..., :3, 3]
    world_from_b = np.zeros(np.broadcast_shapes(a_from_world.shape, b_from_world.shape))
    world_from_b[..., :3, :3] = np.swapaxes(R_b, -1, -2)
    world_from_b[..., :3, 3] = -np.einsum("...ji,...j->...i", R_b, t_b)
    world_from_b[..., 3, 3] = 1.0
    return a_from_world @ world_from_b


def fundamental_from_cameras(K_a: np.ndarray, a_from_world: np.ndarray,
                             K_b: np.ndarray, b_from_world: np.ndarray) -> np.ndarray:
    """(...,3,3) F_ab with x_aᵀ F_ab x_b = 0 for a 3D point seen by camera a and camera b.

    Each camera is taken at its own moment, so a moving camera contributes the pose it had then.
    F is scaled to unit Frobenius norm (the residuals below are scale-invariant except algebraic).
    """
    check_shape("K_a", K_a, (3, 3))
    check_shape("K_b", K_b, (3, 3))
    a_from_b = relative_pose(np.asarray(a_from_world, float), np.asarray(b_from_world, float))
    R, t = a_from_b[..., :3, :3], a_from_b[..., :3, 3]
    E = skew(t) @ R
    F = np.swapaxes(np.linalg.inv(K_a), -1, -2) @ E @ np.linalg.inv(K_b)
    norm = np.linalg.norm(F, axis=(-2, -1), keepdims=True)
    return F / np.where(norm > 0, norm, 1.0)


def _homogeneous(x: np.ndarray) -> np.ndarray:
    return np.concatenate([x, np.ones(x.shape[:-1] + (1,), dtype=x.dtype)], axis=-1)


def _lines_in_a(F_ab: np.ndarray, xb_h: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", F_ab, xb_h)


def epipolar_lines(F_ab: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """(...,3) lines l = (a, b, c), a·x + b·y + c = 0 in image a, of points x_b (...,2) px of image b.

    F_ab (...,3,3) with x_aᵀ F_ab x_b = 0, broadcast against x_b's leading dims. For lines in b of
    points of a, pass F_abᵀ (np.swapaxes(F_ab, -1, -2)). NaN in, NaN out.
    """
    check_shape("F_ab", F_ab, (3, 3))
    x_b = check_shape("x_b", np.asarray(x_b, dtype=np.float64), (2,))
    return _lines_in_a(np.asarray(F_ab, dtype=np.float64), _homogeneous(x_b))


def line_distance(lines: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(...) px: distance of points x (...,2) px to lines (...,3) in the same image (broadcast)."""
    l = check_shape("lines", np.asarray(lines, dtype=np.float64), (3,))
    x = check_shape("x", np.asarray(x, dtype=np.float64), (2,))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.abs(l[..., 0] * x[..., 0] + l[..., 1] * x[..., 1] + l[..., 2]) \
            / np.hypot(l[..., 0], l[..., 1])


def epipolar_residual(F_ab: np.ndarray, x_a: np.ndarray, x_b: np.ndarray,
                      kind: str = "sampson") -> np.ndarray:
    """Residual of x_aᵀ F_ab x_b = 0, broadcast over leading dims. x_a, x_b: (...,2) px.

    sampson:   (x_aᵀFx_b)² / (|(Fx_b)_12|² + |(Fᵀx_a)_12|²)          px²
    symmetric: (x_aᵀFx_b)² (1/|(Fx_b)_12|² + 1/|(Fᵀx_a)_12|²)         px²
    cosine:    (x_aᵀFx_b)² (1/(|x_a|²|Fx_b|²) + 1/(|Fᵀx_a|²|x_b|²))   unitless (homogeneous norms)
    algebraic: |x_aᵀFx_b|                                             depends on F's scale
    """
    if kind not in RESIDUALS:
        raise ValueError(f"unknown residual {kind!r}; choose one of {RESIDUALS}")
    check_shape("F_ab", F_ab, (3, 3))
    xa = _homogeneous(check_shape("x_a", np.asarray(x_a, dtype=np.float64), (2,)))
    xb = _homogeneous(check_shape("x_b", np.asarray(x_b, dtype=np.float64), (2,)))
    l_a = _lines_in_a(F_ab, xb)  # line in a
    l_b = np.einsum("...ji,...j->...i", F_ab, xa)  # line in b
    num = np.einsum("...i,...i->...", xa, l_a)
    if kind == "algebraic":
        return np.abs(num)
    num2 = num * num
    na = l_a[..., 0] ** 2 + l_a[..., 1] ** 2
    nb = l_b[..., 0] ** 2 + l_b[..., 1] ** 2
    if kind == "sampson":
        return num2 / (na + nb)
    if kind == "symmetric":
        return num2 * (1.0 / na + 1.0 / nb)
    return num2 * (1.0 / (np.sum(xa * xa, -1) * np.sum(l_a * l_a, -1))
                   + 1.0 / (np.sum(l_b * l_b, -1) * np.sum(xb * xb, -1)))


def project(K: np.ndarray, cam_from_world: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(...,3) world points -> (...,2) px. Points behind the camera come out NaN."""
    check_shape("K", K, (3, 3))
    check_shape("cam_from_world", cam_from_world, (4, 4))
    check_shape("X", X, (3,))
    Xc = np.einsum("...ij,...j->...i", cam_from_world[..., :3, :3], X) + cam_from_world[..., :3, 3]
    uvw = np.einsum("...ij,...j->...i", K, Xc)
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = uvw[..., :2] / uvw[..., 2:3]
    xy[Xc[..., 2] <= 1e-9] = np.nan
    return xy


def look_at(center: np.ndarray, target: np.ndarray, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(4,4) cam_from_world of a camera at center looking at target (OpenCV: x right, y down, z ahead)."""
    center, target, up = (np.asarray(v, dtype=np.float64) for v in (center, target, up))
    for name, v in (("center", center), ("target", target), ("up", up)):
        check_shape(name, v, (3,), batched=False)
    z = target - center
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:
        x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = -R @ center
    return T


def clip_lines(lines: np.ndarray, width: int, height: int) -> np.ndarray:
    """(...,2,2) end points of lines a·x + b·y + c = 0 (...,3) inside [0,W-1]x[0,H-1]; NaN if outside."""
    l = check_shape("lines", np.asarray(lines, float), (3,))
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
