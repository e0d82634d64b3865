"""vs-inspect bench-pairing: how right Stage 0's cross-view track pairs are on a rendered scene."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("bench-pairing", help="precision and recall of Stage 0's track pairs on a rendered scene",
                       description="Renders a scene with known cameras and offsets (the bench's rendered "
                                   "scene, or the demo's), runs Stage 0 with its calibration and prints, per "
                                   "pair of videos, how many track pairs follow one point (precision) and "
                                   "how many of the possible ones were found (recall), then what Stage 1 + 2 "
                                   "made of them.")
    p.add_argument("scene", choices=["rendered", "demo"], help="the scene to render and pair")
    p.add_argument("--workdir", type=Path, default=Path("/tmp/vs_pairing_scenes"),
                   help="render into (and reuse finished renderings from) this folder")
    p.add_argument("--geometric", choices=["joint", "triangles"], default="joint",
                   help="geometric track pairs: every camera's offset chosen at once from all pairs' votes "
                        "(joint), or each pair's top peaks closing the triangles")
    p.add_argument("--seed", type=int, default=0, help="the rendered scene's seed (the bench's: 0)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..bench.pairing_run import run_pairing_bench

    run_pairing_bench(args.scene, args.workdir, args.geometric == "joint", args.seed,
                      lambda s: print(s, flush=True))
    return 0
