"""Stage 2 with clock drift: per-video (offset_s, drift) from pairwise (offset, rate).

Time model per video v: t_global = offset_s[v] + (1 + drift[v]) * t_local, the reference fixed at
(0, 0). A pair (a, b) measures (sync.posefree's time map)

    offset_ab = (offset_b - offset_a) / (1 + drift_a)        log rate_ab = l_b - l_a,  l = log(1 + drift)

Rates compose multiplicatively, so the solve is linear in l; offsets enter through one product.
Robust nonlinear least squares (scipy, Huber on residuals in units of each pair's uncertainty),
started from a breadth-first walk of the pair graph from the reference.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import csr_array
from scipy.sparse.csgraph import breadth_first_order


@dataclass(frozen=True)
class PairTiming:
    """One pair's measured time map (sync.posefree convention)."""

    a: str
    b: str
    offset_s: float  # Δ_ab in a's clock
    log_rate: float  # log((1 + drift_b) / (1 + drift_a))
    offset_std_s: float
    log_rate_std: float
    pivot_s: float = 0.0  # b's local time at which offset_s is measured: τ_a - τ_b there (0: Δ_ab)


def _predicted_offset(p: PairTiming, off: dict[str, float], lr: dict[str, float]) -> float:
    """τ_a - τ_b at τ_b = pivot under the per-video models (pivot 0: (offset_b - offset_a) / (1 + drift_a))."""
    g = off[p.b] + np.exp(lr[p.b]) * p.pivot_s
    return (g - off[p.a]) * np.exp(-lr[p.a]) - p.pivot_s


@dataclass(frozen=True)
class DriftSolution:
    reference: str
    offsets_s: dict[str, float]  # None-free: only videos connected to the reference
    drift_ppm: dict[str, float]
    offset_std_s: dict[str, float]
    drift_std_ppm: dict[str, float]
    pair_residuals: dict[tuple[str, str], tuple[float, float]]  # (offset s, log rate) measured - model
    with_drift: bool
    pair_weights: dict[tuple[str, str], float] = field(default_factory=dict)
    """Huber weight (0, 1] of each pair's offset residual at the solution (in units of its floored std)."""


def _connected(reference: str, pairs: list[PairTiming]) -> list[str]:
    """The videos the pairs link to the reference, breadth-first from it: the order in which
    _initial seeds them, which the robust solve's result can depend on. A video's neighbours are
    visited in the pairs' order: each pair is stored in both rows of the graph, and a row keeps
    its entries in that order (csgraph walks a row as stored; tests/sync/test_drift.py checks it)."""
    names = list(dict.fromkeys([reference, *(v for p in pairs for v in (p.a, p.b))]))
    idx = {v: i for i, v in enumerate(names)}
    rows = np.array([idx[v] for p in pairs for v in (p.a, p.b)], dtype=np.int64)
    cols = np.array([idx[v] for p in pairs for v in (p.b, p.a)], dtype=np.int64)
    by_row = np.argsort(rows, kind="stable")
    indptr = np.r_[0, np.cumsum(np.bincount(rows, minlength=len(names)))]
    graph = csr_array((np.ones(len(rows)), cols[by_row], indptr), shape=(len(names), len(names)))
    return [names[i] for i in breadth_first_order(graph, 0, directed=True, return_predecessors=False)]


def _initial(reference: str, order: list[str], pairs: list[PairTiming], with_drift: bool):
    off, lr = {reference: 0.0}, {reference: 0.0}
    for v in order[1:]:
        for p in pairs:
            # τ_a = (offset_s + pivot) at τ_b = pivot: the same moment in both models
            if p.b == v and p.a in off:
                lr[v] = lr[p.a] + p.log_rate if with_drift else 0.0
                g = off[p.a] + np.exp(lr[p.a]) * (p.offset_s + p.pivot_s)
                off[v] = g - np.exp(lr[v]) * p.pivot_s
                break
            if p.a == v and p.b in off:
                lr[v] = lr[p.b] - p.log_rate if with_drift else 0.0
                g = off[p.b] + np.exp(lr[p.b]) * p.pivot_s
                off[v] = g - np.exp(lr[v]) * (p.offset_s + p.pivot_s)
                break
    return off, lr


def solve_offsets_drift(reference: str, pairs: list[PairTiming], with_drift: bool = True,
                        min_offset_std_s: float = 1e-3, min_log_rate_std: float = 2e-5,
                        huber_scale: float = 3.0, drift_prior_ppm: float | None = None) -> DriftSolution:
    """Robust global (offset_s, drift) per video; the floors on the pairs' uncertainties keep an
    over-confident pair (correlated residuals make its Jacobian std small) from dominating.
    drift_prior_ppm: a zero-mean prior of this 1-sigma on each video's drift (None: none)."""
    order = _connected(reference, pairs)
    free = order[1:]
    used = [p for p in pairs if p.a in order and p.b in order]
    off0, lr0 = _initial(reference, order, used, with_drift)
    n = len(free)
    pos = {v: i for i, v in enumerate(free)}

    def unpack(x):
        off = {reference: 0.0, **{v: x[pos[v]] for v in free}}
        lr = {reference: 0.0, **{v: (x[n + pos[v]] if with_drift else 0.0) for v in free}}
        return off, lr

    def residuals(x):
        off, lr = unpack(x)
        out = []
        for p in used:
            pred = _predicted_offset(p, off, lr)
            out.append((p.offset_s - pred) / max(p.offset_std_s, min_offset_std_s))
            if with_drift:
                out.append((p.log_rate - (lr[p.b] - lr[p.a])) / max(p.log_rate_std, min_log_rate_std))
        if with_drift and drift_prior_ppm is not None:
            out.extend(lr[v] / (drift_prior_ppm * 1e-6) for v in free)
        return np.asarray(out)

    x0 = np.r_[[off0[v] for v in free], [lr0[v] for v in free] if with_drift else []]
    if n == 0:
        return DriftSolution(reference, {reference: 0.0}, {reference: 0.0}, {reference: 0.0},
                             {reference: 0.0}, {}, with_drift)
    sol = least_squares(residuals, x0, loss="huber", f_scale=huber_scale)
    off, lr = unpack(sol.x)
    try:
        # scipy's jac at a robust solution is already weighted by the loss; the pairs' own
        # uncertainties are rough (curvature, correlated residuals), so the covariance is scaled
        # by the residuals' reduced chi-square when there are more measurements than unknowns:
        # a robust standard error from the solve's residuals and Jacobian
        cov = np.linalg.pinv(sol.jac.T @ sol.jac)
        dof = len(sol.fun) - len(sol.x)
        if dof > 0:
            cov = cov * float(2.0 * np.sum(sol.cost) / dof)
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        std = np.full(len(sol.x), np.nan)
    off_std = {reference: 0.0, **{v: float(std[pos[v]]) for v in free}}
    dr_std = {reference: 0.0, **{v: (float(std[n + pos[v]]) * 1e6 if with_drift else 0.0) for v in free}}
    resid, weight = {}, {}
    for p in used:
        pred = _predicted_offset(p, off, lr)
        resid[(p.a, p.b)] = (float(p.offset_s - pred), float(p.log_rate - (lr[p.b] - lr[p.a])))
        z = abs(resid[(p.a, p.b)][0]) / max(p.offset_std_s, min_offset_std_s)
        weight[(p.a, p.b)] = min(1.0, huber_scale / max(z, 1e-12))
    return DriftSolution(reference, {v: float(o) for v, o in off.items()},
                         {v: float(np.expm1(l) * 1e6) for v, l in lr.items()}, off_std, dr_std, resid,
                         with_drift, weight)
