"""The epipolar vote's compiled kernel: for every candidate track pair, at every offset, whether
b's points stay on the epipolar lines of a's (interpolated at b's moments), and the offset where
they fit best (cues/pairing/votes.py calls it; numba, cached).
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(inline="always")
def _a_at(xa, i, kk, ww):
    """a's point i interpolated between its frames kk and kk + 1 (weight ww on kk + 1)."""
    return (xa[i, kk, 0] + ww * (xa[i, kk + 1, 0] - xa[i, kk, 0]),
            xa[i, kk, 1] + ww * (xa[i, kk + 1, 1] - xa[i, kk, 1]))


@nb.njit(inline="always")
def _sampson(xa, i, kk, ww, G, g, q, l0, l1, l2):
    """Sampson distance² (px²) of a's point interpolated at (kk, ww) and b's point at its frame q
    with line l = G[g, q] x_b."""
    a0, a1 = _a_at(xa, i, kk, ww)
    m0 = G[g, q, 0, 0] * a0 + G[g, q, 1, 0] * a1 + G[g, q, 2, 0]  # line in b: Gᵀ x_a
    m1 = G[g, q, 0, 1] * a0 + G[g, q, 1, 1] * a1 + G[g, q, 2, 1]
    num = a0 * l0 + a1 * l1 + l2
    return num * num / (m0 * m0 + m1 * m1 + l0 * l0 + l1 * l1)  # NaN where a is not seen or G unknown


@nb.njit(inline="always")
def _near(x0, x1, e, r2):
    """(x0, x1) lies within sqrt(r2) px of the homogeneous point e (False when e is at infinity)."""
    if abs(e[2]) < 1e-12:
        return False
    d0 = x0 - e[0] / e[2]
    d1 = x1 - e[1] / e[2]
    return d0 * d0 + d1 * d1 < r2


@nb.njit(inline="always")
def _degenerate(xa, i, kk, ww, xb, j, q, e_a, e_b, g, r2):
    """A moment whose points lie near their epipoles (a's interpolated at (kk, ww), b's at its
    frame q): every epipolar line passes there, so it fits whatever the offset."""
    if r2 <= 0.0:
        return False
    a0, a1 = _a_at(xa, i, kk, ww)
    return _near(xb[j, q, 0], xb[j, q, 1], e_b[g, q], r2) or _near(a0, a1, e_a[g, q], r2)


@nb.njit(inline="always")
def _line_a(xb, j, q, G, g):
    """Epipolar line in a of b's point at its frame q: G[g, q] x_b."""
    y0 = xb[j, q, 0]
    y1 = xb[j, q, 1]
    return (G[g, q, 0, 0] * y0 + G[g, q, 0, 1] * y1 + G[g, q, 0, 2],
            G[g, q, 1, 0] * y0 + G[g, q, 1, 1] * y1 + G[g, q, 1, 2],
            G[g, q, 2, 0] * y0 + G[g, q, 2, 1] * y1 + G[g, q, 2, 2])


@nb.njit(inline="always")
def _first_at_least(k, d, lo, hi, value):
    """The first q in [lo, hi] with k[d, q] >= value (hi + 1 when none); k[d] increases there."""
    while lo <= hi:
        mid = (lo + hi) // 2
        if k[d, mid] >= value:
            hi = mid - 1
        else:
            lo = mid + 1
    return lo


@nb.njit(parallel=True, cache=True)
def _consistency(xa, xb, cand_a, cand_b, G, e_a, e_b, k, w, tau2, min_frames, min_share, max_band,
                 min_sweep, qstep, epi_r2):
    """Per candidate: number of consistent offsets, best offset index, its mean Sampson (px²).

    xa (Na,Ta,2) is interpolated at τ_b + Δ_d via (k, w) (D,Tb); xb (Nb,Tb,2) read at its frames.
    G (Dg,Tb,3,3) with x_aᵀ G[g, q] x_b = 0 at b's frame q, g = d when Dg == D (both cameras move:
    a's pose depends on the offset too) or g = 0 when Dg == 1 (a static: one G repeated for two
    static cameras; per frame when b moves); NaN where a pose is unknown; e_a, e_b (Dg,Tb,3) epipoles
    in a and in b. The fitting moments must spread at least
    min_sweep px across b's epipolar lines. Candidates consistent at more than max_band offsets
    get best -1. Only every qstep-th frame of b is read (frame counts are of those). A fitting
    moment where a point lies within sqrt(epi_r2) px of its epipole (e_a, e_b) is not counted
    (checked for fits only: cheaper, and a miss there is a real miss). The best offset has the
    least mean Sampson over the fitting moments.
    """
    C = cand_a.shape[0]
    D, Tb = k.shape
    per_d = G.shape[0] > 1  # a's pose changes with the offset: lines computed per (d, q)
    n_cons = np.zeros(C, np.int64)
    best = np.full(C, -1, np.int64)
    best_res = np.full(C, np.inf)
    Ta = xa.shape[1]
    # per offset, b's frames whose moment falls within a's frames: [qv0[d], qv1[d]] (k is -1
    # before and after; increasing between)
    qv0 = np.full(D, Tb, np.int64)
    qv1 = np.full(D, -1, np.int64)
    for d in range(D):
        for q in range(Tb):
            if k[d, q] >= 0:
                qv0[d] = min(qv0[d], q)
                qv1[d] = q
    for c in nb.prange(C):
        i = cand_a[c]
        j = cand_b[c]
        lb0 = np.empty(Tb)  # line in a of b's point: G x_b
        lb1 = np.empty(Tb)
        lb2 = np.empty(Tb)
        okb = np.empty(Tb, np.bool_)
        n_okb = np.zeros(Tb + 1, np.int64)  # n_okb[q]: frames of b read before q
        q0, q1, nvb = Tb, -1, 0
        for q in range(Tb):
            y0 = xb[j, q, 0]
            y1 = xb[j, q, 1]
            okb[q] = q % qstep == 0 and not (np.isnan(y0) or np.isnan(y1) or
                                             (not per_d and np.isnan(G[0, q, 0, 0])))
            if okb[q]:
                q0 = min(q0, q)
                q1 = q
                nvb += 1
            lb0[q], lb1[q], lb2[q] = _line_a(xb, j, q, G, 0)
            n_okb[q + 1] = n_okb[q] + okb[q]
        ka0, ka1 = Ta, -1  # a's seen span (interpolation needs frames k and k+1)
        for kk in range(Ta):
            if not np.isnan(xa[i, kk, 0]):
                ka0 = min(ka0, kk)
                ka1 = kk
        if nvb < min_frames or ka1 - ka0 < min_frames - 1:
            continue
        max_miss = (1.0 - min_share) * nvb  # more misses than this can never reach the share
        for d in range(D):
            # k[d] increases with q: skip offsets whose mapped span misses a's span
            if (k[d, q1] >= 0 and k[d, q1] < ka0) or k[d, q0] >= ka1:
                continue
            # the frames of b read whose moment falls within a's seen span, [qa, qb]: at most
            # n_max moments can count, so too few can never be consistent
            qa = max(q0, _first_at_least(k, d, qv0[d], qv1[d], ka0))
            qb = min(q1, _first_at_least(k, d, qv0[d], qv1[d], ka1) - 1)
            n_max = n_okb[qb + 1] - n_okb[qa] if qb >= qa else 0
            if n_max < min_frames:
                continue
            g = d if per_d else 0
            # a few probe moments first: a wrong pair rarely fits more than one of them
            missed = 0
            for m in range(1, 7):
                q = q0 + ((q1 - q0) * m // 7) // qstep * qstep
                kk = k[d, q]
                if not okb[q] or kk < ka0 or kk >= ka1:
                    continue
                if per_d:
                    l0, l1, l2 = _line_a(xb, j, q, G, g)
                else:
                    l0, l1, l2 = lb0[q], lb1[q], lb2[q]
                r = _sampson(xa, i, kk, w[d, q], G, g, q, l0, l1, l2)
                if r >= 2.25 * tau2:  # False for NaN (a not seen there)
                    missed += 1
                    if missed > 1:  # refused already: the other probes cannot change that
                        break
            if missed > 1:
                continue
            n = 0
            fit = 0
            acc = 0.0
            r0 = 0.0  # reference epipolar line in b through the first fitting point
            r1 = 0.0
            r2 = 0.0
            lo = np.inf
            hi = -np.inf
            for q in range(q0 + (qa - q0 + qstep - 1) // qstep * qstep, qb + 1, qstep):
                kk = k[d, q]
                if kk < ka0 or kk >= ka1 or not okb[q]:
                    continue
                if per_d:
                    l0, l1, l2 = _line_a(xb, j, q, G, g)
                else:
                    l0, l1, l2 = lb0[q], lb1[q], lb2[q]
                r = _sampson(xa, i, kk, w[d, q], G, g, q, l0, l1, l2)
                if np.isnan(r):
                    continue
                n += 1
                if r >= tau2:
                    # even if every moment left fitted, the share would fall short
                    if n - fit > max_miss or fit + (n_max - n) < min_share * n_max:
                        break
                    continue
                if _degenerate(xa, i, kk, w[d, q], xb, j, q, e_a, e_b, g, epi_r2):
                    n -= 1  # it fits because every epipolar line passes there: not counted
                    continue
                if fit == 0:
                    y0 = xb[j, q, 0]
                    y1 = xb[j, q, 1]
                    r0 = y1 * e_b[g, q, 2] - e_b[g, q, 1]
                    r1 = e_b[g, q, 0] - y0 * e_b[g, q, 2]
                    r2 = y0 * e_b[g, q, 1] - y1 * e_b[g, q, 0]
                    nn = np.sqrt(r0 * r0 + r1 * r1)
                    if nn > 0:
                        r0 /= nn
                        r1 /= nn
                        r2 /= nn
                fit += 1
                acc += r
                s = r0 * xb[j, q, 0] + r1 * xb[j, q, 1] + r2
                lo = min(lo, s)
                hi = max(hi, s)
            if n >= min_frames and fit >= min_share * n and hi - lo >= min_sweep:
                n_cons[c] += 1
                mean = acc / fit
                if mean < best_res[c]:
                    best_res[c] = mean
                    best[c] = d
        if n_cons[c] > max_band:
            best[c] = -1
    return n_cons, best, best_res
