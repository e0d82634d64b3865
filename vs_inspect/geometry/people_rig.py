"""Cameras of several static views from their pairwise fundamental matrices and the points they
share, consistent over all of them: focal lengths from the F's (principal points at the image
centres, focal lengths in a range), relative poses from the essential matrices, chained along
a maximum spanning tree of the pairs (weighted by inliers), then a bundle adjustment of every
camera's pose and focal length with the shared points (scipy least_squares, robust loss,
sparse Jacobian). Pure numpy/scipy/OpenCV, no I/O.

Conventions: cam_from_world (4,4), x_cam = R X + t; F_ab with x_aᵀ F_ab x_b = 0; K = [[f, 0,
cx], [0, f, cy], [0, 0, 1]]. The world is the reference camera's frame; the scale is set by the
distance from the reference camera to the first camera chained to it (1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
from scipy.spatial.transform import Rotation

from ._shapes import check_shape
from .two_view import essential_from_fundamental, pose_from_fundamental


def intrinsics(focal_px: float, principal_point_px: np.ndarray) -> np.ndarray:
    """(3,3) K of a focal length and a principal point (2,) px, square pixels, no skew."""
    return np.array([[focal_px, 0.0, principal_point_px[0]], [0.0, focal_px, principal_point_px[1]], [0.0, 0.0, 1.0]])


def essential_cost(F_ab: np.ndarray, K_a: np.ndarray, K_b: np.ndarray) -> float:
    """(s1 - s2) / (s1 + s2) of K_aᵀ F_ab K_b's two largest singular values: 0 for an essential matrix."""
    s = np.linalg.svd(essential_from_fundamental(F_ab, K_a, K_b), compute_uv=False)
    return float((s[0] - s[1]) / (s[0] + s[1]))


@dataclass(frozen=True)
class PairF:
    """One pair's fundamental matrix between views a and b (indices), and how much it is trusted."""

    a: int
    b: int
    F_ab: np.ndarray  # (3,3) x_aᵀ F_ab x_b = 0, px
    weight: float  # e.g. its inlier correspondences


def focals_from_pairs(pairs: list[PairF], principal_points_px: np.ndarray, sizes_px: np.ndarray,
                      lo: float = 0.3, hi: float = 5.0, num: int = 64, sweeps: int = 4) -> np.ndarray:
    """(V,) focal length of each view (px) that makes every pair's K_aᵀ F_ab K_b closest to an
    essential matrix (weighted sum of essential_cost), each searched on num geometric steps
    between lo and hi times its size (sizes_px (V,): the larger image side), one view at a time
    (sweeps rounds); a view in no pair keeps its size."""
    pp = np.asarray(principal_points_px, np.float64)
    size = np.asarray(sizes_px, np.float64)
    check_shape("principal_points_px", pp, (None, 2), batched=False)
    V = len(pp)
    grids = [np.geomspace(lo * size[v], hi * size[v], num) for v in range(V)]
    focal = size.copy()
    for _ in range(sweeps):
        for v in range(V):
            mine = [p for p in pairs if v in (p.a, p.b)]
            if not mine:
                continue
            costs = []
            for f in grids[v]:
                trial = focal.copy()
                trial[v] = f
                costs.append(sum(p.weight * essential_cost(p.F_ab, intrinsics(trial[p.a], pp[p.a]),
                                                           intrinsics(trial[p.b], pp[p.b])) for p in mine))
            focal[v] = grids[v][int(np.argmin(costs))]
    return focal


@dataclass(frozen=True)
class PairPose:
    """One pair's relative pose (from its F and the cameras' K) and weight."""

    a: int
    b: int
    b_from_a: np.ndarray  # (4,4), unit translation
    weight: float


def pair_pose(F_ab: np.ndarray, K_a: np.ndarray, K_b: np.ndarray, x_a: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """(4,4) b_from_a (unit t) of F_ab with intrinsics K_a, K_b, by cheirality on x_a, x_b (M,2) px."""
    return pose_from_fundamental(F_ab, K_a, K_b, x_a, x_b)


def chain_poses(num_views: int, reference: int, pairs: list[PairPose]) -> dict[int, np.ndarray]:
    """{view: (4,4) cam_from_world} of the views the pairs connect to the reference, along a
    maximum spanning tree of the pair weights; the reference is the world (identity); each
    tree edge keeps its unit translation (the bundle adjustment sets the scales)."""
    W = np.zeros((num_views, num_views))
    pose = {}
    for p in pairs:
        w = -max(float(p.weight), 1e-9)  # a minimum spanning tree of negated weights
        if w < W[p.a, p.b]:
            W[p.a, p.b] = W[p.b, p.a] = w
            pose[(p.a, p.b)] = p.b_from_a
            pose[(p.b, p.a)] = np.linalg.inv(p.b_from_a)
    tree = minimum_spanning_tree(W)
    tree = tree + tree.T
    order, parent = breadth_first_order(tree, reference, directed=False)
    out = {reference: np.eye(4)}
    for v in order[1:]:
        u = int(parent[v])
        out[int(v)] = pose[(u, int(v))] @ out[u]  # v_from_world = v_from_u · u_from_world
    return out


def triangulate_views(P: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(3,) world point seen by the views P (n,3,4) at x (n,2) px, n >= 2 (homogeneous DLT)."""
    A = np.concatenate([x[:, 0:1] * P[:, 2] - P[:, 0], x[:, 1:2] * P[:, 2] - P[:, 1]])
    A /= np.linalg.norm(A, axis=1, keepdims=True) + 1e-300
    X = np.linalg.svd(A)[2][-1]
    return X[:3] / X[3] if abs(X[3]) > 1e-12 else np.full(3, np.nan)


@dataclass(frozen=True)
class Observations:
    """Points seen by views: one row per sighting."""

    point: np.ndarray  # (M,) int, index of the 3D point
    view: np.ndarray  # (M,) int, index of the view
    xy: np.ndarray  # (M,2) px
    unit: np.ndarray  # (M,) px, the sighting's noise (residuals are divided by it)

    def __post_init__(self) -> None:
        M = len(self.point)
        for name, arr, shape in (("view", self.view, (M,)), ("xy", self.xy, (M, 2)), ("unit", self.unit, (M,))):
            if np.shape(arr) != shape:
                raise ValueError(f"Observations.{name} must be {shape}, got {np.shape(arr)}")


def _triangulate_all(T: dict[int, np.ndarray], focal: dict[int, float], pp: np.ndarray, point: np.ndarray,
                     view: np.ndarray, xy: np.ndarray, N: int) -> np.ndarray:
    """(N,3) every point seen by two views of T or more (NaN: not, or behind one of them)."""
    P = {v: intrinsics(focal[v], pp[v]) @ T[v][:3] for v in T}
    X = np.full((N, 3), np.nan)
    sel = np.isin(view, list(T))
    point, view, xy = point[sel], view[sel], xy[sel]
    order = np.argsort(point, kind="stable")
    bounds = np.searchsorted(point[order], np.arange(N + 1))
    for n in range(N):
        rows = order[bounds[n]:bounds[n + 1]]
        if len(np.unique(view[rows])) >= 2:
            Xn = triangulate_views(np.stack([P[v] for v in view[rows]]), xy[rows])
            depth = [(T[v][:3, :3] @ Xn + T[v][:3, 3])[2] for v in view[rows]]
            if np.all(np.asarray(depth) > 0):
                X[n] = Xn
    return X


def register_views(chained: dict[int, np.ndarray], focal_px: dict[int, float], principal_points_px: np.ndarray,
                   obs: Observations, reference: int, order: list[int]) -> dict[int, np.ndarray]:
    """Poses of the chained views with consistent scales: the reference and the first view of
    order as chained (unit baseline), then each next view resected (OpenCV's RANSAC PnP) from the
    points the views placed so far triangulate, when it sees at least 12 of them; else it keeps
    its chained pose, moved to the scale of the placed views."""
    import cv2

    pp = np.asarray(principal_points_px, np.float64)
    N = int(obs.point.max()) + 1 if len(obs.point) else 0
    placed = {reference: chained[reference]}
    if len(order) > 0:
        placed[order[0]] = chained[order[0]]
    for v in order[1:]:
        X = _triangulate_all(placed, focal_px, pp, obs.point, obs.view, obs.xy, N)
        rows = (obs.view == v) & np.isfinite(X[obs.point]).all(1)
        T = chained[v]
        if rows.sum() >= 12:
            ok, rvec, tvec, inl = cv2.solvePnPRansac(X[obs.point[rows]].astype(np.float64), obs.xy[rows].astype(np.float64),
                                                     intrinsics(focal_px[v], pp[v]), None,
                                                     reprojectionError=float(4 * np.median(obs.unit[rows])),
                                                     iterationsCount=200)
            if ok and inl is not None and len(inl) >= 8:
                T = np.eye(4)
                T[:3, :3] = cv2.Rodrigues(rvec)[0]
                T[:3, 3] = tvec.ravel()
        placed[v] = T
    return placed


@dataclass(frozen=True)
class AdjustedRig:
    """A bundle adjustment's result."""

    cam_from_world: dict[int, np.ndarray]  # view -> (4,4)
    focal_px: dict[int, float]  # view -> focal length, px
    points: np.ndarray  # (N,3) world points (NaN: not triangulated)
    residual_px: np.ndarray  # (M,) reprojection distance of each sighting, px (NaN: its point is not)
    cost_start: float  # robust cost before, in noise units
    cost_end: float  # and after


def _project(params_cam: np.ndarray, pp: np.ndarray, X: np.ndarray) -> np.ndarray:
    R = Rotation.from_rotvec(params_cam[:, :3]).as_matrix()
    Xc = np.einsum("mij,mj->mi", R, X) + params_cam[:, 3:6]
    with np.errstate(invalid="ignore", divide="ignore"):
        return params_cam[:, 6:7] * Xc[:, :2] / Xc[:, 2:3] + pp


def bundle_adjust(cam_from_world: dict[int, np.ndarray], focal_px: dict[int, float], principal_points_px: np.ndarray,
                  obs: Observations, reference: int, focal_bounds_px: dict[int, tuple[float, float]] | None = None,
                  max_nfev: int = 60, loss_scale: float = 1.0) -> AdjustedRig:
    """Poses and focal lengths of the views in cam_from_world (the reference's pose held at the
    identity), with the points obs sees from two or more of them: triangulated first, then all
    adjusted together (soft L1 on reprojection distances in noise units; the reference-to-nearest
    camera distance held at its start). focal_bounds_px: {view: (lo, hi)}."""
    views = sorted(cam_from_world)
    index = {v: i for i, v in enumerate(views)}
    pp = np.asarray(principal_points_px, np.float64)
    use = np.isin(obs.view, views)
    point, view, xy, unit = obs.point[use], obs.view[use], obs.xy[use], obs.unit[use]
    # triangulate every point seen by two views or more, in front of them all
    N = int(obs.point.max()) + 1 if len(obs.point) else 0
    X = _triangulate_all(cam_from_world, focal_px, pp, point, view, xy, N)
    good = np.isfinite(X).all(1)
    keep = good[point]
    point, view, xy, unit = point[keep], view[keep], xy[keep], unit[keep]
    pts = np.unique(point)
    pindex = np.full(N, -1)
    pindex[pts] = np.arange(len(pts))

    def pack(T: dict, f: dict, Xs: np.ndarray) -> np.ndarray:
        cams = [np.r_[Rotation.from_matrix(T[v][:3, :3]).as_rotvec(), T[v][:3, 3], f[v]] for v in views]
        return np.r_[np.concatenate(cams), Xs.ravel()]

    nc = 7 * len(views)
    ref = index[reference]
    fixed = np.zeros(nc, bool)
    fixed[7 * ref:7 * ref + 6] = True  # the reference's pose
    free = np.r_[~fixed, np.ones(3 * len(pts), bool)]
    x0 = pack(cam_from_world, focal_px, X[pts])
    ci = np.array([index[v] for v in view])
    pi = pindex[point]
    anchor, anchor_dist = _scale_anchor(cam_from_world, views, reference)

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        full = x0.copy()
        full[free] = x
        return full[:nc].reshape(-1, 7), full[nc:].reshape(-1, 3)

    def residuals(x: np.ndarray) -> np.ndarray:
        cams, Xs = unpack(x)
        r = (_project(cams[ci], pp[view], Xs[pi]) - xy) / unit[:, None]
        r = np.where(np.isfinite(r), r, 10.0).ravel()
        if anchor is not None:
            c = cams[index[anchor]]
            C = -Rotation.from_rotvec(c[:3]).as_matrix().T @ c[3:6]
            r = np.r_[r, 100.0 * (np.linalg.norm(C) / anchor_dist - 1.0)]
        return r

    S, cols, colpos = _jacobian_sparsity(point, free, ci, pi, nc, anchor, index)
    lo_b, hi_b = _focal_bounds(views, index, cols, colpos, focal_bounds_px)
    xs = x0[free].copy()
    xs = np.clip(xs, lo_b + 1e-9, hi_b - 1e-9)
    r0 = residuals(xs)
    sol = least_squares(residuals, xs, jac_sparsity=S.tocsr(), loss="soft_l1", f_scale=loss_scale, x_scale="jac",
                        tr_solver="lsmr", bounds=(lo_b, hi_b), max_nfev=max_nfev, method="trf")
    cams, Xs = unpack(sol.x)
    T_out, f_out = _poses_and_focals(cams, views, index)
    X_out = np.full((N, 3), np.nan)
    X_out[pts] = Xs
    res = np.full(len(obs.point), np.nan)
    proj = _project(cams[ci], pp[view], Xs[pi])
    res[np.flatnonzero(use)[keep]] = np.linalg.norm(proj - xy, axis=1)

    def robust(r: np.ndarray) -> float:
        z = (r / loss_scale) ** 2
        return float(np.sum(2 * (np.sqrt(1 + z) - 1)))

    return AdjustedRig(T_out, f_out, X_out, res, robust(r0), robust(sol.fun))


def _scale_anchor(cam_from_world: dict[int, np.ndarray], views: list[int], reference: int) -> tuple[int | None, float]:
    """(the view whose camera centre is nearest the reference's (None: no other view), that
    distance (1 without one)): the bundle adjustment holds it, which fixes the scale."""
    # the scale: the nearest camera to the reference stays at its distance
    centres = {v: -cam_from_world[v][:3, :3].T @ cam_from_world[v][:3, 3] for v in views}
    others = [v for v in views if v != reference]
    anchor = min(others, key=lambda v: np.linalg.norm(centres[v] - centres[reference])) if others else None
    anchor_dist = float(np.linalg.norm(centres[anchor] - centres[reference])) if anchor is not None else 1.0
    return anchor, anchor_dist


def _jacobian_sparsity(point: np.ndarray, free: np.ndarray, ci: np.ndarray, pi: np.ndarray, nc: int,
                       anchor: int | None, index: dict[int, int]) -> tuple[lil_matrix, np.ndarray, np.ndarray]:
    """(S, cols, colpos): which free parameters each residual depends on (two rows per sighting:
    its camera's 7 and its point's 3; one last row for the anchor's distance), the free
    parameters' indices among all, and each parameter's column among the free ones (-1: fixed)."""
    M = len(point)
    cols = np.flatnonzero(free)
    colpos = np.full(len(free), -1)
    colpos[cols] = np.arange(len(cols))
    S = lil_matrix((2 * M + (anchor is not None), len(cols)), dtype=np.int8)
    rows = np.arange(M)
    for k in range(7):
        c = colpos[7 * ci + k]
        ok = c >= 0
        S[2 * rows[ok], c[ok]] = 1
        S[2 * rows[ok] + 1, c[ok]] = 1
    for k in range(3):
        c = colpos[nc + 3 * pi + k]
        S[2 * rows, c] = 1
        S[2 * rows + 1, c] = 1
    if anchor is not None:
        for k in range(6):
            c = colpos[7 * index[anchor] + k]
            if c >= 0:
                S[2 * M, c] = 1
    return S, cols, colpos


def _focal_bounds(views: list[int], index: dict[int, int], cols: np.ndarray, colpos: np.ndarray,
                  focal_bounds_px: dict[int, tuple[float, float]] | None) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) bounds of the free parameters: each view's focal length within its
    focal_bounds_px (default above 1e-3 px), the rest unbounded."""
    lo_b = np.full(len(cols), -np.inf)
    hi_b = np.full(len(cols), np.inf)
    for v in views:
        c = colpos[7 * index[v] + 6]
        lo, hi = (focal_bounds_px or {}).get(v, (1e-3, np.inf))
        lo_b[c], hi_b[c] = lo, hi
    return lo_b, hi_b


def _poses_and_focals(cams: np.ndarray, views: list[int], index: dict[int, int]
                      ) -> tuple[dict[int, np.ndarray], dict[int, float]]:
    """({view: cam_from_world (4,4)}, {view: focal px}) from the adjusted parameters (V,7): rotation
    vector, translation, focal length per view."""
    T_out, f_out = {}, {}
    for v in views:
        T = np.eye(4)
        T[:3, :3] = Rotation.from_rotvec(cams[index[v], :3]).as_matrix()
        T[:3, 3] = cams[index[v], 3:6]
        T_out[v], f_out[v] = T, float(cams[index[v], 6])
    return T_out, f_out
