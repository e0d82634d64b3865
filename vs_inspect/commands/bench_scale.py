"""vs-inspect bench-scale: Stage 1 + 2 on synthetic rigs of growing size, local engine vs Ray."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..bench.scale import format_rows, run_scale_bench, same_offsets
from ..sync.config import PairSelection
from ._common import positive_int


def _pairs_mode(text: str) -> str:
    try:
        PairSelection.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def register(sub) -> None:
    p = sub.add_parser("bench-scale", help="wall time, memory and accuracy against rig size, local vs Ray",
                       description="Runs cue-level synthetic ring rigs of each size from their cue bundle "
                                   "with each pair selection on each engine (every cell in a fresh "
                                   "process) and prints wall time, pairs, per-pair cost, peak memory of "
                                   "the driver and of the Ray workers, and the offset errors; then "
                                   "whether the engines gave identical offsets.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--cameras", type=positive_int, nargs="+", default=[8, 16, 32, 64], help="rig sizes")
    p.add_argument("--engines", nargs="+", choices=("local", "ray"), default=["local", "ray"],
                   help="engines to run every cell on")
    p.add_argument("--pairs", nargs="+", type=_pairs_mode, default=["all", "rst", "knn:4"],
                   help="pair selections (as sync's --pairs)")
    p.add_argument("--ray-cpus", type=positive_int, default=None,
                   help="CPUs of the embedded Ray (default: all cores)")
    p.add_argument("--timeout-s", type=float, default=None, help="give up on a cell after this long")
    p.add_argument("--jsonl", type=Path, default=None, help="also append every row to this JSON-lines file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    rows = run_scale_bench(args.cameras, args.engines, args.pairs, args.ray_cpus, args.jsonl, args.timeout_s)
    print()
    print(format_rows(rows))
    for (n, mode), same in sorted(same_offsets(rows).items()):
        print(f"{n} cameras, {mode}: offsets {'identical' if same else 'DIFFER'} across engines")
    return 0
