"""How right Stage 0's cross-view track pairs are on a rendered scene (true cameras and offsets
known), and what Stage 1 + 2 make of them (vs-inspect bench-pairing).

    rendered  the bench's rendered scene (3 static + 1 hand-held camera, 5 s, 480x360; --seed N
              another one)
    demo      the demo's scene (8 s, 640x480, hand-held cam3)

A pair is right when, at the true offset and with the true cameras, the two tracks lie on each
other's epipolar lines (Sampson < 2 px) at most of their common moments (bench/pairing.py);
"possible" is the most one-to-one right pairs among all tracks (recall's denominator).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np  # before pycolmap

from ..synth.world import SceneConfig

RENDERED = SceneConfig(cameras=4, moving=1, seconds=5.0, width=480, height=360, fps=None,
                       variable_rate=1, seed=0)  # bench.videos.rendered_scene(0)


def scene_of(which: str, seed: int = 0) -> tuple[SceneConfig, str]:
    """(the scene to render, its folder's name) of "rendered" (with its seed) or "demo"."""
    if which == "demo":
        from ..commands.demo import DEMO_SCENE

        return DEMO_SCENE, "demo"
    if which != "rendered":
        raise ValueError(f"unknown scene {which!r}: rendered or demo")
    return dataclasses.replace(RENDERED, seed=seed), "rendered" if seed == 0 else f"rendered_s{seed}"


def run_pairing_bench(which: str, workdir: Path, joint: bool, seed: int, say: Callable[[str], None]) -> None:
    """Renders the scene into workdir (reused when rendered already), runs Stage 0 with its
    calibration and says each pair's precision and recall, then each video's offset error."""
    from ..cues import CueConfig
    from ..io.calibration import load_calibration, to_camera_track
    from ..pipeline.config import RunConfig
    from ..pipeline.run import run
    from ..pipeline.stage0 import run_stage0
    from ..synth.videos import render_unless_cached
    from .pairing import bundle_pair_truth

    cfg, name = scene_of(which, seed)
    folder = workdir / name
    render_unless_cached(folder, cfg, progress=False)
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    videos = sorted(folder.glob("cam*.mp4"))
    cue = CueConfig()
    cue = dataclasses.replace(cue, geometric=dataclasses.replace(cue.geometric, joint=joint))
    bundle, stats, _ = run_stage0(videos, folder / "calibration.json", None, cue, progress=False)
    calib = load_calibration(folder / "calibration.json", [v.stem for v in videos])
    cams = {n: to_camera_track(c) for n, c in calib.items()}
    say(f"{which}, geometric pairs {'joint' if joint else 'triangles'}: Stage 0 {stats.timings_s['total_s']:.0f} s")
    say("| pair | pairs | judged | right | possible | precision | recall |")
    say("|---|---|---|---|---|---|---|")
    tot = np.zeros(4, int)
    for (a, b), r in bundle_pair_truth(bundle, cams, truth).items():
        say(f"| {a}__{b} | {r.pairs} | {r.judged} | {r.right} | {r.possible} | {r.precision:.2f} | {r.recall:.3f} |")
        tot += [r.pairs, r.judged, r.right, r.possible]
    say(f"| all | {tot[0]} | {tot[1]} | {tot[2]} | {tot[3]} | {tot[2] / max(tot[1], 1):.2f} | "
        f"{tot[2] / max(tot[3], 1):.3f} |")
    res = run(bundle, RunConfig(), progress=False)
    frame = {v.name: v.frame_interval_s for v in bundle.videos}
    for n in sorted(truth):
        off, t = res.offsets_s.get(n), truth[n] - truth[res.reference]
        if off is None:
            say(f"{n}: null ({res.unresolved_headline.get(n, '') if res.unresolved_headline else ''})")
        else:
            say(f"{n}: {off:+.4f} s, true {t:+.4f} s, error {1000 * (off - t):+.1f} ms "
                f"({(off - t) / frame[n]:+.2f} frames)")
