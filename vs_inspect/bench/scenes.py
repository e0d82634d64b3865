"""Rendered scenes with exact truth for the video benchmarks, by name.

    rendered_s<seed>  3 static + 1 hand-held camera, 5 s, 480x360, each camera at 24-60 fps, one
                      of them at a variable rate (the rendered rows of `vs-inspect bench accuracy`)
    demo              the demo's scene (4 cameras, one hand-held, 8 s, 640x480, mixed rates)
    a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed]
                      cameras spread over an arc of <arc> degrees, so that they share a view: 6 s,
                      640x480, 30 fps (with _mixed each camera's rate is drawn from 24-60 fps, as
                      phones and action cameras filming one event record); a60_c4m1_s12 is what
                      `vs-inspect synth-video --arc-deg 60 --cameras 4 --moving 1 --seed 12
                      --seconds 6` renders
"""

from __future__ import annotations

import dataclasses
import re

from ..synth.world import SceneConfig

RENDERED = SceneConfig(cameras=4, moving=1, seconds=5.0, width=480, height=360, fps=None,
                       variable_rate=1, seed=0)
ARC_SECONDS = 6.0
_ARC = re.compile(r"a(\d+)_c(\d+)m(\d+)_s(\d+)(_mixed)?")
_RENDERED = re.compile(r"rendered_s(\d+)")


def _arc_set(seeds: range, suffix: str = "") -> tuple[str, ...]:
    """12 scenes that mix arcs of 30-90°, 3-5 cameras and 0-2 hand-held ones the same way."""
    kinds = ("a30_c4m1", "a45_c4m1", "a60_c4m1", "a60_c4m1", "a90_c4m1", "a60_c3m0", "a45_c5m2",
             "a30_c3m1", "a60_c4m1", "a90_c4m0", "a45_c4m1", "a60_c5m2")
    return tuple(f"{k}_s{s}{suffix}" for k, s in zip(kinds, seeds, strict=True))


SCENE_SETS: dict[str, tuple[str, ...]] = {
    "rendered": ("rendered_s0", "rendered_s1", "rendered_s2"),
    "seeds-0-9": ("a30_c4m1_s9", "a45_c4m1_s4", "a45_c4m1_s5", "a60_c3m0_s0", "a60_c3m0_s1",
                  "a60_c4m1_s0", "a60_c4m1_s1", "a60_c4m1_s2", "a60_c4m1_s3", "a60_c4m1_s8",
                  "a60_c5m2_s7", "a90_c4m0_s3", "a90_c4m1_s2", "a90_c4m1_s6"),
    **{f"seeds-{lo}-{lo + 11}": _arc_set(range(lo, lo + 12)) for lo in (10, 22, 34, 46, 58)},
    "mixed-rates": _arc_set(range(70, 82), "_mixed"),
}
DEFAULT_SET = "rendered"


def scene_config(name: str) -> SceneConfig:
    """The SceneConfig of a scene name (module docstring); ValueError naming what is wrong."""
    if name == "demo":
        from ..commands.demo import DEMO_SCENE
        return DEMO_SCENE
    if m := _RENDERED.fullmatch(name):
        return dataclasses.replace(RENDERED, seed=int(m.group(1)))
    m = _ARC.fullmatch(name)
    if not m:
        raise ValueError(f"{name!r}: not a scene name: rendered_s<seed>, demo or "
                         "a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed] (e.g. a60_c4m1_s12)")
    arc, cameras, moving, seed = (int(g) for g in m.groups()[:4])
    if not 0 < arc <= 360:
        raise ValueError(f"{name!r}: arc {arc}° is outside 1-360")
    if cameras < 2 or moving > cameras - 1:
        raise ValueError(f"{name!r}: needs at least 2 cameras and one of them static "
                         f"(got {cameras}, {moving} hand-held)")
    return SceneConfig(cameras=cameras, moving=moving, seconds=ARC_SECONDS,
                       fps=None if m.group(5) else 30.0, arc_deg=float(arc), seed=seed)
