"""Stage 2: per-video offsets from accepted pair offsets by Huber IRLS (or plain least squares).

Minimizes Σ ρ(s_b - s_a - Δ_ab) with s_reference = 0, over the videos connected to the
reference through accepted pairs. Others get no offset and a reason, never a guess.

With IRLS, a video whose solved offset lies far (more than conflict_factor Huber thresholds)
from every one of its accepted pairs is a compromise between pairs that contradict each other,
not a measurement: it gets no offset and a reason naming the pairs, and the solve is repeated
without them (the case that motivated it is in BENCHMARKS.md, "Measurements behind defaults").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..result_types import SolveIteration


@dataclass(frozen=True)
class PairMeasurement:
    a: str
    b: str
    offset_s: float  # Δ_ab measured by Stage 1
    sigma_s: float  # its 1-sigma, seconds (finite, > 0)


@dataclass(frozen=True)
class SolveOutput:
    offsets_s: dict[str, float | None]
    uncertainty_s: dict[str, float | None]
    unresolved_reason: dict[str, str]
    iterations: tuple[SolveIteration, ...]
    pairs: tuple[tuple[str, str], ...]  # measurements used, in residual order


def linked_reference(names: list[str], reference: str, pairs: list[tuple[str, str]]) -> str:
    """The reference, or, when none of pairs (the accepted ones, (a, b)) links it to another
    video, the first video (in names' order) of the largest group of videos the pairs link:
    offsets against a reference that no pair reaches would all be unknown, while that group's are
    measured."""
    if not pairs or any(reference in p for p in pairs):
        return reference
    label = _components(names, pairs)
    return names[int(np.argmax(np.bincount(label)[label]))]  # argmax: the first of the largest group


def huber_weights(residual: np.ndarray, delta: float) -> np.ndarray:
    """IRLS weights of the Huber loss: 1 inside ±delta, delta/|r| outside."""
    a = np.abs(residual)
    return np.where(a <= delta, 1.0, delta / np.maximum(a, 1e-300))


def solve_offsets(names: list[str], reference: str, measurements: list[PairMeasurement],
                  solver: str = "irls", huber_delta_s: float = 0.05,
                  max_iterations: int = 50, conflict_factor: float = 3.0) -> SolveOutput:
    if reference not in names:
        raise ValueError(f"reference {reference!r} is not a video; known: {names}")
    out, used = _solve(names, reference, measurements, solver, huber_delta_s, max_iterations)
    if solver != "irls":
        return out
    tol = conflict_factor * huber_delta_s
    reasons: dict[str, str] = {}
    while out.iterations:
        res = out.iterations[-1].residual_s
        # a bridge (a pair whose removal splits the graph) always fits exactly: it is no evidence
        loop = ~_bridges(names, used)
        mine = {v: [(m, r) for m, r, ok in zip(used, res, loop) if ok and v in (m.a, m.b)] for v in names}
        torn = [v for v in names if v != reference and out.offsets_s[v] is not None and mine[v]
                and all(abs(r) > tol for _, r in mine[v])]
        if not torn:
            break
        for v in torn:
            said = "; ".join(f"{m.a}__{m.b} Δ {m.offset_s:+.3f} s, off by {r:+.3f} s" for m, r in mine[v])
            reasons[v] = (f"its accepted pairs contradict each other: the joint solution is more than "
                          f"{1000 * tol:.0f} ms from every one of them ({said})")
        before = out.offsets_s
        keep = [m for m in used if m.a not in torn and m.b not in torn]
        out, used = _solve(names, reference, keep, solver, huber_delta_s, max_iterations)
        for v in names:
            if v not in torn and v not in reasons and before[v] is not None and out.offsets_s[v] is None:
                reasons[v] = (f"connected to the reference only through {', '.join(torn)}, whose pairs "
                              f"contradict each other")
    if not reasons:
        return out
    return SolveOutput(out.offsets_s, out.uncertainty_s, {**out.unresolved_reason, **reasons},
                       out.iterations, out.pairs)


def _components(names: list[str], pairs: list[tuple[str, str]]) -> np.ndarray:
    """(V,) connected-component label of each video in the graph of the pairs (a, b)."""
    pos = {n: i for i, n in enumerate(names)}
    if not pairs:
        return np.arange(len(names))
    g = coo_matrix((np.ones(len(pairs)), ([pos[a] for a, _ in pairs], [pos[b] for _, b in pairs])),
                   shape=(len(names), len(names)))
    return connected_components(g, directed=False)[1]


def _ends(measurements: list[PairMeasurement]) -> list[tuple[str, str]]:
    """The (a, b) of each measurement."""
    return [(m.a, m.b) for m in measurements]


def _bridges(names: list[str], measurements: list[PairMeasurement]) -> np.ndarray:
    """(E,) bool: removing this measurement splits its component (a handful of videos: brute force)."""
    n_before = len(np.unique(_components(names, _ends(measurements))))
    return np.array([len(np.unique(_components(names, _ends(measurements[:i] + measurements[i + 1:])))) > n_before
                     for i in range(len(measurements))], bool)


def _solve(names: list[str], reference: str, measurements: list[PairMeasurement], solver: str,
           huber_delta_s: float, max_iterations: int) -> tuple[SolveOutput, list[PairMeasurement]]:
    """(solution, the measurements it used, in residual order)."""
    pos = {n: i for i, n in enumerate(names)}
    offsets: dict[str, float | None] = {v: None for v in names}
    unc: dict[str, float | None] = {v: None for v in names}
    reasons: dict[str, str] = {}
    label = _components(names, _ends(measurements))
    comp = {v for v in names if label[pos[v]] == label[pos[reference]]}
    for v in names:
        if v not in comp:
            reasons[v] = f"not connected to the reference {reference!r} through accepted pairs"
    offsets[reference] = 0.0
    unc[reference] = 0.0
    used = [m for m in measurements if m.a in comp and m.b in comp]
    unknown = [v for v in names if v in comp and v != reference]
    if not unknown or not used:
        return SolveOutput(offsets, unc, reasons, (), tuple((m.a, m.b) for m in used)), used
    col = {v: i for i, v in enumerate(unknown)}
    A = np.zeros((len(used), len(unknown)))
    for r, m in enumerate(used):
        if m.b in col:
            A[r, col[m.b]] += 1.0
        if m.a in col:
            A[r, col[m.a]] -= 1.0
    y = np.array([m.offset_s for m in used])
    sigma = np.array([m.sigma_s for m in used])
    w = np.ones(len(used))
    iters: list[SolveIteration] = []
    x = np.zeros(len(unknown))
    for _ in range(max_iterations if solver == "irls" else 1):
        sw = np.sqrt(w)
        x_new = np.linalg.lstsq(A * sw[:, None], y * sw, rcond=None)[0]
        res = A @ x_new - y
        if solver == "irls":
            w = huber_weights(res, huber_delta_s)
        iters.append(SolveIteration(res.copy(), w.copy()))
        done = np.max(np.abs(x_new - x)) < 1e-10
        x = x_new
        if done and len(iters) > 1:
            break
    # Uncertainty: pair sigmas propagated through the weighted solve, and the residual scatter
    # when the graph has redundancy; the larger of the two per video.
    AtWA_inv = np.linalg.pinv(A.T @ (A * w[:, None]))
    H = AtWA_inv @ (A * w[:, None]).T
    var = np.einsum("ij,j,ij->i", H, sigma ** 2, H)
    dof = len(used) - len(unknown)
    if dof > 0:
        s2 = float(np.sum(w * res ** 2) / dof)
        var = np.maximum(var, s2 * np.diag(AtWA_inv))
    for v, i in col.items():
        offsets[v] = float(x[i])
        unc[v] = float(np.sqrt(max(var[i], 0.0)))
    return SolveOutput(offsets, unc, reasons, tuple(iters), tuple((m.a, m.b) for m in used)), used
