"""vs-inspect import-drone: the multi-view drone tracking dataset -> a pose-free cue bundle."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..io.drone import import_drone, write_drone_bundle
from ._common import add_force_option

LAYOUT = """folder layout (the multi-view drone tracking datasets):
  DIR/cameras.txt               "camK - model" per line; the order gives the camera ids
  DIR/detections/camK.txt       header, then "frame x y" (1-based frames, px; 0 0 = not detected)
  DIR/calibration/camK.json     "K-matrix", "distCoeff" [k1,k2,p1,p2[,k3]], "fps", "resolution"
  DIR/README.md                 optional: alpha/beta ground-truth tables -> gt.json
"""


def register(sub) -> None:
    p = sub.add_parser("import-drone", help="import the drone dataset's detections into a pose-free bundle",
                       description="Read per-camera drone detections and calibrations, undistort the "
                                   "detections, and write a cue bundle with one track per camera "
                                   "(cameras have K only: marked pose_free) and, when the README has "
                                   "the alpha/beta tables, gt.json with offset_s and drift_ppm per camera "
                                   "(reference = the first camera).",
                       epilog=LAYOUT, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folder", type=Path, help="dataset folder in the layout below")
    p.add_argument("--out", type=Path, required=True, help="cue bundle folder to write")
    add_force_option(p, "--out")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    bundle, gt = import_drone(args.folder)
    write_drone_bundle(bundle, gt, args.out, overwrite=args.force)
    seen = {n: int(np.isfinite(t.xy[0, :, 0]).sum()) for n, t in bundle.tracks.items()}
    print(f"wrote {args.out}: {len(bundle.videos)} pose-free cameras, one drone track each "
          f"(detections: {', '.join(f'{n} {k}' for n, k in seen.items())}), {len(bundle.pairs)} view pairs")
    if gt is not None:
        print("ground truth (reference " + gt.reference + "): " + ", ".join(
            f"{n} {gt.offsets_s[n]:+.4f} s {gt.drift_ppm[n]:+.1f} ppm" for n in bundle.names))
        print(f"README rows disagree with the reference row by up to {gt.row_inconsistency_frames:.2f} "
              f"frames over 10,000 frames")
    return 0
