"""vs-inspect export: what other tools read from a synchronized run: per-video offsets (CSV,
JSON), each video trimmed to the common time span, and the mosaic of all videos."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ._common import (add_force_option, check_output_file, check_output_folder, positive_float,
                      positive_int, sign_in_words)
from ..errors import InputError
from ..io.result import read_run_result
from ..result_types import RunResult
from ..io.video import open_video


def register(sub) -> None:
    p = sub.add_parser("export", help="offsets, trimmed videos and the mosaic of a synchronized run",
                       description="Read OUT/result.json and the input videos it lists "
                                   "(result['input']['videos']) or --videos, and write any of: "
                                   "--offsets, one row per video with its offset in seconds and in "
                                   "its own frames and its frames inside the common time span (the "
                                   "sign is spelled out in the file); --trimmed, each video cut to "
                                   "that span as its own MP4, frame-accurate at its own rate (a "
                                   "timestamps file where the rate varies); --mosaic, one H.264 "
                                   "MP4 with all videos side by side on the global timeline "
                                   "g = local time + offset_s (a dark tile where a video has no "
                                   "frame at g or no offset).",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("out", type=Path, help="run folder holding result.json (or the file itself)")
    p.add_argument("--offsets", type=Path, default=None, metavar="FILE.csv|FILE.json",
                   help="per-video offsets to write (CSV or JSON by the file's ending)")
    p.add_argument("--trimmed", type=Path, default=None, metavar="DIR",
                   help="folder to write each synchronized video into, trimmed to the common span")
    p.add_argument("--mosaic", type=Path, default=None, metavar="FILE.mp4", help="mosaic video to write")
    p.add_argument("--videos", nargs="+", default=None, metavar="PATH",
                   help="input videos (PATH or NAME=PATH; name = file stem) instead of the paths "
                        "in result.json")
    p.add_argument("--fps", type=positive_float, default=None,
                   help="mosaic frame rate (default: the highest input rate)")
    add_force_option(p, "the outputs")
    p.add_argument("--tile-width", type=positive_int, default=480, help="width of each video's tile, px")
    p.add_argument("--crf", type=int, default=17,
                   help="H.264 quality of the trimmed videos (lower is better, 0-51)")
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
    from contextlib import ExitStack

    from ..io.lock import lock_outputs

    with ExitStack() as stack:  # one run at a time into each output
        lock_outputs(stack, (args.offsets, "--offsets"), (args.trimmed, "--trimmed"), (args.mosaic, "--mosaic"))
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    if not (args.offsets or args.trimmed or args.mosaic):
        raise InputError("nothing to export: give --offsets, --trimmed and/or --mosaic")
    if args.offsets is not None:
        if args.offsets.suffix.lower() not in (".csv", ".json"):
            raise InputError(f"--offsets {args.offsets}: the file must end in .csv or .json")
        check_output_file(args.offsets, args.force, "--offsets")
    if args.mosaic is not None:
        check_output_file(args.mosaic, args.force, "--mosaic")
    if args.trimmed is not None:
        check_output_folder(args.trimmed, args.force, "--trimmed")
    if not 0 <= args.crf <= 51:
        raise InputError(f"--crf must be 0-51, got {args.crf}")
    result = read_run_result(args.out)
    result_dir = args.out if args.out.is_dir() else args.out.parent
    if all(o is None for o in result.offsets_s.values()):
        raise InputError(f"{args.out}: no video has an offset; nothing to export")
    sources = None
    if args.mosaic or args.trimmed or not (result_dir / "cues" / "bundle.json").is_file():
        paths = _video_paths(args, result, result_dir)
        input_fps = args.input_fps or result.inputs.fps
        sources = {n: open_video(p, fps=input_fps, name=n) for n, p in paths.items()}
        infos = [s.info for s in sources.values()]
    else:  # offsets alone: the run's own record of every video's clock
        from ..io.bundle import read_video_infos
        by_name = {v.name: v for v in read_video_infos(result_dir / "cues")}
        missing = [n for n in result.offsets_s if n not in by_name and result.offsets_s[n] is not None]
        if missing:
            raise InputError(f"{result_dir / 'cues'}: no clock for {missing}; give --videos")
        infos = [by_name[n] for n in result.offsets_s if n in by_name]
    names = list(result.offsets_s)
    if args.offsets or args.trimmed:
        from ..analysis.common_span import common_span
        try:
            span = common_span(infos, result.offsets_s, result.reference)
        except ValueError as exc:
            raise InputError(f"{args.out}: {exc}") from None
        print(sign_in_words(result.offsets_s, result.reference))
        print(f"common span: {span.start_s:+.3f} s to {span.end_s:+.3f} s on {result.reference}'s clock "
              f"({span.end_s - span.start_s:.2f} s, set by {span.anchor}'s frames)")
        for n, why in span.skipped.items():
            print(f"  {n}: left out: {why}")
    if args.offsets:
        from ..io.sync_exports import write_offsets
        path = write_offsets(args.offsets, span, names, result.offsets_s)
        print(f"wrote {path}: offsets of {len(span.videos)} videos")
    if args.trimmed:
        from ..io.sync_exports import write_trimmed
        files = write_trimmed(args.trimmed, span, sources, crf=args.crf, progress=not args.no_progress)
        for n, s in span.videos.items():
            print(f"  {n}: frames {s.first_frame}..{s.last_frame} ({s.num_frames}), first at "
                  f"{s.first_time_s:+.4f} s")
        print(f"wrote {args.trimmed}: {len(span.videos)} trimmed videos ({len(files)} files)")
    if args.mosaic:
        _write_mosaic(args, result, list(sources.values()))
    return 0


def _write_mosaic(args, result: RunResult, sources) -> None:
    from ..report.mosaic import write_mosaic
    offsets = [result.offsets_s[s.info.name] for s in sources]
    fps = args.fps
    if fps is None:
        rates = [1.0 / s.info.frame_interval_s for s in sources
                 if math.isfinite(s.info.frame_interval_s) and s.info.frame_interval_s > 0]
        fps = max(rates) if rates else 10.0
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be positive, got {fps}")
    if args.tile_width < 32:
        raise InputError(f"--tile-width must be at least 32 px, got {args.tile_width}")
    reasons = [result.unresolved.get(s.info.name) for s in sources]
    plan = write_mosaic(args.mosaic, sources, offsets, fps, args.tile_width, reasons,
                        progress=not args.no_progress)
    dur = plan.times_s[-1] - plan.times_s[0]
    print(f"wrote {args.mosaic}: {len(plan.times_s)} frames at {fps:.4g} fps "
          f"({dur:.2f} s of global time from {plan.times_s[0]:+.3f} s), "
          f"{len(sources)} videos, {sum(o is None for o in offsets)} unresolved")
