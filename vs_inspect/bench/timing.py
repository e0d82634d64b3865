"""End-to-end time of `vs-inspect sync` on videos (vs-inspect bench timing), against the time
target: 4 × 10 s 720p videos in under 3 minutes on 2 cores, Stage 0 from video to offsets.

A rendered scene (vs_inspect.synth: 3 static + 1 hand-held camera, every video as long, exact
truth) is synchronized by `vs-inspect sync` with default settings in a fresh process per run,
once with estimated cameras and once with the scene's calibration. The process's wall time, CPU
time and peak memory come from os.wait4 (what /usr/bin/time -v reports); the per-stage times are
the run's result.json timings_s. Rendering the scene is not timed (it is cached in the work
folder). An optional reference run (the bench's 480x360 5 s rendered scene) measured in the same
invocation gives a ratio that is less sensitive to the load of a shared machine than the seconds.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import InputError
from ..eval.metrics import evaluate_offsets
from ..synth.world import SceneConfig
from .scenes import RENDERED

TARGET_S = 180.0  # the time target: 4 × 10 s 720p videos in under 3 minutes on 2 cores

# (column, timings_s key of result.json): Stage 0 steps summed over the videos, then Stage 1 + 2
STAGES = (("decode", "stage0_decode_s"), ("motion", "stage0_motion_s"),
          ("track", "stage0_tracking_s"), ("feat", "stage0_features_s"),
          ("sfm_img", "stage0_sfm_frames_s"), ("match", "stage0_matching_s"),
          ("cams", "stage0_cameras_s"), ("geo", "stage0_geometric_pairs_s"),
          ("heads", "stage0_heads_s"), ("stage1", "stage1_s"), ("stage2", "stage2_s"))
# a video's own steps: their seconds are sums over the videos, which may run two at a time
PER_VIDEO = ("decode", "motion", "track", "feat", "sfm_img")
COLUMNS = ("scene", "cameras") + tuple(c for c, _ in STAGES) + (
    "other", "wall_s", "cpu_s", "rss_mb", "resolved", "med_ms", "max_ms", "target")


# the timed scene: 3 static + 1 hand-held camera, every video 10 s of 1280x720 at 30 fps
TIMING_SCENE = SceneConfig(cameras=4, moving=1, seconds=10.0, same_length=True, width=1280, height=720,
                           fps=30.0, seed=0)
REFERENCE_SCENE = RENDERED  # the bench's 480x360 5 s rendered scene, as a load reference


def label(scene: SceneConfig) -> str:
    """'4x10s 1280x720 30fps': cameras, length, size and rate of a scene."""
    rate = f"{scene.fps:g}fps" if scene.fps else "mixed-fps"
    return f"{scene.cameras}x{scene.seconds:g}s {scene.width}x{scene.height} {rate}"


@dataclass(frozen=True)
class TimingRow:
    scene: str  # label(the scene)
    cameras: str  # "estimated" or "calibration"
    stages_s: dict[str, float]  # column of STAGES -> s (absent stages are not in it)
    total_s: float  # the run's own total (result.json timings_s.total_s), s
    wall_s: float  # the sync process from start to exit (imports, recording, result.json), s
    cpu_s: float  # user + system CPU time of that process and its children, s
    max_rss_mb: float  # its peak resident memory, MB
    resolved: int  # videos with an offset
    videos: int
    median_error_ms: float  # over resolved non-reference videos (NaN if none)
    max_error_ms: float
    offsets_s: dict[str, float | None] = field(default_factory=dict)
    target_s: float | None = TARGET_S  # None: no target for this scene (the reference)
    videos_s: float | None = None  # wall time of the videos' own steps together (None: not recorded)
    camera_source: str | None = None  # result.json's cues.camera_source: where the cameras came from

    @property
    def met(self) -> bool | None:
        if self.target_s is None:
            return None
        return self.wall_s < self.target_s and self.resolved == self.videos


def render(scene: SceneConfig, workdir: Path, progress: bool = False) -> Path:
    """The scene's folder in workdir, rendered unless a finished rendering of it is there."""
    from ..synth.videos import render_unless_cached

    folder = Path(workdir) / (f"timing_{scene.width}x{scene.height}_{scene.seconds:g}s_"
                              f"{scene.fps or 'mixed'}_c{scene.cameras}_s{scene.seed}"
                              f"{'' if scene.max_offset_s == 1.5 else f'_o{scene.max_offset_s:g}'}"
                              f"{'' if scene.same_length else '_varlen'}")
    render_unless_cached(folder, scene, progress=progress)
    return folder


def _run_measured(cmd: list[str], env: dict[str, str], timeout_s: float | None
                  ) -> tuple[int, float, float, float, str]:
    """(exit code, wall s, CPU s, peak RSS MB, stderr tail) of one child process, from os.wait4
    (the child and the descendants it waited for, as /usr/bin/time -v counts them)."""
    with tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err, text=True)
        timer = threading.Timer(timeout_s, proc.kill) if timeout_s else None
        if timer:
            timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            if timer:
                timer.cancel()
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        err.seek(0)
        tail = err.read()[-2000:]
    if timer is not None and proc.returncode == -signal.SIGKILL:
        raise InputError(f"sync took longer than {timeout_s:g} s: {' '.join(cmd)}")
    return proc.returncode, wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0, tail


def time_sync(folder: Path, out: Path, calibrated: bool, scene_label: str,
              target_s: float | None = TARGET_S, extra_args: tuple[str, ...] = (),
              timeout_s: float | None = None) -> TimingRow:
    """Run `vs-inspect sync` on the scene's videos in a fresh process and measure it."""
    folder, out = Path(folder), Path(out)
    videos = sorted(str(p) for p in folder.glob("cam*.mp4"))
    cmd = [sys.executable, "-m", "vs_inspect", "sync", *videos, "--out", str(out),
           "--no-progress", "--force", *extra_args]
    if calibrated:
        cmd += ["--calib", str(folder / "calibration.json")]
    env = dict(os.environ)
    env["VS_INSPECT_RECORDINGS"] = str(out.parent / "recordings")  # never the caller's ./recordings
    result_path = out / "result.json"
    result_path.unlink(missing_ok=True)  # an earlier run's result must not pass for this one's
    code, wall, cpu, rss_mb, err = _run_measured(cmd, env, timeout_s)
    if not result_path.is_file():
        last = err.strip().splitlines()[-1] if err.strip() else "no message"
        raise InputError(f"sync wrote no result.json (exit {code}): {last}")
    result = json.loads(result_path.read_text())
    offsets = {k: (None if v is None else float(v)) for k, v in result["offsets_s"].items()}
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    m = evaluate_offsets({n: offsets.get(n) for n in truth}, truth, result["reference"])
    t = result.get("timings_s", {})
    stages = {col: float(t[key]) for col, key in STAGES if key in t}
    return TimingRow(scene_label, "calibration" if calibrated else "estimated", stages,
                     float(t.get("total_s", math.nan)), wall, cpu, rss_mb,
                     sum(1 for n in truth if offsets.get(n) is not None), len(truth),
                     m.delta_med_ms, m.delta_max_ms, offsets, target_s,
                     videos_s=float(t["stage0_videos_s"]) if "stage0_videos_s" in t else None,
                     camera_source=(result.get("cues") or {}).get("camera_source"))


def _fmt(v: float | None, digits: int = 1) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def table_header() -> str:
    return "| " + " | ".join(COLUMNS) + " |\n|" + "---|" * len(COLUMNS)


def table_line(r: TimingRow) -> str:
    """One run as a Markdown table row: stage seconds, the rest of the wall time (start-up,
    recording, writing: the videos' own steps counted by their wall time together when it is
    known), wall, CPU, peak memory, resolved videos, errors and the target."""
    per_video = sum(v for c, v in r.stages_s.items() if c in PER_VIDEO) if r.videos_s is None else r.videos_s
    staged = per_video + sum(v for c, v in r.stages_s.items() if c not in PER_VIDEO)
    target = "-" if r.met is None else f"{'met' if r.met else 'MISSED'} (<{r.target_s:g} s)"
    if r.met is False and r.wall_s < r.target_s:  # say which half failed: fast, but not every video
        target = f"MISSED: in time (<{r.target_s:g} s), {r.resolved}/{r.videos} resolved"
    source = r.camera_source
    cameras = r.cameras if source in (None, r.cameras) else f"{r.cameras} ({source})"
    cells = [r.scene, cameras] + [_fmt(r.stages_s.get(c)) for c, _ in STAGES] + [
        _fmt(r.wall_s - staged), _fmt(r.wall_s), _fmt(r.cpu_s), _fmt(r.max_rss_mb, 0),
        f"{r.resolved}/{r.videos}", _fmt(r.median_error_ms, 2), _fmt(r.max_error_ms, 2), target]
    return "| " + " | ".join(cells) + " |"


def format_table(rows: list[TimingRow]) -> str:
    """A Markdown table, one row per run (table_line)."""
    return "\n".join([table_header()] + [table_line(r) for r in rows])


def ratios(rows: list[TimingRow], reference: list[TimingRow]) -> list[str]:
    """Each run's wall time as a multiple of the reference scene's run with the same cameras."""
    ref = {r.cameras: r for r in reference}
    out = []
    for r in rows:
        if r.cameras in ref and ref[r.cameras].wall_s > 0:
            out.append(f"{r.scene}, {r.cameras}: {r.wall_s / ref[r.cameras].wall_s:.2f} x the wall "
                       f"time of {ref[r.cameras].scene} ({ref[r.cameras].wall_s:.1f} s)")
    return out


def run_timing_bench(workdir: Path, scene: SceneConfig = TIMING_SCENE,
                     modes: tuple[str, ...] = ("estimated", "calibration"), with_reference: bool = False,
                     target_s: float = TARGET_S, extra_args: tuple[str, ...] = (),
                     timeout_s: float | None = None, progress: bool = False,
                     on_row: Callable[[TimingRow], None] | None = None
                     ) -> tuple[list[TimingRow], list[TimingRow]]:
    """(rows of the scene, rows of the reference scene or []) for every camera mode; on_row is
    called with each row as soon as its run ends (a long benchmark shows what it has)."""
    def done(row: TimingRow) -> TimingRow:
        if on_row is not None:
            on_row(row)
        return row

    for m in modes:
        if m not in ("estimated", "calibration"):
            raise InputError(f"unknown camera mode {m!r}: use estimated or calibration")
    workdir = Path(workdir)
    folder = render(scene, workdir, progress)
    rows = [done(time_sync(folder, workdir / f"run_{m}", m == "calibration", label(scene), target_s,
                           extra_args, timeout_s)) for m in modes]
    ref_rows = []
    if with_reference:
        ref_folder = render(REFERENCE_SCENE, workdir, progress)
        ref_rows = [done(time_sync(ref_folder, workdir / f"ref_{m}", m == "calibration",
                                   label(REFERENCE_SCENE), None, extra_args, timeout_s)) for m in modes]
    return rows, ref_rows
