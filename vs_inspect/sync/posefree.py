"""Pose-free pair sync: the time shift, the clock rate and the fundamental matrix of two cameras
from one moving point seen by both (Albl et al., "On the two-view geometry of unsynchronized
cameras", CVPR 2017, is the idea: RANSAC over candidate time maps, then a continuous refinement).

Time map of a pair (DESIGN.md "Time and offsets", with a rate): local times tau_a, tau_b show the
same moment when

    tau_b = (tau_a - offset_s) / rate            offset_s = Δ_ab, rate = (1 + drift_b) / (1 + drift_a)

so with per-video models g = offset_v + (1 + drift_v) * tau_v, offset_s = (offset_b - offset_a) /
(1 + drift_a) and rate - 1 is b's drift relative to a's. Point b is linearly interpolated at the
mapped times of a's detections (only between two detected frames), which makes the residuals
continuous in (offset_s, rate).

Stages, each cheap enough for tracks of tens of thousands of frames:
1. coarse: offsets over the whole overlap on a grid, rate = 1; per candidate a MAGSAC F from a
   time-uniform subsample, moved to the nearest F with an essential matrix (K known), scored by
   the inliers among all matches (a short overlap cannot win);
2. per coarse peak, a finer offset line, then scipy least_squares over (offset, log rate, F as
   R, t of E = [t]x R with the known K) on Sampson distances with a robust loss; the peak whose
   refined F explains most matches wins; the Jacobian gives the uncertainty.
(The recording's (offset, rate) image of a pair is the energy's, sync.rate's, not drawn here.)

Pure numpy/scipy/OpenCV, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..geometry.epipolar import skew
from ..geometry.offsets import grid_around, grid_between, overlap_bounds, span_of
from ..geometry.two_view import fundamental_ransac, nearest_calibrated_fundamental, pose_from_fundamental, sampson_px


@dataclass(frozen=True)
class PoseFreeConfig:
    coarse_step_s: float = 0.4
    """Offset grid step of the coarse search; well under the width of the inlier-count peak."""
    coarse_points: int = 200
    """Matches (uniform in time) each coarse RANSAC sees."""
    min_overlap: float = 0.2
    """A candidate needs this share of the smaller track's detections matched."""
    threshold_px: float = 5.0
    """Sampson distance under which a match is an inlier (coarse and fine scores)."""
    top_k: int = 3
    """Coarse peaks (at least 2 s apart) of each of the two scores refined; the one explaining
    most matches wins."""
    fine_half_width_s: float = 0.4
    fine_step_s: float = 0.04
    """The offset line examined around each coarse peak."""
    fine_points: int = 800
    refine_loss_scale_px: float = 2.0
    """soft_l1 scale of the continuous refinement (Sampson px)."""
    refine_max_points: int = 6000
    """Matches (uniform in time) used by the continuous refinement."""
    estimate_rate: bool = True
    """False: constant-offset model (rate fixed at 1), the ablation."""
    seed: int = 0


@dataclass(frozen=True)
class PoseFreePair:
    """Result for one pair (a, b) in the time map above."""

    offset_s: float  # Δ_ab, in a's clock
    rate: float  # (1 + drift_b) / (1 + drift_a)
    offset_std_s: float  # from the refinement's Jacobian (residuals taken as independent)
    log_rate_std: float
    F_ab: np.ndarray  # (3,3) x_aᵀ F_ab x_b = 0 (geometry.epipolar's convention), undistorted px
    inlier_share: float  # matches with Sampson distance < threshold_px at the solution
    num_matches: int
    median_sampson_px: float  # over inliers
    coarse_offsets_s: np.ndarray  # (S,) coarse grid
    coarse_score: np.ndarray  # (S,) inliers of the nearest calibrated F among all matches (0: overlap too small)
    coarse_score_F: np.ndarray  # (S,) the same for the RANSAC F itself
    pivot_s: float  # a's local time in the middle of the overlap, about which the refinement turns the rate
    b_from_a: np.ndarray | None = None  # (4,4) the relative pose behind F_ab (unit baseline): x_b = R x_a + t

    @property
    def drift_ppm(self) -> float:
        return (self.rate - 1.0) * 1e6

    @property
    def drift_std_ppm(self) -> float:
        return self.log_rate_std * 1e6


def interpolate_track(t_query_s: np.ndarray, t_s: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(Q,2) positions at t_query_s, linear between two neighbouring frames; NaN outside the
    video or when either neighbour of a time between frames is unseen. t_s (T,) strictly increasing, xy (T,2) px."""
    t_query_s = np.asarray(t_query_s, dtype=np.float64)
    if xy.shape != (len(t_s), 2):
        raise ValueError(f"xy must have shape ({len(t_s)},2), got {xy.shape}")
    f = np.interp(t_query_s, t_s, np.arange(len(t_s), dtype=np.float64), left=-1.0, right=-1.0)
    i0 = np.floor(f).astype(np.int64)
    ok = (i0 >= 0) & (f <= len(t_s) - 1)
    out = np.full((len(t_query_s), 2), np.nan)
    i = i0[ok]
    j = np.minimum(i + 1, len(t_s) - 1)
    w = (f[ok] - i)[:, None]
    with np.errstate(invalid="ignore"):
        # on a frame exactly, its neighbour does not matter (even when unseen)
        out[ok] = np.where(w > 0, xy[i] * (1 - w) + xy[j] * w, xy[i])
    return out


class _Pair:
    """The two tracks and the matching under a candidate time map."""

    def __init__(self, t_a, xy_a, t_b, xy_b, K_a=None, K_b=None):
        self.K_a, self.K_b = K_a, K_b
        seen = np.isfinite(xy_a).all(axis=1)
        self.t_a = np.asarray(t_a, dtype=np.float64)[seen]
        self.x_a = np.asarray(xy_a, dtype=np.float64)[seen]
        self.t_b = np.asarray(t_b, dtype=np.float64)
        self.xy_b = np.asarray(xy_b, dtype=np.float64)
        self.min_matches = 0

    def match(self, offset_s: float, rate: float):
        xb = interpolate_track((self.t_a - offset_s) / rate, self.t_b, self.xy_b)
        ok = np.isfinite(xb).all(axis=1)
        return self.x_a[ok], xb[ok], ok

    def score(self, offset_s: float, rate: float, n_sample: int, thr: float) -> tuple[int, np.ndarray | None]:
        n, _, F = self.scores(offset_s, rate, n_sample, thr)
        return n, F

    def scores(self, offset_s: float, rate: float, n_sample: int, thr: float):
        """(inliers of the nearest calibrated F, inliers of the RANSAC F, that F).

        Where the drone hovers or flies straight, a wrong time map still gets an F that fits
        every match, but rarely one with an essential matrix's two equal singular values; the
        projection onto those is crude for a noisy F, though, so both counts propose peaks."""
        xa, xb, _ = self.match(offset_s, rate)
        if len(xa) < max(self.min_matches, 16):
            return 0, 0, None
        F = _ransac_F(xa, xb, n_sample, thr)
        if F is None:
            return 0, 0, None
        n_F = int(np.count_nonzero(sampson_px(F, xa, xb) < thr))
        if self.K_a is None:
            return n_F, n_F, F
        n_E = int(np.count_nonzero(sampson_px(nearest_calibrated_fundamental(F, self.K_a, self.K_b), xa, xb) < thr))
        return n_E, n_F, F


def _uniform(n_total: int, n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n_total - 1, min(n, n_total)).astype(np.int64))


def _ransac_F(xa, xb, n_sample, thr):
    """F_ab (MAGSAC) of a time-uniform subsample of n_sample matches, or None."""
    idx = _uniform(len(xa), n_sample)
    return fundamental_ransac(xa[idx], xb[idx], thr, 0.999, 500)[0]


def _peaks(score: np.ndarray, grid: np.ndarray, k: int, min_sep: float) -> list[float]:
    out: list[float] = []
    for i in np.argsort(-score, kind="stable"):
        if score[i] <= 0 or len(out) == k:
            break
        if all(abs(grid[i] - p) >= min_sep for p in out):
            out.append(float(grid[i]))
    return out


def _E_params(F_ab: np.ndarray, K_a: np.ndarray, K_b: np.ndarray, xa: np.ndarray, xb: np.ndarray):
    """(rotvec (3,), t angles (2,)) of b_from_a in F_ab, chosen by cheirality."""
    T = pose_from_fundamental(F_ab, K_a, K_b, xa, xb)
    t = T[:3, 3] / np.linalg.norm(T[:3, 3])
    return Rotation.from_matrix(T[:3, :3]).as_rotvec(), np.array([np.arccos(np.clip(t[2], -1, 1)),
                                                                  np.arctan2(t[1], t[0])])


def _pose_from_params(p: np.ndarray) -> np.ndarray:
    """(4,4) b_from_a of (R = rotvec p[:3], t = unit vector at polar angles p[3:5])."""
    th, ph = p[3], p[4]
    out = np.eye(4)
    out[:3, :3] = Rotation.from_rotvec(p[:3]).as_matrix()
    out[:3, 3] = [np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)]
    return out


def _F_from_params(p: np.ndarray, K_a_inv: np.ndarray, K_b_inv: np.ndarray) -> np.ndarray:
    """F_ab of b_from_a = (R = rotvec p[:3], t = unit vector at polar angles p[3:5])."""
    T = _pose_from_params(p)
    return (K_b_inv.T @ skew(T[:3, 3]) @ T[:3, :3] @ K_a_inv).T


def estimate_pair(t_a: np.ndarray, xy_a: np.ndarray, K_a: np.ndarray,
                  t_b: np.ndarray, xy_b: np.ndarray, K_b: np.ndarray,
                  config: PoseFreeConfig = PoseFreeConfig(),
                  offset_range_s: tuple[float, float] | None = None,
                  coarse: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                  peaks_s: list[float] | None = None) -> PoseFreePair | None:
    """Time map and F of a pair from one point track per camera; None when no candidate has
    enough overlap.

    t_a (Ta,), t_b (Tb,): local frame times (s); xy_a (Ta,2), xy_b (Tb,2): undistorted px, NaN
    where unseen; K_a, K_b (3,3) px. offset_range_s: (lo, hi) of the offsets searched (an
    OffsetGrid's pair_bounds; default: every offset with some overlap). coarse: (offsets, score, score_F) of an earlier run on the same tracks (e.g. the
    drift model's, reused by the constant-offset ablation); peaks_s: refine only these offsets
    instead of the coarse peaks (e.g. the drift model's solution).
    """
    cfg = config
    for name, t, xy in (("a", t_a, xy_a), ("b", t_b, xy_b)):
        if np.asarray(xy).shape != (len(t), 2):
            raise ValueError(f"xy_{name} must have shape ({len(t)},2), got {np.asarray(xy).shape}")
    pair = _Pair(t_a, xy_a, t_b, xy_b, np.asarray(K_a, dtype=np.float64), np.asarray(K_b, dtype=np.float64))
    n_b = int(np.isfinite(np.asarray(xy_b)).all(axis=1).sum())
    pair.min_matches = int(cfg.min_overlap * min(len(pair.t_a), n_b))
    lo, hi = offset_range_s if offset_range_s is not None else overlap_bounds(span_of(t_a), span_of(t_b))

    # 1. coarse offsets, rate 1
    if coarse is None:
        grid = grid_between(lo, hi, cfg.coarse_step_s)
        both = np.array([pair.scores(d, 1.0, cfg.coarse_points, cfg.threshold_px)[:2] for d in grid]).reshape(-1, 2)
        coarse = (grid, both[:, 0], both[:, 1])
    coarse, coarse_score, coarse_score_F = coarse
    if peaks_s is not None:
        peaks = list(peaks_s)
    else:
        peaks = _peaks(coarse_score, coarse, cfg.top_k, 2.0)
        peaks += [p for p in _peaks(coarse_score_F, coarse, cfg.top_k, 2.0)
                  if all(abs(p - q) >= 2.0 for q in peaks)]

    # 2. per peak: a finer line of offsets at rate 1, then the continuous refinement. A wrong
    # offset can out-score the true one in the coarse count (a 7-dof F fits one track loosely),
    # not after the refinement, so the refined inlier count picks the peak.
    best: _Refined | None = None
    for p in peaks:
        offs = grid_around(p, cfg.fine_half_width_s, cfg.fine_step_s, (lo, hi))
        line = [pair.score(d, 1.0, cfg.fine_points, cfg.threshold_px)[0] for d in offs]
        if max(line) <= 0:
            continue
        ref = _refine(pair, float(offs[int(np.argmax(line))]), K_a, K_b, cfg)
        if ref is not None and (best is None or ref.num_inliers > best.num_inliers):
            best = ref
    if best is None:
        return None

    return PoseFreePair(best.offset_s, best.rate, best.offset_std_s, best.log_rate_std, best.F_ab,
                        best.inlier_share, best.num_matches, best.median_sampson_px,
                        coarse, coarse_score, coarse_score_F, best.pivot_s, best.b_from_a)


@dataclass(frozen=True)
class _Refined:
    offset_s: float
    rate: float
    offset_std_s: float
    log_rate_std: float
    F_ab: np.ndarray
    inlier_share: float
    num_inliers: int
    num_matches: int
    median_sampson_px: float
    pivot_s: float
    b_from_a: np.ndarray  # (4,4)


def _refine(pair: _Pair, d0: float, K_a: np.ndarray, K_b: np.ndarray, cfg: PoseFreeConfig) -> _Refined | None:
    """Continuous (offset, log rate, R, t) from an offset at rate 1. The time map is written
    about a pivot in the middle of the overlap, tau_b = c + (tau_a - pivot) / rate, so that the
    shift c and the rate are nearly uncorrelated (offset_s = pivot - rate * c)."""
    _, F0 = pair.score(d0, 1.0, cfg.fine_points * 4, cfg.threshold_px)
    if F0 is None:
        return None
    xa0, xb0, ok0 = pair.match(d0, 1.0)
    inl = sampson_px(F0, xa0, xb0) < cfg.threshold_px
    if inl.sum() < 8:
        return None
    pivot = float(np.median(pair.t_a[ok0]))
    rotvec, tang = _E_params(F0, K_a, K_b, xa0[inl], xb0[inl])
    Kai, Kbi = np.linalg.inv(K_a), np.linalg.inv(K_b)
    sel = _uniform(len(pair.t_a), cfg.refine_max_points)
    t_a, x_a = pair.t_a[sel], pair.x_a[sel]

    def tb_of(x):
        return x[0] + (t_a - pivot) * (np.exp(-x[1]) if cfg.estimate_rate else 1.0)

    def residuals(x):
        xb = interpolate_track(tb_of(x), pair.t_b, pair.xy_b)
        ok = np.isfinite(xb).all(axis=1)
        res = np.full(len(t_a), cfg.threshold_px)  # unmatched: a constant, no gradient
        res[ok] = sampson_px(_F_from_params(x[2:], Kai, Kbi), x_a[ok], xb[ok])
        return res

    x0 = np.r_[pivot - d0, 0.0, rotvec, tang]
    scale = np.r_[0.01, 1e-4, 1e-2, 1e-2, 1e-2, 1e-2, 1e-2]
    sol = least_squares(residuals, x0, loss="soft_l1", f_scale=cfg.refine_loss_scale_px, x_scale=scale,
                        max_nfev=200)
    x = sol.x
    rate = float(np.exp(x[1])) if cfg.estimate_rate else 1.0
    offset_s = pivot - rate * x[0]
    F = _F_from_params(x[2:], Kai, Kbi)
    xa, xb, _ = pair.match(offset_s, rate)
    err = sampson_px(F, xa, xb)
    inl = err < cfg.threshold_px
    # uncertainty from the inliers' Jacobian (Gauss-Newton covariance, residuals taken as
    # independent, which they are not along a smooth track: a lower bound)
    r = residuals(x)
    keep = r < cfg.threshold_px
    cols = [0, 1] if cfg.estimate_rate else [0]
    cols += list(range(2, len(x)))
    Jk = sol.jac[keep][:, cols]
    sigma2 = float(np.sum(r[keep] ** 2) / max(int(keep.sum()) - len(cols), 1))
    cov = np.linalg.pinv(Jk.T @ Jk) * sigma2
    if cfg.estimate_rate:
        g = np.array([-rate, -rate * x[0]])  # d offset_s / d (c, log rate)
        offset_var = float(g @ cov[:2, :2] @ g)
        log_rate_std = float(np.sqrt(max(cov[1, 1], 0.0)))
    else:
        offset_var, log_rate_std = float(cov[0, 0]), 0.0
    return _Refined(float(offset_s), rate, float(np.sqrt(max(offset_var, 0.0))), log_rate_std,
                    F / np.linalg.norm(F), float(inl.mean()) if len(inl) else 0.0, int(inl.sum()),
                    int(len(xa)), float(np.median(err[inl])) if inl.any() else float("nan"), float(pivot),
                    _pose_from_params(x[2:]))


def fit_at_time_map(t_a: np.ndarray, xy_a: np.ndarray, K_a: np.ndarray,
                    t_b: np.ndarray, xy_b: np.ndarray, K_b: np.ndarray, offset_s: float, rate: float,
                    config: PoseFreeConfig = PoseFreeConfig()) -> tuple[float, float]:
    """(median Sampson px over inliers, inlier share) of the best E-constrained F with the time
    map held fixed: how well a given (e.g. ground-truth) time map explains the tracks, to compare
    with the estimate's own numbers."""
    _, median_px, share = fit_F_at_time_map(t_a, xy_a, K_a, t_b, xy_b, K_b, offset_s, rate, config)
    return median_px, share


def fit_F_at_time_map(t_a: np.ndarray, xy_a: np.ndarray, K_a: np.ndarray,
                      t_b: np.ndarray, xy_b: np.ndarray, K_b: np.ndarray, offset_s: float, rate: float,
                      config: PoseFreeConfig = PoseFreeConfig()) -> tuple[np.ndarray | None, float, float]:
    """(F_ab, median Sampson px over inliers, inlier share) of the best E-constrained F with the
    time map held fixed (MAGSAC, then the continuous refinement of R, t on Sampson distances);
    F_ab None (and NaN, 0) when too few matches. Inputs as in estimate_pair."""
    cfg = config
    pair = _Pair(t_a, xy_a, t_b, xy_b)
    xa, xb, _ = pair.match(offset_s, rate)
    if len(xa) < 16:
        return None, float("nan"), 0.0
    F0 = _ransac_F(xa, xb, cfg.fine_points * 4, cfg.threshold_px)
    if F0 is None:
        return None, float("nan"), 0.0
    inl = sampson_px(F0, xa, xb) < cfg.threshold_px
    if inl.sum() < 8:
        return None, float("nan"), 0.0
    rotvec, tang = _E_params(F0, K_a, K_b, xa[inl], xb[inl])
    Kai, Kbi = np.linalg.inv(K_a), np.linalg.inv(K_b)
    sel = _uniform(len(xa), cfg.refine_max_points)
    sol = least_squares(lambda p: sampson_px(_F_from_params(p, Kai, Kbi), xa[sel], xb[sel]),
                        np.r_[rotvec, tang], loss="soft_l1", f_scale=cfg.refine_loss_scale_px, max_nfev=200)
    F = _F_from_params(sol.x, Kai, Kbi)
    err = sampson_px(F, xa, xb)
    inl = err < cfg.threshold_px
    return F, (float(np.median(err[inl])) if inl.any() else float("nan")), float(inl.mean())
