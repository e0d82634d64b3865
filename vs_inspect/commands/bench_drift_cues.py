"""vs-inspect bench-drift-cues: `sync --drift` against the constant-offset model on synthetic cue
scenes whose clocks drift."""

from __future__ import annotations

import argparse

from ..bench.datasets import DIFFICULTIES
from ..bench.drift_cues import per_scene, run_drift_cues, summarize


def register(sub) -> None:
    p = sub.add_parser("bench-drift-cues", help="--drift vs constant offsets on drifting synthetic cue scenes",
                       description="Synthetic cue scenes (5 cameras) whose non-reference clocks run ± "
                                   "--drift-ppm off; each is synchronized with the drift model and with "
                                   "constant offsets (the ablation). Prints the offset errors (ms, at "
                                   "local time 0 and at each video's last frame) and the drift errors.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--difficulty", choices=sorted(DIFFICULTIES), default="default")
    p.add_argument("--seeds", type=int, default=5, help="scenes 0..N-1")
    p.add_argument("--drift-ppm", type=float, default=200.0,
                   help="clock drift of every non-reference video, ± this with a random sign (ppm)")
    p.add_argument("--seconds", type=float, default=None,
                   help="typical video length (default: the scenes' usual 8 s)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    rows = run_drift_cues(args.difficulty, tuple(range(args.seeds)), args.drift_ppm, args.seconds)
    print(summarize(rows))
    print(per_scene(rows))
    return 0
