"""Stage 2: one offset per video from the accepted pairs' landscapes (robust global solve, or with
the drift model an offset and a drift), each video without one given the reason: no accepted
path to the reference, contradicting pairs, or too long a chain of worn-camera sightings.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..result_types import PairLandscape, SolveIteration, SyncResult
from ..types import CueBundle, pairs_by_reason
from .config import DriftConfig, SolveConfig
from .drift import PairTiming, solve_offsets_drift
from .sightings import RESIDUAL as SIGHTING
from .solve import PairMeasurement, linked_reference, solve_offsets


def _long_sighting_chains(lands, reference: str, max_chain: int) -> dict[str, str]:
    """{video: why} for the videos whose offset would rest on more than max_chain worn-camera
    sighting pairs in a chain from the reference."""
    return {v: with_its_pairs(lands, v, (
        f"its offset would rest on {hops} sightings of camera carriers in a chain from the reference (at "
        f"most {max_chain}), and their errors add up"))
        for v, hops in _sighting_hops(lands, reference).items() if hops > max_chain}


def _sighting_hops(lands, reference: str) -> dict[str, int]:
    """{video: fewest worn-camera sighting pairs on a chain of accepted pairs from the reference}
    (0-1 breadth-first search: a sighting pair counts 1, an epipolar pair 0)."""
    from collections import deque

    edges: dict[str, list[tuple[str, int]]] = {}
    for p in lands:
        if p.decision.accepted and math.isfinite(p.best_offset_s):
            w = int(p.residual == SIGHTING)
            edges.setdefault(p.a, []).append((p.b, w))
            edges.setdefault(p.b, []).append((p.a, w))
    hops = {reference: 0}
    todo = deque([reference])
    while todo:
        v = todo.popleft()
        for u, w in edges.get(v, []):
            if hops[v] + w < hops.get(u, 1 << 30):
                hops[u] = hops[v] + w
                (todo.appendleft if w == 0 else todo.append)(u)
    return hops


def _unlinked_reference(wanted: str, reference: str) -> str:
    """Why the wanted reference has no offset (reference: the one used instead, or itself)."""
    why = "the reference, but no accepted pair links it to another video, so no offset was measured against it"
    if reference != wanted:
        why += f"; {reference}, of the largest group of videos that accepted pairs link, is the reference instead"
    return why


def with_its_pairs(lands, v: str, why: str) -> str:
    """why, followed by the decisions of v's evaluated pairs, each distinct reason once with the
    pairs it holds for (at most three reasons)."""
    mine = [(f"{p.a}__{p.b}", p.decision.reason) for p in lands if v in (p.a, p.b)]
    if not mine:
        return why + " (no pair with it was evaluated)"
    grouped = pairs_by_reason(mine)
    more = f"; and {len(grouped) - 3} more reason(s)" if len(grouped) > 3 else ""
    return why + "; its pairs: " + "; ".join(grouped[:3]) + more


def solve_stage2(bundle: CueBundle, lands: list[PairLandscape] | tuple[PairLandscape, ...],
                 solve: SolveConfig = SolveConfig(), max_sighting_chain: int = 1) -> SyncResult:
    """Stage 2: per-video offsets from the accepted pairs' landscapes (robust global solve).

    The benchmark's Stage 2 ablations (plain least squares, the filter off, fewer pairs) call this
    with other landscapes or settings. Returns a SyncResult without timings.
    """
    names = bundle.names
    reference = solve.reference or names[0]
    if reference not in names:
        raise InputError(f"--reference {reference!r} is not a video of the bundle; known: {names}")
    finite = [v.frame_interval_s for v in bundle.videos if math.isfinite(v.frame_interval_s)]
    slowest = max(finite) if finite else 0.1
    delta = solve.huber_delta_s or 0.5 * slowest
    meas = []
    for land in lands:
        if land.decision.accepted and math.isfinite(land.best_offset_s):
            step = land.offsets_s[1] - land.offsets_s[0] if len(land.offsets_s) > 1 else slowest
            floor = step / math.sqrt(12.0)  # the grid's own resolution if the curvature is unknown
            sigma = land.uncertainty_s if math.isfinite(land.uncertainty_s) else floor
            meas.append(PairMeasurement(land.a, land.b, land.best_offset_s, max(sigma, 1e-6)))
    wanted, reference = reference, linked_reference(names, reference, [(m.a, m.b) for m in meas])
    out = solve_offsets(names, reference, meas, solve.solver, delta, solve.max_iterations)

    reasons = {v: with_its_pairs(lands, v, why) for v, why in out.unresolved_reason.items()}
    offsets, unc = dict(out.offsets_s), dict(out.uncertainty_s)
    for v, why in _long_sighting_chains(lands, reference, max_sighting_chain).items():
        if offsets.get(v) is not None:
            offsets[v], unc[v], reasons[v] = None, None, why
    if len(names) > 1 and not any(wanted in (m.a, m.b) for m in meas):
        # its 0.0 is a definition, not a measurement: with no accepted pair it says nothing
        offsets[wanted], unc[wanted] = None, None
        reasons[wanted] = with_its_pairs(lands, wanted, _unlinked_reference(wanted, reference))
    return SyncResult(reference, offsets, unc, reasons, tuple(lands),
                      out.pairs, out.iterations, solve.solver)


def solve_stage2_drift(bundle: CueBundle, lands: list[PairLandscape] | tuple[PairLandscape, ...],
                       solve: SolveConfig = SolveConfig(), drift: DriftConfig = DriftConfig(),
                       max_sighting_chain: int = 1) -> SyncResult:
    """Stage 2 with clock drift: per-video offset_s and drift from the accepted pairs' (Δ at the
    pivot, rate) (sync.drift: robust, the reference fixed at offset 0 and drift 0)."""
    names = bundle.names
    reference = solve.reference or names[0]
    if reference not in names:
        raise InputError(f"--reference {reference!r} is not a video of the bundle; known: {names}")
    timings = []
    for land in lands:
        if not (land.decision.accepted and math.isfinite(land.best_offset_s)):
            continue
        if math.isfinite(land.pivot_offset_s):
            off, pivot, std = land.pivot_offset_s, land.pivot_s, land.pivot_offset_std_s
        else:  # the rate fit found no energy around the minimum: the 1-D result at its rate
            off, pivot, std = land.best_offset_s, 0.0, land.uncertainty_s
        if not math.isfinite(std):  # no curvature there: the 1-D figure, else the grid's resolution
            step = land.offsets_s[1] - land.offsets_s[0] if len(land.offsets_s) > 1 else 0.1
            std = land.uncertainty_s if math.isfinite(land.uncertainty_s) else step / math.sqrt(12.0)
        lstd = land.log_rate_std
        # a rate the pair cannot tell is left to the other pairs and the drift prior
        timings.append(PairTiming(land.a, land.b, off, math.log(land.rate), std,
                                  lstd if math.isfinite(lstd) else 1.0, pivot))
    wanted, reference = reference, linked_reference(names, reference, [(t.a, t.b) for t in timings])
    sol = solve_offsets_drift(reference, timings, with_drift=True, drift_prior_ppm=drift.prior_ppm)
    offsets: dict[str, float | None] = {v: None for v in names}
    unc: dict[str, float | None] = {v: None for v in names}
    drift: dict[str, float | None] = {v: None for v in names}
    drift_std: dict[str, float | None] = {v: None for v in names}
    reasons: dict[str, str] = {}
    for v in names:
        if v in sol.offsets_s:
            offsets[v], unc[v] = sol.offsets_s[v], sol.offset_std_s[v]
            drift[v], drift_std[v] = sol.drift_ppm[v], sol.drift_std_ppm[v]
        else:
            reasons[v] = with_its_pairs(lands, v, "no chain of accepted pairs links it to the reference "
                                         + reference)
    for v, why in _long_sighting_chains(lands, reference, max_sighting_chain).items():
        if offsets.get(v) is not None:
            offsets[v] = unc[v] = drift[v] = drift_std[v] = None
            reasons[v] = why
    if len(names) > 1 and not any(wanted in (t.a, t.b) for t in timings):
        offsets[wanted] = unc[wanted] = drift[wanted] = drift_std[wanted] = None
        reasons[wanted] = with_its_pairs(lands, wanted, _unlinked_reference(wanted, reference))
    used = tuple((t.a, t.b) for t in timings if (t.a, t.b) in sol.pair_residuals)
    res = np.array([sol.pair_residuals[p][0] for p in used])
    weight = np.array([sol.pair_weights[p] for p in used])
    return SyncResult(reference, offsets, unc, reasons, tuple(lands), used,
                      (SolveIteration(res, weight),) if len(res) else (), "drift-huber",
                      drift_ppm=drift, drift_std_ppm=drift_std)
