"""Compiled inner loops of the energy landscape (numba, parallel over track pairs).

Roles: the "sampled" video s is read at its own frames j; the "interpolated" video i is read at
time t_s[j] ± Δ, between its frames k[d,j] and k[d,j]+1 with weight w[d,j]. G is oriented so that
x_sᵀ G x_i = 0. Each track pair's data (a few kB) stays in cache while every offset d is scored,
which is what makes this fast; per-thread partial sums avoid write contention.
"""

from __future__ import annotations

import numba as nb
import numpy as np

RESIDUAL_CODE = {"sampson": 0, "symmetric": 1, "cosine": 2, "algebraic": 3}
LOSS_CODE = {"mean": 0, "truncated": 1}
# fast-math without the no-NaN/no-inf flags: the NaN tests below must survive optimization.
_FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}


@nb.njit(inline="always", fastmath=_FAST)
def _residual(kind, num, ma0, ma1, ma2, g0, g1, g2, xs0, xs1, xi0, xi1):
    # num = x_sᵀ G x_i; m = Gᵀ x_s (line in i); g = G x_i (line in s).
    if kind == 0:
        return num * num / (ma0 * ma0 + ma1 * ma1 + g0 * g0 + g1 * g1)
    if kind == 1:
        return num * num * (1.0 / (ma0 * ma0 + ma1 * ma1) + 1.0 / (g0 * g0 + g1 * g1))
    if kind == 2:
        ns = xs0 * xs0 + xs1 * xs1 + 1.0
        ni = xi0 * xi0 + xi1 * xi1 + 1.0
        return num * num * (1.0 / (ns * (g0 * g0 + g1 * g1 + g2 * g2))
                            + 1.0 / (ni * (ma0 * ma0 + ma1 * ma1 + ma2 * ma2)))
    return abs(num)


@nb.njit(inline="always", fastmath=_FAST)
def _loss(loss, r, scale):
    if loss == 1:
        return r if r < scale else scale
    return r


@nb.njit(parallel=True, fastmath=_FAST, cache=True)
def landscape_static(xs, xi, pair_s, pair_i, weight, G, k, w, kind, loss, scale, nthreads):
    """Constant G (both cameras static).

    xs: (Ns,Ts,2) px; xi: (Ni,Ti,2) px; pair_s/pair_i: (P,) track indices; weight: (P,)
    G: (3,3); k: (D,Ts) int (-1 = outside i); w: (D,Ts).
    Returns (sum of weighted loss (D,), sum of weights (D,), count of terms (D,)).
    """
    P = pair_s.shape[0]
    D, Ts = k.shape
    Ti = xi.shape[1]
    acc = np.zeros((nthreads, D))
    wsum = np.zeros((nthreads, D))
    cnt = np.zeros((nthreads, D), dtype=np.int64)
    chunk = (P + nthreads - 1) // nthreads
    for th in nb.prange(nthreads):
        m = np.empty((Ts, 3))
        okm = np.empty(Ts, dtype=np.bool_)
        g = np.empty((Ti, 3))
        oki = np.empty(Ti, dtype=np.bool_)
        for p in range(th * chunk, min(P, (th + 1) * chunk)):
            a = pair_s[p]
            b = pair_i[p]
            wp = weight[p]
            for j in range(Ts):
                x0 = xs[a, j, 0]
                x1 = xs[a, j, 1]
                okm[j] = not (np.isnan(x0) or np.isnan(x1))
                # m = Gᵀ x_s
                m[j, 0] = G[0, 0] * x0 + G[1, 0] * x1 + G[2, 0]
                m[j, 1] = G[0, 1] * x0 + G[1, 1] * x1 + G[2, 1]
                m[j, 2] = G[0, 2] * x0 + G[1, 2] * x1 + G[2, 2]
            for q in range(Ti):
                y0 = xi[b, q, 0]
                y1 = xi[b, q, 1]
                oki[q] = not (np.isnan(y0) or np.isnan(y1))
                g[q, 0] = G[0, 0] * y0 + G[0, 1] * y1 + G[0, 2]
                g[q, 1] = G[1, 0] * y0 + G[1, 1] * y1 + G[1, 2]
                g[q, 2] = G[2, 0] * y0 + G[2, 1] * y1 + G[2, 2]
            for d in range(D):
                s_acc = 0.0
                s_cnt = 0
                for j in range(Ts):
                    kk = k[d, j]
                    if kk < 0 or not okm[j]:
                        continue
                    if not (oki[kk] and oki[kk + 1]):
                        continue
                    ww = w[d, j]
                    y0 = xi[b, kk, 0] + ww * (xi[b, kk + 1, 0] - xi[b, kk, 0])
                    y1 = xi[b, kk, 1] + ww * (xi[b, kk + 1, 1] - xi[b, kk, 1])
                    # G x_i is linear in x_i, so it interpolates like x_i does.
                    g0 = g[kk, 0] + ww * (g[kk + 1, 0] - g[kk, 0])
                    g1 = g[kk, 1] + ww * (g[kk + 1, 1] - g[kk, 1])
                    g2 = g[kk, 2] + ww * (g[kk + 1, 2] - g[kk, 2])
                    num = m[j, 0] * y0 + m[j, 1] * y1 + m[j, 2]
                    r = _residual(kind, num, m[j, 0], m[j, 1], m[j, 2], g0, g1, g2,
                                  xs[a, j, 0], xs[a, j, 1], y0, y1)
                    s_acc += _loss(loss, r, scale)
                    s_cnt += 1
                acc[th, d] += wp * s_acc
                wsum[th, d] += wp * s_cnt
                cnt[th, d] += s_cnt
    return acc.sum(axis=0), wsum.sum(axis=0), cnt.sum(axis=0)


@nb.njit(parallel=True, fastmath=_FAST, cache=True)
def landscape_moving(xs, xi, pair_s, pair_i, weight, G, k, w, kind, loss, scale, nthreads):
    """G per (offset, sampled frame): G (D,Ts,3,3), NaN where a pose is unknown. Else as above."""
    P = pair_s.shape[0]
    D, Ts = k.shape
    acc = np.zeros((nthreads, D))
    wsum = np.zeros((nthreads, D))
    cnt = np.zeros((nthreads, D), dtype=np.int64)
    chunk = (P + nthreads - 1) // nthreads
    for th in nb.prange(nthreads):
        for p in range(th * chunk, min(P, (th + 1) * chunk)):
            a = pair_s[p]
            b = pair_i[p]
            wp = weight[p]
            for d in range(D):
                s_acc = 0.0
                s_cnt = 0
                for j in range(Ts):
                    kk = k[d, j]
                    if kk < 0:
                        continue
                    x0 = xs[a, j, 0]
                    x1 = xs[a, j, 1]
                    ya0 = xi[b, kk, 0]
                    yb0 = xi[b, kk + 1, 0]
                    if np.isnan(x0) or np.isnan(x1) or np.isnan(ya0) or np.isnan(yb0):
                        continue
                    if np.isnan(G[d, j, 0, 0]):
                        continue
                    ww = w[d, j]
                    y0 = ya0 + ww * (yb0 - ya0)
                    y1 = xi[b, kk, 1] + ww * (xi[b, kk + 1, 1] - xi[b, kk, 1])
                    Gd = G[d, j]
                    m0 = Gd[0, 0] * x0 + Gd[1, 0] * x1 + Gd[2, 0]
                    m1 = Gd[0, 1] * x0 + Gd[1, 1] * x1 + Gd[2, 1]
                    m2 = Gd[0, 2] * x0 + Gd[1, 2] * x1 + Gd[2, 2]
                    g0 = Gd[0, 0] * y0 + Gd[0, 1] * y1 + Gd[0, 2]
                    g1 = Gd[1, 0] * y0 + Gd[1, 1] * y1 + Gd[1, 2]
                    g2 = Gd[2, 0] * y0 + Gd[2, 1] * y1 + Gd[2, 2]
                    num = m0 * y0 + m1 * y1 + m2
                    r = _residual(kind, num, m0, m1, m2, g0, g1, g2, x0, x1, y0, y1)
                    if np.isnan(r):
                        continue
                    s_acc += _loss(loss, r, scale)
                    s_cnt += 1
                acc[th, d] += wp * s_acc
                wsum[th, d] += wp * s_cnt
                cnt[th, d] += s_cnt
    return acc.sum(axis=0), wsum.sum(axis=0), cnt.sum(axis=0)
