"""The accuracy benchmark: vs_inspect, its ablations (the paper's Tables 2 and 3) and two
classical peers on the same data in the same run, with the paper's metrics, time per stage and
peak memory.

A run is a list of dataset plans; each plan produces rows keyed by (dataset, method, variant).
Every row is a pure function of its dataset and settings (fixed seeds), so a quick run's rows
equal the same rows of a full run. Failures become rows with an error, never dropped.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
import tracemalloc
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..baselines.motion_xcorr import sync_motion_xcorr
from ..baselines.ransac_inlier import sync_ransac_inlier
from ..eval.metrics import evaluate_offsets, pair_auc
from ..geometry.epipolar import RESIDUALS
from ..sync.config import DecisionConfig, LandscapeConfig, PairSelection, SolveConfig, SyncConfig
from ..sync.decision import decide
from ..sync.pairs import select_pairs
from ..pipeline.stage12 import solve_stage2, sync_bundle
from ..sync.sightings import RESIDUAL as SIGHTING
from ..pipeline.config import RunConfig
from ..result_types import PairLandscape, RunResult
from .datasets import BenchData
from .videos import VideoSet

log = logging.getLogger(__name__)

PAIR_MODES = ("rst", "0.5", "0.8")  # 1.0 = all pairs = the default run


@dataclass(frozen=True)
class Row:
    """One method/variant on one dataset."""

    dataset: str  # e.g. "cue/default/s0"
    group: str  # e.g. "cue/default"
    method: str  # vs_inspect | motion-xcorr | ransac-inlier
    variant: str  # "default", "residual=cosine", "solver=ls", "filter=off", "pairs=rst/seed=2", ...
    a100: float  # %
    a500: float  # %
    delta_mean_ms: float
    delta_med_ms: float
    delta_med_frames: float  # δ_med in frames of the dataset's typical frame interval
    unresolved: int  # videos without an offset (their pairs count as wrong in A@)
    videos: int
    stage0_s: float = float("nan")  # cue extraction (video datasets only)
    stage1_s: float = float("nan")  # pair landscapes / pair scores (NaN = reused from the default run)
    stage2_s: float = float("nan")  # global solve
    peak_mb: float = float("nan")  # peak traced Python/numpy memory of the run (tracemalloc)
    error: str = ""  # the failure, when the run failed

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.dataset, self.method, self.variant)

    def accuracy(self) -> tuple:
        """The numbers that must be identical between runs (no timings)."""
        return (self.a100, self.a500, self.delta_mean_ms, self.delta_med_ms, self.unresolved, self.error)


@dataclass(frozen=True)
class PlanOptions:
    residuals: tuple[str, ...] = RESIDUALS  # residual ablation (sampson is the default run)
    true_cameras: bool = True  # also run with the exact cameras when the dataset has them
    pair_seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    peers: bool = True


@dataclass
class Meter:
    """Wall time and peak traced memory of a block."""

    seconds: float = 0.0
    peak_mb: float = float("nan")
    _t: float = field(default=0.0, repr=False)

    def __enter__(self) -> Meter:
        tracemalloc.start()
        self._t = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.seconds = time.perf_counter() - self._t
        self.peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()


def _fix(x: float) -> float:
    return float(x) if x is not None and math.isfinite(x) else float("nan")


def score(data: BenchData, offsets_s: dict, method: str, variant: str, **extra) -> Row:
    if data.bundle is not None:
        truth, ref = data.bundle.gt_offsets_s, data.bundle.names[0]
    else:  # Stage 0 failed: only methods that need no cue bundle have a result
        truth = data.notes["truth"]
        ref = next(iter(truth))
    est = {v: offsets_s.get(v) for v in truth}  # a video missing from the result is unresolved
    m = evaluate_offsets(est, truth, ref)
    fi = data.frame_interval_s
    return Row(data.name, data.group, method, variant, round(m.a100, 6), round(m.a500, 6),
               round(_fix(m.delta_mean_ms), 6), round(_fix(m.delta_med_ms), 6),
               round(_fix(m.delta_med_ms) / (1000.0 * fi), 4) if math.isfinite(fi) else float("nan"),
               m.num_unresolved, len(truth), **extra)


def stage0_failed(data: BenchData, error: str, stage0_s: float) -> list[Row]:
    """Stage 0 gave no cue bundle: vs_inspect and the RANSAC peer (which needs the tracks and
    track pairs) fail with it; the motion peer runs on the decoded frames alone."""
    from ..baselines.motion_xcorr import sync_motion_xcorr_videos

    rows = [failed(data, m, "default", error, stage0_s=stage0_s) for m in ("vs_inspect", "ransac-inlier")]
    try:
        with Meter() as m:
            pr = sync_motion_xcorr_videos(list(data.notes["videos_info"]), data.notes["motion_signals"])
        rows.insert(1, score(data, pr.offsets_s, "motion-xcorr", "default", stage1_s=pr.timings_s["stage1_s"],
                             stage2_s=pr.timings_s["stage2_s"], peak_mb=m.peak_mb))
    except Exception as exc:  # noqa: BLE001
        rows.insert(1, failed(data, "motion-xcorr", "default", _text(exc)))
    return rows


def _text(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def failed(data: BenchData, method: str, variant: str, error: str, **extra) -> Row:
    if data.bundle is not None:
        n = len(data.bundle.gt_offsets_s)
    else:
        n = len(data.notes["truth"]) if "truth" in data.notes else int(data.notes.get("videos", 0))
    log.warning("%s %s %s failed: %s", data.name, method, variant, error)
    return Row(data.name, data.group, method, variant, 0.0, 0.0, float("nan"), float("nan"),
               float("nan"), n, n, error=error[:200], **extra)


def frame_motion_signal(src, max_side: int = 320) -> tuple[np.ndarray, np.ndarray]:
    """Mean absolute grey-level difference of consecutive frames per second (the motion peer on video)."""
    import cv2

    from ..baselines.motion_xcorr import motion_signal_from_frames
    from ..io.video import iter_frames

    frames = (cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) for _, img in iter_frames(src, max_side=max_side))
    return motion_signal_from_frames(frames, src.info.timestamps_s)


def run_videos(vs: VideoSet, name: str, group: str, opts: PlanOptions) -> list[Row]:
    """A video dataset: the motion peer's signals from the decoded frames, then the videos through
    pipeline.run as `vs-inspect sync` runs them (its result is the default row), then the
    ablations and the RANSAC peer on the cue bundle that run wrote (the truth kept for every
    input video, so that a video Stage 0 left out counts as unresolved everywhere)."""
    import tempfile

    from ..io.bundle import read_bundle
    from ..io.calibration import load_calibration, to_camera_track
    from ..io.video import open_video
    from .videos import run_set

    srcs = [open_video(p) for p in vs.videos]
    notes = {"motion_signals": {s.info.name: frame_motion_signal(s) for s in srcs}, "truth": vs.truth_s,
             "videos_info": [s.info for s in srcs], "videos": len(srcs)}
    frame_s = 1.0 / float(np.median(list(vs.fps.values())))
    with tempfile.TemporaryDirectory(prefix="vs_bench_run_") as tmp:
        run = run_set(vs, RunConfig(), Path(tmp))
        cues = run.folder / "cues"
        bundle = read_bundle(cues) if (cues / "bundle.json").is_file() else None
    res, stage0_s = run.result, run.result.timings_s["stage0_with_io_s"]
    if bundle is None:
        data = BenchData(name, group, None, None, frame_s, notes)
        return stage0_failed(data, f"NoUsableVideos: {res.headlines().get(res.reference, 'no video could be used')}",
                             stage0_s)
    exact = None
    if vs.true_cameras is not None:
        exact = {n: to_camera_track(c) for n, c in load_calibration(vs.true_cameras, bundle.names).items()}
    data = BenchData(name, group, dataclasses.replace(bundle, gt_offsets_s=dict(vs.truth_s)), exact,
                     frame_s, notes)
    return run_dataset(data, opts, stage0_s=stage0_s, default=res)


# ---- Stage 2 from given landscapes (ablations that keep Stage 1: pipeline.solve_stage2) --------


def without_filter(lands: list[PairLandscape]) -> list[PairLandscape]:
    """The same landscapes decided with the spurious-pair filter off (best minimum unchanged); a
    worn-camera sighting pair keeps its own decision (the filter is the epipolar landscapes')."""
    off = DecisionConfig(enabled=False)
    out = []
    for land in lands:
        if land.residual == SIGHTING:
            out.append(land)
            continue
        d, _ = decide(land.energy, land.support, land.offsets_s, land.num_track_pairs, off)
        out.append(dataclasses.replace(land, decision=d))
    return out


def stage1_pairwise(data: BenchData, lands: list[PairLandscape]) -> tuple[float, float]:
    """A@100, A@500 of the Stage 1 pair offsets themselves (every pair of videos; a pair without a
    minimum counts as wrong), before the global solve."""
    truth = data.bundle.gt_offsets_s
    by = {(p.a, p.b): p.best_offset_s for p in lands}
    names = list(truth)
    err = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            d = by.get((a, b), float("nan"))
            err.append(1000 * abs(d - (truth[b] - truth[a])) if math.isfinite(d) else math.inf)
    e = np.array(err)
    return round(pair_auc(e, 100.0), 6), round(pair_auc(e, 500.0), 6)


# ---- one dataset ------------------------------------------------------------------------------


def run_dataset(data: BenchData, opts: PlanOptions, stage0_s: float = float("nan"),
                default: RunResult | None = None) -> list[Row]:
    """Every method and variant on one dataset's cue bundle; default: the result of the run that
    made the bundle from videos (else Stage 1 + 2 on the bundle are the default run)."""
    rows: list[Row] = []
    bundle, lands = data.bundle, None
    try:
        res, peak_mb = default, float("nan")  # a video run's memory is not traced (it would slow Stage 0)
        if res is None:
            with Meter() as m:
                res = sync_bundle(bundle, SyncConfig(), progress=False)
            peak_mb = m.peak_mb
        rows.append(score(data, res.offsets_s, "vs_inspect", "default", stage0_s=stage0_s,
                          stage1_s=res.timings_s["stage1_s"], stage2_s=res.timings_s["stage2_s"],
                          peak_mb=peak_mb))
        lands = list(res.pairs)
    except Exception as exc:  # noqa: BLE001  (a failure is a result)
        rows.append(failed(data, "vs_inspect", "default", _text(exc), stage0_s=stage0_s))
    if lands is not None:
        rows += stage2_ablations(data, lands, opts.pair_seeds)
    # Stage 1 ablations: other residuals, exact cameras
    for r in opts.residuals:
        if r != SyncConfig().landscape.residual:
            rows.append(_variant(data, f"residual={r}", bundle, SyncConfig(landscape=LandscapeConfig(residual=r))))
    if opts.true_cameras and data.true_cameras is not None:
        rows.append(_variant(data, "cameras=true", dataclasses.replace(bundle, cameras=dict(data.true_cameras)),
                             SyncConfig()))
    if opts.peers:
        rows += _peers(data, stage0_s)
    return rows


def stage2_ablations(data: BenchData, lands: list[PairLandscape], pair_seeds: tuple[int, ...]) -> list[Row]:
    """The Stage 2 ablations on the default run's landscapes: least squares, the spurious-pair
    filter off, Stage 1 alone, and fewer pairs (PAIR_MODES, each with every pair seed)."""
    bundle = data.bundle
    rows = []
    for variant, chosen, cfg in (("solver=ls", lands, SolveConfig(solver="ls")),
                                 ("filter=off", without_filter(lands), SolveConfig())):
        t = time.perf_counter()
        rows.append(score(data, solve_stage2(bundle, chosen, cfg).offsets_s, "vs_inspect", variant,
                          stage2_s=time.perf_counter() - t))
    a100, a500 = stage1_pairwise(data, lands)
    rows.append(Row(data.name, data.group, "vs_inspect", "stage1-only", a100, a500, float("nan"),
                    float("nan"), float("nan"), 0, len(bundle.gt_offsets_s)))
    # candidates: the pairs with track pairs, and those a worn-camera sighting timed
    has = {k for k, v in bundle.pairs.items() if len(v.index)} | {(p.a, p.b) for p in lands
                                                                   if p.residual == SIGHTING}
    by = {(p.a, p.b): p for p in lands}
    for mode in PAIR_MODES:
        for seed in pair_seeds:
            chosen = select_pairs(bundle.names, has, PairSelection.parse(mode, seed))
            t = time.perf_counter()
            offs = solve_stage2(bundle, [by[p] for p in chosen], SolveConfig()).offsets_s
            rows.append(score(data, offs, "vs_inspect", f"pairs={mode}/seed={seed}",
                              stage2_s=time.perf_counter() - t))
    return rows


def _variant(data: BenchData, variant: str, bundle, cfg: SyncConfig) -> Row:
    """Stage 1 + 2 again on a bundle with other settings (timed, memory traced)."""
    try:
        with Meter() as m:
            res = sync_bundle(bundle, cfg, progress=False)
        return score(data, res.offsets_s, "vs_inspect", variant, stage1_s=res.timings_s["stage1_s"],
                     stage2_s=res.timings_s["stage2_s"], peak_mb=m.peak_mb)
    except Exception as exc:  # noqa: BLE001
        return failed(data, "vs_inspect", variant, _text(exc))


def _peers(data: BenchData, stage0_s: float) -> list[Row]:
    """The two classical peers on the dataset (the motion peer on every decoded video when there
    are videos, also those Stage 0 left out of the bundle: it needs no cameras)."""
    bundle = data.bundle
    signals, every_video = data.notes.get("motion_signals"), data.notes.get("videos_info")

    def motion():
        if every_video is not None:
            from ..baselines.motion_xcorr import sync_motion_xcorr_videos
            return sync_motion_xcorr_videos(list(every_video), signals, reference=bundle.names[0])
        return sync_motion_xcorr(bundle, signals=signals)

    rows = []
    for method, fn in (("motion-xcorr", motion), ("ransac-inlier", lambda: sync_ransac_inlier(bundle))):
        try:
            with Meter() as m:
                pr = fn()
            rows.append(score(data, pr.offsets_s, method, "default", stage0_s=stage0_s,
                              stage1_s=pr.timings_s["stage1_s"], stage2_s=pr.timings_s["stage2_s"],
                              peak_mb=m.peak_mb))
        except Exception as exc:  # noqa: BLE001
            rows.append(failed(data, method, "default", _text(exc), stage0_s=stage0_s))
    return rows
