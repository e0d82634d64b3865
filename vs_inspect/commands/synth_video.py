"""vs-inspect synth-video: render a synthetic multi-camera scene into videos with exact truth."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..errors import InputError
from ..synth.videos import is_complete, render_scene
from ..synth.world import SceneConfig, make_scene
from ._common import add_force_option, positive_int


def add_image_and_clock_options(p: argparse.ArgumentParser, d) -> None:
    """--width, --height, --fps, --max-offset-s of a rendered scene (synth-video, bench timing),
    with d's values as defaults (a SceneConfig)."""
    p.add_argument("--width", type=positive_int, default=d.width, help="image width (px)")
    p.add_argument("--height", type=positive_int, default=d.height, help="image height (px)")
    p.add_argument("--fps", type=float, default=d.fps,
                   help="frame rate of every camera; 0 = drawn per camera from 24-60")
    p.add_argument("--max-offset-s", type=float, default=d.max_offset_s,
                   help="start offsets are drawn in ± this around cam0")


def register(sub) -> None:
    d = SceneConfig()
    p = sub.add_parser("synth-video", help="render a synthetic multi-camera scene (videos + truth)",
                       description="Renders a small dynamic 3D world (textured ground, walls and "
                                   "crates; a walking figure, a bouncing ball, a thrown ball and a "
                                   "spinning box) from static and hand-held cameras into H.264 "
                                   "videos, with gt.json, calibration.json, trajectories.npz and "
                                   "the true cue bundle (OUT/bundle).",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--out", type=Path, required=True, help="scene folder to write")
    p.add_argument("--cameras", type=int, default=d.cameras, help="number of cameras (videos)")
    p.add_argument("--moving", type=int, default=d.moving, help="how many are hand-held")
    p.add_argument("--seconds", type=float, default=d.seconds, help="length of the reference video")
    p.add_argument("--same-length", action="store_true",
                   help="every video lasts --seconds (else the others get 0.75-1.0 of it)")
    p.add_argument("--seed", type=int, default=d.seed, help="seed of everything random")
    add_image_and_clock_options(p, d)
    p.add_argument("--variable-rate", type=int, default=d.variable_rate,
                   help="static cameras with a variable frame rate")
    p.add_argument("--little-motion", type=int, default=d.little_motion,
                   help="extra cameras that look mostly away from the action")
    p.add_argument("--motion-blur", action="store_true", help="average renders over an open shutter")
    p.add_argument("--exposure", action="store_true", help="different exposure and white balance per camera")
    p.add_argument("--points-per-object", type=int, default=d.points_per_object,
                   help="tracked surface points per moving object (true cue bundle)")
    p.add_argument("--arc-deg", type=float, default=d.arc_deg,
                   help="spread the cameras over an arc of this many degrees (360 = all around)")
    p.add_argument("--crf", type=int, default=20, help="H.264 quality (lower = better, larger)")
    add_force_option(p, "--out")  # --overwrite: the old name, kept as an alias
    p.add_argument("--benchmark", action="store_true",
                   help="print a benchmark line (frames, seconds, frames/s) at the end")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if is_complete(out) and not args.force:
        raise InputError(f"{out} already holds a finished scene; pass --force to replace it")
    cfg = SceneConfig(cameras=args.cameras, moving=args.moving, seconds=args.seconds,
                      same_length=args.same_length,
                      width=args.width, height=args.height, fps=args.fps or None,
                      max_offset_s=args.max_offset_s, variable_rate=args.variable_rate,
                      little_motion=args.little_motion, motion_blur=args.motion_blur,
                      exposure=args.exposure, points_per_object=args.points_per_object, arc_deg=args.arc_deg,
                      seed=args.seed)
    scene = make_scene(cfg)
    t = render_scene(scene, out, crf=args.crf, progress=not args.no_progress)
    for c in scene.cameras:
        rate = f"{c.fps:g} fps" if c.fps else "variable frame rate"
        print(f"{c.name}: {c.role:<13} {c.width}x{c.height} {rate:<20} {c.num_frames:4d} frames  "
              f"offset {c.offset_s:+.4f} s")
    print(f"wrote {out} (videos, gt.json, calibration.json, trajectories.npz, bundle/)")
    if args.benchmark:
        print("benchmark: " + json.dumps({"cameras": len(scene.cameras), "frames": t["frames"],
                                          "size": f"{cfg.width}x{cfg.height}",
                                          "render_s": t["render_total_s"], "total_s": t["total_s"],
                                          "frames_per_s": t["frames_per_s"]}))
    return 0
