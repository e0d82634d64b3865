"""vs-inspect cues: videos -> cue bundle (cameras, tracks, cross-view track pairs)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..errors import InputError
from ..io.bundle import write_bundle
from ..io.result import write_cue_stats
from ..pipeline.stage0 import check_cue_config, run_stage0
from ._common import add_config_file_option, add_cue_options, add_force_option, check_videos_exist, run_config


def register(sub) -> None:
    p = sub.add_parser("cues", help="extract cues from videos into a cue bundle",
                       description="Stage 0 on real videos: moving regions, KLT tracks inside them, "
                                   "cross-view track pairs from keyframe SIFT matches and, between static "
                                   "cameras, from epipolar consistency over time, and cameras "
                                   "(imported with --calib or estimated with pycolmap). Writes a cue "
                                   "bundle folder (DESIGN.md, format v1) with cues_stats.json (timings, counts, left-out videos) in it.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("videos", nargs="+", type=Path, help="video files or image folders")
    p.add_argument("--out", type=Path, required=True, help="bundle folder to write")
    add_force_option(p, "--out")  # --overwrite: the old name, kept as an alias
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_config_file_option(p)
    add_cue_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    if args.out.exists() and any(args.out.iterdir()) and not args.force:
        raise InputError(f"{args.out} exists and is not empty (use --force)")
    cfg = run_config(args)
    check_cue_config(cfg.cues)  # before the output folder is touched
    check_videos_exist(args.videos)
    bundle, stats, inputs = run_stage0(args.videos, args.calib, args.fps, cfg.cues,
                                       progress=not args.no_progress)
    write_bundle(bundle, args.out, overwrite=args.force)
    write_cue_stats(stats, args.out, inputs, total_with_io_s=time.perf_counter() - t0)
    print(f"wrote {args.out}: {len(bundle.videos)} videos, {stats.tracks} tracks, "
          f"{stats.track_pairs} track pairs, {stats.registered_cameras} cameras "
          f"({stats.camera_source})")
    for name, why in stats.dropped.items():
        print(f"  {name}: left out: {why}")
    return 0 if len(bundle.videos) >= 2 else 2
