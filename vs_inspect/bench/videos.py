"""Videos with true offsets, run as a user runs them: `vs_inspect.pipeline.run` into a run folder
(result.json and the cue bundle), and nothing read but what that run gives.

Truth:
- VisualSync clips `<scene>_<cam>_<start>_<end>_<k>.mp4` show frames start, start+1, ... of one
  common 10 fps timeline: offset_s = start / 10 (DESIGN.md: the global time of local time 0).
- caliscope: frame k of cam_N.mp4 is row k of that camera in timestamps.csv; a clip cut by c
  leading frames starts at frame_time[c], so offset_s[v] = frame_time_v[c_v] (less the
  reference's). Cut clips are re-encoded at the nominal 6 fps, as a user's cut would be.
- rendered scenes (bench.scenes) carry their exact offsets and cameras.
Errors are counted in frames of the slower of the video and the reference.
"""

from __future__ import annotations

import json
import re
import statistics
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np  # before pycolmap

from ..errors import InputError
from ..io.result import write_run_result
from ..io.video import VideoWriter, iter_frames, open_video
from ..pipeline.config import RunConfig
from ..pipeline.run import run
from ..result_types import RunResult
from .datasets import CALISCOPE, read_caliscope_frame_times

CLIPS = "visualsync_clips"
CLIP_FPS = 10.0
CLIP_SCENES = ("blenderbox", "pan160906", "sequence69", "fencing1")
CALISCOPE_FPS = 6.0  # the webcams' nominal rate
_CLIP = re.compile(r"_(\d+)_(\d+)_(\d+)$")  # <scene>_<cam>_<start>_<end>_<k>
CAMERAS = ("calibration", "estimated", "board")


@dataclass(frozen=True)
class VideoSet:
    """Videos of one scene with their true offsets: one input of a video benchmark."""

    name: str
    videos: tuple[Path, ...]
    truth_s: dict[str, float]  # video name -> true offset_s (DESIGN.md convention), s
    fps: dict[str, float]  # video name -> frame rate, for errors in frames, 1/s
    calibration: Path | None = None  # the cameras given to the run (None: estimated from the videos)
    true_cameras: Path | None = None  # the exact cameras when known (a rendered scene's calibration)


@dataclass(frozen=True)
class SetRun:
    """One run of a VideoSet: its result and each non-reference video's error."""

    videos: VideoSet
    result: RunResult
    folder: Path  # the run folder: result.json and cues/ (the cue bundle; absent when no video was usable)
    errors_s: dict[str, float | None]  # video -> signed error of its offset, s (None: unresolved)
    errors_frames: dict[str, float | None]  # the same in frames of the slower of it and the reference


def clip_truth(paths) -> dict[str, float]:
    """{clip stem: start / 10 s} of VisualSync clips; InputError for a name without frame numbers."""
    out = {}
    for p in map(Path, paths):
        m = _CLIP.search(p.stem)
        if m is None:
            raise InputError(f"{p.name}: not a VisualSync clip name <scene>_<cam>_<start>_<end>_<k>.mp4")
        out[p.stem] = int(m.group(1)) / CLIP_FPS
    return out


def clip_set(data: Path, scene: str) -> VideoSet:
    """The VisualSync clips of one scene (no calibration: cameras estimated)."""
    paths = tuple(sorted((Path(data) / CLIPS / scene).glob("*.mp4")))
    if len(paths) < 2:
        raise InputError(f"{Path(data) / CLIPS / scene}: fewer than 2 clips")
    truth = clip_truth(paths)
    return VideoSet(f"clips/{scene}", paths, truth, dict.fromkeys(truth, CLIP_FPS))


def caliscope_truth(frame_times: dict[str, np.ndarray], cuts: dict[str, int]) -> dict[str, float]:
    """Each cut clip's true start (s, the host clock): frame_times[v][cuts[v]]."""
    return {n: float(frame_times[n][c]) for n, c in cuts.items()}


def write_cut(src_path: Path, dest: Path, first: int) -> None:
    """A video from its frame `first` on, re-encoded at its nominal rate."""
    src = open_video(src_path)
    with VideoWriter(dest, src.info.width, src.info.height, src.info.fps or CALISCOPE_FPS, crf=16) as w:
        for k, img in iter_frames(src):
            if k >= first:
                w.write(img)


def caliscope_sets(data: Path, workdir: Path, trials: int, max_cut: int = 12, seed: int = 0,
                   cameras: str = "calibration") -> Iterator[VideoSet]:
    """caliscope's four webcams, each cut by a random number (0..max_cut, seeded) of leading
    frames, per trial; cameras: the session's calibration, estimated, or from the ChArUco board
    in the cut videos (as `vs-inspect calibrate-board` makes them)."""
    if cameras not in CAMERAS:
        raise InputError(f"unknown cameras {cameras!r}: one of {', '.join(CAMERAS)}")
    root = Path(data) / CALISCOPE
    frame_times = read_caliscope_frame_times(root)
    rng = np.random.default_rng(seed)
    for trial in range(trials):
        cuts = {f"cam_{i}": int(c) for i, c in enumerate(rng.integers(0, max_cut + 1, 4))}
        folder = Path(workdir) / f"caliscope_t{trial}"
        paths = []
        for name, c in cuts.items():
            paths.append(folder / f"{name}.mp4")
            write_cut(root / "calibration" / "extrinsic" / f"{name}.mp4", paths[-1], c)
        calib = root / "camera_array.toml" if cameras == "calibration" else None
        if cameras == "board":
            calib = _board_calibration(paths, root / "charuco.toml", folder / "board_calibration.json")
        yield VideoSet(f"caliscope/t{trial} cuts {'-'.join(map(str, cuts.values()))}", tuple(paths),
                       caliscope_truth(frame_times, cuts), dict.fromkeys(cuts, CALISCOPE_FPS), calib)


def _board_calibration(paths: list[Path], board: Path, out: Path) -> Path:
    from ..io.atomic import write_json_atomic
    from ..io.calibration import rig_to_json
    from ..pipeline.board import estimate_from_board

    rig, _ = estimate_from_board([open_video(p) for p in paths], board, progress=False)
    return write_json_atomic(rig_to_json(rig), out)


def speed_set(data: Path, workdir: Path, seconds: int = 10, calibrated: bool = True) -> VideoSet:
    """caliscope's videos blended up to 30 fps and `seconds` long (720p): a real-video workload.
    No cut: the true offsets are the first frames' host timestamps."""
    import cv2

    root = Path(data) / CALISCOPE
    frame_times = read_caliscope_frame_times(root)
    paths = []
    for i in range(4):
        paths.append(Path(workdir) / f"speed_{seconds}s" / f"cam_{i}.mp4")
        if paths[-1].is_file():
            continue
        src = open_video(root / "calibration" / "extrinsic" / f"cam_{i}.mp4")
        frames = [img for _, img in iter_frames(src)]
        with VideoWriter(paths[-1], src.info.width, src.info.height, 30.0, crf=20) as w:
            for k in range(seconds * 30):
                x = k / 5.0  # 6 fps to 30 fps
                j = min(int(x), len(frames) - 2)
                w.write(cv2.addWeighted(frames[j], 1 - (x - j), frames[j + 1], x - j, 0))
    truth = {f"cam_{i}": float(frame_times[f"cam_{i}"][0]) for i in range(4)}
    return VideoSet(f"speed/{seconds}s 720p 30fps", tuple(paths), truth, dict.fromkeys(truth, 30.0),
                    root / "camera_array.toml" if calibrated else None)


def rendered_set(name: str, workdir: Path, calibrated: bool = True) -> VideoSet:
    """A rendered scene (bench.scenes), rendered into workdir/name unless finished there already."""
    from ..synth.videos import render_unless_cached
    from .scenes import scene_config

    try:
        config = scene_config(name)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    folder = Path(workdir) / name
    render_unless_cached(folder, config, progress=False)
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    fps = {c["name"]: c["fps"] for c in json.loads((folder / "scene.json").read_text())["cameras"]}
    calib = folder / "calibration.json"
    return VideoSet(f"rendered/{name}", tuple(sorted(folder.glob("cam*.mp4"))), truth, fps,
                    calib if calibrated else None, calib)


def run_set(vs: VideoSet, config: RunConfig, folder: Path) -> SetRun:
    """The set through pipeline.run as `vs-inspect sync` runs it, into folder (result.json and
    the cue bundle in cues/), with the truth kept in the result."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    res = run(list(vs.videos), config, calibration=vs.calibration, bundle_out=folder / "cues",
              progress=False, truth_offsets_s=vs.truth_s)
    write_run_result(res, folder / "result.json")
    errors = offset_errors_s(res.reference, res.offsets_s, vs.truth_s)
    frames = {v: None if e is None else e * min(vs.fps[v], vs.fps[res.reference]) for v, e in errors.items()}
    return SetRun(vs, res, folder, errors, frames)


def offset_errors_s(reference: str, offsets_s: dict[str, float | None],
                    truth_s: dict[str, float]) -> dict[str, float | None]:
    """Signed error (s) of every non-reference video's offset, the reference aligned with the
    truth (None: it or the reference unresolved)."""
    ref = offsets_s.get(reference)
    return {v: None if offsets_s.get(v) is None or ref is None else
            (offsets_s[v] - ref) - (t - truth_s[reference]) for v, t in truth_s.items() if v != reference}


@dataclass(frozen=True)
class Summary:
    offsets: int  # non-reference videos over all sets
    resolved: int
    within_1: int  # |error| <= 1 frame
    from_1_to_2: int  # 1 < |error| <= 2 frames
    over_2: int  # |error| > 2 frames: the safety target says 0
    median_abs_frames: float | None  # over the resolved offsets
    max_abs_frames: float | None
    median_abs_ms: float | None
    max_abs_ms: float | None


def summarize(errors_frames: list[float | None], errors_s: list[float | None]) -> Summary:
    """Counts and sizes of the offsets' errors (in frames and in s, None: unresolved) of some runs."""
    frames = [abs(e) for e in errors_frames if e is not None]
    ms = [1000 * abs(e) for e in errors_s if e is not None]
    return Summary(len(errors_frames), len(frames), sum(e <= 1 for e in frames),
                   sum(1 < e <= 2 for e in frames), sum(e > 2 for e in frames),
                   statistics.median(frames) if frames else None, max(frames, default=None),
                   statistics.median(ms) if ms else None, max(ms, default=None))
