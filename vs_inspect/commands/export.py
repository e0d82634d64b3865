"""vs-inspect export: a synchronized mosaic video of a run's input videos."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ._common import add_force_option, check_output_file, positive_float, positive_int
from ..errors import InputError
from ..io.result import read_run_result
from ..types import RunResult
from ..io.video import open_video


def register(sub) -> None:
    p = sub.add_parser("export", help="write the inputs side by side on the global timeline",
                       description="Read OUT/result.json and the input videos it lists "
                                   "(result['input']['videos']) or --videos, and write one H.264 "
                                   "MP4 with all videos side by side on the global timeline: "
                                   "g = local time + offset_s. A dark tile where a video has no "
                                   "frame at g or no offset.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("out", type=Path, help="run folder holding result.json (or the file itself)")
    p.add_argument("--mosaic", type=Path, required=True, metavar="FILE.mp4", help="video to write")
    p.add_argument("--videos", nargs="+", default=None, metavar="PATH",
                   help="input videos (PATH or NAME=PATH; name = file stem) instead of the paths "
                        "in result.json")
    p.add_argument("--fps", type=positive_float, default=None,
                   help="output frame rate (default: the highest input rate)")
    add_force_option(p, "--mosaic")
    p.add_argument("--tile-width", type=positive_int, default=480, help="width of each video's tile, px")
    p.add_argument("--input-fps", type=positive_float, default=None,
                   help="frame rate of image-folder inputs (default: the run's --fps if recorded)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _video_paths(args, result: RunResult, result_dir: Path) -> dict[str, Path]:
    names = list(result.offsets_s)
    if args.videos:
        paths: dict[str, Path] = {}
        for item in args.videos:
            name, sep, p = item.partition("=")
            path = Path(p) if sep else Path(item)
            if not sep:
                name = path.stem if path.suffix else path.name
            if name in paths:
                raise InputError(f"--videos: two videos named {name!r}")
            paths[name] = path
    else:
        listed = result.inputs.videos
        if not listed:
            raise InputError(f"{result_dir}: result.json lists no input videos "
                             f"(input.videos); give them with --videos")
        paths = {}
        for n, p in listed.items():
            path = Path(p)
            if not path.is_absolute() and not path.exists() and (result_dir / path).exists():
                path = result_dir / path  # relative to the run folder
            paths[n] = path
    unknown = sorted(set(paths) - set(names))
    missing = sorted(set(names) - set(paths))
    if unknown or missing:
        raise InputError(f"videos and result do not match: result has {names}; videos "
                         f"{sorted(paths)} (no offset in the result for {unknown}, "
                         f"no video for {missing})")
    return {n: paths[n] for n in names}


def run(args: argparse.Namespace) -> int:
    from ..io.lock import output_lock

    with output_lock(args.mosaic, "--mosaic"):  # one run at a time into the mosaic's file
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    from ..report.mosaic import write_mosaic

    check_output_file(args.mosaic, args.force, "--mosaic")
    result = read_run_result(args.out)
    result_dir = args.out if args.out.is_dir() else args.out.parent
    paths = _video_paths(args, result, result_dir)
    input_fps = args.input_fps or result.inputs.fps
    sources = [open_video(p, fps=input_fps, name=n) for n, p in paths.items()]
    offsets = [result.offsets_s[n] for n in paths]
    if all(o is None for o in offsets):
        raise InputError(f"{args.out}: no video has an offset; nothing to export")
    fps = args.fps
    if fps is None:
        rates = [1.0 / s.info.frame_interval_s for s in sources
                 if math.isfinite(s.info.frame_interval_s) and s.info.frame_interval_s > 0]
        fps = max(rates) if rates else 10.0
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be positive, got {fps}")
    if args.tile_width < 32:
        raise InputError(f"--tile-width must be at least 32 px, got {args.tile_width}")
    reasons = [result.unresolved.get(n) for n in paths]
    plan = write_mosaic(args.mosaic, sources, offsets, fps, args.tile_width, reasons,
                        progress=not args.no_progress)
    dur = plan.times_s[-1] - plan.times_s[0]
    print(f"wrote {args.mosaic}: {len(plan.times_s)} frames at {fps:.4g} fps "
          f"({dur:.2f} s of global time from {plan.times_s[0]:+.3f} s), "
          f"{len(sources)} videos, {sum(o is None for o in offsets)} unresolved")
    return 0
