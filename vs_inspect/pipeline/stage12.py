"""Stage 1 over the selected pairs, then Stage 2: a cue bundle in, a SyncResult out.

Stage 1 (pair_landscape) gives each pair an energy over candidate offsets and a decision;
Stage 2 (solve_stage2) solves one offset per video from the accepted pairs.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time

import numpy as np

from ..analysis.record_views import pair_record_view, run_record_view
from ..engine import Engine, LocalEngine, TaskFailed
from ..errors import InputError
from ..record.sink import NullSink, Sink
from ..types import CueBundle, PairDecision, PairLandscape, SyncResult, TrackPairs
from ..sync.config import SolveConfig, SyncConfig
from ..sync.decision import check_inliers, check_track_pairs_at_best, decide
from ..sync.landscape import PairInput, compute_landscape, curvature_uncertainty, refine_minimum
from ..sync.pairs import select_pairs
from ..sync.solve import PairMeasurement, solve_offsets

log = logging.getLogger(__name__)


def pair_landscape(bundle: CueBundle, a: str, b: str, cfg: SyncConfig):
    """Stage 1 for one ordered pair: (PairLandscape, PairEnergy or None)."""
    tp = bundle.pair(a, b) or TrackPairs(a, b, np.zeros((0, 2), dtype=np.int64))
    side = {n: PairInput(bundle.video(n), bundle.cameras[n], bundle.tracks[n]) for n in (a, b)}
    raw, pe = compute_landscape(side[a], side[b], tp, cfg.landscape)
    decision, minima = decide(raw.energy, raw.support, raw.offsets_s, len(tp.index), cfg.decision)
    best, best_e, sigma = float("nan"), float("nan"), float("nan")
    if len(minima):
        best_idx = int(minima[0])
        best, best_e = refine_minimum(pe, raw, best_idx)
        sigma = curvature_uncertainty(raw, best_idx, best_e, len(tp.index))
        va, vb = bundle.video(a), bundle.video(b)
        tau_px = cfg.decision.inlier_px_fraction * max(np.hypot(va.width, va.height),
                                                       np.hypot(vb.width, vb.height))
        r = pe.residuals(best, kind="sampson")
        seen = int(np.isfinite(r).any(axis=1).sum()) if r.ndim == 2 else 0
        r = r[np.isfinite(r)]
        inliers = float(np.mean(np.sqrt(r) < tau_px)) if r.size else float("nan")
        decision = check_inliers(decision, inliers, tau_px, cfg.decision)
        decision = check_track_pairs_at_best(decision, seen, best, cfg.decision)
    if len(tp.index) == 0 and not decision.accepted:
        decision = PairDecision(False, "no cross-view track pairs (the views share no matched motion)",
                                0.0, 0.0, 0, 0, False)
    land = PairLandscape(a, b, raw.offsets_s, raw.energy, raw.support, minima, best, best_e, sigma,
                         len(tp.index), decision, cfg.landscape.residual, raw.robust_scale)
    return land, pe


def _pair_task(shared: tuple[CueBundle, SyncConfig], pair: tuple[str, str]) -> PairLandscape:
    """Stage 1 of one pair as an engine task: the landscape only (the PairEnergy stays behind)."""
    bundle, cfg = shared
    return pair_landscape(bundle, pair[0], pair[1], cfg)[0]


def _fixed_threads(cfg: SyncConfig) -> SyncConfig:
    """cfg with the kernel's work split fixed to this process's thread count, so that a task on
    another worker or node sums in the same order and gives the same landscape bit for bit."""
    if cfg.landscape.threads:
        return cfg
    import numba
    return dataclasses.replace(cfg, landscape=dataclasses.replace(cfg.landscape,
                                                                  threads=numba.get_num_threads()))


def sync_bundle(bundle: CueBundle, cfg: SyncConfig = SyncConfig(), sink: Sink | None = None,
                progress: bool = True, engine: Engine | None = None) -> SyncResult:
    """Stage 1 over the pairs that cfg.pairs selects, then Stage 2, reported to the sink.

    engine: where the pairs' landscapes are computed (default: in this process); Stage 2 and
    everything reported to the sink stay here, in pair order, whatever the engine."""
    sink = sink or NullSink()
    engine = engine or LocalEngine()
    names = bundle.names
    reference = cfg.solve.reference or names[0]
    if reference not in names:
        raise InputError(f"--reference {reference!r} is not a video of the bundle; known: {names}")
    timings: dict[str, float] = {}
    sink.bundle(bundle)
    t0 = time.perf_counter()
    has = {k for k, v in bundle.pairs.items() if len(v.index)}
    chosen = select_pairs(names, has, cfg.pairs, bundle.cameras)
    lands: list[PairLandscape] = []
    task_cfg = _fixed_threads(cfg)
    for (a, b), land in zip(chosen, engine.map(_pair_task, chosen, shared=(bundle, task_cfg),
                                                desc="pair landscapes", unit="pair", progress=progress)):
        if isinstance(land, TaskFailed):  # its worker died: the pair counts as not evaluated
            log.warning("%s__%s: %s", a, b, land.reason)
            sink.stage_event("landscapes", f"{a}__{b}: not evaluated: {land.reason}")
            continue
        lands.append(land)
        log.info("%s__%s: %s Δ=%+.4f s (%s)", a, b, "accepted" if land.decision.accepted else
                 "rejected", land.best_offset_s, land.decision.reason)
        sink.pair_landscape(land, None if sink.options is None else
                            pair_record_view(bundle, land, sink.options, sink.image_frames(a)))
    timings["stage1_s"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    result = solve_stage2(bundle, lands, cfg.solve)
    timings["stage2_s"] = time.perf_counter() - t1
    result = dataclasses.replace(result, timings_s=timings)
    sink.sync_result(result, None if sink.options is None else
                     run_record_view(bundle, result, sink.options))
    return result


def solve_stage2(bundle: CueBundle, lands: list[PairLandscape] | tuple[PairLandscape, ...],
                 solve: SolveConfig = SolveConfig()) -> SyncResult:
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
    out = solve_offsets(names, reference, meas, solve.solver, delta, solve.max_iterations)

    def with_its_pairs(v: str, why: str) -> str:
        mine = [p for p in lands if v in (p.a, p.b)]
        if not mine:
            return why + " (no pair with it was evaluated)"
        return why + "; its pairs: " + "; ".join(f"{p.a}__{p.b}: {p.decision.reason}" for p in mine[:3])

    reasons = {v: with_its_pairs(v, why) for v, why in out.unresolved_reason.items()}
    offsets, unc = dict(out.offsets_s), dict(out.uncertainty_s)
    if len(names) > 1 and not any(reference in (m.a, m.b) for m in meas):
        # its 0.0 is a definition, not a measurement: with no accepted pair it says nothing
        offsets[reference], unc[reference] = None, None
        reasons[reference] = with_its_pairs(reference, "the reference, but no accepted pair links it to "
                                            "another video, so no offset was measured against it")
    return SyncResult(reference, offsets, unc, reasons, tuple(lands),
                      out.pairs, out.iterations, solve.solver)
