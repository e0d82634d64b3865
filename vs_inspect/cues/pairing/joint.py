"""The joint choice of every camera's offset from all camera pairs' votes (joint_offsets), and
when it is not sure, the vote peaks that close every triangle (consistent_peaks). Pure functions
of the votes, no I/O."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .votes import GeometricPairStats, vote_z


@dataclass(frozen=True)
class JointChoice:
    """Offsets of all cameras chosen at once from every pair's vote histogram."""

    offsets_s: dict[str, float]  # camera -> offset_s (the first camera's is 0)
    score: float  # Σ over pairs of the vote z-score at the implied Δ_ab
    margin: dict[str, float]  # camera -> score lost by the best choice that moves it by > tol_s

    @property
    def origin(self) -> str:
        """The camera whose offset is 0: the first by name (joint_offsets)."""
        return min(self.offsets_s)


def joint_offsets(found: dict[tuple[str, str], GeometricPairStats], tol_s: float,
                  candidates: int = 10, max_combinations: int = 200_000) -> JointChoice | None:
    """Offsets of every camera that together collect the most votes over all pairs.

    Each pair's votes are z-scored (vote_z); a choice of offsets scores the sum over pairs of
    the z-score at its Δ_ab = offset_b - offset_a (a Δ outside a pair's grid or its --around window scores -5). The
    choices tried: with each camera in turn as the reference, every combination of the
    `candidates` highest z-peaks of its pairs with the others. A single pair can have a false
    peak above its true one (a repeated motion, points moving along their epipolar lines), but
    the false peaks of several pairs rarely close. margin says how much each camera's offset is
    preferred over the best choice that moves it by more than tol_s against every other camera. None when no camera is
    paired with every other (or there are fewer than three cameras).
    """
    found = {k: st for k, st in found.items() if st.votes is not None and len(st.votes)}
    names = sorted({n for k in found for n in k})
    if len(names) < 3:
        return None
    zs = {k: vote_z(st) for k, st in found.items()}

    def lookup(a: str, b: str, delta: np.ndarray) -> np.ndarray:
        offs, z = zs[(a, b)]  # called for the pairs of zs only
        i = np.clip(np.searchsorted(offs, delta), 1, max(1, len(offs) - 1))
        i = np.where(np.abs(offs[i] - delta) < np.abs(offs[i - 1] - delta), i, i - 1)
        inside = (delta >= offs[0] - 1e-9) & (delta <= offs[-1] + 1e-9) & found[(a, b)].allows(delta)
        return np.where(inside, z[i], -5.0)

    def peaks_of(a: str, b: str) -> list[float]:
        offs, z = zs[(a, b)] if (a, b) in zs else (-zs[(b, a)][0], zs[(b, a)][1])
        st = found[(a, b)] if (a, b) in found else found[(b, a)].swapped()
        sep = max(st.halfwidth_s, 1e-6) * 2
        out: list[float] = []
        for i in np.argsort(-z, kind="stable"):
            if len(out) >= per:
                break
            if not st.allows(offs[i]):  # outside the pair's --around window
                continue
            if all(abs(offs[i] - o) > sep for o in out):
                out.append(float(offs[i]))
        return out

    per = max(1, min(candidates, int(max_combinations ** (1.0 / (len(names) - 1)))))
    rows, scores = [], []
    for ref in names:
        others = [n for n in names if n != ref]
        if not all((ref, c) in zs or (c, ref) in zs for c in others):
            continue
        grids = np.meshgrid(*[np.array(peaks_of(ref, c)) for c in others], indexing="ij")
        combo = np.zeros((grids[0].size, len(names)))
        for c, g in zip(others, grids):
            combo[:, names.index(c)] = g.ravel()
        score = np.zeros(len(combo))
        for (a, b) in zs:
            score += lookup(a, b, combo[:, names.index(b)] - combo[:, names.index(a)])
        rows.append(combo - combo[:, :1])  # first camera at 0
        scores.append(score)
    if not rows:
        return None
    combo, score = np.concatenate(rows), np.concatenate(scores)
    top = int(np.argmax(score))
    margin = {}
    for c, n in enumerate(names):
        # c moved against every other camera (the first camera's offset is 0 by definition, so
        # "moved" must be relative, or it would never move)
        rel = (combo - combo[:, c:c + 1]) - (combo[top] - combo[top, c])
        away = np.all(np.abs(np.delete(rel, c, axis=1)) > tol_s, axis=1)
        margin[n] = float(score[top] - score[away].max()) if away.any() else float("inf")
    return JointChoice({n: float(combo[top, c]) for c, n in enumerate(names)}, float(score[top]), margin)


def consistent_peaks(peaks: dict[tuple[str, str], tuple[tuple[float, ...], tuple[int, ...]]],
                     tol_s: float, max_pairs: int = 10
                     ) -> tuple[dict[tuple[str, str], int] | None, str]:
    """One vote peak per camera pair such that every triangle closes, Δ_ab + Δ_bc ≈ Δ_ac.

    peaks: (a, b) -> (peak offsets Δ_ab in s, votes), names in a fixed order within each key.
    A choice must close every triangle within tol_s. Among those, the one with the least cost
    Σ_pairs ((v_top - v) / √v_top)² + Σ_triangles (closure / (tol_s / 3))² wins: vote counts
    vary like Poisson counts, so peaks a few √v apart are near-ties that the closure decides
    (each peak is located to about a frame, tol_s is about three). Returns (choice, "chosen"), or
    (None, why): "no triangle" (fewer than three cameras with peaks), "too many pairs" (the
    search tries every combination), "inconsistent" (no choice closes every triangle) or "one
    triangle" (three cameras: a single closure is one check on 27 choices of three peaks, and
    some close within tol_s by chance).
    """
    keys = [k for k in peaks if len(peaks[k][0])]
    if len(keys) > max_pairs:
        return None, "too many pairs"

    def delta(ch, u, v):
        return peaks[(u, v)][0][ch[(u, v)]] if (u, v) in ch else -peaks[(v, u)][0][ch[(v, u)]]

    names = sorted({n for k in keys for n in k})
    triangles = [t for t in itertools.combinations(names, 3)
                 if all((u, v) in keys or (v, u) in keys for u, v in itertools.combinations(t, 2))]
    if not triangles:
        return None, "no triangle"
    top = {k: max(peaks[k][1]) for k in keys}
    sigma_s = tol_s / 3.0
    best, best_cost = None, np.inf
    for choice in itertools.product(*[range(len(peaks[k][0])) for k in keys]):
        ch = dict(zip(keys, choice))
        closure = np.array([delta(ch, a, b) + delta(ch, b, c) - delta(ch, a, c) for a, b, c in triangles])
        if np.all(np.abs(closure) <= tol_s):
            cost = sum(((top[k] - peaks[k][1][ch[k]]) / np.sqrt(max(top[k], 1))) ** 2 for k in keys)
            cost += float(np.sum((closure / sigma_s) ** 2)) if sigma_s > 0 else 0.0
            if cost < best_cost:
                best, best_cost = ch, cost
    if best is None:
        return None, "inconsistent"
    if len(triangles) == 1:
        return None, "one triangle"
    return best, "chosen"
