"""The spurious-pair decision, read off the landscape's shape.

The paper rejects a pair when the best minimum is not clearly deeper than the next one or when
there are more than two minima; its research code keeps minima that are Pareto-optimal in energy
and overlap. Depths here are measured below the landscape's median energy, so they compare
across pairs and residual kinds.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

from ..types import PairDecision
from .config import DecisionConfig


def local_minima(energy: np.ndarray, min_prominence: float) -> np.ndarray:
    """Indices of local minima (edges included) with at least that prominence, best first."""
    e = np.asarray(energy, dtype=np.float64)
    finite = np.isfinite(e)
    if not finite.any():
        return np.zeros(0, dtype=np.int64)
    # Pad with +inf-like walls so that minima on the border of the range count too.
    top = np.nanmax(e) + 1.0
    filled = np.where(finite, e, top)
    padded = np.concatenate([[top], filled, [top]])
    idx, _ = find_peaks(-padded, prominence=max(min_prominence, 1e-15))
    idx = idx - 1
    if len(idx) == 0:
        idx = np.array([int(np.nanargmin(e))])
    return idx[np.argsort(filled[idx], kind="stable")].astype(np.int64)


def pareto_minima(energy: np.ndarray, support: np.ndarray, minima: np.ndarray) -> np.ndarray:
    """Minima not dominated by another minimum with lower energy and at least as much overlap."""
    keep = []
    for m in minima:
        dominated = any(energy[o] < energy[m] and support[o] >= support[m] for o in minima if o != m)
        if not dominated:
            keep.append(m)
    return np.asarray(keep, dtype=np.int64)


def decide(energy: np.ndarray, support: np.ndarray, offsets_s: np.ndarray, num_track_pairs: int,
           cfg: DecisionConfig) -> tuple[PairDecision, np.ndarray]:
    """(decision, minima indices best first)."""
    finite = np.isfinite(energy)
    if num_track_pairs < cfg.min_track_pairs:
        return PairDecision(False, f"too few track pairs ({num_track_pairs} < {cfg.min_track_pairs})",
                            0.0, 0.0, 0, 0, False), np.zeros(0, dtype=np.int64)
    if not finite.any():
        why = ("no candidate offset leaves the required overlap" if len(energy) == 0 else
               "no offset has enough co-visible track observations (tracks never overlap in time)")
        return PairDecision(False, why, 0.0, 0.0, 0, 0, False), np.zeros(0, dtype=np.int64)
    e_best = float(np.nanmin(energy))
    e_base = float(np.nanmedian(energy))
    depth = e_base - e_best
    minima = local_minima(energy, cfg.min_prominence * depth if depth > 0 else 0.0)
    best = int(minima[0])
    contrast = depth / e_base if e_base > 0 else 0.0
    depths = np.array([e_base - energy[m] for m in minima])
    second = float(max(depths[1], 0.0) / depth) if len(minima) > 1 and depth > 0 else 0.0
    significant = int(np.sum(depths >= 0.5 * depth)) if depth > 0 else len(minima)
    pareto = pareto_minima(energy, support, minima)
    edge = best in (0, len(energy) - 1) or not (finite[max(best - 1, 0)] and finite[min(best + 1, len(energy) - 1)])
    nums = dict(contrast=float(contrast), second_depth_ratio=second, num_minima=significant,
                num_pareto_minima=len(pareto), at_range_edge=bool(edge))

    accepted, reason = True, f"single clear minimum (contrast {contrast:.2f}, 2nd/1st depth {second:.2f})"
    if not cfg.enabled:
        reason = "accepted without checks (spurious-pair filter off)"
    elif contrast < cfg.min_contrast:
        accepted = False
        reason = (f"flat landscape: best energy only {100 * contrast:.0f}% below the median "
                  f"(< {100 * cfg.min_contrast:.0f}%): wrong matches, wrong poses or no shared motion")
    elif second >= cfg.max_second_ratio:
        accepted = False
        reason = (f"ambiguous: a second minimum at {offsets_s[minima[1]]:+.3f} s is {100 * second:.0f}% "
                  f"as deep as the best at {offsets_s[best]:+.3f} s")
    elif significant > cfg.max_minima:
        accepted = False
        reason = f"ambiguous: {significant} minima at least half as deep as the best (> {cfg.max_minima})"
    elif edge and cfg.reject_range_edge:
        accepted = False
        reason = (f"best minimum at the edge of the search range ({offsets_s[best]:+.3f} s): "
                  "the true offset may lie outside it")
    return PairDecision(accepted, reason, **nums), minima
