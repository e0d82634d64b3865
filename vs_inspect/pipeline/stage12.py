"""Stage 1 over the selected pairs, then Stage 2: a cue bundle in, a SyncResult out.

Stage 1 (pair_landscape) gives each pair an energy over candidate offsets and a decision;
Stage 2 (solve_stage2) solves one offset per video from the accepted pairs.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from typing import NamedTuple

import numpy as np

from ..analysis.record_views import pair_record_view, run_record_view
from ..engine import Engine, LocalEngine, TaskFailed
from ..errors import InputError
from ..geometry.offsets import OffsetGrid, grid_between, span_of
from ..record.sink import NullSink, Sink
from ..types import (CameraTrack, CueBundle, PairDecision, PairLandscape, SolveIteration, SyncResult,
                     TrackPairs, pairs_by_reason)
from ..sync.config import DriftConfig, SolveConfig, SyncConfig
from ..sync.decision import (check_chosen_offset, check_inliers, check_track_pairs_at_best, check_uncertainty,
                             decide)
from ..sync.landscape import (PairEnergy, PairInput, RawLandscape, compute_landscape, curvature_uncertainty,
                              landscape_step_s, refine_minimum)
from ..sync.pairs import select_pairs
from ..sync.drift import PairTiming, solve_offsets_drift
from ..sync.posefree import PoseFreeConfig, PoseFreePair, estimate_pair
from ..sync.rate import fit_rate, rate_landscape, scaled_video
from ..sync.sightings import RESIDUAL as SIGHTING
from ..sync.sightings import sighting_pair
from ..sync.solve import PairMeasurement, linked_reference, solve_offsets

log = logging.getLogger(__name__)


def pair_landscape(bundle: CueBundle, a: str, b: str, cfg: SyncConfig,
                   pose_free: PoseFreePair | None = None, pose_free_pair: bool = False):
    """Stage 1 for one ordered pair: (PairLandscape, PairEnergy or None).

    pose_free_pair: the pair has no usable cameras; pose_free is then what its tracks gave
    (sync.posefree: F, shift, rate), the energy uses the cameras of that F and is searched in a
    window around that shift (None: the pair is rejected with the reason). With the drift model
    (cfg.drift.enabled) the 1-D minimum is refined over (Δ, rate) (sync.rate)."""
    tp = bundle.pair(a, b) or TrackPairs(a, b, np.zeros((0, 2), dtype=np.int64))
    side = {n: PairInput(bundle.video(n), bundle.cameras[n], bundle.tracks[n]) for n in (a, b)}
    grid = cfg.offset_grid(bundle.names)
    window = grid.pair_window(a, b)
    offsets, rate0, decision_cfg = None, 1.0, cfg.decision
    if pose_free_pair:
        if pose_free is None or pose_free.b_from_a is None or pose_free.inlier_share < MIN_POSE_FREE_INLIERS:
            return dataclasses.replace(_pose_free_rejected(bundle, a, b, tp, cfg, pose_free), window_s=window), None
        side, offsets, rate0 = _pose_free_inputs(bundle, a, b, side, cfg, pose_free, grid)
        # one track followed by both cameras is the evidence here (its F explains most matches)
        decision_cfg = dataclasses.replace(cfg.decision, min_track_pairs=min(cfg.decision.min_track_pairs, 1))
    raw, pe, minima, decision, best, best_e, sigma = _decided_landscape(side[a], side[b], tp, cfg, decision_cfg,
                                                                        offsets, grid)
    confirm = None
    if decision.accepted and tp.unchecked is not None and tp.unchecked.any() and decision_cfg.enabled \
            and decision_cfg.unchecked_agree_frames > 0:
        decision, confirm = _confirm_without_unchecked(side[a], side[b], tp, cfg, decision_cfg, offsets, decision,
                                                       best, grid)
    if len(tp.index) == 0 and not decision.accepted:
        decision = PairDecision(False, "no cross-view track pairs (no matched motion, or Stage 0 kept none)",
                                0.0, 0.0, 0, 0, False)
    land = PairLandscape(a, b, raw.offsets_s, raw.energy, raw.support, minima, best, best_e, sigma,
                         len(tp.index), decision, cfg.landscape.residual, raw.robust_scale,
                         confirm_energy=None if confirm is None else confirm.raw.energy,
                         confirm_offset_s=confirm.best_s if confirm is not None and confirm.decision.accepted
                         else float("nan"), window_s=window)
    if pose_free_pair:
        land = dataclasses.replace(land, rate=rate0, pose_free=True)
    if cfg.drift.enabled and math.isfinite(best):
        # b unscaled: the grid starts from (best, rate0) in the pair's own clocks
        side_b = dataclasses.replace(side[b], video=bundle.video(b))
        if pose_free_pair:
            # the rate its tracks gave (a continuous fit on every detection) is sharper than the
            # energy's over a single track, whose terms enter and leave as the rate turns: the
            # pair keeps it, with the energy's minimum at that rate; the energy's (Δ, rate) grid
            # is only the image shown, so it is not fitted
            img = rate_landscape(side[a], side_b, tp, cfg.landscape, cfg.drift, best, rate0, raw.robust_scale)
            if img is not None:
                land = dataclasses.replace(land, log_rate_std=pose_free.log_rate_std, pivot_s=img.pivot_s,
                                           pivot_offset_s=best + (rate0 - 1.0) * img.pivot_s,
                                           pivot_offset_std_s=sigma, rate_landscape=img)
        else:
            fit = fit_rate(side[a], side_b, tp, cfg.landscape, cfg.drift, best, rate0, raw.robust_scale,
                           max(len(tp.index), 1))
            if fit is not None:
                land = dataclasses.replace(land, best_offset_s=fit.offset_s, best_energy=fit.energy,
                                           rate=fit.rate, log_rate_std=fit.log_rate_std, pivot_s=fit.pivot_s,
                                           pivot_offset_s=fit.pivot_offset_s,
                                           pivot_offset_std_s=fit.pivot_offset_std_s,
                                           rate_landscape=fit.landscape)
    return land, pe


class _Decided(NamedTuple):
    """One set of track pairs' landscape, the decision on it and its refined minimum."""

    raw: RawLandscape
    energy_fn: PairEnergy
    minima: np.ndarray  # (M,) int, indices of significant minima, best first
    decision: PairDecision
    best_s: float  # refined best Δ_ab, s (NaN: no minimum)
    best_energy: float
    sigma_s: float  # its 1-sigma from the curvature


def _decided_landscape(a: PairInput, b: PairInput, tp: TrackPairs, cfg: SyncConfig, decision_cfg,
                       offsets: np.ndarray | None, grid: OffsetGrid | None = None) -> _Decided:
    """The landscape of one set of track pairs, the decision on it and the checks at its refined
    minimum."""
    raw, pe = compute_landscape(a, b, tp, cfg.landscape, offsets, grid)
    allowed = None if grid is None else grid.within_window(a.video.name, b.video.name, raw.offsets_s)
    decision, minima = decide(raw.energy, raw.support, raw.offsets_s, len(tp.index), decision_cfg,
                              None if allowed is None or allowed.all() else allowed)
    best, best_e, sigma = float("nan"), float("nan"), float("nan")
    if len(minima):
        best_idx = int(minima[0])
        best, best_e = refine_minimum(pe, raw, best_idx)
        sigma = curvature_uncertainty(raw, best_idx, best_e, len(tp.index))
        va, vb = a.video, b.video
        tau_px = decision_cfg.inlier_px_fraction * max(np.hypot(va.width, va.height),
                                                       np.hypot(vb.width, vb.height))
        r = pe.residuals(best, kind="sampson")
        seen = int(np.isfinite(r).any(axis=1).sum()) if r.ndim == 2 else 0
        r = r[np.isfinite(r)]
        inliers = float(np.mean(np.sqrt(r) < tau_px)) if r.size else float("nan")
        decision = check_inliers(decision, inliers, tau_px, decision_cfg)
        decision = check_track_pairs_at_best(decision, seen, best, decision_cfg)
        frame_s = max(va.frame_interval_s, vb.frame_interval_s)
        decision = check_uncertainty(decision, sigma, best, frame_s, decision_cfg)
        decision = check_chosen_offset(decision, best, tp.chosen_at_offset_s, frame_s, decision_cfg)
    return _Decided(raw, pe, minima, decision, best, best_e, sigma)


def _confirm_without_unchecked(a: PairInput, b: PairInput, tp: TrackPairs, cfg: SyncConfig, decision_cfg,
                               offsets: np.ndarray | None, decision: PairDecision, best: float,
                               grid: OffsetGrid | None = None) -> tuple[PairDecision, _Decided]:
    """(decision, the other track pairs' own landscape and decision): the accepted decision, or
    a rejection when the pair's other track pairs alone (found by
    appearance, without assuming an offset) give no accepted minimum within
    unchecked_agree_frames of the coarser video's frames of best: the unchecked rows were chosen
    by an epipolar vote at an offset no third camera checked, and two views cannot tell a wrong
    vote peak from a right one (a moving body's two sides fit a shifted offset)."""
    keep = ~tp.unchecked
    alone = TrackPairs(tp.a, tp.b, tp.index[keep], None if tp.weight is None else tp.weight[keep])
    confirm = _decided_landscape(a, b, alone, cfg, decision_cfg, offsets, grid)
    own, own_best = confirm.decision, confirm.best_s
    tol_s = decision_cfg.unchecked_agree_frames * max(a.video.frame_interval_s, b.video.frame_interval_s)
    head = (f"no third camera to check: {int(tp.unchecked.sum())} of the {len(tp.index)} track pairs "
            f"were chosen by an epipolar vote at an offset no triangle checked, and the "
            f"{len(alone.index)} found by appearance alone ")
    if not own.accepted:
        why = head + f"give no minimum of their own to confirm {best:+.3f} s ({own.reason})"
    elif abs(own_best - best) > tol_s:
        why = head + (f"put it at {own_best:+.3f} s, not {best:+.3f} s (more than "
                      f"{decision_cfg.unchecked_agree_frames:g} frames, {tol_s * 1000:.0f} ms, apart)")
    else:
        return dataclasses.replace(decision, reason=decision.reason + f"; confirmed by the {len(alone.index)} "
                                   f"track pairs found by appearance alone ({own_best:+.3f} s)"), confirm
    return dataclasses.replace(decision, accepted=False, reason=why), confirm


MIN_POSE_FREE_INLIERS = 0.5
"""A pose-free pair whose refined F explains fewer of its matches than this has no geometry to
build the energy on (a wrong shift, or too little common motion)."""


def is_pose_free_pair(bundle: CueBundle, a: str, b: str) -> bool:
    """The pair's cameras cannot give F: either video is marked pose-free (K only), or both
    cameras are static at the same centre (no baseline, F = 0)."""
    if a in bundle.pose_free or b in bundle.pose_free:
        return True
    ca, cb = bundle.cameras[a], bundle.cameras[b]
    if ca.is_moving or cb.is_moving:
        return False
    centre = [c.centers()[0] for c in (ca, cb)]
    return bool(np.linalg.norm(centre[0] - centre[1]) < 1e-9)


def _pair_track_rows(bundle: CueBundle, a: str, b: str) -> tuple[int, int]:
    """The track pair seen in most frames by both sides: the one posefree estimates from."""
    tp = bundle.pair(a, b)
    seen = {n: np.isfinite(bundle.tracks[n].xy).all(axis=2).sum(axis=1) for n in (a, b)}
    counts = np.minimum(seen[a][tp.index[:, 0]], seen[b][tp.index[:, 1]])
    i = int(np.argmax(counts))
    return int(tp.index[i, 0]), int(tp.index[i, 1])


def _static_K(cam) -> np.ndarray:
    return cam.K if cam.K.ndim == 2 else cam.K[0]


def pose_free_job(bundle: CueBundle, a: str, b: str, cfg: SyncConfig) -> tuple:
    """The arguments of sync.posefree.estimate_pair for one pose-free pair."""
    ia, ib = _pair_track_rows(bundle, a, b)
    va, vb = bundle.video(a), bundle.video(b)
    pcfg = PoseFreeConfig(estimate_rate=cfg.drift.enabled)
    rng = cfg.offset_grid(bundle.names).pair_bounds(a, span_of(va.timestamps_s), b, span_of(vb.timestamps_s))
    return (va.timestamps_s, bundle.tracks[a].xy[ia], _static_K(bundle.cameras[a]),
            vb.timestamps_s, bundle.tracks[b].xy[ib], _static_K(bundle.cameras[b]), pcfg, rng)


def _pose_free_task(shared: tuple[CueBundle, SyncConfig], item: tuple[str, str]) -> PoseFreePair | None:
    """sync.posefree for one pose-free pair as an engine task."""
    bundle, cfg = shared
    t_a, xy_a, K_a, t_b, xy_b, K_b, pcfg, rng = pose_free_job(bundle, *item, cfg)
    return estimate_pair(t_a, xy_a, K_a, t_b, xy_b, K_b, pcfg, offset_range_s=rng)


def estimate_pose_free_pairs(bundle: CueBundle, chosen: list[tuple[str, str]], cfg: SyncConfig,
                             progress: bool = False, engine: Engine | None = None
                             ) -> dict[tuple[str, str], PoseFreePair | TaskFailed | None]:
    """sync.posefree over the chosen pose-free pairs, on the engine (default: local, one forked
    process per core), in the order of chosen; a pair whose task died with its worker is TaskFailed."""
    if not chosen:  # nothing to send (a Ray engine would still ship the bundle)
        return {}
    engine = engine or LocalEngine()
    out = engine.map(_pose_free_task, chosen, shared=(bundle, cfg), desc="pose-free pairs", unit="pair",
                     progress=progress, processes=True)
    return dict(zip(chosen, out))


def _pose_free_inputs(bundle: CueBundle, a: str, b: str, side: dict[str, PairInput], cfg: SyncConfig,
                      pf: PoseFreePair, grid: OffsetGrid):
    """(the pair's inputs with the cameras of pf's F, the window of offsets, the rate read at)."""
    cam_a = CameraTrack(_static_K(bundle.cameras[a]), np.eye(4))
    cam_b = CameraTrack(_static_K(bundle.cameras[b]), pf.b_from_a)
    rate0 = pf.rate if cfg.drift.enabled else 1.0
    vb = scaled_video(bundle.video(b), rate0)
    side = {a: dataclasses.replace(side[a], camera=cam_a),
            b: dataclasses.replace(side[b], camera=cam_b, video=vb)}
    step = landscape_step_s(side[a].video, vb, cfg.landscape)
    half = cfg.pose_free.window_s
    lo, hi = grid.pair_bounds(a, span_of(side[a].video.timestamps_s), b, span_of(bundle.video(b).timestamps_s),
                              window=False)
    offsets = grid_between(max(pf.offset_s - half, lo), min(pf.offset_s + half, hi), step, grid.max_count,
                           f"{a!r} and {b!r}")
    return side, offsets, rate0


def _pose_free_rejected(bundle: CueBundle, a: str, b: str, tp: TrackPairs, cfg: SyncConfig,
                        pf: PoseFreePair | None) -> PairLandscape:
    why = ("pose-free pair: its tracks gave no time shift (too little common motion)" if pf is None else
           f"pose-free pair: the F of its best time shift explains {pf.inlier_share:.0%} of the matches "
           f"(< {MIN_POSE_FREE_INLIERS:.0%})")
    nan = float("nan")
    empty = np.zeros(0)
    return PairLandscape(a, b, empty, empty, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64),
                         nan, nan, nan, len(tp.index), PairDecision(False, why, 0.0, 0.0, 0, 0, False),
                         cfg.landscape.residual, nan, pose_free=True)


def _pair_task(shared: tuple[CueBundle, SyncConfig],
               item: tuple[str, str, PoseFreePair | None, bool]) -> PairLandscape:
    """Stage 1 of one pair as an engine task: the landscape only (the PairEnergy stays behind)."""
    bundle, cfg = shared
    a, b, pf, is_pose_free = item
    return pair_landscape(bundle, a, b, cfg, pf, is_pose_free)[0]


def _fixed_threads(cfg: SyncConfig) -> SyncConfig:
    """cfg with the kernel's work split fixed to this process's thread count, so that a task on
    another worker or node sums in the same order and gives the same landscape bit for bit."""
    if cfg.landscape.threads:
        return cfg
    import numba
    return dataclasses.replace(cfg, landscape=dataclasses.replace(cfg.landscape,
                                                                  threads=numba.get_num_threads()))


def sync_bundle(bundle: CueBundle, cfg: SyncConfig = SyncConfig(), sink: Sink | None = None,
                progress: bool = True,
                pose_free: dict[tuple[str, str], PoseFreePair | None] | None = None,
                engine: Engine | None = None) -> SyncResult:
    """Stage 1 over the pairs that cfg.pairs selects, then Stage 2, reported to the sink.

    pose_free: estimates of pose-free pairs made earlier (estimate_pose_free_pairs; e.g. the drift
    model's, reused by the benchmark's constant-offset ablation); the others are estimated here.
    engine: where the pairs' landscapes are computed (default: in this process); Stage 2 and
    everything reported to the sink stay here, in pair order, whatever the engine."""
    sink = sink or NullSink()
    engine = engine or LocalEngine()
    names = bundle.names
    reference = cfg.solve.reference or names[0]
    if reference not in names:
        raise InputError(f"--reference {reference!r} is not a video of the bundle; known: {names}")
    cfg.offset_grid(names)  # a window of no video: refused before any work
    timings: dict[str, float] = {}
    sink.bundle(bundle)
    t0 = time.perf_counter()
    has = {k for k, v in bundle.pairs.items() if len(v.index)}
    chosen = select_pairs(names, has, cfg.pairs, bundle.cameras)
    lands: list[PairLandscape] = []
    pose_free_pairs = [(a, b) for a, b in chosen if is_pose_free_pair(bundle, a, b)]
    given = dict(pose_free or {})
    pose_free = {**{k: given[k] for k in pose_free_pairs if k in given},
                 **estimate_pose_free_pairs(bundle, [k for k in pose_free_pairs if k not in given], cfg, progress,
                                            engine)}
    for (a, b), pf in list(pose_free.items()):
        if isinstance(pf, TaskFailed):  # its worker died: the pair counts as not evaluated
            log.warning("%s__%s: %s", a, b, pf.reason)
            sink.stage_event("landscapes", f"{a}__{b}: not evaluated: {pf.reason}")
            chosen = [k for k in chosen if k != (a, b)]
    task_cfg = _fixed_threads(cfg)
    items = [(a, b, pose_free.get((a, b)), (a, b) in pose_free) for a, b in chosen]
    for (a, b), land in zip(chosen, engine.map(_pair_task, items, shared=(bundle, task_cfg),
                                                desc="pair landscapes", unit="pair", progress=progress)):
        if isinstance(land, TaskFailed):  # its worker died: the pair counts as not evaluated
            log.warning("%s__%s: %s", a, b, land.reason)
            sink.stage_event("landscapes", f"{a}__{b}: not evaluated: {land.reason}")
            continue
        lands.append(land)
    if cfg.sightings.enabled and bundle.heads:
        lands = _with_sightings(bundle, lands, cfg, sink)
    for land in lands:
        log.info("%s__%s: %s Δ=%+.4f s (%s)", land.a, land.b, "accepted" if land.decision.accepted else
                 "rejected", land.best_offset_s, land.decision.reason)
        sink.pair_landscape(land, None if sink.options is None else
                            pair_record_view(bundle, land, sink.options, sink.image_frames(land.a)))
    timings["stage1_s"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    chain = cfg.sightings.max_chain
    result = (solve_stage2_drift(bundle, lands, cfg.solve, cfg.drift, chain) if cfg.drift.enabled else
              solve_stage2(bundle, lands, cfg.solve, chain))
    timings["stage2_s"] = time.perf_counter() - t1
    result = dataclasses.replace(result, timings_s=timings)
    sink.sync_result(result, None if sink.options is None else
                     run_record_view(bundle, result, sink.options))
    return result


def _with_sightings(bundle: CueBundle, lands: list[PairLandscape], cfg: SyncConfig,
                    sink: Sink) -> list[PairLandscape]:
    """lands, where a worn camera's sightings (sync/sightings.py) time a pair whose track pairs gave
    no accepted offset: an accepted sighting landscape takes the pair's place (its reason says
    what the track pairs gave); a rejected one is kept for a pair that had no landscape, and
    otherwise adds its reason to the pair's."""
    out = list(lands)
    names = bundle.names
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            mine = [k for k, p in enumerate(out) if {p.a, p.b} == {a, b}]
            if any(out[k].decision.accepted for k in mine):
                continue
            land = sighting_pair(bundle, a, b, cfg)
            if land is None:
                continue
            if mine and land.decision.accepted:
                land = dataclasses.replace(land, decision=dataclasses.replace(
                    land.decision, reason=f"{land.decision.reason}; its track pairs: {out[mine[0]].decision.reason}"))
                out[mine[0]] = land
            elif not mine:
                out.append(land)
            else:  # both refused: the pair's reason gives both
                old = out[mine[0]]
                out[mine[0]] = dataclasses.replace(old, decision=dataclasses.replace(
                    old.decision, reason=f"{old.decision.reason}; {land.decision.reason}"))
    return out


def _long_sighting_chains(lands, reference: str, max_chain: int) -> dict[str, str]:
    """{video: why} for the videos whose offset would rest on more than max_chain worn-camera
    sighting pairs in a chain from the reference."""
    return {v: _with_its_pairs(lands, v, (
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


def _with_its_pairs(lands, v: str, why: str) -> str:
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

    reasons = {v: _with_its_pairs(lands, v, why) for v, why in out.unresolved_reason.items()}
    offsets, unc = dict(out.offsets_s), dict(out.uncertainty_s)
    for v, why in _long_sighting_chains(lands, reference, max_sighting_chain).items():
        if offsets.get(v) is not None:
            offsets[v], unc[v], reasons[v] = None, None, why
    if len(names) > 1 and not any(wanted in (m.a, m.b) for m in meas):
        # its 0.0 is a definition, not a measurement: with no accepted pair it says nothing
        offsets[wanted], unc[wanted] = None, None
        reasons[wanted] = _with_its_pairs(lands, wanted, _unlinked_reference(wanted, reference))
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
            reasons[v] = _with_its_pairs(lands, v, "no chain of accepted pairs links it to the reference "
                                         + reference)
    for v, why in _long_sighting_chains(lands, reference, max_sighting_chain).items():
        if offsets.get(v) is not None:
            offsets[v] = unc[v] = drift[v] = drift_std[v] = None
            reasons[v] = why
    if len(names) > 1 and not any(wanted in (t.a, t.b) for t in timings):
        offsets[wanted] = unc[wanted] = drift[wanted] = drift_std[wanted] = None
        reasons[wanted] = _with_its_pairs(lands, wanted, _unlinked_reference(wanted, reference))
    used = tuple((t.a, t.b) for t in timings if (t.a, t.b) in sol.pair_residuals)
    res = np.array([sol.pair_residuals[p][0] for p in used])
    weight = np.array([sol.pair_weights[p] for p in used])
    return SyncResult(reference, offsets, unc, reasons, tuple(lands), used,
                      (SolveIteration(res, weight),) if len(res) else (), "drift-huber",
                      drift_ppm=drift, drift_std_ppm=drift_std)
