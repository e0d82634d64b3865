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
# fast-math without the no-NaN/no-inf flags (the NaN tests below must survive optimization) and
# without reassociation: with it, a freshly compiled kernel and the same kernel loaded from
# numba's cache summed in different orders, so a machine's first run gave other offsets (in the
# 5th digit) than its later runs and than Ray workers; without it, the same speed (bench energy).
_FAST = {"nsz", "arcp", "contract", "afn"}


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
    Per pair, G x is precomputed for every frame in float32 and the inner loop is branch-free
    (invalid terms are multiplied by a 0 mask), which lets LLVM vectorize it.
    """
    P = pair_s.shape[0]
    D, Ts = k.shape
    Ti = xi.shape[1]
    kc = np.empty((D, Ts), dtype=np.int64)
    kv = np.empty((D, Ts), dtype=np.float32)
    w32 = np.empty((D, Ts), dtype=np.float32)
    for d in range(D):
        for j in range(Ts):
            inside = k[d, j] >= 0
            kc[d, j] = k[d, j] if inside else 0
            kv[d, j] = 1.0 if inside else 0.0
            w32[d, j] = w[d, j]
    acc = np.zeros((nthreads, D))
    wsum = np.zeros((nthreads, D))
    cnt = np.zeros((nthreads, D))
    chunk = (P + nthreads - 1) // nthreads
    sc = np.float32(scale)
    zero = np.float32(0.0)
    for th in nb.prange(nthreads):
        S = np.empty((6, Ts), dtype=np.float32)  # x0 x1 m0 m1 m2 valid   (m = Gᵀ x_s)
        I = np.empty((6, Ti), dtype=np.float32)  # y0 y1 g0 g1 g2 valid(q and q+1)   (g = G x_i)
        for p in range(th * chunk, min(P, (th + 1) * chunk)):
            a = pair_s[p]
            b = pair_i[p]
            wp = weight[p]
            for j in range(Ts):
                x0 = xs[a, j, 0]
                x1 = xs[a, j, 1]
                ok = not (np.isnan(x0) or np.isnan(x1))
                if not ok:
                    x0 = 0.0
                    x1 = 0.0
                S[0, j] = x0
                S[1, j] = x1
                S[2, j] = G[0, 0] * x0 + G[1, 0] * x1 + G[2, 0]
                S[3, j] = G[0, 1] * x0 + G[1, 1] * x1 + G[2, 1]
                S[4, j] = G[0, 2] * x0 + G[1, 2] * x1 + G[2, 2]
                S[5, j] = 1.0 if ok else 0.0
            for q in range(Ti):
                y0 = xi[b, q, 0]
                y1 = xi[b, q, 1]
                ok = not (np.isnan(y0) or np.isnan(y1))
                if not ok:
                    y0 = 0.0
                    y1 = 0.0
                I[0, q] = y0
                I[1, q] = y1
                I[2, q] = G[0, 0] * y0 + G[0, 1] * y1 + G[0, 2]
                I[3, q] = G[1, 0] * y0 + G[1, 1] * y1 + G[1, 2]
                I[4, q] = G[2, 0] * y0 + G[2, 1] * y1 + G[2, 2]
                I[5, q] = 1.0 if ok else 0.0
            for q in range(Ti - 1):
                I[5, q] = I[5, q] * I[5, q + 1]
            I[5, Ti - 1] = 0.0
            for d in range(D):
                s_acc = np.float32(0.0)
                s_cnt = np.float32(0.0)
                for j in range(Ts):
                    kk = kc[d, j]
                    k1 = kk + 1 if kk + 1 < Ti else kk
                    ww = w32[d, j]
                    # G x_i is linear in x_i, so it interpolates like x_i does.
                    y0 = I[0, kk] + ww * (I[0, k1] - I[0, kk])
                    y1 = I[1, kk] + ww * (I[1, k1] - I[1, kk])
                    g0 = I[2, kk] + ww * (I[2, k1] - I[2, kk])
                    g1 = I[3, kk] + ww * (I[3, k1] - I[3, kk])
                    g2 = I[4, kk] + ww * (I[4, k1] - I[4, kk])
                    num = S[2, j] * y0 + S[3, j] * y1 + S[4, j]
                    r = _residual(kind, num, S[2, j], S[3, j], S[4, j], g0, g1, g2,
                                  S[0, j], S[1, j], y0, y1)
                    v = S[5, j] * I[5, kk] * kv[d, j]
                    # a select, not a branch: masked terms may hold 0/0 (NaN * 0 is still NaN)
                    s_acc += _loss(loss, r, sc) if v > 0 else zero
                    s_cnt += v
                acc[th, d] += wp * s_acc
                wsum[th, d] += wp * s_cnt
                cnt[th, d] += s_cnt
    return acc.sum(axis=0), wsum.sum(axis=0), cnt.sum(axis=0).astype(np.int64)


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
