"""Stage 2: per-video offsets from accepted pair offsets by Huber IRLS (or plain least squares).

Minimizes Σ ρ(s_b - s_a - Δ_ab) with s_reference = 0, over the videos connected to the
reference through accepted pairs. Others get no offset and a reason, never a guess.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..types import SolveIteration


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


def huber_weights(residual: np.ndarray, delta: float) -> np.ndarray:
    """IRLS weights of the Huber loss: 1 inside ±delta, delta/|r| outside."""
    a = np.abs(residual)
    return np.where(a <= delta, 1.0, delta / np.maximum(a, 1e-300))


def solve_offsets(names: list[str], reference: str, measurements: list[PairMeasurement],
                  solver: str = "irls", huber_delta_s: float = 0.05,
                  max_iterations: int = 50) -> SolveOutput:
    if reference not in names:
        raise ValueError(f"reference {reference!r} is not a video; known: {names}")
    pos = {n: i for i, n in enumerate(names)}
    n = len(names)
    offsets: dict[str, float | None] = {v: None for v in names}
    unc: dict[str, float | None] = {v: None for v in names}
    reasons: dict[str, str] = {}
    if measurements:
        g = coo_matrix((np.ones(len(measurements)),
                        ([pos[m.a] for m in measurements], [pos[m.b] for m in measurements])),
                       shape=(n, n))
        _, label = connected_components(g, directed=False)
    else:
        label = np.arange(n)
    comp = {v for v in names if label[pos[v]] == label[pos[reference]]}
    for v in names:
        if v not in comp:
            reasons[v] = f"not connected to the reference {reference!r} through accepted pairs"
    offsets[reference] = 0.0
    unc[reference] = 0.0
    used = [m for m in measurements if m.a in comp and m.b in comp]
    unknown = [v for v in names if v in comp and v != reference]
    if not unknown or not used:
        return SolveOutput(offsets, unc, reasons, (), tuple((m.a, m.b) for m in used))
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
    return SolveOutput(offsets, unc, reasons, tuple(iters), tuple((m.a, m.b) for m in used))
