"""One association of people held at every candidate shift (sync/people_pairs.py's step 2): its
F fitted at each, each frame's labelling under it, the evidence of the shifts, and how far around
the best one the others fit about as well.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.two_view import fundamental_irls
from .decision import local_minima
from .people_config import PeoplePairConfig
from .people_search import (EPS_S, _Association, _Side, _associate, _moments, _pooled, _ransac, _sampson2,
                            _score, _side_of)


@dataclass(frozen=True)
class _Fit:
    """One association's F at one shift."""

    F_ab: np.ndarray
    cost: float  # mean truncated squared Sampson distance in noise units, 0..1
    inliers: int
    points: int  # correspondences
    mirrored: dict  # (i, j) -> (Q,) bool, each frame's labelling
    frames: np.ndarray  # (Q,) frames of a the shift pairs with b's moments
    frame_cost: np.ndarray  # (K,Q) each pairing's mean cost in each frame (NaN: no correspondence)


def _rows(xa, xb, pairs, mirror, unit):
    """Per pairing: (a (Q,L,2), b as labelled (Q,L,2), b mirrored (Q,L,2), unit)."""
    return [(xa[i], xb[j], xb[j][:, mirror], unit[i, j]) for i, j in pairs]


def _labels(F: np.ndarray, rows) -> tuple[dict, float, int, int, np.ndarray]:
    """Each frame's better labelling under F: ({k: (Q,) bool mirrored}, total truncated cost,
    inliers, correspondences, (K,Q) each pairing's mean cost per frame (NaN: none)). A
    correspondence on the minority side of the epipole (_side_of) costs as much as a misfit."""
    terms = []
    for xa, xb, xm, u in rows:
        per = []
        for other in (xb, xm):
            la = other @ F[:, :2].T + F[:, 2]
            r2 = _sampson2(F, xa, other) / u ** 2
            per.append((r2, _side_of(F, xa, la)))
        terms.append(per)
    votes = sum(float(np.where(r2 < 1, sd, 0.0).sum()) for per in terms for r2, sd in per)
    majority = 1.0 if votes >= 0 else -1.0
    out, total, inl, n = {}, 0.0, 0, 0
    per_frame = []
    for k, per in enumerate(terms):
        costs = []
        for r2, sd in per:
            seen = np.isfinite(r2)
            c = np.where(sd == majority, np.minimum(r2, 1.0), 1.0)
            costs.append((np.where(seen, c, 0.0).sum(-1), seen.sum(-1), ((r2 < 1) & (sd == majority)).sum(-1)))
        # a frame's labelling: the one with fewer misfits over the landmarks both see
        miss_d = costs[0][0] + (costs[1][1] - costs[0][1]).clip(0)
        miss_m = costs[1][0] + (costs[0][1] - costs[1][1]).clip(0)
        m = miss_m < miss_d
        out[k] = m
        c_sum, c_n = np.where(m, costs[1][0], costs[0][0]), np.where(m, costs[1][1], costs[0][1])
        total += float(c_sum.sum())
        n += int(c_n.sum())
        inl += int(np.where(m, costs[1][2], costs[0][2]).sum())
        with np.errstate(invalid="ignore", divide="ignore"):
            per_frame.append(np.where(c_n > 0, c_sum / c_n, np.nan))
    return out, total, inl, n, np.array(per_frame).reshape(len(terms), -1)


def _chosen(rows, labels: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x_a (M,2), x_b (M,2), unit (M,)) of every pairing in each frame's labelling."""
    xs, ys, us = [], [], []
    for k, (xa, xb, xm, u) in enumerate(rows):
        b = np.where(labels[k][:, None, None], xm, xb)
        ok = np.isfinite(xa).all(-1) & np.isfinite(b).all(-1)
        xs.append(xa[ok])
        ys.append(b[ok])
        us.append(np.full(int(ok.sum()), u))
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(us)


def _fit_held(frames, xa, xb, assoc: _Association, starts: list, mirror, unit, cfg: PeoplePairConfig) -> _Fit | None:
    """The association at one shift: from each start F (None: a fresh RANSAC fit), IRLS, each
    frame's labelling under it (IRLS again when some frames changed labelling); the lowest cost."""
    rows = _rows(xa, xb, assoc.pairs, mirror, unit)
    init = {k: np.full(xa.shape[1], assoc.mirrored[p]) for k, p in enumerate(assoc.pairs)}
    x_a, x_b, u = _chosen(rows, init)
    if len(x_a) < max(cfg.min_pair_points, 8):
        return None
    best = None
    for F in starts:
        if F is None:
            fr = np.zeros(len(x_a), np.int64)
            F = _ransac(x_a, x_b, fr, u, cfg)
            if F is None:
                continue
        F = fundamental_irls(x_a, x_b, F, u, cfg.irls_iterations)
        labels, total, inl, n, per_frame = _labels(F, rows)
        if any((labels[k] != init[k]).any() for k in labels):  # some frames fit better the other way
            ya, yb, yu = _chosen(rows, labels)
            if len(ya) >= 8:
                F = fundamental_irls(ya, yb, F, yu, cfg.irls_iterations)
                labels, total, inl, n, per_frame = _labels(F, rows)
        fit = _Fit(F, total / max(n, 1), inl, n, {p: labels[k] for k, p in enumerate(assoc.pairs)}, frames, per_frame)
        if best is None or fit.cost < best.cost:
            best = fit
    return best


def _landscape(a: _Side, b: _Side, offsets_s: np.ndarray, assoc: _Association, mirror: np.ndarray,
               unit: np.ndarray, cfg: PeoplePairConfig, every: int = 1) -> list[_Fit | None]:
    """The association held at every shift (a _Fit, None: too few correspondences there), swept
    outwards from the shift where it was found, each shift started from its neighbour's F (and
    every fresh_every shifts from a fresh RANSAC fit too); every > 1: at every that many shifts
    only (a sketch)."""
    out: list[_Fit | None] = [None] * len(offsets_s)
    i0 = int(np.argmin(np.abs(offsets_s - assoc.offset_s)))
    for sweep in (range(i0, len(offsets_s), every), range(i0 - every, -1, -every)):
        F = assoc.F_ab
        for n, i in enumerate(sweep):
            frames, xa, xb = _moments(a, b, float(offsets_s[i]), None)
            starts = [F] + ([None] if n % cfg.fresh_every == 0 else [])
            fit = _fit_held(frames, xa, xb, assoc, starts, mirror, unit, cfg)
            out[i] = fit
            if fit is not None:
                F = fit.F_ab
    return out


def _evidence(fits: list[_Fit | None]) -> np.ndarray:
    """(D,) how far each shift's mean cost lies below the landscape's median, times the square
    root of its correspondences (0 where there are none)."""
    cost = np.array([f.cost if f is not None else np.nan for f in fits])
    n = np.array([f.points if f is not None else 0 for f in fits], dtype=np.float64)
    if not np.isfinite(cost).any():
        return np.zeros(len(fits))
    median = float(np.nanmedian(cost))
    return np.where(np.isfinite(cost), (median - np.nan_to_num(cost)) * np.sqrt(n), 0.0)


def _indistinct_span(offsets_s: np.ndarray, fits: list[_Fit | None], best: int, t_min: float) -> tuple[float, float]:
    """(lo, hi) Δ around the best shift over which the cost is not significantly higher than the
    best's: walking outwards, a shift is indistinct while the paired difference of the pairings'
    per-frame costs (the same frames of a, at both shifts) has a t-statistic under t_min."""
    ref = fits[best]
    span = [float(offsets_s[best]), float(offsets_s[best])]
    for side, step in ((0, -1), (1, 1)):
        j = best + step
        while 0 <= j < len(fits):
            f = fits[j]
            if f is None:
                break
            common, ia, ib = np.intersect1d(ref.frames, f.frames, return_indices=True)
            d = (f.frame_cost[:, ib] - ref.frame_cost[:, ia]).ravel()
            d = d[np.isfinite(d)]
            if len(d) < 2:
                break
            t = float(d.mean() / max(d.std(ddof=1) / np.sqrt(len(d)), 1e-12))
            if t >= t_min:
                break
            span[side] = float(offsets_s[j])
            j += step
    return span[0], span[1]


def _rival_peak(offsets_s: np.ndarray, evidence: np.ndarray, best: int, distinct_s: float) -> tuple[int | None, float]:
    """(the most prominent other peak of evidence at least distinct_s from offsets_s[best], the
    best peak's prominence over that one's; inf without one). Peaks are compared by their
    prominence, as Stage 1 compares minima (sync/decision.local_minima): a bump on the side of a
    broad valley is no rival."""
    minima, prom = local_minima(-np.where(np.isfinite(evidence), evidence, np.nan), 0.0)
    own = prom[minima == best]
    rivals = [(p, int(m)) for m, p in zip(minima, prom) if abs(offsets_s[m] - offsets_s[best]) >= distinct_s - EPS_S]
    if not len(own) or not rivals:
        return None, np.inf
    p, m = max(rivals)
    return m, float(own[0] / max(p, 1e-12))


def _grown(a: _Side, b: _Side, assoc: _Association, mirror: np.ndarray, unit: np.ndarray,
           cfg: PeoplePairConfig) -> _Association | None:
    """The association at its shift with every person pairing that fits its F there over all
    frames (the search saw some only), when that adds any and keeps it; else None."""
    _, xa, xb = _moments(a, b, assoc.offset_s, None)
    F = assoc.F_ab
    for _ in range(2):
        sc = _score(F, xa, xb, mirror, unit)
        pairs = tuple(sorted(_associate(sc, cfg)))
        if not set(assoc.pairs) <= set(pairs):
            return None
        mirrored = {p: bool(2 * sc.mirrored[p] > sc.frames[p].sum()) for p in pairs}
        x_a, x_b, _, u = _pooled(xa, xb, pairs, mirrored, mirror, unit)
        F = fundamental_irls(x_a, x_b, F, u, cfg.irls_iterations)
    if pairs == assoc.pairs:
        return None
    return _Association(assoc.offset_s, assoc.score, pairs, mirrored, F)
