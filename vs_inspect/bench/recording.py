"""Size and write time of vs_inspect recordings (.rrd), one line per case (vs-inspect bench recording).

    demo       the demo scene (cue-level synthetic, no frames): default options, --rrd-minimal,
               --rrd-all-offsets --rrd-all-tracks
    budget     the size budget: 4 videos x 10 s x 30 fps x 1280x720, EVERY frame and mask sent to
               the sink (real caliscope frames cycled), tracks and pairs from a 4-camera synthetic
               scene; once more with full-resolution frames
    caliscope  the caliscope session: real videos -> Stage 0 (its calibration) -> sync, recorded

Every recording is checked with `rerun rrd verify`. "log s" is the time spent inside the sink's
hooks plus closing the file (the cost of recording); "run s" is the whole run with the sink open.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np  # before pycolmap

from ..pipeline import RunConfig, run
from ..analysis.record_options import RecordOptions
from ..record.rerun_sink import RerunSink
from ..record.native_viewer import rerun_executable
from ..synth.cues import CueSceneConfig, make_cue_scene

CASES = ("demo", "budget", "caliscope")
CALISCOPE = "caliscope_post_optimization"


def verify(path: Path) -> str:
    """"verify ok", or why `rerun rrd verify` refused the file."""
    exe = rerun_executable()
    if exe is None:
        return "not verified (no rerun executable)"
    p = subprocess.run([str(exe), "rrd", "verify", str(path)], capture_output=True, text=True)
    return "verify ok" if p.returncode == 0 else f"VERIFY FAILED: {p.stderr.strip()[-200:]}"


def line(case: str, sink: RerunSink, t_run: float) -> str:
    """One case's line: size, time spent recording, the run's time, the verification."""
    return (f"{case:<44} {sink.stats['size_mb']:8.2f} MB  log {sink.stats['write_s']:6.2f} s  "
            f"run {t_run:6.1f} s  {verify(sink.path)}")


def bench_demo(out: Path, say: Callable[[str], None]) -> None:
    bundle = make_cue_scene(CueSceneConfig()).bundle
    for case, opts in (("demo (7 videos, default options)", RecordOptions()),
                       ("demo --rrd-minimal", RecordOptions.minimal()),
                       ("demo --rrd-all-offsets --rrd-all-tracks", RecordOptions().with_flags(True, False, True))):
        t = time.perf_counter()
        with RerunSink(out / f"{case.split()[0]}-{len(list(out.iterdir()))}.rrd", options=opts,
                       progress=False) as sink:
            run(bundle, sink=sink, progress=False)
        say(line(case, sink, time.perf_counter() - t))


def _real_frames(caliscope: Path) -> list[np.ndarray]:
    import cv2
    frames = []
    for v in sorted((caliscope / "calibration" / "extrinsic").glob("cam_*.mp4")):
        cap = cv2.VideoCapture(str(v))
        while True:
            ok, img = cap.read()
            if not ok:
                break
            frames.append(img)
    return frames


def bench_budget(out: Path, caliscope: Path, say: Callable[[str], None], full_frames: bool = False) -> None:
    import cv2
    real = _real_frames(caliscope)
    if not real:
        raise FileNotFoundError(f"no caliscope frames in {caliscope / 'calibration' / 'extrinsic'}")
    scene = make_cue_scene(CueSceneConfig(cameras=4, moving=1, variable_rate=0, seconds=11.5,
                                          fps_choices=(30.0,), seed=1))
    b = scene.bundle  # video sizes differ from the 720p frames fed below; only the size matters here
    opts = RecordOptions().with_flags(full_frames=full_frames)
    name = "budget-full.rrd" if full_frames else "budget.rrd"
    t = time.perf_counter()
    n_frames = 0
    with RerunSink(out / name, options=opts, progress=True) as sink:
        for vi, v in enumerate(b.videos):
            sink.video(v, None)
            for k in range(min(v.num_frames, 300)):
                img = real[(vi * 57 + k) % len(real)]
                img = np.roll(img, 3 * k, axis=1)  # make consecutive frames differ
                sink.video_frame(v.name, k, img)
                grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
                sink.dynamic_mask(v.name, k, (grey > 160).astype(np.int32) * (1 + (k // 50) % 3))
                n_frames += 1
        run(b, sink=sink, progress=False)
    say(line(f"4 x 10 s x 30 fps 720p, {n_frames} frames+masks" + (" (full)" if full_frames else ""),
             sink, time.perf_counter() - t))


def bench_caliscope(out: Path, caliscope: Path, say: Callable[[str], None]) -> None:
    from unittest import mock

    from ..cues.video import extract

    paths = sorted((caliscope / "calibration" / "extrinsic").glob("cam_*.mp4"))
    for case, shown in (("caliscope 4 x 57 frames 720p (8 frames/video)", extract.SHOWN_FRAMES),
                        ("caliscope, every frame sent to the sink", 10_000)):
        t = time.perf_counter()
        with mock.patch.object(extract, "SHOWN_FRAMES", shown), \
                RerunSink(out / f"caliscope-{shown}.rrd", progress=False) as sink:
            run(paths, RunConfig(), sink, calibration=caliscope / "camera_array.toml", progress=False)
        say(line(case, sink, time.perf_counter() - t))


def run_recording_bench(cases: tuple[str, ...], out: Path, data: Path, say: Callable[[str], None]) -> None:
    """Each case of CASES asked for, its lines said as they come; the .rrd files stay in out."""
    caliscope = data / CALISCOPE
    if "demo" in cases:
        bench_demo(out, say)
    if "budget" in cases:
        bench_budget(out, caliscope, say)
        bench_budget(out, caliscope, say, full_frames=True)
    if "caliscope" in cases:
        bench_caliscope(out, caliscope, say)
