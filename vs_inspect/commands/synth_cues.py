"""vs-inspect synth-cues: write a synthetic cue bundle with gt.json."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..io.bundle import write_bundle
from ..synth.cues import CueSceneConfig, make_cue_scene
from ._common import add_force_option


def register(sub) -> None:
    p = sub.add_parser("synth-cues", help="write a synthetic cue bundle with true offsets",
                       description="A cue-level synthetic scene: moving 3D points seen by static "
                                   "and moving cameras, with noise, fragmented tracks, wrong pairs "
                                   "and pose errors. Writes a bundle folder with gt.json.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    d = CueSceneConfig()
    p.add_argument("--out", type=Path, required=True, help="bundle folder to write")
    p.add_argument("--cameras", type=int, default=d.cameras, help="number of videos")
    p.add_argument("--moving", type=int, default=d.moving, help="moving (hand-held) cameras")
    p.add_argument("--variable-rate", type=int, default=d.variable_rate, help="variable frame rate videos")
    p.add_argument("--seconds", type=float, default=d.seconds, help="typical video length")
    p.add_argument("--noise-px", type=float, default=d.noise_px, help="pixel noise, 1-sigma")
    p.add_argument("--wrong-fraction", type=float, default=d.wrong_fraction, help="share of wrong track pairs")
    p.add_argument("--pose-error-deg", type=float, default=d.pose_error_deg, help="rotation error of the written poses")
    p.add_argument("--no-match-pairs", type=int, default=d.no_match_pairs, help="view pairs without track pairs")
    p.add_argument("--no-all-wrong-pair", action="store_true", help="do not plant a pair with all-wrong matches")
    p.add_argument("--seed", type=int, default=d.seed)
    p.add_argument("--drift-ppm", type=float, default=d.drift_ppm,
                   help="clock drift of every non-reference video, ± this many ppm (gt.json gets drift_ppm)")
    add_force_option(p, "--out")  # --overwrite: the old name, kept as an alias
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    cfg = CueSceneConfig(cameras=args.cameras, moving=args.moving, variable_rate=args.variable_rate,
                         seconds=args.seconds, noise_px=args.noise_px, wrong_fraction=args.wrong_fraction,
                         pose_error_deg=args.pose_error_deg, no_match_pairs=args.no_match_pairs,
                         all_wrong_pair=not args.no_all_wrong_pair, seed=args.seed,
                         drift_ppm=args.drift_ppm)
    scene = make_cue_scene(cfg)
    write_bundle(scene.bundle, args.out, overwrite=args.force)
    b = scene.bundle
    print(f"wrote {args.out}: {len(b.videos)} videos, {sum(t.num_tracks for t in b.tracks.values())} "
          f"tracks, {len(b.pairs)} view pairs with track pairs")
    if scene.all_wrong_pair:
        print(f"planted all-wrong pair: {scene.all_wrong_pair[0]}__{scene.all_wrong_pair[1]}")
    return 0
