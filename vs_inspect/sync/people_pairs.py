"""Two videos of the same people: which person in one is which in the other, the pair's
fundamental matrix and the time shift, found together (sync/posefree.py's idea for one moving
point, here for every landmark of every person at once).

The same landmark of the same person seen by two cameras at one moment is one 3D point, whatever
the viewpoint. So at the right shift Δ_ab (DESIGN.md: x_a(t + Δ) and x_b(t) show one moment) one
F_ab fits every landmark of every person both videos see, x_aᵀ F_ab x_b = 0; at a wrong shift the
moving ones leave it. b's landmarks are interpolated at a's frame times minus Δ (only between
two frames that see them), so any Δ can be tried. A landmark's position is uncertain in
proportion to the person's size in the image, so every distance is measured in units of
noise_share × that size (the geometric mean of the two views').

Steps, each a pure function of the people's landmarks (no I/O):
1. search: every search_step_s, RANSAC over person pairings. A pairing of one person of a with
   one of b, labelled as given or mirrored (left and right swapped, geometry/skeleton.MIRROR),
   proposes an F from its own landmarks (MAGSAC, on frames spread over the overlap); every
   pairing is scored on it, each frame under whichever labelling fits it better and on the side
   of the epipole most are on (the oriented epipolar constraint, which a fit with its epipole
   amid the people breaks); people are associated greedily (most inliers first, one partner per
   person and frame); F is refitted on the associated people and they are associated again.
   Each association found is carried to the shifts around it. The associations found where the
   search's score stands out most (above its median, times the square root of the frames the
   shift overlaps) are the candidates;
2. each candidate, grown by every pairing that fits at its shift over all frames, is held over
   every fourth shift (a sketch), the best sketched ones over every shift: at each, the F
   minimizing a robust Sampson cost (fundamental_irls, from the neighbouring shift's F and now
   and then from a fresh RANSAC fit, whichever ends lower), each frame's labelling chosen under
   it. Its landscape is the evidence at each shift: how far the mean truncated cost lies below
   the landscape's median, times the square root of the number of correspondences (a
   standardized depth: a short overlap fits a few landmarks well by chance, and weighs little);
3. refusal (shifts with little common time are neither chosen nor rivals): too few inliers at
   the best shift, a flat landscape, another peak of evidence at a distinct shift whose
   prominence is within min_margin of the best's, or another candidate of other people whose
   best lies elsewhere with such evidence: each with its plain reason;
4. a continuous refinement of (Δ, F) on the inliers' Sampson distances, b's landmarks
   interpolated in time (scipy least_squares, soft L1), and its 1-sigma.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numba as nb
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..geometry.sampling import tracks_between_frames
from ..geometry.skeleton import GEOMETRY_LANDMARKS, person_scale_px, subset_mirror
from ..geometry.timing import frame_brackets
from ..geometry.two_view import fundamental_irls, fundamental_ransac, sampson_px
from ..people_types import PeopleAssociation, PeoplePair
from .decision import local_minima

EPS_S = 1e-9


@dataclass(frozen=True)
class PeoplePairConfig:
    """How the people of two videos give their association, F and time shift."""

    landmarks: tuple[int, ...] = GEOMETRY_LANDMARKS
    """BlazePose landmarks used (indices; closed under the left/right mirror)."""
    noise_share: float = 0.025
    """A landmark's position noise as a share of the person's size in the image (the diagonal of
    the box around its landmarks); a correspondence is an inlier within this many of those."""
    min_noise_px: float = 1.5
    """The noise unit is at least this many px (very small people)."""
    search_step_s: float = 0.2
    """The search tries the candidate shifts this far apart (at least every candidate)..."""
    search_noise: float = 2.0
    """...measuring distances in this many noise units, so that a shift half a step from the
    right one still shows its association."""
    search_frames: int = 24
    """Frames of the overlap (evenly spread) the search scores at each shift."""
    sample_points: int = 200
    """Correspondences (evenly spread in time) each RANSAC sees."""
    max_hypotheses: int = 8
    """Person pairings (with the most correspondences) that propose an F at each shift, each as
    labelled and mirrored."""
    min_pair_points: int = 40
    """A person pairing proposes an F, or is associated, from this many correspondences on."""
    min_pair_inlier_share: float = 0.35
    """An associated person pairing has at least this share of its correspondences as inliers."""
    distinct_s: float = 0.5
    """Two shifts closer than this are one valley of the landscape."""
    min_inliers: int = 150
    """A pair is refused with fewer inlier correspondences at its best shift."""
    min_support_fraction: float = 0.4
    """Shifts with fewer common frames than this share of the median shift's are neither chosen
    nor rivals (a fit over few frames is good by chance)."""
    min_contrast: float = 0.3
    """The best shift's mean cost must lie this share below the landscape's median, else the
    landscape is flat (people who hardly move fit one geometry at every shift)."""
    max_uncertainty_frames: float = 1.0
    """Refused when shifts more than this many frames (of the slower video) from the best fit
    about as well (their per-frame costs not worse by t_min)."""
    t_min: float = 2.0
    """A shift fits worse than the best when the paired difference of their per-frame costs has a
    t-statistic of at least this."""
    min_margin: float = 1.5
    """The best peak of evidence must be this many times as prominent as the next distinct one
    (and as high as another candidate's of other people at another shift), else refused."""
    candidates: int = 12
    """Associations (of the search's best distinct shifts) whose landscapes are sketched (at every
    sketch_every-th shift)..."""
    sketch_every: int = 4
    full_landscapes: int = 2
    """...and the ones of these whose sketch has the most evidence, computed at every shift."""
    irls_iterations: int = 4
    """Reweighting steps of each F fitted on the landscape."""
    fresh_every: int = 4
    """On the landscape, a fresh RANSAC start at every this many shifts (the neighbour's F at all)."""
    refine_loss_scale: float = 0.5
    """soft L1 scale of the continuous refinement, in noise units."""
    refine_max_points: int = 1500
    """Inlier correspondences (evenly spread) the continuous refinement uses."""
    seed: int = 0
    """Seed of OpenCV's random generator for this pair's RANSAC fits."""

    def __post_init__(self) -> None:
        subset_mirror(self.landmarks)  # ValueError when not closed under the mirror
        if self.sketch_every < 1 or self.full_landscapes < 1 or self.noise_share <= 0 or self.search_frames < 8 or self.search_step_s <= 0 or self.search_noise < 1 or self.sample_points < 8 \
                or self.min_pair_points < 8 or self.min_margin < 1 or self.fresh_every < 1:
            raise ValueError(f"PeoplePairConfig out of range: {self}")


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


# ---- the landscape of one association -----------------------------------------------------------


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


# ---- continuous refinement ----------------------------------------------------------------------


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


# ---- the pair -------------------------------------------------------------------------------------------


def _step(offsets_s: np.ndarray) -> float:
    return float(np.median(np.diff(offsets_s))) if len(offsets_s) > 1 else 1.0


def estimate_people_pair(a: str, times_a_s: np.ndarray, xy_a: np.ndarray, b: str, times_b_s: np.ndarray,
                         xy_b: np.ndarray, offsets_s: np.ndarray,
                         cfg: PeoplePairConfig = PeoplePairConfig()) -> PeoplePair:
    """Association, F_ab and Δ_ab of videos a and b from their people.

    times_a_s (Ta,), times_b_s (Tb,): local frame times, s; xy_a (Pa,Ta,L,2), xy_b (Pb,Tb,L,2):
    the people's cfg.landmarks in px (undistorted), NaN where unseen; offsets_s (D,): the
    candidate Δ_ab, increasing and evenly spaced (an OffsetGrid's pair_offsets at a frame step).
    Always a PeoplePair: offset_s None with the reason when refused.
    """
    times_a_s = np.asarray(times_a_s, np.float64)
    times_b_s = np.asarray(times_b_s, np.float64)
    xy_a = np.asarray(xy_a, np.float64)
    xy_b = np.asarray(xy_b, np.float64)
    L = len(cfg.landmarks)
    for n, t, xy in ((a, times_a_s, xy_a), (b, times_b_s, xy_b)):
        if xy.ndim != 4 or xy.shape[1:] != (len(t), L, 2):
            raise ValueError(f"{n}: people must be (P,{len(t)},{L},2), got {xy.shape}")
    offsets_s = np.asarray(offsets_s, np.float64)
    mirror = subset_mirror(cfg.landmarks)
    cv2.setRNGSeed(cfg.seed)  # OpenCV's RANSAC draws from its global generator: the same pair, the same answer
    A, B = _Side.of(times_a_s, xy_a), _Side.of(times_b_s, xy_b)
    unit = _noise_px(A, B, cfg)
    noise = float(np.median(unit)) if unit.size else cfg.min_noise_px

    def refused(why: str, **kw) -> PeoplePair:
        return PeoplePair(a, b, None, why, noise_px=noise, offsets_s=offsets_s, **kw)

    if not len(offsets_s):
        return refused("no candidate shift leaves enough common time")
    if not A.people or not B.people:
        return refused(f"no person followed in {a if not A.people else b}")

    # 1. the search: RANSAC every search_step_s (distances in search_noise units), each
    # association found carried to the shifts around it (in noise units)
    stride = max(int(round(cfg.search_step_s / _step(offsets_s))), 1)
    fresh = {int(k): _search_at(A, B, float(offsets_s[k]), mirror, cfg.search_noise * unit, cfg)[:2]
             for k in range(0, len(offsets_s), stride)}
    found: list[list[_Association]] = []
    for k in range(len(offsets_s)):
        near = {}
        for j in range(max(k - stride, 0), min(k + stride, len(offsets_s) - 1) + 1):
            for c in fresh.get(j, []):
                near.setdefault(c.pairs, c)
        here = [c for c in (_carried(A, B, float(offsets_s[k]), c, mirror, unit, cfg) for c in near.values())
                if c is not None]
        found.append(sorted(here, key=lambda r: -r.score))
    score = np.array([f[0].score if f else 0.0 for f in found])
    kw: dict = dict(search_score=score)
    if not score.max(initial=0):
        return refused("no person pairing fits one epipolar geometry at any shift (too few landmarks seen "
                       "in both videos at once)", **kw)
    # candidates in the order of the search's own evidence: its score above the median, times the
    # square root of the frames the shift overlaps (a short overlap pairs people up by chance)
    overlap = np.array([np.count_nonzero((A.times_s - d >= B.times_s[0] - EPS_S) & (A.times_s - d <= B.times_s[-1] + EPS_S))
                        for d in offsets_s], dtype=np.float64)
    ranked = (score - np.median(score)) * np.sqrt(overlap)
    usual = float(np.median(overlap))
    supported = overlap >= cfg.min_support_fraction * usual
    cands: list[_Association] = []
    for k in np.argsort(-np.where(supported, ranked, -np.inf), kind="stable"):
        if score[k] <= 0 or not supported[k] or len(cands) == cfg.candidates:
            break
        if all(found[k][0].pairs != c.pairs and abs(offsets_s[k] - c.offset_s) >= cfg.distinct_s - EPS_S
               for c in cands):
            cands.append(found[k][0])

    if not cands:
        return refused("no person pairing fits one epipolar geometry at a shift that leaves the videos enough "
                       "common time", **kw)

    # 2. each candidate's landscape
    sketched = []
    for c in cands:
        c = _grown(A, B, c, mirror, unit, cfg) or c
        sketch = _evidence(_landscape(A, B, offsets_s, c, mirror, unit, cfg, every=cfg.sketch_every))
        sketched.append((float(np.where(supported, sketch, -np.inf).max()), c))
    lands = []
    for _, c in sorted(sketched, key=lambda x: -x[0])[:cfg.full_landscapes]:
        fits = _landscape(A, B, offsets_s, c, mirror, unit, cfg)
        lands.append((c, fits, _evidence(fits)))
    # shifts with little common time are no candidates for the best, nor rivals
    lands = [(c, fits, np.where(supported, ev, -np.inf)) for c, fits, ev in lands]
    which = int(np.argmax([ev.max() for _, _, ev in lands]))
    start, land, evidence = lands[which]
    best_i = int(np.argmax(evidence))
    fit = land[best_i]
    cost = np.array([f.cost if f is not None else 1.0 for f in land])
    inliers = np.array([f.inliers if f is not None else 0 for f in land])
    assoc = tuple(PeopleAssociation(i, j, bool(2 * fit.mirrored[(i, j)].sum() > len(fit.mirrored[(i, j)])))
                  for i, j in start.pairs)
    kw.update(cost=cost, inliers=inliers, evidence=np.where(np.isfinite(evidence), evidence, np.nan),
              associations=assoc, F_ab=fit.F_ab,
              best_grid_offset_s=float(offsets_s[best_i]))

    # 3. refusals, in order
    if fit.inliers < cfg.min_inliers:
        return refused(f"too few landmarks fit one epipolar geometry ({fit.inliers} inlier correspondences at "
                       f"the best shift, at least {cfg.min_inliers} needed)", **kw)
    median = float(np.median(cost))
    contrast = (median - cost[best_i]) / median if median > 0 else 0.0
    kw.update(contrast=float(contrast))
    if evidence[best_i] <= 0 or contrast < cfg.min_contrast:
        return refused(f"flat landscape: the best shift's cost is only {100 * contrast:.0f}% below the median "
                       f"(at least {100 * cfg.min_contrast:.0f}% needed): the people move too little to time them",
                       **kw)
    lo, hi = _indistinct_span(offsets_s, land, best_i, cfg.t_min)
    frame_s = max(_step(times_a_s), _step(times_b_s))
    kw.update(indistinct_s=(lo, hi))
    if max(offsets_s[best_i] - lo, hi - offsets_s[best_i]) > cfg.max_uncertainty_frames * frame_s + EPS_S:
        return refused(f"uncertain shift: from {lo:+.2f} to {hi:+.2f} s the people fit about as well as at "
                       f"{offsets_s[best_i]:+.2f} s (more than {cfg.max_uncertainty_frames:g} frame either way): "
                       f"they move too slowly to time them within a frame", **kw)
    second, margin = _rival_peak(offsets_s, evidence, best_i, cfg.distinct_s)
    if second is not None:
        kw.update(second_offset_s=float(offsets_s[second]), margin=float(margin))
    if margin < cfg.min_margin:
        return refused(f"ambiguous shift: {offsets_s[second]:+.2f} s fits almost as well as {offsets_s[best_i]:+.2f} s "
                       f"(margin {margin:.2f}, {cfg.min_margin:g} needed)", **kw)
    for k, (other, _, ev) in enumerate(lands):
        r = int(np.argmax(ev))
        if k == which or set(other.pairs) & set(start.pairs) \
                or abs(offsets_s[r] - offsets_s[best_i]) < cfg.distinct_s - EPS_S:
            continue  # the same people, or other people at the same shift: no rival
        rival_margin = evidence[best_i] / max(ev[r], 1e-12)
        if rival_margin < cfg.min_margin:
            kw.update(rival_offset_s=float(offsets_s[r]), rival_margin=float(rival_margin))
            return refused(f"ambiguous people: other people paired up fit almost as well at {offsets_s[r]:+.2f} s "
                           f"(margin {rival_margin:.2f}, {cfg.min_margin:g} needed)", **kw)

    # 4. continuous refinement
    delta, F, std, n_in = _refine(A, B, float(offsets_s[best_i]), fit, start.pairs, mirror, unit,
                                  (float(offsets_s[0]), float(offsets_s[-1])), cfg)
    if abs(delta - offsets_s[best_i]) > 2 * _step(offsets_s):
        return refused(f"the refinement left the best shift ({offsets_s[best_i]:+.3f} s -> {delta:+.3f} s)", **kw)
    kw.update(F_ab=F, offset_std_s=std, refined_inliers=n_in)
    return PeoplePair(a, b, delta, f"clear best shift (margin {margin:.2f})", noise_px=noise,
                      offsets_s=offsets_s, **kw)
