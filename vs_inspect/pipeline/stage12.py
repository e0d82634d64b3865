"""Stage 1 over the selected pairs, then Stage 2: a cue bundle in, a SyncResult out. This module
only sequences the steps of sync/ (pairs chosen, pose-free pairs estimated, each pair's landscape
on the engine, worn-camera sightings, the global solve) and reports them to the sink.
"""

from __future__ import annotations

import dataclasses
import logging
import time

from ..analysis.record_views import pair_record_view, run_record_view
from ..engine import Engine, LocalEngine, TaskFailed
from ..errors import InputError
from ..memo import NO_MEMO, Memo, digest
from ..record.sink import NullSink, Sink
from ..sync.config import SyncConfig
from ..sync.pair import is_pose_free_pair, pair_landscape, pose_free_job
from ..sync.pairs import select_pairs
from ..sync.posefree import PoseFreePair, estimate_pair
from ..sync.sightings import with_sightings
from ..sync.stage2 import solve_stage2, solve_stage2_drift
from ..result_types import PairLandscape, SyncResult
from ..types import CueBundle

log = logging.getLogger(__name__)

__all__ = ["estimate_pose_free_pairs", "pair_landscape", "solve_stage2", "solve_stage2_drift", "sync_bundle"]


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
                engine: Engine | None = None, memo: Memo = NO_MEMO) -> SyncResult:
    """Stage 1 over the pairs that cfg.pairs selects, then Stage 2, reported to the sink.

    pose_free: estimates of pose-free pairs made earlier (estimate_pose_free_pairs; e.g. the drift
    model's, reused by the benchmark's constant-offset ablation); the others are estimated here.
    engine: where the pairs' landscapes are computed (default: in this process); Stage 2 and
    everything reported to the sink stay here, in pair order, whatever the engine. memo: where
    the pairs' landscapes are kept (default: nowhere)."""
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
    keys = ["pair-" + digest(item, [(bundle.video(n), bundle.cameras[n], bundle.tracks[n]) for n in item[:2]],
                             bundle.pair(item[0], item[1]), task_cfg) for item in items]
    todo = [i for i, k in enumerate(keys) if not memo.has(k)]
    done = dict(zip(todo, engine.map(_pair_task, [items[i] for i in todo], shared=(bundle, task_cfg),
                                     desc="pair landscapes", unit="pair", progress=progress)))
    for i, (a, b) in enumerate(chosen):
        land = done[i] if isinstance(done.get(i), TaskFailed) else memo.get(keys[i], lambda: done[i])
        if isinstance(land, TaskFailed):  # its worker died: the pair counts as not evaluated
            log.warning("%s__%s: %s", a, b, land.reason)
            sink.stage_event("landscapes", f"{a}__{b}: not evaluated: {land.reason}")
            continue
        lands.append(land)
    if cfg.sightings.enabled and bundle.heads:
        lands = with_sightings(bundle, lands, cfg)
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


