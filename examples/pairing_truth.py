"""How right Stage 0's cross-view track pairs are on a rendered scene (true cameras and offsets
known), and what Stage 1 + 2 make of them.

    # the bench's rendered scene (3 static + 1 hand-held camera, 5 s, 480x360); --seed N another one
    PYTHONPATH=. python examples/pairing_truth.py rendered --workdir /tmp/vs_scenes
    # the demo's scene (8 s, 640x480, hand-held cam3), each way of choosing geometric pairs
    PYTHONPATH=. python examples/pairing_truth.py demo --geometric triangles

A pair is right when, at the true offset and with the true cameras, the two tracks lie on each
other's epipolar lines (Sampson < 2 px) at most of their common moments (bench/pairing.py);
"possible" is the most one-to-one right pairs among all tracks (recall's denominator).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np  # noqa: F401  (before pycolmap)

from vs_inspect.bench.pairing import bundle_pair_truth
from vs_inspect.commands.demo import DEMO_SCENE
from vs_inspect.cues import CueConfig
from vs_inspect.io.calibration import load_calibration, to_camera_track
from vs_inspect.pipeline.config import RunConfig
from vs_inspect.pipeline.run import run
from vs_inspect.pipeline.stage0 import run_stage0
from vs_inspect.synth.videos import render_unless_cached
from vs_inspect.synth.world import SceneConfig

RENDERED = SceneConfig(cameras=4, moving=1, seconds=5.0, width=480, height=360, fps=None,
                       variable_rate=1, seed=0)  # bench.videos.rendered_scene(0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", choices=["rendered", "demo"])
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/vs_pairing_scenes"),
                    help="render into (and reuse finished renderings from) this folder")
    ap.add_argument("--geometric", choices=["joint", "triangles"], default="joint")
    ap.add_argument("--seed", type=int, default=0, help="the rendered scene's seed (bench: 0)")
    args = ap.parse_args()
    cfg = dataclasses.replace(RENDERED, seed=args.seed) if args.scene == "rendered" else DEMO_SCENE
    folder = args.workdir / (f"rendered_s{args.seed}" if args.scene == "rendered" and args.seed else args.scene)
    render_unless_cached(folder, cfg, progress=False)
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    videos = sorted(folder.glob("cam*.mp4"))
    cue = CueConfig()
    cue = dataclasses.replace(cue, geometric=dataclasses.replace(cue.geometric, joint=args.geometric == "joint"))
    bundle, stats, _ = run_stage0(videos, folder / "calibration.json", None, cue, progress=False)
    calib = load_calibration(folder / "calibration.json", [v.stem for v in videos])
    cams = {n: to_camera_track(c) for n, c in calib.items()}
    print(f"{args.scene}, geometric pairs {args.geometric}: Stage 0 {stats.timings_s['total_s']:.0f} s")
    print("| pair | pairs | judged | right | possible | precision | recall |")
    print("|---|---|---|---|---|---|---|")
    tot = np.zeros(4, int)
    for (a, b), r in bundle_pair_truth(bundle, cams, truth).items():
        print(f"| {a}__{b} | {r.pairs} | {r.judged} | {r.right} | {r.possible} | {r.precision:.2f} | {r.recall:.3f} |")
        tot += [r.pairs, r.judged, r.right, r.possible]
    print(f"| all | {tot[0]} | {tot[1]} | {tot[2]} | {tot[3]} | {tot[2] / max(tot[1], 1):.2f} | "
          f"{tot[2] / max(tot[3], 1):.3f} |")
    res = run(bundle, RunConfig(), progress=False)
    frame = {v.name: v.frame_interval_s for v in bundle.videos}
    for n in sorted(truth):
        off, t = res.offsets_s.get(n), truth[n] - truth[res.reference]
        if off is None:
            print(f"{n}: null ({res.unresolved.get(n, '')[:160]})")
        else:
            print(f"{n}: {off:+.4f} s, true {t:+.4f} s, error {1000 * (off - t):+.1f} ms "
                  f"({(off - t) / frame[n]:+.2f} frames)")


if __name__ == "__main__":
    main()
