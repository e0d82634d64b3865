"""A whole run: videos (or a cue bundle) in, one RunResult out.

    from vs_inspect.pipeline import run
    result = run(["cam0.mp4", "cam1.mp4", "cam2.mp4"], calibration="calibration.json")
    print(result.offsets_s)

The run writes no file except, when asked (bundle_out), the cue bundle that Stage 0 extracted;
result.json is io.result.write_run_result(result, folder).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence

from .. import signals
from ..engine import Engine, open_engine
from ..errors import InputError, NoUsableVideos
from ..record.sink import NullSink, Sink
from ..sync.config import SyncConfig
from ..cue_stats import CueStats
from ..result_types import RunInputs, RunResult, SyncResult
from ..types import CueBundle
from .config import RunConfig
from .reasons import plain_reason, with_plain_reason
from .stage0 import run_stage0
from .stage12 import sync_bundle

PathLike = str | os.PathLike


def run(inputs: CueBundle | PathLike | Sequence[PathLike], config: RunConfig = RunConfig(),
        sink: Sink | None = None, *, calibration: PathLike | None = None, fps: float | None = None,
        bundle_out: PathLike | None = None, progress: bool = True,
        recorded_inputs: RunInputs | None = None, engine: Engine | None = None,
        truth_offsets_s: dict[str, float] | None = None) -> RunResult:
    """Synchronize: one offset per input video (None with the reason when it has none).

    inputs: a cue bundle (CueBundle, or the path of its folder) for Stage 1 + 2, or a list of
    video files / image folders for Stage 0 + 1 + 2. calibration, fps: Stage 0's camera
    calibration file and the frame rate of image folders (videos only). bundle_out: write the
    extracted cue bundle there (replacing it; videos only). sink: receives every stage's
    results and, last, sink.run_summary(result). recorded_inputs: what result.json's "input"
    says (default: the paths given).

    truth_offsets_s: the true offsets when known (--gt): the bundle's (and the written cue
    bundle's) truth, so that the recording draws the true Δ of every pair and the result keeps it;
    it replaces a bundle's own gt.json.

    config.engine says where Stage 0's per-video and Stage 1's per-pair work runs (this process,
    or Ray tasks); Stage 2, the sink and the result are the driver's, the same either way.
    engine: an engine already open (it is left open), instead of opening config.engine's.

    Never stops because Stage 0 could not use a video: such videos (even all of them, even the
    reference) get None and the reason, and when the reference is one of them another video
    with cues takes its place (said in its reason).
    """
    if engine is not None:
        return _run(inputs, config, sink or NullSink(), engine, calibration, fps, bundle_out, progress,
                    recorded_inputs, truth_offsets_s)
    with open_engine(config.engine) as opened:
        return _run(inputs, config, sink or NullSink(), opened, calibration, fps, bundle_out, progress,
                    recorded_inputs, truth_offsets_s)


def _run(inputs, config: RunConfig, sink: Sink, engine: Engine, calibration, fps, bundle_out,
         progress: bool, recorded_inputs: RunInputs | None, truth_offsets_s: dict[str, float] | None
         ) -> RunResult:
    t0 = time.perf_counter()
    if isinstance(inputs, CueBundle) or isinstance(inputs, (str, os.PathLike)):
        if calibration is not None or fps is not None or bundle_out is not None:
            raise InputError("calibration, fps and bundle_out apply to videos, not to a cue bundle")
        bundle, stats, videos = _with_truth(_read_bundle(inputs), truth_offsets_s), None, {}
        where = RunInputs(bundle=str(inputs)) if not isinstance(inputs, CueBundle) else RunInputs()
        stage0_timings: dict[str, float] = {}
    else:
        try:
            bundle, stats, videos = run_stage0(list(inputs), calibration, fps, config.cues, sink=sink,
                                               progress=progress, engine=engine, sync=config.sync)
        except NoUsableVideos as exc:  # nothing to synchronize, but every video gets its reason
            result = _nothing_usable(exc, config, RunInputs(videos=exc.inputs, fps=fps),
                                     recorded_inputs, time.perf_counter() - t0)
            sink.run_summary(result)
            return result
        bundle = _with_truth(bundle, truth_offsets_s)
        signals.checkpoint()  # between stages
        if bundle_out is not None:
            from ..io.bundle import write_bundle
            write_bundle(bundle, bundle_out, overwrite=True)
        where = RunInputs(bundle=str(bundle_out) if bundle_out is not None else None,
                          videos=videos, fps=fps)
        stage0_timings = {f"stage0_{k}": v for k, v in stats.timings_s.items()}
        stage0_timings["stage0_with_io_s"] = time.perf_counter() - t0
    signals.checkpoint()  # between stages
    sync_cfg, moved = _usable_reference(config.sync, bundle, stats, list(videos))
    sync_cfg = _windows_of(sync_cfg, bundle)
    sync = sync_bundle(bundle, sync_cfg, sink=sink, progress=progress, engine=engine)
    timings = {**stage0_timings, **sync.timings_s, "total_s": time.perf_counter() - t0}
    result = _run_result(sync, stats, recorded_inputs or where, config, bundle.gt_offsets_s or None,
                         timings, moved)
    if sync.drift_ppm is not None or bundle.gt_drift_ppm is not None:
        result = dataclasses.replace(result, gt_drift_ppm=bundle.gt_drift_ppm, **_drift_of(sync, stats))
    signals.checkpoint()
    sink.run_summary(result)
    return result


def _with_truth(bundle: CueBundle, truth_offsets_s: dict[str, float] | None) -> CueBundle:
    """The bundle with the given true offsets of its videos (unchanged without any)."""
    if not truth_offsets_s:
        return bundle
    known = {n: float(truth_offsets_s[n]) for n in bundle.names if n in truth_offsets_s}
    return dataclasses.replace(bundle, gt_offsets_s=known or None)


def _read_bundle(inputs: CueBundle | PathLike) -> CueBundle:
    if isinstance(inputs, CueBundle):
        return inputs
    from ..io.bundle import read_bundle
    return read_bundle(inputs)


def _usable_reference(cfg: SyncConfig, bundle: CueBundle, stats: CueStats | None,
                      inputs: list[str]) -> tuple[SyncConfig, str | None]:
    """(settings of Stage 1 + 2, the wanted reference when Stage 0 left it out, else None).

    The wanted reference is --reference or the first input video. When Stage 0 left it out (no
    camera, unreadable), the first video of the bundle takes its place, so that the videos that
    do have cues are still synchronized.
    """
    wanted = cfg.solve.reference or (inputs[0] if inputs else bundle.names[0])
    if stats is None or wanted in bundle.names or wanted not in stats.dropped:
        return cfg, None
    return dataclasses.replace(cfg, solve=dataclasses.replace(cfg.solve, reference=bundle.names[0])), wanted


def _windows_of(cfg: SyncConfig, bundle: CueBundle) -> SyncConfig:
    """cfg without the --around windows of videos Stage 0 left out (they have no pairs to limit;
    a window of a name no input had was refused before Stage 0)."""
    around = {n: w for n, w in cfg.landscape.around.items() if n in bundle.names}
    if around == cfg.landscape.around:
        return cfg
    return dataclasses.replace(cfg, landscape=dataclasses.replace(cfg.landscape, around=around))


def _nothing_usable(exc: NoUsableVideos, config: RunConfig, where: RunInputs,
                    recorded_inputs: RunInputs | None, elapsed_s: float) -> RunResult:
    """The RunResult when Stage 0 could use no video: every offset None, each with its reason."""
    names = list(exc.inputs) or list(exc.stats.dropped)
    reference = config.sync.solve.reference or names[0]
    if reference not in names:
        raise InputError(f"--reference {reference!r} is not one of the videos; known: {names}")
    unresolved = {n: exc.stats.dropped.get(n, "Stage 0 could not use this video") for n in names}
    unresolved[reference] += "; no video could be used, so even the reference has no offset"
    headlines = {n: plain_reason(n, why, exc.stats) for n, why in unresolved.items()}
    unresolved = {n: with_plain_reason(headlines[n], why) for n, why in unresolved.items()}
    timings = {f"stage0_{k}": v for k, v in exc.stats.timings_s.items()}
    timings["stage0_with_io_s"] = elapsed_s
    timings["total_s"] = elapsed_s
    return RunResult(reference, {n: None for n in names}, {n: None for n in names}, unresolved, (),
                     config.sync.solve.solver, (), (), timings, recorded_inputs or where,
                     config.to_dict(), exc.stats, None, unresolved_headline=headlines)


def _drift_of(sync: SyncResult, stats: CueStats | None) -> dict:
    """RunResult's drift fields of the drift model's SyncResult (None for videos Stage 0 left out)."""
    if sync.drift_ppm is None:
        return {}
    drift, std = dict(sync.drift_ppm), dict(sync.drift_std_ppm or {})
    for name in (stats.dropped if stats is not None else {}):
        drift[name] = std[name] = None
    return {"drift_ppm": drift, "drift_std_ppm": std}


def _run_result(sync: SyncResult, stats: CueStats | None, inputs: RunInputs, config: RunConfig,
                gt_offsets_s: dict[str, float] | None, timings_s: dict[str, float],
                moved_reference: str | None = None) -> RunResult:
    """The RunResult of Stage 1 + 2's SyncResult; videos Stage 0 left out get None and the reason
    (moved_reference: the wanted reference that Stage 0 left out, see _usable_reference)."""
    offsets, unc, unresolved = dict(sync.offsets_s), dict(sync.uncertainty_s), dict(sync.unresolved_reason)
    for name, why in (stats.dropped if stats is not None else {}).items():
        offsets[name] = None
        unc[name] = None
        unresolved[name] = why
    # in the user's terms: what was missing and what to try (the technical account follows it)
    headlines = {n: plain_reason(n, why, stats, sync.pairs) for n, why in unresolved.items()}
    for name in unresolved:  # its pairs say "no/too few track pairs"; Stage 0 may know why
        why = stats.geometric_refusal(name) if stats is not None else None
        if why:
            unresolved[name] = f"{why}; {unresolved[name]}"
        others = stats.other_models_note(name) if stats is not None and name not in stats.dropped else None
        if others:
            unresolved[name] += f" (other camera models tried: {others})"
    if moved_reference is not None:
        unresolved[moved_reference] += (f"; it cannot be the reference, so {sync.reference} is the "
                                         "reference instead")
    unresolved = {n: with_plain_reason(headlines[n], why) for n, why in unresolved.items()}
    return RunResult(sync.reference, offsets, unc, unresolved, sync.pairs, sync.solver,
                     sync.solve_pairs, sync.iterations, timings_s, inputs, config.to_dict(), stats,
                     dict(gt_offsets_s) if gt_offsets_s else None, unresolved_headline=headlines)
