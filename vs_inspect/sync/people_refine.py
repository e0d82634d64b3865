"""The continuous refinement of a pair's shift and F on its people's inliers (sync/people_pairs.py's
step 4): b's landmarks interpolated at a's frame times minus Δ, and the shift's 1-sigma.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..geometry.timing import frame_brackets
from .people_config import PeoplePairConfig
from .people_landscape import _Fit
from .people_search import EPS_S, _Side, _moments, _sampson2


def _F_params(F: np.ndarray) -> np.ndarray:
    """(7,) F = U diag(1, s, 0) Vᵀ as (rotvec U (3,), rotvec V (3,), log s)."""
    U, S, Vt = np.linalg.svd(F)
    U = U * np.sign(np.linalg.det(U))
    V = Vt.T * np.sign(np.linalg.det(Vt))
    return np.r_[Rotation.from_matrix(U).as_rotvec(), Rotation.from_matrix(V).as_rotvec(),
                 np.log(max(S[1] / S[0], 1e-9))]


def _F_of(p: np.ndarray) -> np.ndarray:
    U = Rotation.from_rotvec(p[:3]).as_matrix()
    V = Rotation.from_rotvec(p[3:6]).as_matrix()
    return U @ np.diag([1.0, np.exp(p[6]), 0.0]) @ V.T


def _inlier_rows(a: _Side, b: _Side, delta: float, fit: _Fit, pairs, mirror: np.ndarray, unit: np.ndarray):
    """(person in a, person in b, landmark in a, landmark in b, frame of a, unit px) (M,) each:
    the inliers of fit at delta, each frame in its labelling."""
    frames, xa, xb = _moments(a, b, delta, None)
    L = xa.shape[2]
    out = []
    for i, j in pairs:
        m = fit.mirrored[(i, j)]
        lab = np.where(m[:, None], mirror[None], np.arange(L)[None])  # (Q,L) b's landmark
        bb = np.take_along_axis(xb[j], lab[..., None], axis=1)
        r2 = _sampson2(fit.F_ab, xa[i], bb) / unit[i, j] ** 2
        q, l = np.nonzero(r2 < 1)
        out.append((np.full(len(q), i), np.full(len(q), j), l, lab[q, l], frames[q], np.full(len(q), unit[i, j])))
    if not out:
        return tuple(np.zeros(0) for _ in range(6))
    cols = [np.concatenate([o[c] for o in out]) for c in range(6)]
    return tuple(c.astype(np.int64) for c in cols[:5]) + (cols[5],)


def _refine(a: _Side, b: _Side, delta0: float, fit: _Fit, pairs, mirror, unit, bounds: tuple[float, float],
            cfg: PeoplePairConfig) -> tuple[float, np.ndarray, float, int]:
    """(Δ, F_ab, 1-sigma of Δ (s), inliers at Δ), refined continuously from (delta0, fit): b's
    landmarks interpolated at a's frame times minus Δ, soft L1 over the Sampson distances (noise
    units) of the inliers at the start (a row b no longer sees counts as one unit)."""
    ia, jb, la, lb, ka, u = _inlier_rows(a, b, delta0, fit, pairs, mirror, unit)
    x_a = a.xy[ia, ka, la]
    t_a = a.times_s[ka]
    Tb = len(b.times_s)
    # rows b sees on both sides of the start by a frame or more: the residuals stay continuous
    # wherever the refinement goes (bounded to that span below)
    step = float(np.median(np.diff(b.times_s))) if Tb > 1 else 1.0
    lo, hi = max(bounds[0], delta0 - step), min(bounds[1], delta0 + step)
    ok = np.ones(len(ka), bool)
    for d in (lo, delta0, hi):
        k, _ = frame_brackets(b.times_s, t_a - d)
        k0 = np.clip(k, 0, max(Tb - 2, 0))
        ok &= (k >= 0) & np.isfinite(b.xy[jb, k0, lb]).all(-1) & np.isfinite(b.xy[jb, np.minimum(k0 + 1, Tb - 1), lb]).all(-1)
    keep = np.nonzero(ok)[0]
    if len(keep) > cfg.refine_max_points:
        keep = keep[np.unique(np.linspace(0, len(keep) - 1, cfg.refine_max_points).astype(np.int64))]
    x_a, t_a, jb, lb, u = x_a[keep], t_a[keep], jb[keep], lb[keep], u[keep]

    def b_at(delta: float) -> np.ndarray:
        k, w = frame_brackets(b.times_s, t_a - delta)
        k0 = np.clip(k, 0, max(Tb - 2, 0))
        k1 = np.minimum(k0 + 1, Tb - 1)
        x0, x1 = b.xy[jb, k0, lb], b.xy[jb, k1, lb]
        with np.errstate(invalid="ignore"):
            x = np.where(w[:, None] > 0, x0 + w[:, None] * (x1 - x0), x0)
        x[k < 0] = np.nan
        return x

    def residuals(p: np.ndarray) -> np.ndarray:
        r = np.sqrt(_sampson2(_F_of(p[1:]), x_a, b_at(p[0]))) / u
        return np.where(np.isfinite(r), r, 1.0)

    p0 = np.r_[min(max(delta0, lo), hi), _F_params(fit.F_ab)]
    sol = least_squares(residuals, p0, loss="soft_l1", f_scale=cfg.refine_loss_scale,
                        x_scale=np.r_[0.01, np.full(7, 1e-3)], diff_step=np.r_[1e-4, np.full(7, 1e-6)],
                        bounds=(np.r_[lo - EPS_S, np.full(7, -np.inf)], np.r_[hi + EPS_S, np.full(7, np.inf)]),
                        max_nfev=100)
    r = residuals(sol.x)
    keep = r < 1
    J = sol.jac[keep]
    sigma2 = float(np.sum(r[keep] ** 2) / max(int(keep.sum()) - len(sol.x), 1))
    cov = np.linalg.pinv(J.T @ J) * sigma2
    return float(sol.x[0]), _F_of(sol.x[1:]), float(np.sqrt(max(cov[0, 0], 0.0))), int(keep.sum())
