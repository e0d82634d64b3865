"""vs-inspect bench-timing: end-to-end time of `sync` on rendered 720p videos against the time
target (4 × 10 s 720p videos in under 3 minutes on 2 cores)."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from ..bench.timing import (
    TARGET_S,
    TimingScene,
    ratios,
    run_timing_bench,
    table_header,
    table_line,
)
from ._common import positive_float
from .synth_video import add_image_and_clock_options


def register(sub) -> None:
    d = TimingScene()
    p = sub.add_parser("bench-timing", help="end-to-end time of sync on 4 rendered 720p videos "
                                            "against the 3-minute target",
                       description="Renders a scene (3 static + 1 hand-held camera, every video as "
                                   "long, exact truth) into a work folder, then times `vs-inspect "
                                   "sync` with default settings on its videos in a fresh process, "
                                   "with estimated cameras and with the scene's calibration. Prints "
                                   "each stage's seconds (result.json), the rest of the wall time "
                                   "(start-up, recording, writing), wall and CPU time and peak "
                                   "memory of the process, the offsets' errors against the truth, "
                                   "and whether the run met the target. Rendering is not timed.")
    add_image_and_clock_options(p, d)
    p.add_argument("--seconds", type=positive_float, default=d.seconds, help="length of every video")
    p.add_argument("--seed", type=int, default=d.seed, help="seed of the scene")
    p.add_argument("--cameras", nargs="+", choices=("estimated", "calibration"),
                   default=["estimated", "calibration"], help="camera modes to time")
    p.add_argument("--reference", action="store_true",
                   help="also time the bench's 480x360 5 s rendered scene in the same run and "
                        "print each run's wall time as a multiple of it (a shared machine's load "
                        "changes the seconds more than the ratio)")
    p.add_argument("--target-s", type=positive_float, default=TARGET_S, help="the time target (s)")
    p.add_argument("--workdir", type=Path, default=None,
                   help="keep the rendered scenes and runs here (reused when rendered with the "
                        "same settings; default: a temporary folder, removed at the end)")
    p.add_argument("--timeout-s", type=positive_float, default=None, help="give up on a run after this long")
    p.add_argument("--sync-args", default="", metavar="'ARGS'",
                   help="extra options passed to every sync run, e.g. '--max-side 480'")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import shlex

    scene = TimingScene(width=args.width, height=args.height, seconds=args.seconds,
                        fps=args.fps or None, max_offset_s=args.max_offset_s, seed=args.seed)
    extra = tuple(shlex.split(args.sync_args))
    print(table_header(), flush=True)

    def show(row) -> None:  # each run's line as soon as it ends
        print(table_line(row), flush=True)

    if args.workdir is not None:
        rows, ref = run_timing_bench(args.workdir, scene, tuple(args.cameras), args.reference,
                                     args.target_s, extra, args.timeout_s, on_row=show)
    else:
        with tempfile.TemporaryDirectory(prefix="vs-inspect-timing-") as tmp:
            rows, ref = run_timing_bench(Path(tmp), scene, tuple(args.cameras), args.reference,
                                         args.target_s, extra, args.timeout_s, on_row=show)
    for line in ratios(rows, ref):
        print(line)
    return 0
