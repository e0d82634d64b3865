"""vs-inspect import-visualsync: cues made by the VisualSync paper's tools -> a cue bundle."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..io.bundle import write_bundle
from ..io.visualsync import CAMERAS_FILE, PAIRS_DIR, TRACKS_FILE, ImportConfig, import_visualsync
from ._common import add_force_option, positive_float

LAYOUT = f"""folder layout:
  DIR/<video>/{TRACKS_FILE}             CoTracker: pickled dict, pred_tracks (T,N,2) px,
                                        pred_visibilities or pred_valid (T,N); numpy or torch
  DIR/<video>/{CAMERAS_FILE}  VGGT: c2w (F,4,4), K (F,3,3), valid (F,)
  DIR/<video>/*.mp4                     optional: the video (frame times and size)
  DIR/{PAIRS_DIR}/<a>__<b>.npz                filtered_corr_indices (P,2): (track in a, track in b)
"""


def register(sub) -> None:
    p = sub.add_parser("import-visualsync", help="import CoTracker/MASt3R/VGGT cues into a bundle",
                       description="Read per-video CoTracker tracks, VGGT cameras and filtered "
                                   "cross-view pairs made by the VisualSync paper's tools and "
                                   "write a cue bundle for 'vs-inspect sync --bundle'.",
                       epilog=LAYOUT, formatter_class=argparse.RawDescriptionHelpFormatter)
    d = ImportConfig()
    p.add_argument("folder", type=Path, help="folder in the layout below")
    p.add_argument("--out", type=Path, required=True, help="cue bundle folder to write")
    p.add_argument("--fps", type=positive_float, default=None,
                   help="frame rate of videos whose folder has no video file")
    p.add_argument("--calib", type=Path, default=None,
                   help="use this calibration (COLMAP folder, .json, .toml) instead of VGGT cameras")
    p.add_argument("--visibility-threshold", type=float, default=d.visibility_threshold,
                   help=f"visibility above which a track point counts as seen (default {d.visibility_threshold})")
    add_force_option(p, "--out")  # --overwrite: the old name, kept as an alias
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    cfg = ImportConfig(fps=args.fps, visibility_threshold=args.visibility_threshold)
    calibration = None
    if args.calib is not None:
        from ..io.calibration import load_calibration
        names = sorted(p.name for p in args.folder.iterdir() if (p / TRACKS_FILE).is_file()) \
            if args.folder.is_dir() else []
        calibration = load_calibration(args.calib, names)
    bundle = import_visualsync(args.folder, cfg, calibration)
    write_bundle(bundle, args.out, overwrite=args.force)
    print(f"wrote {args.out}: {len(bundle.videos)} videos "
          f"({sum(c.is_moving for c in bundle.cameras.values())} moving cameras), "
          f"{sum(t.num_tracks for t in bundle.tracks.values())} tracks, "
          f"{sum(len(p.index) for p in bundle.pairs.values())} track pairs in {len(bundle.pairs)} view pairs")
    return 0
