"""The spurious-pair decision, read off the landscape's shape.

The paper rejects a pair when the best minimum is not clearly deeper than the next one or when
there are more than two minima; its research code keeps minima that are Pareto-optimal in energy
and overlap. Depths here are measured below the landscape's median energy, so they compare
across pairs and residual kinds.

Weak evidence is refused even when the shape looks clear, since a null is better than a wrong
offset: a minimum that rests on a small share of the landscape's usual overlap, or that few track
pairs see, is an energy averaged over too few terms.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.signal import find_peaks

from ..result_types import PairDecision
from .config import DecisionConfig

MIN_SUPPORT_FRACTION = 0.4  # a minimum resting on fewer terms than this share of the landscape's median is refused
MIN_CONTRAST = 0.3  # refused when the best energy is less than this fraction below the median (flat)
MAX_SECOND_RATIO = 0.7  # refused when a rival minimum is at least this prominent relative to the best
MAX_MINIMA = 2  # refused when more minima than this are at least half as prominent as the best (the paper: 2)
MIN_RIVAL_SUPPORT = 0.5  # a minimum rivals the best only with at least this share of its terms
MIN_PROMINENCE = 0.1  # a local minimum counts from this fraction of the best depth
MIN_INLIER_FRACTION = 0.45  # refused when fewer observations lie this close to their epipolar lines...
INLIER_PX_FRACTION = 0.01  # ...within this fraction of the larger image diagonal (14.7 px at 720p)
REJECT_RANGE_EDGE = True  # refused when the best minimum lies on the border of the search range


def local_minima(energy: np.ndarray, min_prominence: float) -> tuple[np.ndarray, np.ndarray]:
    """Local minima (edges included) with at least that prominence: (indices, prominences), best first.

    Prominence is how far a minimum dips below the higher ground that separates it from any
    deeper minimum (scipy's peak prominence of -E). The walls beyond the range are at the
    landscape's maximum, so the global minimum's prominence is the whole range of E.
    """
    e = np.asarray(energy, dtype=np.float64)
    finite = np.isfinite(e)
    if not finite.any():
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    top = float(np.nanmax(e))
    filled = np.where(finite, e, top)
    padded = np.concatenate([[top], filled, [top]])
    idx, props = find_peaks(-padded, prominence=max(min_prominence, 1e-15), plateau_size=(1, None))
    prom = props["prominences"]
    idx = idx - 1
    if len(idx) == 0:
        return np.array([int(np.nanargmin(e))]), np.array([0.0])
    order = np.argsort(filled[idx], kind="stable")
    return idx[order].astype(np.int64), prom[order]


def pareto_minima(energy: np.ndarray, support: np.ndarray, minima: np.ndarray) -> np.ndarray:
    """Minima not dominated by another minimum with lower energy and at least as much overlap."""
    keep = []
    for m in minima:
        dominated = any(energy[o] < energy[m] and support[o] >= support[m] for o in minima if o != m)
        if not dominated:
            keep.append(m)
    return np.asarray(keep, dtype=np.int64)


def check_inliers(decision: PairDecision, inlier_fraction: float, tau_px: float,
                  cfg: DecisionConfig) -> PairDecision:
    """Add the inlier share at the best offset; reject a pair accepted so far that has too few.

    A landscape can have a clear minimum even when every match is wrong (wrong matches on the
    same rigid object still move together), but then few observations lie near their epipolar
    lines even at the best offset: right pairs have 65-90 % there, all-wrong ones 25-35 %.
    """
    out = replace(decision, inlier_fraction=float(inlier_fraction), inlier_tau_px=float(tau_px))
    if decision.accepted and cfg.enabled and np.isfinite(inlier_fraction) \
            and inlier_fraction < MIN_INLIER_FRACTION:
        out = replace(out, accepted=False, reason=(
            f"few epipolar inliers at the best offset: {100 * inlier_fraction:.0f}% of observations "
            f"within {tau_px:.1f} px (< {100 * MIN_INLIER_FRACTION:.0f}%): wrong matches or wrong "
            "camera poses"))
    return out


def check_track_pairs_at_best(decision: PairDecision, seen: int, offset_s: float,
                              cfg: DecisionConfig) -> PairDecision:
    """Add how many track pairs have a term at the best offset; reject a pair accepted so far when
    fewer than cfg.min_track_pairs do.

    The pair may have many track pairs, yet at a wrong offset only a handful overlap in time:
    the minimum is then the chance agreement of those few, whatever the others say.
    """
    out = replace(decision, track_pairs_at_best=int(seen))
    if decision.accepted and cfg.enabled and seen < cfg.min_track_pairs:
        out = replace(out, accepted=False, reason=(
            f"only {seen} track pairs seen at the best offset {offset_s:+.3f} s (fewer than "
            f"{cfg.min_track_pairs}): too little evidence for an offset"))
    return out


def check_uncertainty(decision: PairDecision, sigma_s: float, offset_s: float, frame_s: float,
                      cfg: DecisionConfig) -> PairDecision:
    """Reject a pair accepted so far whose best minimum's 1-sigma sigma_s is wider than
    cfg.max_uncertainty_frames frames of frame_s (the coarser video's): a shallow, wide minimum
    over few track pairs does not time the pair to a frame, however alone it stands (wrong
    descriptor pairs can make one far from the truth). NaN (no curvature at the minimum) is left to the other checks."""
    limit = cfg.max_uncertainty_frames * frame_s
    if decision.accepted and cfg.enabled and limit > 0 and np.isfinite(sigma_s) and sigma_s > limit:
        return replace(decision, accepted=False, reason=(
            f"its minimum at {offset_s:+.3f} s is too wide to time the pair: 1-sigma {1000 * sigma_s:.0f} ms, "
            f"{sigma_s / frame_s:.1f} frames of the coarser video (more than {cfg.max_uncertainty_frames:g})"))
    return decision


def check_chosen_offset(decision: PairDecision, offset_s: float, chosen_at_offset_s: float | None,
                        frame_s: float, cfg: DecisionConfig) -> PairDecision:
    """Reject a pair accepted so far whose best minimum offset_s lies more than
    cfg.chosen_agree_frames frames of frame_s (the coarser video's) from the Δ at which Stage 0
    kept its track pairs (TrackPairs.chosen_at_offset_s; None: no such Δ, no check). Each of
    them was consistent with the cameras' epipolar geometry there, so a minimum elsewhere means
    the track pairs and the cameras disagree."""
    limit = cfg.chosen_agree_frames * frame_s
    if not (decision.accepted and cfg.enabled and limit > 0 and chosen_at_offset_s is not None
            and np.isfinite(offset_s)):
        return decision
    gap = abs(offset_s - chosen_at_offset_s)
    if gap <= limit:
        return decision
    return replace(decision, accepted=False, reason=(
        f"its minimum at {offset_s:+.3f} s lies {gap / frame_s:.1f} frames from the Δ {chosen_at_offset_s:+.3f} s "
        f"at which Stage 0 kept its track pairs (more than {cfg.chosen_agree_frames:g}): each was consistent with "
        f"the cameras there, so the track pairs and the cameras disagree"))


def support_fraction(support: np.ndarray, energy: np.ndarray, best: int) -> tuple[float, float]:
    """(terms at the minimum / the landscape's usual overlap, that usual overlap): the usual
    overlap is the median term count over the offsets that have an energy."""
    have = np.isfinite(energy)
    usual = float(np.median(support[have])) if have.any() else 0.0
    return (float(support[best]) / usual if usual > 0 else float("nan")), usual


def decide(energy: np.ndarray, support: np.ndarray, offsets_s: np.ndarray, num_track_pairs: int,
           cfg: DecisionConfig, allowed: np.ndarray | None = None) -> tuple[PairDecision, np.ndarray]:
    """(decision, minima indices best first). allowed (D,) bool: the offsets a minimum may be
    chosen at (an --around window); the landscape's median, range and edges stay the whole
    landscape's, and minima outside are no rivals."""
    finite = np.isfinite(energy)
    if num_track_pairs < cfg.min_track_pairs:
        return PairDecision(False, f"too few track pairs: only {num_track_pairs} (fewer than "
                            f"{cfg.min_track_pairs})", 0.0, 0.0, 0, 0, False), np.zeros(0, dtype=np.int64)
    if not finite.any():
        why = ("no candidate offset leaves the required overlap" if len(energy) == 0 else
               "no offset has enough co-visible track observations (tracks never overlap in time)")
        return PairDecision(False, why, 0.0, 0.0, 0, 0, False), np.zeros(0, dtype=np.int64)
    e_best = float(np.nanmin(energy))
    e_base = float(np.nanmedian(energy))
    e_range = float(np.nanmax(energy)) - e_best
    minima, prom = local_minima(energy, MIN_PROMINENCE * e_range)
    if allowed is not None:
        inside = np.asarray(allowed, bool)[minima]
        if not inside.any():
            return PairDecision(False, "no minimum of the landscape within the --around window", 0.0, 0.0, 0, 0,
                                False), np.zeros(0, dtype=np.int64)
        minima, prom = minima[inside], prom[inside]
    # The lowest minimum may itself rest on much less overlap than another nearly as prominent
    # (e.g. a periodic motion matched again near the end of the range): by the rule below it is
    # then the weaker of the two, so the better supported minimum becomes the best.
    weaker_lowest = None
    for i in range(1, len(minima) if cfg.enabled else 1):
        if prom[i] >= MAX_SECOND_RATIO * prom[0] \
                and support[minima[0]] < MIN_RIVAL_SUPPORT * support[minima[i]]:
            weaker_lowest = int(minima[0])
            order = [i] + [j for j in range(len(minima)) if j != i]
            minima, prom = minima[order], prom[order]
            break
    best = int(minima[0])
    depth = e_base - float(energy[best])
    contrast = depth / e_base if e_base > 0 else 0.0
    # Rivals are compared by prominence (their own dip), not by depth below a global level, so a
    # trend in the landscape (energy drifting with the overlap) does not make a shallow dip look
    # deep. A minimum resting on much less overlap than the best is a weaker rival: its energy
    # is a mean over fewer terms and dips by chance (dominated in energy and overlap).
    keep = [i for i in range(1, len(minima))
            if support[minima[i]] >= MIN_RIVAL_SUPPORT * support[best]]
    rivals = minima[keep]
    rival_prom = prom[keep]
    best_prom = prom[0] if prom[0] > 0 else 1e-300
    second = float(rival_prom.max() / best_prom) if len(rivals) else 0.0
    significant = 1 + int(np.sum(rival_prom >= 0.5 * best_prom))
    first_rival = rivals[int(np.argmax(rival_prom))] if len(rivals) else best
    pareto = pareto_minima(energy, support, minima)
    edge = best in (0, len(energy) - 1) or not (finite[max(best - 1, 0)] and finite[min(best + 1, len(energy) - 1)])
    share, usual = support_fraction(support, energy, best)
    nums = dict(contrast=float(contrast), second_depth_ratio=second, num_minima=significant,
                num_pareto_minima=len(pareto), at_range_edge=bool(edge), support_fraction=share)

    accepted, reason = _verdict(cfg, offsets_s, support, best, first_rival, weaker_lowest, contrast, second,
                                significant, edge, share, usual)
    return PairDecision(accepted, reason, **nums), minima


def _verdict(cfg: DecisionConfig, offsets_s: np.ndarray, support: np.ndarray, best: int, first_rival: int,
             weaker_lowest: int | None, contrast: float, second: float, significant: int, edge: bool,
             share: float, usual: float) -> tuple[bool, str]:
    """(accepted, reason) of decide's measures, the first failed check named."""
    accepted, reason = True, f"single clear minimum (contrast {contrast:.2f}, rival/best prominence {second:.2f})"
    if weaker_lowest is not None:
        reason += (f"; the lowest energy, at {offsets_s[weaker_lowest]:+.3f} s, rests on "
                   f"{100 * support[weaker_lowest] / support[best]:.0f}% of this minimum's overlap")
    if not cfg.enabled:
        reason = "accepted without checks (spurious-pair filter off)"
    elif contrast < MIN_CONTRAST:
        accepted = False
        reason = (f"flat landscape: best energy only {100 * contrast:.0f}% below the median "
                  f"(< {100 * MIN_CONTRAST:.0f}%): wrong matches, wrong poses or no shared motion")
    elif second >= MAX_SECOND_RATIO:
        accepted = False
        reason = (f"ambiguous: another minimum at {offsets_s[first_rival]:+.3f} s is {100 * second:.0f}% "
                  f"as prominent as the best at {offsets_s[best]:+.3f} s")
    elif significant > MAX_MINIMA:
        accepted = False
        reason = f"ambiguous: {significant} minima at least half as prominent as the best (> {MAX_MINIMA})"
    elif edge and REJECT_RANGE_EDGE:
        accepted = False
        reason = (f"best minimum at the edge of the search range ({offsets_s[best]:+.3f} s): "
                  "the true offset may lie outside it")
    elif share < MIN_SUPPORT_FRACTION:
        accepted = False
        reason = (f"minimum at {offsets_s[best]:+.3f} s supported by {100 * share:.0f}% of the "
                  f"landscape's usual overlap ({int(support[best])} of a median {usual:.0f} "
                  f"(track pair, frame) terms; fewer than {100 * MIN_SUPPORT_FRACTION:.0f}%): "
                  "a mean over few terms dips by chance")
    return accepted, reason
