"""vs-inspect bench-drone: pose-free sync with clock drift on the drone dataset vs its ground truth."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..bench.drone import format_table, load_drone_bundle, run_drone_bench
from ..sync.posefree import PoseFreeConfig


def register(sub) -> None:
    p = sub.add_parser("bench-drone", help="pose-free sync with drift on the drone dataset (offset and ppm errors)",
                       description="Estimates every camera pair's time shift, clock rate and fundamental "
                                   "matrix from the drone detections alone, solves per-camera offset and "
                                   "drift (camera 0 fixed), and prints the errors against the README's "
                                   "ground truth, with the constant-offset model as the ablation.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("path", type=Path, help="a bundle written by import-drone, or the dataset folder")
    p.add_argument("--workers", type=int, default=2, help="processes estimating pairs in parallel")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    bundle, drift = load_drone_bundle(args.path)
    res = run_drone_bench(bundle, drift, PoseFreeConfig(), workers=args.workers)
    print(format_table(res, bundle))
    return 0
