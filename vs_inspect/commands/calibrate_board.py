"""vs-inspect calibrate-board: cameras of a rig from a ChArUco board waved in unsynchronized videos."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import positive_float
from ..errors import InputError


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate-board", help="estimate the cameras of a rig from a ChArUco board in its videos",
        description="Cameras from a ChArUco board waved in front of the rig, without synchronized "
                    "frames: intrinsics per camera (OpenCV calibrateCamera), then for each pair the "
                    "time offset at which the board poses of both videos agree and the relative pose "
                    "there (the pose most frame pairings fit, MSAC, refined by scipy least_squares). "
                    "Writes the calibration JSON that --calib reads (the first placed camera is the "
                    "world frame). For static cameras.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("videos", nargs="+", type=Path, help="video files or image folders")
    p.add_argument("--board", type=Path, required=True,
                   help="board description: caliscope charuco.toml (columns, rows, dictionary, "
                        "aruco_scale, square_size_override_cm or board size and units, inverted)")
    p.add_argument("--out", type=Path, required=True, help="calibration JSON to write")
    p.add_argument("--fps", type=positive_float, default=None, help="frame rate of image folders")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..io.board import load_board
    from ..io.atomic import write_json_atomic
    from ..io.calibration import rig_to_json
    from ..pipeline.board import estimate_from_board
    from ..pipeline.stage0 import open_sources

    if len(args.videos) < 2:
        raise InputError(f"need at least 2 videos of the rig, got {len(args.videos)}")
    load_board(args.board)  # a bad board file fails before any decoding
    sources, _, dropped = open_sources(args.videos, args.fps)
    if len(sources) < 2:
        raise InputError("fewer than 2 readable videos (" +
                         "; ".join(f"{n}: {r}" for n, r in dropped.items()) + ")")
    rig, seconds = estimate_from_board(sources, args.board, progress=not args.no_progress)
    if len(rig.cameras) < 2:
        why = "; ".join(f"{n}: {r}" for n, r in {**dropped, **rig.unregistered}.items())
        raise InputError(f"the board placed fewer than 2 cameras ({why})")
    data = rig_to_json(rig)
    data["unregistered"].update(dropped)
    path = write_json_atomic(data, args.out)
    print(f"wrote {path}: {len(rig.cameras)} cameras in {seconds:.1f} s")
    for n, info in data["board"].items():
        where = (f"placed from {info['placed_from']} at coarse offset {info['coarse_offset_s']:+.3f} s, "
                 f"median board error {info['median_reprojection_px']:.2f} px"
                 if "placed_from" in info else ("world frame" if n in rig.cameras else "not placed"))
        print(f"  {n}: {info['views']} board views, calibration RMS {info['rms_px']:.2f} px; {where}")
    for n, why in data["unregistered"].items():
        print(f"  {n}: no camera: {why}")
    return 0
