"""vs-inspect report: a run folder or a recording (.rrd) alone -> PNG figures and index.html."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..errors import InputError
from ._common import add_force_option, add_gt_option, check_output_folder


def register(sub) -> None:
    p = sub.add_parser("report", help="render report figures (PNG/PDF/SVG + index.html) from a run or a .rrd",
                       description="Turn a run folder (OUT/result.json and its cue bundle) or a "
                                   "recording alone into figures: 3D scene, energy landscapes, pair "
                                   "graph, timeline, epipolar panel, and a mosaic when the videos "
                                   "can be read. Nothing is recomputed except what the figures draw. "
                                   "The same run gives the same figures from its folder and from "
                                   "its .rrd.")
    p.add_argument("source", type=Path, metavar="RUN_DIR_OR_RRD", help="run folder or .rrd file")
    p.add_argument("--out", type=Path, required=True, help="folder for the figures and index.html")
    p.add_argument("--pair", nargs=2, metavar=("A", "B"), default=None,
                   help="pair for the epipolar panel (default: the accepted pair with the sharpest landscape)")
    p.add_argument("--format", default="png", metavar="LIST",
                   help="comma-separated figure formats: png, pdf, svg (default: png)")
    p.add_argument("--dpi", type=float, default=200.0,
                   help="resolution of the PNGs (and of the 3D scene's picture in PDF/SVG), dots per inch")
    p.add_argument("--size", choices=("column", "page"), default="page",
                   help="printed width the figures are made for: a paper's column (3.5 in) or its "
                        "text width (7.1 in); their text is 7-9 pt at that width (default: page)")
    add_gt_option(p)
    add_force_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..io.lock import output_lock

    with output_lock(args.out, "--out"):  # one run at a time into --out
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    from ..analysis.report_data import load_report_data
    from ..report.build import render_report
    from ..report.figure_style import checked_render_options

    formats = checked_render_options(args.format, args.dpi, args.size)  # before any loading
    gt = None
    if args.gt is not None:
        from ..io.bundle import read_gt
        gt = read_gt(args.gt)
    check_output_folder(args.out, args.force)
    t0 = time.perf_counter()
    data = load_report_data(args.source, tuple(args.pair) if args.pair else None, gt=gt)
    if gt is not None:
        unknown = sorted(set(gt) - set(data.offsets_s))
        if unknown:
            raise InputError(f"--gt {args.gt}: names unknown videos {unknown} (known: {list(data.offsets_s)})")
        if data.reference not in gt:
            raise InputError(f"--gt {args.gt}: no true offset for the reference video {data.reference!r}")
    t1 = time.perf_counter()
    paths = render_report(data, args.out, overwrite=args.force, formats=formats, dpi=args.dpi, size=args.size)
    t2 = time.perf_counter()
    for key, p in paths.items():
        print(f"{key:<11} {p}")
    for note in data.notes:
        print(f"note: {note}")
    errs = data.errors_ms()
    if errs:
        frames = data.errors_frames() if data.videos else {}
        print("errors against the truth (reference aligned):")
        for v, e in errs.items():
            f = frames.get(v)
            print(f"  {v:<16}" + ("unresolved" if e is None else
                                  f"{e:8.1f} ms" + (f"  {f:6.2f} frames" if f is not None else "")))
    print(f"report: loaded in {t1 - t0:.2f} s, rendered {len(paths) - 1} figures "
          f"({', '.join(formats)}, {args.size} size, {args.dpi:g} dpi) in {t2 - t1:.2f} s")
    return 0
