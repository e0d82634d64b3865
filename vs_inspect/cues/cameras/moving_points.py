"""Cameras from the moving points themselves, for static cameras whose background does not
reconstruct (wide baselines, textureless or repetitive walls).

For a reference video r and each other static video v: search the time offset whose aligned
track pairs (x_r(t + Δ), x_v(t)) give the most consistent fundamental matrix (RANSAC inlier
share, as in unsynchronized two-view geometry; with three or more static cameras the offsets of
all of them together, every pair's share summed with its triangles closed), self-calibrate one
focal length per pair (the f that makes K_rᵀ F_rv K_v closest to an essential matrix, principal
points at the image centres), decompose into a relative pose, and fix the scale of every pair
from points triangulated on the reference's tracks. With three or more cameras, one focal per
camera and every pose are then fitted to the track pairs of all camera pairs at once (scipy
least squares, Cauchy loss), started from the per-pair focals and from a few shared guesses: one
pair's focal is ill-posed when the optical axes nearly meet, as they do around a scene. Pure
functions of arrays; the coarse offsets found here are only used to build the cameras, Stage 1
searches the offsets again.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ...geometry.epipolar import epipolar_residual, fundamental_from_cameras
from ...geometry.offsets import OffsetGrid, span_of
from ...geometry.two_view import (essential_from_fundamental, focal_from_fundamental, fundamental_ransac, normalized_points, pose_from_essential, signed_sampson_px)
from ...types import CameraTrack, TrackPairs, VideoInfo

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PairGeometry:
    offset_s: float  # coarse Δ_rv, seconds
    F: np.ndarray  # (3,3) F_rv: x_rᵀ F x_v = 0 (full-resolution px)
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


@dataclass(frozen=True)
class OffsetCurve:
    """How well one F explains a pair's aligned track pairs at each coarse offset Δ_ab (offsets
    with at least min_share_of_max of the largest overlap only: a few correspondences fit any F)."""

    offsets_s: np.ndarray  # (K,) Δ_ab, seconds, increasing on the finer video's frame step
    step_s: float  # the grid step, seconds
    share: np.ndarray  # (K,) MAGSAC inlier share of the best F at each offset
    count: np.ndarray  # (K,) aligned correspondences used at each offset
    F: tuple  # K (3,3) arrays F_ab: x_aᵀ F x_b = 0 (full-resolution px)

    def at(self, delta_s: np.ndarray) -> np.ndarray:
        """share at the grid offsets nearest delta_s (any shape); NaN off the curve."""
        d = np.asarray(delta_s, np.float64)
        last = len(self.offsets_s) - 1
        right = np.clip(np.searchsorted(self.offsets_s, d), 0, last)
        left = np.clip(right - 1, 0, last)
        k = np.where(np.abs(self.offsets_s[left] - d) <= np.abs(self.offsets_s[right] - d), left, right)
        near = np.abs(self.offsets_s[k] - d) <= 0.5 * self.step_s + 1e-9
        return np.where(near, self.share[k], np.nan)


def offset_curve(xy_a, info_a, xy_b, info_b, index, min_corr: int = 40, thresh_px: float = 2.0,
                 max_corr: int = 2000, seed: int = 0, min_share_of_max: float = 0.5,
                 grid: OffsetGrid = OffsetGrid()) -> OffsetCurve | None:
    """The pair's OffsetCurve from its track pairs (index (P,2): track of a, track of b) over
    grid's candidate offsets on the finer video's frame step, or None when no offset aligns
    min_corr correspondences that one F can be fitted to."""
    if len(index) < 8:
        return None
    step = min(info_a.frame_interval_s, info_b.frame_interval_s)
    rng = np.random.default_rng(seed)
    cands = []
    for d in grid.pair_offsets(info_a.name, span_of(info_a.timestamps_s), info_b.name,
                               span_of(info_b.timestamps_s), step):
        A, B, _ = aligned_correspondences(xy_a, info_a, xy_b, info_b, index, d)
        if len(A) < min_corr:
            continue
        if len(A) > max_corr:
            sel = rng.choice(len(A), max_corr, replace=False)
            A, B = A[sel], B[sel]
        F, inl = fundamental_ransac(A, B, thresh_px, 0.999, 2000)
        if F is None:
            continue
        cands.append((float(d), float(inl.mean()), len(A), F))
    if not cands:
        return None
    n_max = max(c[2] for c in cands)
    kept = [c for c in cands if c[2] >= min_share_of_max * n_max]
    return OffsetCurve(np.array([c[0] for c in kept]), step, np.array([c[1] for c in kept]),
                       np.array([c[2] for c in kept]), tuple(c[3] for c in kept))


def _geometry_at(curve: OffsetCurve, k: int, info_r: VideoInfo, info_v: VideoInfo) -> PairGeometry:
    """The PairGeometry of curve's offset k, with a focal self-calibrated from its F."""
    ca = np.array([(info_r.width - 1) / 2, (info_r.height - 1) / 2])
    cb = np.array([(info_v.width - 1) / 2, (info_v.height - 1) / 2])
    F = curve.F[k]
    f = focal_from_fundamental(F, ca, cb, float(max(info_r.width, info_r.height, info_v.width, info_v.height)))
    return PairGeometry(float(curve.offsets_s[k]), F, float(curve.share[k]), int(curve.count[k]), f)


def search_pair(xy_r, info_r, xy_v, info_v, index, **kwargs) -> PairGeometry | None:
    """Best coarse offset and F between r and v from their track pairs (offset_curve's options)."""
    curve = offset_curve(xy_r, info_r, xy_v, info_v, index, **kwargs)
    return None if curve is None else _geometry_at(curve, int(np.argmax(curve.share)), info_r, info_v)


def joint_coarse_offsets(ref: str, curves: dict[tuple[str, str], OffsetCurve], max_grid: int = 2_000_000
                         ) -> tuple[dict[str, int], float] | None:
    """Coarse offsets Δ_rv of every camera v with a curve against ref that together explain the
    most: the sum of every pair's inlier share at Δ_uv = Δ_rv − Δ_ru (a triangle must close, so a
    wrong peak of one pair is outvoted by the two pairs that go round it). ({v: index of Δ_rv in
    curves[(ref, v)].offsets_s}, the summed share), or None with fewer than two such cameras or no
    pair between them. Every combination of ref's curves' grid offsets is scored while there are at
    most max_grid; beyond, every k-th offset, then each camera's offset refined on its full grid
    with the others held."""
    others = sorted(v for (a, v) in curves if a == ref)
    linked = [k for k in curves if ref not in k and k[0] in others and k[1] in others]
    if len(others) < 2 or not linked:
        return None
    grids = [curves[(ref, v)].offsets_s for v in others]
    stride = 1
    while np.prod([float(len(g[::stride])) for g in grids]) > max_grid:
        stride += 1

    def score(ks: list[np.ndarray]) -> np.ndarray:  # ks: each camera's grid indices, broadcast together
        mesh = [g[k] for g, k in zip(grids, ks)]
        total = sum(curves[(ref, v)].share[k] for v, k in zip(others, ks))
        for a, b in linked:  # a pair with too little overlap there: NaN, not a candidate
            total = total + curves[(a, b)].at(mesh[others.index(b)] - mesh[others.index(a)])
        return np.nan_to_num(total, nan=-np.inf)

    ks = np.meshgrid(*[np.arange(0, len(g), stride) for g in grids], indexing="ij")
    total = score(ks)
    best = np.unravel_index(int(np.argmax(total)), total.shape)
    chosen = [int(k[best]) for k in ks]
    for _ in range(3 if stride > 1 else 0):
        for i, g in enumerate(grids):
            near = np.nonzero(np.abs(g - g[chosen[i]]) <= stride * curves[(ref, others[i])].step_s + 1e-9)[0]
            s_near = score([near if j == i else np.full(len(near), c) for j, c in enumerate(chosen)])
            chosen[i] = int(near[int(np.argmax(s_near))])
    best_score = float(score([np.array([c]) for c in chosen])[0])
    if not np.isfinite(best_score):
        return None
    return dict(zip(others, chosen)), best_score


def cameras_from_tracks(ref: str, infos: dict[str, VideoInfo], xy: dict[str, np.ndarray],
                        pairs: dict[tuple[str, str], TrackPairs], moving: dict[str, bool],
                        refine: bool = True, min_inlier_share: float = 0.2, max_median_fraction: float = 0.01,
                        joint: bool = True, grid: OffsetGrid = OffsetGrid()
                        ) -> tuple[dict[str, CameraTrack], dict[str, str], dict[str, dict]]:
    """Static cameras in the reference's camera frame: (cameras, unregistered reasons, details).

    A camera needs min_inlier_share of its correspondences with the reference within 2 px of the
    best F (right offsets score higher than wrong ones; the measured shares are in BENCHMARKS.md).
    joint: with two or more other static cameras that share track pairs, the coarse offsets are
    chosen together (joint_coarse_offsets: every pair's curve, triangles closed) instead of each
    camera's best with the reference alone; details["joint_offsets"] names the cameras it moved.
    refine: with three or more cameras, fit every focal and pose to all pairs at once
    (refine_cameras; details["joint_fit"] says how well); when the fit leaves the median track
    pair farther than max_median_fraction of the image diagonal from its epipolar line (Stage 1's
    inlier tolerance), no camera is returned. grid: the limits of the coarse offsets searched."""
    reasons: dict[str, str] = {}
    details: dict[str, dict] = {}
    found: dict[str, tuple] = {}  # name -> (PairGeometry, aligned correspondences with ref)
    info_r = infos[ref]
    curves: dict[tuple[str, str], OffsetCurve] = {}  # (ref, v) and (u, v) of the other static cameras
    index: dict[str, np.ndarray] = {}  # v -> its track pairs with ref, ref's track first
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
        curve = offset_curve(xy[ref], info_r, xy[v], infos[v], idx, grid=grid)
        if curve is None:
            reasons[v] = ("camera could not be registered: no consistent two-view geometry from the "
                          f"moving points shared with {ref}")
            continue
        curves[(ref, v)], index[v] = curve, idx
    chosen = {v: int(np.argmax(curves[(ref, v)].share)) for v in index}  # v -> index on its curve with ref
    if joint and len(index) >= 2:
        for (a, b), tp in sorted(pairs.items()):
            if a in index and b in index and len(tp.index) >= 8:
                curve = offset_curve(xy[a], infos[a], xy[b], infos[b], tp.index, grid=grid)
                if curve is not None:
                    curves[(a, b)] = curve
        together = joint_coarse_offsets(ref, curves)
        if together is not None:
            alone, (chosen, score) = chosen, together
            details["joint_offsets"] = {
                "pairs": len(curves), "summed_share": round(score, 3),
                "moved": {v: {"alone_s": round(float(curves[(ref, v)].offsets_s[alone[v]]), 4),
                              "together_s": round(float(curves[(ref, v)].offsets_s[chosen[v]]), 4)}
                          for v in chosen if chosen[v] != alone[v]}}
    for v, idx in index.items():
        g = _geometry_at(curves[(ref, v)], chosen[v], info_r, infos[v])
        if g.inlier_share < min_inlier_share:
            reasons[v] = ("camera could not be registered: no consistent two-view geometry from the "
                          f"moving points shared with {ref}")
            continue
        found[v] = (g, aligned_correspondences(xy[ref], info_r, xy[v], infos[v], idx, g.offset_s))
        details[v] = {"coarse_offset_s": round(g.offset_s, 4), "inlier_share": round(g.inlier_share, 3),
                      "correspondences": g.num_correspondences, "focal_px": round(g.focal_px, 1)}
    if not found:
        return {}, reasons, details
    cams, with_scale = _cameras_at(ref, infos, found, {v: g.focal_px for v, (g, _) in found.items()})
    for v in found:
        details[v]["scale_from_shared_points"] = with_scale[v]
    if refine and len(cams) >= 3:
        cams, refused = _fitted_together(ref, infos, xy, pairs, found, cams, details, max_median_fraction)
        if refused:
            return {}, reasons | refused, details
    return cams, reasons, details


def _fitted_together(ref: str, infos: dict[str, VideoInfo], xy: dict[str, np.ndarray],
                     pairs: dict[tuple[str, str], TrackPairs], found: dict[str, tuple], cams: dict[str, CameraTrack],
                     details: dict, max_median_fraction: float) -> tuple[dict[str, CameraTrack], dict[str, str]]:
    """(cameras, {camera: why} when refused) of refine_cameras on all pairs at once, started from the
    per-pair focals and from a few shared guesses (the joint fit is not convex); details["joint_fit"]
    says how well. Refused when the median track pair stays farther than max_median_fraction of the
    image diagonal from its epipolar line: the coarse offsets or the pairs are wrong."""
    size = float(np.median([max(i.width, i.height) for i in infos.values()]))
    coarse = {v: g.offset_s for v, (g, _) in found.items()}
    best = None
    for start in ["per pair"] + list(FOCAL_STARTS):
        init = cams if start == "per pair" else _cameras_at(ref, infos, found, {v: start * size for v in found})[0]
        fitted, fit = refine_cameras(init, ref, infos, xy, pairs, coarse)
        if "cost" in fit and (best is None or fit["cost"] < best[1]["cost"]):
            best = (fitted, fit | {"start": start if start == "per pair" else f"{start} x image size"})
    if best is None:
        return cams, {}
    details["joint_fit"] = best[1]
    tol_px = max_median_fraction * max(np.hypot(i.width, i.height) for i in infos.values())
    if best[1]["median_px_after"] > tol_px:
        why = (f"camera could not be registered: the cameras fitted to the moving points leave half "
               f"their track pairs more than {best[1]['median_px_after']:.1f} px from the epipolar "
               f"lines (tolerance {tol_px:.1f} px, {100 * max_median_fraction:g} % of the diagonal)")
        return best[0], {n: why for n in best[0]}
    return best[0], {}


FOCAL_STARTS = (0.5, 0.8, 1.2, 2.0)  # shared focal guesses (image sizes) that start the joint fit


def _cameras_at(ref: str, infos: dict[str, VideoInfo], found: dict[str, tuple], focal_px: dict[str, float]
                ) -> tuple[dict[str, CameraTrack], dict[str, bool]]:
    """Cameras from each pair's F with the reference, given one focal per pair (shared by both
    cameras of the pair), in a common scale from points triangulated on the same reference
    observation: ({name: camera}, {name: whether its scale came from shared points})."""
    info_r = infos[ref]

    def K(info, f):
        return np.array([[f, 0, (info.width - 1) / 2], [0, f, (info.height - 1) / 2], [0, 0, 1]])

    geo = {}
    for v, (g, (A, B, keys)) in found.items():
        Ka, Kb = K(info_r, focal_px[v]), K(infos[v], focal_px[v])
        na, nb = normalized_points(A, Ka), normalized_points(B, Kb)
        T = pose_from_essential(essential_from_fundamental(g.F, Ka, Kb), na, nb)
        R, t = T[:3, :3], T[:3, 3]
        P0 = np.hstack([np.eye(3), np.zeros((3, 1))])
        P1 = np.hstack([R, t.reshape(3, 1)])
        X = cv2.triangulatePoints(P0, P1, na.T, nb.T)
        X = (X[:3] / X[3]).T
        front = (X[:, 2] > 0) & ((X @ R.T + t.reshape(1, 3))[:, 2] > 0)
        geo[v] = (R, t.reshape(3), keys[front], X[front], Kb)
    # common scale: points triangulated from different pairs on the same reference observation
    order = sorted(geo, key=lambda v: -len(geo[v][2]))
    scale, with_scale = {order[0]: 1.0}, {order[0]: False}
    for v in order[1:]:
        kv, Xv = geo[v][2], geo[v][3]
        ratios = []
        for u in scale:
            ku, Xu = geo[u][2], geo[u][3]
            common, iu, iv = np.intersect1d(ku, kv, return_indices=True)
            if len(common) >= 5:
                ratios.append(np.median(np.linalg.norm(Xu[iu], axis=1) / np.maximum(np.linalg.norm(Xv[iv], axis=1), 1e-9)) * scale[u])
        scale[v] = float(np.median(ratios)) if ratios else 1.0
        with_scale[v] = bool(ratios)
    cams = {}
    for v, (R, t, _, _, Kb) in geo.items():
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, t * scale[v]
        cams[v] = CameraTrack(Kb, T)
    cams[ref] = CameraTrack(K(info_r, float(np.median(list(focal_px.values())))), np.eye(4))
    return cams, with_scale


def _pair_data(cams, infos, xy, pairs, coarse_offset_s, max_per_pair, seed):
    """[(a, b, x_a (P,3), x_b (P,3) homogeneous)] of every pair of cams, aligned at Δ_ab = Δ_rb − Δ_ra."""
    rng = np.random.default_rng(seed)
    data = []
    for (a, b), tp in sorted(pairs.items()):
        if a not in cams or b not in cams or len(tp.index) < 8:
            continue
        d_ab = coarse_offset_s.get(b, 0.0) - coarse_offset_s.get(a, 0.0)
        A, B, _ = aligned_correspondences(xy[a], infos[a], xy[b], infos[b], tp.index, d_ab)
        if len(A) < 40:
            continue
        if len(A) > max_per_pair:
            sel = rng.choice(len(A), max_per_pair, replace=False)
            A, B = A[sel], B[sel]
        data.append((a, b, np.c_[A, np.ones(len(A))], np.c_[B, np.ones(len(B))]))
    return data


def epipolar_fit_px(cams: dict[str, CameraTrack], infos: dict[str, VideoInfo], xy: dict[str, np.ndarray],
                    pairs: dict[tuple[str, str], TrackPairs], coarse_offset_s: dict[str, float],
                    max_per_pair: int = 400, seed: int = 0) -> tuple[float, int]:
    """(median |Sampson distance| px, number of pairs) of the track pairs of every pair of static
    cams at the coarse offsets: how well a set of cameras explains the moving points."""
    data = _pair_data(cams, infos, xy, pairs, coarse_offset_s, max_per_pair, seed)
    if not data:
        return float("nan"), 0
    r2 = np.concatenate([epipolar_residual(fundamental_from_cameras(cams[a].K, cams[a].cam_from_world,
                                                                    cams[b].K, cams[b].cam_from_world),
                                           A[:, :2], B[:, :2], "sampson") for a, b, A, B in data])
    return float(np.median(np.sqrt(r2))), len(data)


def refine_cameras(cams: dict[str, CameraTrack], ref: str, infos: dict[str, VideoInfo],
                   xy: dict[str, np.ndarray], pairs: dict[tuple[str, str], TrackPairs],
                   coarse_offset_s: dict[str, float], max_per_pair: int = 150, loss_scale_px: float = 2.0,
                   seed: int = 0) -> tuple[dict[str, CameraTrack], dict]:
    """One focal per camera and every pose, fitted to the track pairs of every camera pair at once.

    A focal length from one fundamental matrix is ill-posed when the optical axes nearly meet
    (cameras around a scene, the usual rig), so the per-pair focals of cameras_from_tracks can
    be far off; the pairs between non-reference cameras constrain them together. Each pair's
    correspondences are taken at the offset implied by the coarse offsets to the reference
    (Δ_ab = Δ_rb − Δ_ra) and the signed Sampson distances minimized with scipy's Cauchy loss
    (scale loss_scale_px). The reference stays at the origin; the scale is fixed by the first
    other camera's distance. Returns (cameras, {"cost" (scipy's, robust), "median_px_before",
    "median_px_after", "pairs", "focal_px"}).
    """
    names = [ref] + sorted(n for n in cams if n != ref)
    data = [(names.index(a), names.index(b), A, B)
            for a, b, A, B in _pair_data(cams, infos, xy, pairs, coarse_offset_s, max_per_pair, seed)]
    if len(data) < 2:
        return cams, {"pairs": len(data)}
    pp = [np.array([(infos[n].width - 1) / 2, (infos[n].height - 1) / 2]) for n in names]
    T0 = [np.asarray(cams[n].cam_from_world, float) for n in names]
    scale = float(np.linalg.norm(T0[1][:3, 3])) or 1.0
    x0 = [np.log(cams[n].K[0, 0]) for n in names]
    for T in T0[1:]:
        x0 += list(Rotation.from_matrix(T[:3, :3]).as_rotvec()) + list(T[:3, 3] / scale)

    def unpack(x):
        Ks, Ts = [], [np.eye(4)]
        for i, n in enumerate(names):
            f = np.exp(x[i])
            Ks.append(np.array([[f, 0, pp[i][0]], [0, f, pp[i][1]], [0, 0, 1.0]]))
        for j in range(len(names) - 1):
            p = x[len(names) + 6 * j: len(names) + 6 * j + 6]
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = Rotation.from_rotvec(p[:3]).as_matrix(), p[3:]
            Ts.append(T)
        return Ks, Ts

    ia, ib = np.array([d[0] for d in data]), np.array([d[1] for d in data])

    def residuals(x):
        Ks, Ts = unpack(x)
        Ks, Ts = np.stack(Ks), np.stack(Ts)
        F = fundamental_from_cameras(Ks[ia], Ts[ia], Ks[ib], Ts[ib])  # all pairs at once
        out = [signed_sampson_px(F[k], A, B) for k, (_, _, A, B) in enumerate(data)]
        out.append(np.array([10.0 * (np.linalg.norm(Ts[1][:3, 3]) - 1.0)]))  # scale gauge
        return np.concatenate(out)

    x0 = np.array(x0)
    # focal within the range the per-pair self-calibration searches (0.3-5 image sizes)
    size = [float(max(infos[n].width, infos[n].height)) for n in names]
    lo = np.r_[np.log(0.3 * np.array(size)), np.full(len(x0) - len(names), -np.inf)]
    hi = np.r_[np.log(5.0 * np.array(size)), np.full(len(x0) - len(names), np.inf)]
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    r0 = residuals(x0)[:-1]
    # Cauchy, not soft-L1: half or more of the track pairs can be wrong matches, and soft-L1's
    # linear tail lets them pull a focal to its bound
    sol = least_squares(residuals, x0, bounds=(lo, hi), loss="cauchy", f_scale=loss_scale_px,
                        x_scale="jac", ftol=1e-6, max_nfev=100)
    r1 = residuals(sol.x)[:-1]
    Ks, Ts = unpack(sol.x)
    out = {n: CameraTrack(Ks[i], Ts[i]) for i, n in enumerate(names)}
    return out, {"cost": float(sol.cost), "median_px_before": round(float(np.median(np.abs(r0))), 3),
                 "median_px_after": round(float(np.median(np.abs(r1))), 3), "pairs": len(data),
                 "focal_px": {n: round(float(Ks[i][0, 0]), 1) for i, n in enumerate(names)}}
