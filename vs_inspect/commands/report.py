"""vs-inspect report: a run folder or a recording (.rrd) alone -> PNG figures and index.html."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ._common import add_force_option, check_output_folder


def register(sub) -> None:
    p = sub.add_parser("report", help="render report images (PNG + index.html) from a run or a .rrd",
                       description="Turn a run folder (OUT/result.json and its cue bundle) or a "
                                   "recording alone into figures: 3D scene, energy landscapes, pair "
                                   "graph, timeline, epipolar panel, and a mosaic when the videos "
                                   "can be read. Nothing is recomputed except what the figures draw.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("source", type=Path, metavar="RUN_DIR_OR_RRD", help="run folder or .rrd file")
    p.add_argument("--out", type=Path, required=True, help="folder for the PNGs and index.html")
    p.add_argument("--pair", nargs=2, metavar=("A", "B"), default=None,
                   help="pair for the epipolar panel (default: the accepted pair with the sharpest landscape)")
    add_force_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..analysis.report_data import load_report_data
    from ..report.build import render_report

    check_output_folder(args.out, args.force)
    t0 = time.perf_counter()
    data = load_report_data(args.source, tuple(args.pair) if args.pair else None)
    t1 = time.perf_counter()
    paths = render_report(data, args.out, overwrite=args.force)
    t2 = time.perf_counter()
    for key, p in paths.items():
        print(f"{key:<11} {p}")
    for note in data.notes:
        print(f"note: {note}")
    print(f"report: loaded in {t1 - t0:.2f} s, rendered {len(paths) - 1} figures in {t2 - t1:.2f} s")
    return 0
