"""The search for which person of one video is which of another (sync/people_pairs.py's step 1):
each video's people, both videos' at one shift, every person pairing scored under an F, and the
associations RANSAC over person pairings finds at a shift or carries from a nearby one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from ..geometry.sampling import tracks_between_frames
from ..geometry.skeleton import person_scale_px
from ..geometry.timing import frame_brackets
from ..geometry.two_view import fundamental_irls, fundamental_ransac
from .people_config import PeoplePairConfig

EPS_S = 1e-9


# ---- one video's people, and both at one shift -----------------------------------------------


@dataclass(frozen=True)
class _Side:
    """One video's people: times (T,) s, seen landmarks (P,T,L,2) px (NaN: unseen), sizes (P,) px."""

    times_s: np.ndarray
    xy: np.ndarray
    size_px: np.ndarray

    @staticmethod
    def of(times_s: np.ndarray, xy: np.ndarray) -> _Side:
        size = person_scale_px(xy)  # (P,T)
        med = np.array([np.median(s[np.isfinite(s)]) if np.isfinite(s).any() else np.nan for s in size])
        return _Side(times_s, xy, med)

    @property
    def people(self) -> int:
        return self.xy.shape[0]


def _b_at(b: _Side, query_s: np.ndarray) -> np.ndarray:
    """(Pb,Q,L,2) b's landmarks at b's local times query_s (Q,), linear between frames."""
    P, T, L, _ = b.xy.shape
    if T < 2:
        return np.full((P, len(query_s), L, 2), np.nan)
    k, w = frame_brackets(b.times_s, query_s)
    flat = b.xy.transpose(0, 2, 1, 3).reshape(P * L, T, 2)
    return tracks_between_frames(flat, k, w).reshape(P, L, len(query_s), 2).transpose(0, 2, 1, 3)


def _moments(a: _Side, b: _Side, delta: float, max_frames: int | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(frames of a (Q,), a's landmarks there (Pa,Q,L,2), b's at the same moments (Pb,Q,L,2)),
    over the frames of a whose moment b saw; at most max_frames, evenly spread."""
    q = a.times_s - delta
    frames = np.nonzero((q >= b.times_s[0] - EPS_S) & (q <= b.times_s[-1] + EPS_S))[0]
    if max_frames is not None and len(frames) > max_frames:
        frames = frames[np.unique(np.linspace(0, len(frames) - 1, max_frames).astype(np.int64))]
    return frames, a.xy[:, frames], _b_at(b, q[frames])


def _noise_px(a: _Side, b: _Side, cfg: PeoplePairConfig) -> np.ndarray:
    """(Pa,Pb) the noise unit of each person pairing, px."""
    unit = cfg.noise_share * np.sqrt(np.outer(a.size_px, b.size_px))
    return np.maximum(np.nan_to_num(unit, nan=cfg.min_noise_px), cfg.min_noise_px)


def _sampson2(F: np.ndarray, x_a: np.ndarray, x_b: np.ndarray) -> np.ndarray:
    """Squared Sampson distance (px²) of broadcast x_a, x_b (...,2); NaN where either is unseen."""
    la = x_b @ F[:, :2].T + F[:, 2]  # F x_b
    lb = x_a @ F[:2] + F[2]  # Fᵀ x_a
    num = x_a[..., 0] * la[..., 0] + x_a[..., 1] * la[..., 1] + la[..., 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        return num * num / (la[..., 0] ** 2 + la[..., 1] ** 2 + lb[..., 0] ** 2 + lb[..., 1] ** 2)


def _side_of(F: np.ndarray, x_a: np.ndarray, la: np.ndarray) -> np.ndarray:
    """The oriented epipolar constraint's sign of correspondences (x_a (...,2), la = F x_b
    (...,3)): sign((e_a × x_a) · F x_b) with e_a the epipole in a. Points in front of both
    cameras all share one sign; a fit whose epipole sits amid the points (every line passing near
    every point) splits them, so the minority is counted as misfits."""
    e = np.linalg.svd(F)[0][:, 2]  # e_aᵀ F = 0
    c0 = e[1] - e[2] * x_a[..., 1]
    c1 = e[2] * x_a[..., 0] - e[0]
    c2 = e[0] * x_a[..., 1] - e[1] * x_a[..., 0]
    return np.sign(c0 * la[..., 0] + c1 * la[..., 1] + c2 * la[..., 2])


@dataclass(frozen=True)
class _Scored:
    """Every person pairing under one F, each frame under its better labelling."""

    counts: np.ndarray  # (Pa,Pb) inliers
    points: np.ndarray  # (Pa,Pb) correspondences
    mirrored: np.ndarray  # (Pa,Pb) frames whose better labelling is the mirrored one
    frames: np.ndarray  # (Pa,Pb,Q) bool, frames both see


@nb.njit(cache=True)
def _score_kernel(F, e, xa, xb, mirror, unit2):
    """_score's loops: two passes over every (pairing, frame, landmark, labelling), the first for
    the majority side of the epipole among the correspondences near their lines, the second for
    the inliers on that side."""
    Pa, Q, L = xa.shape[0], xa.shape[1], xa.shape[2]
    Pb = xb.shape[0]
    vote = 0.0
    for pass_ in range(2):
        majority = 1.0 if vote >= 0 else -1.0
        counts = np.zeros((Pa, Pb), np.int64)
        points = np.zeros((Pa, Pb), np.int64)
        mirrored = np.zeros((Pa, Pb), np.int64)
        frames = np.zeros((Pa, Pb, Q), np.bool_)
        for i in range(Pa):
            for q in range(Q):
                for j in range(Pb):
                    nd = 0
                    nm = 0
                    for l in range(L):
                        a0, a1 = xa[i, q, l, 0], xa[i, q, l, 1]
                        if not (np.isfinite(a0) and np.isfinite(a1)):
                            continue
                        lb0 = F[0, 0] * a0 + F[1, 0] * a1 + F[2, 0]
                        lb1 = F[0, 1] * a0 + F[1, 1] * a1 + F[2, 1]
                        if np.isfinite(xb[j, q, l, 0]) and np.isfinite(xb[j, q, l, 1]):
                            points[i, j] += 1
                            frames[i, j, q] = True
                        for m in range(2):
                            k = l if m == 0 else mirror[l]
                            b0, b1 = xb[j, q, k, 0], xb[j, q, k, 1]
                            if not (np.isfinite(b0) and np.isfinite(b1)):
                                continue
                            la0 = F[0, 0] * b0 + F[0, 1] * b1 + F[0, 2]
                            la1 = F[1, 0] * b0 + F[1, 1] * b1 + F[1, 2]
                            la2 = F[2, 0] * b0 + F[2, 1] * b1 + F[2, 2]
                            num = a0 * la0 + a1 * la1 + la2
                            if num * num >= unit2[i, j] * (la0 * la0 + la1 * la1 + lb0 * lb0 + lb1 * lb1):
                                continue
                            side = (e[1] - e[2] * a1) * la0 + (e[2] * a0 - e[0]) * la1 + (e[0] * a1 - e[1] * a0) * la2
                            if pass_ == 0:
                                vote += 1.0 if side > 0 else (-1.0 if side < 0 else 0.0)
                            elif side * majority > 0:
                                if m == 0:
                                    nd += 1
                                else:
                                    nm += 1
                    if pass_ == 1:
                        counts[i, j] += max(nd, nm)
                        if nm > nd:
                            mirrored[i, j] += 1
    return counts, points, mirrored, frames


def _score(F: np.ndarray, xa: np.ndarray, xb: np.ndarray, mirror: np.ndarray, unit: np.ndarray) -> _Scored:
    """xa (Pa,Q,L,2), xb (Pb,Q,L,2) at the same moments; unit (Pa,Pb) px. An inlier is near its
    epipolar line (Sampson distance under one unit) and on the side of the epipole most such
    correspondences are on (_side_of); each frame of a pairing counts under its better labelling."""
    e = np.linalg.svd(F)[0][:, 2]
    counts, points, mirrored, frames = _score_kernel(np.ascontiguousarray(F, np.float64), np.ascontiguousarray(e),
                                                     np.ascontiguousarray(xa, np.float64),
                                                     np.ascontiguousarray(xb, np.float64),
                                                     np.ascontiguousarray(mirror, np.int64),
                                                     np.ascontiguousarray(unit ** 2, np.float64))
    return _Scored(counts, points, mirrored, frames)


def _associate(sc: _Scored, cfg: PeoplePairConfig) -> list[tuple[int, int]]:
    """Person pairings, most inliers first, each with enough inliers, none giving a person two
    partners in one frame (a person's track cut in two may share its partner)."""
    Pb = sc.counts.shape[1]
    taken_a = np.zeros((sc.counts.shape[0], sc.frames.shape[-1]), bool)
    taken_b = np.zeros((Pb, sc.frames.shape[-1]), bool)
    out = []
    for flat in np.argsort(-sc.counts, axis=None, kind="stable"):
        i, j = divmod(int(flat), Pb)
        n = sc.counts[i, j]
        if n < cfg.min_pair_points:
            break
        if n < cfg.min_pair_inlier_share * sc.points[i, j]:
            continue
        f = sc.frames[i, j]
        if (taken_a[i] & f).sum() > 0.1 * f.sum() or (taken_b[j] & f).sum() > 0.1 * f.sum():
            continue
        taken_a[i] |= f
        taken_b[j] |= f
        out.append((i, j))
    return out


def _pooled(xa: np.ndarray, xb: np.ndarray, pairs, mirrored: dict, mirror: np.ndarray, unit: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(x_a (M,2), x_b (M,2), frame (M,), unit (M,) px) of the pairings, each in its labelling
    (mirrored[(i, j)]: a bool, or (Q,) bools per frame)."""
    out = [[], [], [], []]
    L = xa.shape[2]
    for i, j in pairs:
        m = np.broadcast_to(np.asarray(mirrored.get((i, j), False)), (xa.shape[1],))
        b = np.where(m[:, None, None], xb[j][:, mirror], xb[j][:, np.arange(L)])
        ok = np.isfinite(xa[i]).all(-1) & np.isfinite(b).all(-1)
        q, _ = np.nonzero(ok)
        for c, v in enumerate((xa[i][ok], b[ok], q, np.full(len(q), unit[i, j]))):
            out[c].append(v)
    if not out[0]:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0)
    return tuple(np.concatenate(v) for v in out)


def _spread(frame: np.ndarray, n: int) -> np.ndarray:
    """Indices of at most n rows, evenly spread over time (rows sorted by frame)."""
    order = np.argsort(frame, kind="stable")
    return order[np.unique(np.linspace(0, len(order) - 1, min(n, len(order))).astype(np.int64))]


def _ransac(x_a, x_b, frame, unit, cfg: PeoplePairConfig, reweigh: bool = True) -> np.ndarray | None:
    """F_ab by MAGSAC on a subsample spread over time, then (reweigh) reweighted on all
    (fundamental_irls)."""
    if len(x_a) < 8:
        return None
    idx = _spread(frame, cfg.sample_points)
    F, _ = fundamental_ransac(x_a[idx], x_b[idx], float(np.median(unit)), 0.999, 200)
    if F is None or not reweigh:
        return F
    return fundamental_irls(x_a, x_b, F, unit, cfg.irls_iterations)


@dataclass(frozen=True)
class _Association:
    """An association found at one shift by the search."""

    offset_s: float
    score: float  # inliers per frame scored
    pairs: tuple[tuple[int, int], ...]  # (person in a, person in b), sorted
    mirrored: dict  # (i, j) -> bool: most frames fit better mirrored
    F_ab: np.ndarray


def _settle(xa: np.ndarray, xb: np.ndarray, F: np.ndarray, delta: float, mirror: np.ndarray, unit: np.ndarray,
            cfg: PeoplePairConfig) -> _Association | None:
    """From an F: associate, refit on the associated people, associate again (twice); the
    association (None: no pairing fits)."""
    Q = xa.shape[1]
    pairs: list = []
    for _ in range(2):
        sc = _score(F, xa, xb, mirror, unit)
        pairs = _associate(sc, cfg)
        if not pairs:
            return None
        mirrored = {p: bool(2 * sc.mirrored[p] > sc.frames[p].sum()) for p in pairs}
        x_a, x_b, _, u = _pooled(xa, xb, pairs, mirrored, mirror, unit)
        F = fundamental_irls(x_a, x_b, F, u, 3)
    sc = _score(F, xa, xb, mirror, unit)
    pairs = _associate(sc, cfg)
    if not pairs:
        return None
    key = tuple(sorted(pairs))
    return _Association(delta, float(sum(sc.counts[p] for p in pairs)) / Q, key,
                        {p: bool(2 * sc.mirrored[p] > sc.frames[p].sum()) for p in key}, F)


def _search_at(a: _Side, b: _Side, delta: float, mirror: np.ndarray, unit: np.ndarray,
               cfg: PeoplePairConfig) -> list[_Association]:
    """The distinct associations RANSAC over person pairings finds at one shift, best first."""
    _, xa, xb = _moments(a, b, delta, cfg.search_frames)
    if not xa.shape[1] or not a.people or not b.people:
        return []
    points = np.einsum("iql,jql->ij", np.isfinite(xa[..., 0]).astype(np.int32),
                       np.isfinite(xb[..., 0]).astype(np.int32))
    order = np.argsort(-points, axis=None, kind="stable")
    cands = [divmod(int(f), b.people) for f in order if points.flat[f] >= cfg.min_pair_points][:cfg.max_hypotheses]
    found: dict[tuple, _Association] = {}
    for i, j in cands:
        if found and (i, j) in max(found.values(), key=lambda r: r.score).pairs:
            continue  # it would propose the association already found
        for m in (False, True):
            x_a, x_b, fr, u = _pooled(xa, xb, [(i, j)], {(i, j): m}, mirror, unit)
            F = _ransac(x_a, x_b, fr, u, cfg, reweigh=False)
            if F is None or (_sampson2(F, x_a, x_b) < u ** 2).sum() < cfg.min_pair_inlier_share * len(x_a):
                continue
            res = _settle(xa, xb, F, delta, mirror, unit, cfg)
            if res is not None and (res.pairs not in found or res.score > found[res.pairs].score):
                found[res.pairs] = res
    return sorted(found.values(), key=lambda r: -r.score)


def _carried(a: _Side, b: _Side, delta: float, assoc: _Association, mirror: np.ndarray, unit: np.ndarray,
             cfg: PeoplePairConfig) -> _Association | None:
    """An association found at a nearby shift, settled at delta from its F."""
    _, xa, xb = _moments(a, b, delta, cfg.search_frames)
    if not xa.shape[1]:
        return None
    x_a, x_b, _, u = _pooled(xa, xb, assoc.pairs, assoc.mirrored, mirror, unit)
    if len(x_a) < 8:
        return None
    F = fundamental_irls(x_a, x_b, assoc.F_ab, u, 3)
    return _settle(xa, xb, F, delta, mirror, unit, cfg)
