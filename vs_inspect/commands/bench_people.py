"""vs-inspect bench-people: the people cue on the VisualSync clips and caliscope, then Stage 1 + 2."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..bench.people import SCENES, format_table, run_benchmark
from ..errors import InputError
from ..geometry.offsets import OffsetGrid
from .bench import _default_data


def register(sub) -> None:
    p = sub.add_parser("bench-people", help="people as cross-view correspondences: cameras and offsets from video alone",
                       description="Finds and follows the people of every video (BlazePose), pairs them up "
                                   "across videos with each pair's epipolar geometry and time shift, makes "
                                   "cameras from those pairs (no background cameras), then runs Stage 1 + 2 "
                                   "on the landmarks; prints each video's error against the truth, the reason "
                                   "of every null and the seconds spent, beside the VisualSync paper's numbers.")
    p.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES),
                   help=f"scenes (default: {' '.join(SCENES)})")
    p.add_argument("--data", type=Path, default=None,
                   help="folder with the real data (default: $VS_INSPECT_DATA or ../shared/data)")
    p.add_argument("--range-s", type=float, default=None, help="search only |Δ| <= this many seconds")
    p.add_argument("--min-overlap-s", type=float, default=1.0, help="least common time of two videos (default: 1)")
    p.add_argument("--seed", type=int, default=0, help="seed of caliscope's leading cuts (default: 0)")
    p.add_argument("--rrd", type=Path, default=None, metavar="DIR",
                   help="write each scene's people cue as a recording people-<scene>.rrd into DIR")
    p.add_argument("--people", type=Path, default=None, metavar="DIR",
                   help="reuse each video's people saved in DIR by an earlier run (saved there when missing): "
                        "the people step's time is then 0")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    data = args.data or _default_data()
    if not data.is_dir():
        raise InputError(f"{data}: no data folder (give --data or set VS_INSPECT_DATA)")
    grid = OffsetGrid(min_overlap_s=args.min_overlap_s, range_s=args.range_s)
    runs = run_benchmark(data, args.scenes, grid, seed=args.seed, rrd_folder=args.rrd, people_folder=args.people,
                         log=lambda s: print(s, flush=True))
    print()
    print(format_table(runs))
    return 0
