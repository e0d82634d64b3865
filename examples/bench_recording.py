"""Size and write time of vs_inspect recordings (.rrd), printed as one line per case.

    # the demo scene (cue-level synthetic, no frames), default options and --rrd-minimal
    PYTHONPATH=. python examples/bench_recording.py demo
    # the size budget: 4 videos x 10 s x 30 fps x 1280x720, EVERY frame and mask sent to the sink
    # (real caliscope frames cycled), tracks and pairs from a 4-camera synthetic scene
    PYTHONPATH=. python examples/bench_recording.py budget
    # the caliscope session: real videos -> Stage 0 (imported calibration) -> sync, recorded
    PYTHONPATH=. python examples/bench_recording.py caliscope

Every recording is checked with `rerun rrd verify`. "log s" is the time spent inside the sink's
hooks plus closing the file (the cost of recording); "run s" is the whole run with the sink open.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np  # noqa: F401  (before pycolmap)

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from vs_inspect.record.options import RecordOptions  # noqa: E402
from vs_inspect.record.rerun_sink import RerunSink  # noqa: E402
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene  # noqa: E402
from vs_inspect.pipeline import RunConfig, run  # noqa: E402

DATA = REPO.parent / "shared" / "data"
CALI = DATA / "caliscope_post_optimization"


def verify(path: Path) -> str:
    env = dict(os.environ)
    env.setdefault("XDG_CONFIG_HOME", str(REPO / ".cache" / "xdg-config"))
    env.setdefault("XDG_DATA_HOME", str(REPO / ".cache" / "xdg-data"))
    p = subprocess.run([str(Path(sys.executable).parent / "rerun"), "rrd", "verify", str(path)],
                       capture_output=True, text=True, env=env)
    return "verify ok" if p.returncode == 0 else f"VERIFY FAILED: {p.stderr.strip()[-200:]}"


def report(case: str, sink: RerunSink, t_run: float) -> None:
    print(f"{case:<44} {sink.stats['size_mb']:8.2f} MB  log {sink.stats['write_s']:6.2f} s  "
          f"run {t_run:6.1f} s  {verify(sink.path)}", flush=True)


def bench_demo(out: Path) -> None:
    bundle = make_cue_scene(CueSceneConfig()).bundle
    for case, opts in (("demo (7 videos, default options)", RecordOptions()),
                       ("demo --rrd-minimal", RecordOptions.minimal()),
                       ("demo --rrd-all-offsets --rrd-all-tracks", RecordOptions().with_flags(True, False, True))):
        t = time.perf_counter()
        with RerunSink(out / f"{case.split()[0]}-{len(list(out.iterdir()))}.rrd", options=opts,
                       progress=False) as sink:
            run(bundle, sink=sink, progress=False)
        report(case, sink, time.perf_counter() - t)


def _real_frames() -> list[np.ndarray]:
    import cv2
    frames = []
    for v in sorted((CALI / "calibration" / "extrinsic").glob("cam_*.mp4")):
        cap = cv2.VideoCapture(str(v))
        while True:
            ok, img = cap.read()
            if not ok:
                break
            frames.append(img)
    return frames


def bench_budget(out: Path, full_frames: bool = False) -> None:
    import cv2
    real = _real_frames()
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
    report(f"4 x 10 s x 30 fps 720p, {n_frames} frames+masks" + (" (full)" if full_frames else ""),
           sink, time.perf_counter() - t)


def bench_caliscope(out: Path) -> None:
    from vs_inspect.cues import CueConfig
    paths = sorted((CALI / "calibration" / "extrinsic").glob("cam_*.mp4"))
    for case, cfg in (("caliscope 4 x 57 frames 720p (8 frames/video)", CueConfig()),
                      ("caliscope, every frame sent to the sink", dataclasses.replace(CueConfig(), sink_frames=10_000))):
        t = time.perf_counter()
        with RerunSink(out / f"caliscope-{cfg.sink_frames}.rrd", progress=False) as sink:
            run(paths, RunConfig(cues=cfg), sink, calibration=CALI / "camera_array.toml", progress=False)
        report(case, sink, time.perf_counter() - t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("case", choices=("demo", "budget", "caliscope", "all"))
    ap.add_argument("--out", type=Path, default=None, help="folder for the .rrd files (default: a temporary one)")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="vs-inspect-bench-rrd-"))
    out.mkdir(parents=True, exist_ok=True)
    if args.case in ("demo", "all"):
        bench_demo(out)
    if args.case in ("budget", "all"):
        bench_budget(out)
        bench_budget(out, full_frames=True)
    if args.case in ("caliscope", "all"):
        bench_caliscope(out)
    print(f"recordings in {out}")


if __name__ == "__main__":
    main()
