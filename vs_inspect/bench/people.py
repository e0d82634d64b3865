"""The people cue on real videos, cues to offsets (vs-inspect bench people).

Per scene: the people cue alone (cues/people_cue.find_people_cameras: people, pairs, cameras; no
background cameras), then Stage 1 + 2 (pipeline.stage12.sync_bundle) on the cue's bundle: its
cameras, the landmarks as tracks and the cross-view landmark pairs. Errors per video against the
truth, in frames of that video and in ms; the reason of every null; the seconds of the people
step and of the whole run; the machine's load (the benchmark shares its cores).

Truth: VisualSync clip <scene>_<cam>_<start>_<end>_<k>.mp4 shows common-timeline frames start,
start+1, ... at 10 fps, so offset_s = start / 10 (against the reference clip). caliscope: each
camera cut by a number of leading frames (seeded), re-encoded at its nominal 6 fps; the true
start is the recorded frame time of its first kept frame (bench/stage0.py's convention).

The paper's numbers beside them are its per-dataset video synchronization errors (Table 1, mean
and median over each dataset's scenes, ms) and, for fencing, its per-scene median (the appendix
table of camera pose error against synchronization accuracy); it gives no per-scene number for
the other clips, and none for caliscope (not in the paper).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cues.people_cue import PeopleCueConfig, find_people_cameras
from ..geometry.offsets import OffsetGrid
from ..types import PeopleCue

CLIPS = "visualsync_clips"
CALISCOPE = "caliscope_post_optimization"
SCENES = ("pan160906", "fencing1", "blenderbox", "sequence69", "caliscope")

# VisualSync (paper) Table 1, video synchronization, (mean, median) ms per dataset; the appendix
# table "Camera pose error vs. synchronization accuracy" gives Fencing's median: 9.6 ms
PAPER = {
    "pan160906": "CMU Panoptic: mean 112.6, median 41.5 ms (Table 1)",
    "fencing1": "EgoHumans: mean 122.1, median 46.6 ms (Table 1); Fencing median 9.6 ms (appendix)",
    "sequence69": "3D-POP: mean 114.7, median 77.8 ms (Table 1)",
    "blenderbox": "UDBD: mean 20.2, median 5.9 ms (Table 1)",
    "caliscope": "not in the paper",
}


@dataclass(frozen=True)
class VideoRow:
    scene: str
    video: str
    true_offset_s: float
    cue_offset_s: float | None  # the people cue's own offset (from its pair shifts)
    offset_s: float | None  # after Stage 1 + 2 on the cue's bundle
    frame_s: float  # the video's frame length, s
    reason: str | None  # why null

    @property
    def error_s(self) -> float | None:
        return None if self.offset_s is None else self.offset_s - self.true_offset_s

    @property
    def error_frames(self) -> float | None:
        e = self.error_s
        return None if e is None else e / self.frame_s


@dataclass(frozen=True)
class SceneRun:
    scene: str
    rows: tuple[VideoRow, ...]
    people_s: float  # the people step (finding and following people in every video)
    cue_s: float  # the whole people cue (people, pairs, cameras)
    total_s: float  # cue + Stage 1 + 2
    load: tuple[float, float]  # 1-minute load average at the start and the end
    pairs: tuple[str, ...]  # each pair's verdict, one line
    cue: PeopleCue | None = field(default=None, repr=False)


def visualsync_truth(paths) -> dict[str, float]:
    from .stage0 import visualsync_truth as truth

    return truth(paths)


def _relative(offsets: dict[str, float | None], ref: str, truth: dict[str, float]) -> dict[str, float | None]:
    """Offsets moved so that ref has its true offset (the errors are then per video)."""
    if offsets.get(ref) is None:
        return {v: None for v in offsets}
    return {v: None if o is None else o - offsets[ref] + truth[ref] for v, o in offsets.items()}


def _cached_people(srcs, folder: Path | None):
    """({video: VideoPeople}, {video: background motion px}) saved in folder by an earlier run,
    or None when any is missing."""
    from ..types import VideoPeople

    if folder is None:
        return None
    people, motion = {}, {}
    for s in srcs:
        f = Path(folder) / f"{s.info.name}.npz"
        if not f.is_file():
            return None
        with np.load(f) as z:
            people[s.info.name] = VideoPeople(s.info.name, z["landmarks"], z["times_s"], float(z["min_visibility"]))
            motion[s.info.name] = float(z["background_motion_px"])
    return people, motion


def _save_people(cue: PeopleCue, folder: Path) -> None:
    from ..io.atomic import atomic_path

    Path(folder).mkdir(parents=True, exist_ok=True)
    for n, p in cue.people.items():
        with atomic_path(Path(folder) / f"{n}.npz") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, landmarks=p.landmarks, times_s=p.times_s, min_visibility=p.min_visibility,
                     background_motion_px=cue.background_motion_px.get(n, np.nan))


def run_scene(scene: str, paths: list[Path], truth: dict[str, float], grid: OffsetGrid, config: PeopleCueConfig,
              rrd_folder: Path | None = None, people_folder: Path | None = None) -> SceneRun:
    """The people cue, then Stage 1 + 2, on one scene's videos. people_folder: each video's people
    reused from there when all are (the people step's time is then 0), else saved there."""
    from ..io.video import open_video
    from ..pipeline.stage12 import sync_bundle
    from ..sync.config import LandscapeConfig, SyncConfig

    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    srcs = [open_video(p) for p in paths]
    names = [s.info.name for s in srcs]
    ref = names[0]
    cached = _cached_people(srcs, people_folder)
    if cached is not None:
        from ..cues.people_cue import cameras_from_people, moving_cameras

        people, motion = cached
        cue = cameras_from_people(people, [s.info for s in srcs], grid, config, ref,
                                  failed=moving_cameras(motion, config))
        cue = dataclasses.replace(cue, timings_s={**cue.timings_s, "people": 0.0}, background_motion_px=motion)
    else:
        cue = find_people_cameras(srcs, grid, config, reference=ref)
        if people_folder is not None:
            _save_people(cue, people_folder)
    cue_s = time.perf_counter() - t0
    final: dict[str, float | None] = {n: None for n in names}
    reasons = {n: cue.refused[n] for n in names if n in cue.refused}
    if len(cue.cameras) >= 2:
        bundle = cue.bundle({n: truth[n] for n in names})
        cfg = SyncConfig(landscape=LandscapeConfig(min_overlap_s=grid.min_overlap_s, range_s=grid.range_s))
        sync = sync_bundle(bundle, cfg, progress=False)
        final.update(_relative(dict(sync.offsets_s), sync.reference, truth))
        for n, why in sync.unresolved_reason.items():
            reasons.setdefault(n, f"Stage 1/2: {why}")
    total_s = time.perf_counter() - t0
    cue_rel = _relative({n: cue.offsets_s.get(n) for n in names}, ref, truth)
    infos = {s.info.name: s.info for s in srcs}
    rows = tuple(VideoRow(scene, n, truth[n], cue_rel[n], final[n], infos[n].frame_length_s,
                          None if final[n] is not None else reasons.get(n, "no offset"))
                 for n in names)
    pairs = tuple(f"{p.a} / {p.b}: " + (f"Δ {p.offset_s:+.3f} s (true {truth[p.b] - truth[p.a]:+.3f}), {p.reason}"
                                         if p.accepted else p.reason) for p in cue.pairs)
    if rrd_folder is not None:
        _record(cue, Path(rrd_folder) / f"people-{scene}.rrd")
    return SceneRun(scene, rows, cue.timings_s.get("people", float("nan")), cue_s, total_s,
                    (load0, os.getloadavg()[0]), pairs, cue)


def _record(cue: PeopleCue, path: Path) -> None:
    import rerun as rr

    from ..io.atomic import atomic_path
    from ..record.people import log_people_cue

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        rec = rr.RecordingStream("vs_inspect", recording_id=f"people-{path.stem}")
        rec.save(str(tmp))
        log_people_cue(rec, cue)
        rec.flush()
        rec.disconnect()


def clip_scene_paths(data: Path, scene: str) -> tuple[list[Path], dict[str, float]]:
    paths = sorted((Path(data) / CLIPS / scene).glob("*.mp4"))
    if len(paths) < 2:
        raise FileNotFoundError(f"{Path(data) / CLIPS / scene}: fewer than 2 clips")
    return paths, visualsync_truth(paths)


@contextlib.contextmanager
def caliscope_cut_paths(data: Path, seed: int, max_cut: int = 12):
    """(paths of the four cut videos in a temporary folder, their true starts), cuts drawn from
    seed in [0, max_cut] leading frames."""
    from .datasets import read_caliscope_frame_times
    from .stage0 import caliscope_truth, write_cut

    root = Path(data) / CALISCOPE
    frame_times = read_caliscope_frame_times(root)
    rng = np.random.default_rng(seed)
    cuts = {f"cam_{i}": int(c) for i, c in enumerate(rng.integers(0, max_cut + 1, len(frame_times)))}
    with tempfile.TemporaryDirectory(prefix="vs-inspect-people-") as tmp:
        paths = []
        for name, c in cuts.items():
            p = Path(tmp) / f"{name}.mp4"
            write_cut(root / "calibration" / "extrinsic" / f"{name}.mp4", p, c)
            paths.append(p)
        yield paths, caliscope_truth(frame_times, cuts), cuts


def run_benchmark(data: Path, scenes=SCENES, grid: OffsetGrid = OffsetGrid(min_overlap_s=1.0),
                  config: PeopleCueConfig = PeopleCueConfig(), seed: int = 0, rrd_folder: Path | None = None,
                  people_folder: Path | None = None, log=print) -> list[SceneRun]:
    """Every scene in order; log(line) reports each as it ends."""
    runs = []
    for scene in scenes:
        if scene == "caliscope":
            with caliscope_cut_paths(data, seed) as (paths, truth, cuts):
                log(f"caliscope: leading frames cut {cuts}")
                run = run_scene(scene, paths, truth, grid, config, rrd_folder,
                                None if people_folder is None else Path(people_folder) / f"caliscope-seed{seed}")
        else:
            paths, truth = clip_scene_paths(data, scene)
            run = run_scene(scene, paths, truth, grid, config, rrd_folder, people_folder)
        runs.append(run)
        log(format_scene(run))
    return runs


def _fmt(x: float | None, spec: str) -> str:
    return "null" if x is None else format(x, spec)


def format_scene(run: SceneRun) -> str:
    lines = [f"{run.scene}: people {run.people_s:.1f} s, people cue {run.cue_s:.1f} s, with Stage 1+2 "
             f"{run.total_s:.1f} s (load {run.load[0]:.1f} -> {run.load[1]:.1f} on {os.cpu_count()} cores)"]
    lines += [f"  {p}" for p in run.pairs]
    return "\n".join(lines)


def format_table(runs: list[SceneRun]) -> str:
    """One row per video: truth, the cue's offset, the final one, error in frames and ms, why null."""
    head = ("| scene | video | true offset s | people cue s | Stage 1+2 s | error frames | error ms | null reason |"
            " people step s | whole run s | VisualSync (paper) |")
    out = [head, "| " + " | ".join(["---"] * 11) + " |"]
    for run in runs:
        for i, r in enumerate(run.rows):
            e = r.error_s
            out.append(f"| {run.scene} | {r.video} | {r.true_offset_s:+.3f} | {_fmt(r.cue_offset_s, '+.3f')} | "
                       f"{_fmt(r.offset_s, '+.3f')} | {_fmt(r.error_frames, '+.2f')} | "
                       f"{_fmt(None if e is None else 1000 * e, '+.0f')} | {(r.reason or '').replace('|', '/')[:160]} | "
                       f"{run.people_s:.1f} | {run.total_s:.1f} | {PAPER.get(run.scene, '') if i == 0 else ''} |")
    return "\n".join(out)
