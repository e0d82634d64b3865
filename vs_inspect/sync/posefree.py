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
   time-uniform subsample, scored by the inliers among all matches (a short overlap cannot win);
2. fine: a (offset, rate) grid around the best coarse candidates, same score;
3. continuous: scipy least_squares over (offset_s, log rate, F as R, t of E = [t]x R with the
   known K) on Sampson distances with a robust loss; the Jacobian gives the uncertainty.

Pure numpy/scipy/OpenCV, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..geometry.epipolar import skew


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
    """Coarse peaks (at least 2 s apart) examined by the fine search."""
    fine_half_width_s: float = 0.4
    fine_step_s: float = 0.04
    rate_half_width_ppm: float = 2000.0
    rate_step_ppm: float = 200.0
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
    F_ab: np.ndarray  # (3,3) x_b^T F x_a = 0, undistorted px
    inlier_share: float  # matches with Sampson distance < threshold_px at the solution
    num_matches: int
    median_sampson_px: float  # over inliers
    coarse_offsets_s: np.ndarray  # (S,) coarse grid
    coarse_score: np.ndarray  # (S,) inliers among all matches (0 where the overlap is too small)
    fine_offsets_s: np.ndarray  # (U,)
    fine_rates_ppm: np.ndarray  # (V,) (rate - 1) * 1e6
    fine_score: np.ndarray  # (V,U) inliers; the (offset, rate) image for the recording

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


def sampson_px(F: np.ndarray, xa: np.ndarray, xb: np.ndarray) -> np.ndarray:
    """(M,) first-order geometric distance of x_b^T F x_a = 0 (px)."""
    ha = np.c_[xa, np.ones(len(xa))]
    hb = np.c_[xb, np.ones(len(xb))]
    Fa = ha @ F.T
    Fb = hb @ F
    num = np.sum(hb * Fa, axis=1)
    den = np.sqrt(Fa[:, 0] ** 2 + Fa[:, 1] ** 2 + Fb[:, 0] ** 2 + Fb[:, 1] ** 2)
    return np.abs(num) / np.maximum(den, 1e-12)


class _Pair:
    """The two tracks and the matching under a candidate time map."""

    def __init__(self, t_a, xy_a, t_b, xy_b):
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
        xa, xb, _ = self.match(offset_s, rate)
        if len(xa) < max(self.min_matches, 16):
            return 0, None
        F = _ransac_F(xa, xb, n_sample, thr)
        if F is None:
            return 0, None
        return int(np.count_nonzero(sampson_px(F, xa, xb) < thr)), F


def _uniform(n_total: int, n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n_total - 1, min(n, n_total)).astype(np.int64))


def _ransac_F(xa, xb, n_sample, thr):
    idx = _uniform(len(xa), n_sample)
    try:
        F, _ = cv2.findFundamentalMat(xa[idx], xb[idx], cv2.USAC_MAGSAC, thr, 0.999, 500)
    except cv2.error:
        return None
    if F is None or F.shape != (3, 3):
        return None
    return F


def _peaks(score: np.ndarray, grid: np.ndarray, k: int, min_sep: float) -> list[float]:
    out: list[float] = []
    for i in np.argsort(-score, kind="stable"):
        if score[i] <= 0 or len(out) == k:
            break
        if all(abs(grid[i] - p) >= min_sep for p in out):
            out.append(float(grid[i]))
    return out


def _E_params(F: np.ndarray, K_a: np.ndarray, K_b: np.ndarray, xa: np.ndarray, xb: np.ndarray):
    """(rotvec (3,), t angles (2,)) of the pose in F, chosen by cheirality."""
    E = K_b.T @ F @ K_a
    na = cv2.undistortPoints(xa.reshape(-1, 1, 2), K_a, None).reshape(-1, 2)
    nb = cv2.undistortPoints(xb.reshape(-1, 1, 2), K_b, None).reshape(-1, 2)
    _, R, t, _ = cv2.recoverPose(E, na, nb, np.eye(3))
    t = t.ravel() / np.linalg.norm(t)
    return Rotation.from_matrix(R).as_rotvec(), np.array([np.arccos(np.clip(t[2], -1, 1)), np.arctan2(t[1], t[0])])


def _F_from_params(p: np.ndarray, K_a_inv: np.ndarray, K_b_inv: np.ndarray) -> np.ndarray:
    R = Rotation.from_rotvec(p[:3]).as_matrix()
    th, ph = p[3], p[4]
    t = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    return K_b_inv.T @ skew(t) @ R @ K_a_inv


def estimate_pair(t_a: np.ndarray, xy_a: np.ndarray, K_a: np.ndarray,
                  t_b: np.ndarray, xy_b: np.ndarray, K_b: np.ndarray,
                  config: PoseFreeConfig = PoseFreeConfig(),
                  offset_range_s: tuple[float, float] | None = None,
                  coarse: tuple[np.ndarray, np.ndarray] | None = None) -> PoseFreePair | None:
    """Time map and F of a pair from one point track per camera; None when no candidate has
    enough overlap.

    t_a (Ta,), t_b (Tb,): local frame times (s); xy_a (Ta,2), xy_b (Tb,2): undistorted px, NaN
    where unseen; K_a, K_b (3,3) px. offset_range_s: the offsets searched (default: every offset
    with some overlap). coarse: (offsets, score) of an earlier run on the same tracks (e.g. the
    drift model's, reused by the constant-offset ablation).
    """
    cfg = config
    for name, t, xy in (("a", t_a, xy_a), ("b", t_b, xy_b)):
        if np.asarray(xy).shape != (len(t), 2):
            raise ValueError(f"xy_{name} must have shape ({len(t)},2), got {np.asarray(xy).shape}")
    pair = _Pair(t_a, xy_a, t_b, xy_b)
    n_b = int(np.isfinite(np.asarray(xy_b)).all(axis=1).sum())
    pair.min_matches = int(cfg.min_overlap * min(len(pair.t_a), n_b))
    lo, hi = offset_range_s if offset_range_s is not None else (t_a[0] - t_b[-1], t_a[-1] - t_b[0])

    # 1. coarse offsets, rate 1
    if coarse is None:
        grid = np.arange(lo, hi + 1e-9, cfg.coarse_step_s)
        coarse = (grid, np.array([pair.score(d, 1.0, cfg.coarse_points, cfg.threshold_px)[0] for d in grid]))
    coarse, coarse_score = coarse
    peaks = _peaks(coarse_score, coarse, cfg.top_k, 2.0)
    if not peaks:
        return None

    # 2. fine (offset, rate) grid around each peak; keep the best peak's image
    rates_ppm = (np.arange(-cfg.rate_half_width_ppm, cfg.rate_half_width_ppm + 1e-9, cfg.rate_step_ppm)
                 if cfg.estimate_rate else np.zeros(1))
    # A wrong offset can out-score the true one here (7-dof F fits a single track loosely), so
    # several peaks go on to the finer, more discriminating score.
    best = None
    for p in peaks:
        offs = p + np.arange(-cfg.fine_half_width_s, cfg.fine_half_width_s + 1e-9, cfg.fine_step_s)
        img = np.zeros((len(rates_ppm), len(offs)), dtype=np.int64)
        for i, r in enumerate(rates_ppm):
            for j, d in enumerate(offs):
                img[i, j] = pair.score(d, 1.0 + r * 1e-6, cfg.fine_points, cfg.threshold_px)[0]
        if best is None or img.max() > best[2].max():
            best = (offs, rates_ppm, img)
    offs, rates_ppm, img = best
    # the centroid of the top cells is steadier than the single best cell of a noisy count
    top = img >= np.quantile(img, 0.98)
    w = np.where(top, img, 0).astype(np.float64)
    d0 = float((w.sum(axis=0) @ offs) / w.sum())
    r0 = float((w.sum(axis=1) @ rates_ppm) / w.sum()) * 1e-6
    _, F0 = pair.score(d0, 1.0 + r0, cfg.fine_points * 4, cfg.threshold_px)
    if F0 is None:
        return None

    # 3. continuous refinement of (offset, log rate, R, t)
    xa0, xb0, _ = pair.match(d0, 1.0 + r0)
    inl = sampson_px(F0, xa0, xb0) < cfg.threshold_px
    rotvec, tang = _E_params(F0, K_a, K_b, xa0[inl], xb0[inl])
    Kai, Kbi = np.linalg.inv(K_a), np.linalg.inv(K_b)
    sel = _uniform(len(pair.t_a), cfg.refine_max_points)
    sub = _Pair(pair.t_a[sel], pair.x_a[sel], t_b, xy_b)

    def residuals(x):
        rate = np.exp(x[1]) if cfg.estimate_rate else 1.0
        xb = interpolate_track((sub.t_a - x[0]) / rate, sub.t_b, sub.xy_b)
        ok = np.isfinite(xb).all(axis=1)
        res = np.full(len(sub.t_a), cfg.threshold_px)  # unmatched: a constant, no gradient
        res[ok] = sampson_px(_F_from_params(x[2:], Kai, Kbi), sub.x_a[ok], xb[ok])
        return res

    x0 = np.r_[d0, np.log1p(r0), rotvec, tang]
    if not cfg.estimate_rate:
        x0[1] = 0.0
    scale = np.r_[0.01, 1e-4, 1e-2, 1e-2, 1e-2, 1e-2, 1e-2]
    sol = least_squares(residuals, x0, loss="soft_l1", f_scale=cfg.refine_loss_scale_px, x_scale=scale,
                        max_nfev=200)
    x = sol.x
    rate = float(np.exp(x[1])) if cfg.estimate_rate else 1.0
    F = _F_from_params(x[2:], Kai, Kbi)
    xa, xb, _ = pair.match(x[0], rate)
    err = sampson_px(F, xa, xb)
    inl = err < cfg.threshold_px
    # uncertainty from the inliers' Jacobian (Gauss-Newton covariance, residuals independent)
    r = residuals(x)
    J = sol.jac
    keep = r < cfg.threshold_px
    Jk = J[keep]
    dof = max(int(keep.sum()) - len(x), 1)
    sigma2 = float(np.sum(r[keep] ** 2) / dof)
    cols = [0, 1] if cfg.estimate_rate else [0]
    cols += list(range(2, len(x)))
    try:
        cov = np.linalg.pinv(Jk[:, cols].T @ Jk[:, cols]) * sigma2
        offset_std = float(np.sqrt(max(cov[0, 0], 0.0)))
        log_rate_std = float(np.sqrt(max(cov[1, 1], 0.0))) if cfg.estimate_rate else 0.0
    except np.linalg.LinAlgError:
        offset_std, log_rate_std = float("nan"), float("nan")
    return PoseFreePair(float(x[0]), rate, offset_std, log_rate_std, F / np.linalg.norm(F),
                        float(inl.mean()) if len(inl) else 0.0, int(len(xa)),
                        float(np.median(err[inl])) if inl.any() else float("nan"),
                        coarse, coarse_score, offs, rates_ppm, img)
