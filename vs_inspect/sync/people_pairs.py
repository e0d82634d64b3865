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

import cv2
import numpy as np

from ..geometry.skeleton import subset_mirror
from ..people_types import PeopleAssociation, PeoplePair
from .people_config import PeoplePairConfig
from .people_landscape import _Fit, _evidence, _grown, _indistinct_span, _landscape, _rival_peak
from .people_refine import _refine
from .people_search import EPS_S, _Association, _carried, _noise_px, _search_at, _Side


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
    times_a_s, xy_a, times_b_s, xy_b = _checked_people(a, times_a_s, xy_a, b, times_b_s, xy_b, cfg)
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

    # 1. the search, and the best distinct associations it found
    found = _search_every_shift(A, B, offsets_s, mirror, unit, cfg)
    score = np.array([f[0].score if f else 0.0 for f in found])
    kw: dict = dict(search_score=score)
    if not score.max(initial=0):
        return refused("no person pairing fits one epipolar geometry at any shift (too few landmarks seen "
                       "in both videos at once)", **kw)
    supported, cands = _candidates(A, B, offsets_s, found, score, cfg)
    if not cands:
        return refused("no person pairing fits one epipolar geometry at a shift that leaves the videos enough "
                       "common time", **kw)

    # 2. each candidate's landscape
    lands = _held_candidates(A, B, offsets_s, cands, supported, mirror, unit, cfg)
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
    why = _fit_refusal(offsets_s, times_a_s, times_b_s, land, fit, cost, evidence, best_i, kw, cfg)
    if why is not None:
        return refused(why, **kw)
    second, margin = _rival_peak(offsets_s, evidence, best_i, cfg.distinct_s)
    if second is not None:
        kw.update(second_offset_s=float(offsets_s[second]), margin=float(margin))
    if margin < cfg.min_margin:
        return refused(f"ambiguous shift: {offsets_s[second]:+.2f} s fits almost as well as {offsets_s[best_i]:+.2f} s "
                       f"(margin {margin:.2f}, {cfg.min_margin:g} needed)", **kw)
    why = _rival_refusal(offsets_s, lands, which, start, evidence, best_i, kw, cfg)
    if why is not None:
        return refused(why, **kw)

    # 4. continuous refinement
    delta, F, std, n_in = _refine(A, B, float(offsets_s[best_i]), fit, start.pairs, mirror, unit,
                                  (float(offsets_s[0]), float(offsets_s[-1])), cfg)
    if abs(delta - offsets_s[best_i]) > 2 * _step(offsets_s):
        return refused(f"the refinement left the best shift ({offsets_s[best_i]:+.3f} s -> {delta:+.3f} s)", **kw)
    kw.update(F_ab=F, offset_std_s=std, refined_inliers=n_in)
    return PeoplePair(a, b, delta, f"clear best shift (margin {margin:.2f})", noise_px=noise,
                      offsets_s=offsets_s, **kw)


def _checked_people(a: str, times_a_s: np.ndarray, xy_a: np.ndarray, b: str, times_b_s: np.ndarray,
                    xy_b: np.ndarray, cfg: PeoplePairConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(times_a_s, xy_a, times_b_s, xy_b) as float64 arrays; ValueError naming the video and the
    shape received when a video's people are not (P,T,L,2) with T its frames and L cfg.landmarks."""
    times_a_s = np.asarray(times_a_s, np.float64)
    times_b_s = np.asarray(times_b_s, np.float64)
    xy_a = np.asarray(xy_a, np.float64)
    xy_b = np.asarray(xy_b, np.float64)
    L = len(cfg.landmarks)
    for n, t, xy in ((a, times_a_s, xy_a), (b, times_b_s, xy_b)):
        if xy.ndim != 4 or xy.shape[1:] != (len(t), L, 2):
            raise ValueError(f"{n}: people must be (P,{len(t)},{L},2), got {xy.shape}")
    return times_a_s, xy_a, times_b_s, xy_b


def _search_every_shift(A: _Side, B: _Side, offsets_s: np.ndarray, mirror: np.ndarray, unit: np.ndarray,
                        cfg: PeoplePairConfig) -> list[list[_Association]]:
    """(D,) the associations found at each candidate shift, best first: RANSAC every search_step_s
    (distances in search_noise units), each association found there settled again at the shifts
    around it (in noise units)."""
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
    return found


def _candidates(A: _Side, B: _Side, offsets_s: np.ndarray, found: list[list[_Association]], score: np.ndarray,
                cfg: PeoplePairConfig) -> tuple[np.ndarray, list[_Association]]:
    """((D,) bool: the shifts that leave the videos enough common time (min_support_fraction), the
    best association of at most cfg.candidates of those shifts, distinct in people and shift)."""
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
    return supported, cands


def _held_candidates(A: _Side, B: _Side, offsets_s: np.ndarray, cands: list[_Association], supported: np.ndarray,
                     mirror: np.ndarray, unit: np.ndarray, cfg: PeoplePairConfig) -> list[tuple]:
    """[(association, its _Fit at every shift (D,), its evidence (D,))] of the full_landscapes
    candidates whose sketch has the most evidence, each grown by the pairings that fit it over all
    frames; the evidence is -inf at the shifts not supported."""
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
    return lands


def _fit_refusal(offsets_s: np.ndarray, times_a_s: np.ndarray, times_b_s: np.ndarray, land: list, fit: _Fit,
                 cost: np.ndarray, evidence: np.ndarray, best_i: int, kw: dict, cfg: PeoplePairConfig) -> str | None:
    """Why the best shift of the chosen landscape is refused on its own (too few inliers, a flat
    landscape, shifts more than max_uncertainty_frames away that fit about as well), or None; kw
    gets the contrast and the indistinct span it measured."""
    if fit.inliers < cfg.min_inliers:
        return (f"too few landmarks fit one epipolar geometry ({fit.inliers} inlier correspondences at "
                f"the best shift, at least {cfg.min_inliers} needed)")
    median = float(np.median(cost))
    contrast = (median - cost[best_i]) / median if median > 0 else 0.0
    kw.update(contrast=float(contrast))
    if evidence[best_i] <= 0 or contrast < cfg.min_contrast:
        return (f"flat landscape: the best shift's cost is only {100 * contrast:.0f}% below the median "
                f"(at least {100 * cfg.min_contrast:.0f}% needed): the people move too little to time them")
    lo, hi = _indistinct_span(offsets_s, land, best_i, cfg.t_min)
    frame_s = max(_step(times_a_s), _step(times_b_s))
    kw.update(indistinct_s=(lo, hi))
    if max(offsets_s[best_i] - lo, hi - offsets_s[best_i]) > cfg.max_uncertainty_frames * frame_s + EPS_S:
        return (f"uncertain shift: from {lo:+.2f} to {hi:+.2f} s the people fit about as well as at "
                f"{offsets_s[best_i]:+.2f} s (more than {cfg.max_uncertainty_frames:g} frame either way): "
                f"they move too slowly to time them within a frame")
    return None


def _rival_refusal(offsets_s: np.ndarray, lands: list[tuple], which: int, start: _Association, evidence: np.ndarray,
                   best_i: int, kw: dict, cfg: PeoplePairConfig) -> str | None:
    """Why the best shift is refused for another landscape of other people whose best lies at a
    distinct shift with almost as much evidence (min_margin), or None; kw gets that rival."""
    for k, (other, _, ev) in enumerate(lands):
        r = int(np.argmax(ev))
        if k == which or set(other.pairs) & set(start.pairs) \
                or abs(offsets_s[r] - offsets_s[best_i]) < cfg.distinct_s - EPS_S:
            continue  # the same people, or other people at the same shift: no rival
        rival_margin = evidence[best_i] / max(ev[r], 1e-12)
        if rival_margin < cfg.min_margin:
            kw.update(rival_offset_s=float(offsets_s[r]), rival_margin=float(rival_margin))
            return (f"ambiguous people: other people paired up fit almost as well at {offsets_s[r]:+.2f} s "
                    f"(margin {rival_margin:.2f}, {cfg.min_margin:g} needed)")
    return None
