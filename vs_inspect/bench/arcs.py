"""Rendered scenes whose cameras share a view (an arc of 30-90°), through the whole pipeline with
estimated cameras: the safety benchmark of issue 19 ("no offset reported resolved with an error
over 2 frames"), counted per offset.

A scene is named a<arc>_c<cameras>m<hand-held>_s<seed>, e.g. a60_c4m1_s12: 60° arc, 4 cameras of
which 1 hand-held, seed 12, rendered as `vs-inspect synth-video --arc-deg 60 --cameras 4
--moving 1 --seed 12 --seconds 6` would render it (640×480, 30 fps).
"""

from __future__ import annotations

import re
import statistics
from dataclasses import dataclass

SCENE_SECONDS = 6.0
_NAME = re.compile(r"a(\d+)_c(\d+)m(\d+)_s(\d+)")

# stop 43's sweep, which the rules of stops 43-45 were built on (its square-pixel scenes need a
# scratch change of the renderer and are not here)
TUNING_SCENES = ("a30_c4m1_s9", "a45_c4m1_s4", "a45_c4m1_s5", "a60_c3m0_s0", "a60_c3m0_s1",
                 "a60_c4m1_s0", "a60_c4m1_s1", "a60_c4m1_s2", "a60_c4m1_s3", "a60_c4m1_s8",
                 "a60_c5m2_s7", "a90_c4m0_s3", "a90_c4m1_s2", "a90_c4m1_s6")
# seeds no rule was measured on (stop 46), the default
HELD_OUT_SCENES = ("a30_c4m1_s10", "a45_c4m1_s11", "a60_c4m1_s12", "a60_c4m1_s13", "a90_c4m1_s14",
                   "a60_c3m0_s15", "a45_c5m2_s16", "a30_c3m1_s17", "a60_c4m1_s18", "a90_c4m0_s19",
                   "a45_c4m1_s20", "a60_c5m2_s21")
# seeds no rule was measured on when stop 47's were (stop 48): held-out's mix of arcs and cameras
HELD_OUT_2_SCENES = ("a30_c4m1_s22", "a45_c4m1_s23", "a60_c4m1_s24", "a60_c4m1_s25", "a90_c4m1_s26",
                     "a60_c3m0_s27", "a45_c5m2_s28", "a30_c3m1_s29", "a60_c4m1_s30", "a90_c4m0_s31",
                     "a45_c4m1_s32", "a60_c5m2_s33")
# seeds rendered after every rule up to stop 53 (stop 54): the same mix again
HELD_OUT_3_SCENES = ("a30_c4m1_s34", "a45_c4m1_s35", "a60_c4m1_s36", "a60_c4m1_s37", "a90_c4m1_s38",
                     "a60_c3m0_s39", "a45_c5m2_s40", "a30_c3m1_s41", "a60_c4m1_s42", "a90_c4m0_s43",
                     "a45_c4m1_s44", "a60_c5m2_s45")
SCENE_SETS = {"held-out": HELD_OUT_SCENES, "tuning": TUNING_SCENES, "held-out-2": HELD_OUT_2_SCENES,
              "held-out-3": HELD_OUT_3_SCENES}


@dataclass(frozen=True)
class ArcScene:
    name: str
    arc_deg: float  # cameras spread over this arc (degrees)
    cameras: int
    moving: int  # how many of the cameras are hand-held
    seed: int

    def scene_config(self):
        from ..synth.world import SceneConfig

        return SceneConfig(cameras=self.cameras, moving=self.moving, seconds=SCENE_SECONDS,
                           arc_deg=self.arc_deg, seed=self.seed)


def parse_scene(name: str) -> ArcScene:
    """ArcScene from a name a<arc>_c<cameras>m<hand-held>_s<seed>; ValueError names what is wrong."""
    m = _NAME.fullmatch(name)
    if not m:
        raise ValueError(f"{name!r}: not a scene name a<arc>_c<cameras>m<hand-held>_s<seed> (e.g. a60_c4m1_s12)")
    arc, cams, moving, seed = (int(g) for g in m.groups())
    if not 0 < arc <= 360:
        raise ValueError(f"{name!r}: arc {arc}° is outside 1-360")
    if cams < 2 or moving > cams - 1:
        raise ValueError(f"{name!r}: needs at least 2 cameras and one of them static (got {cams}, {moving} hand-held)")
    return ArcScene(name, float(arc), cams, moving, seed)


def frame_errors(reference: str, offsets_s: dict[str, float | None], truth_s: dict[str, float],
                 fps: float) -> dict[str, float | None]:
    """Signed error of every non-reference video's offset in frames of 1/fps s (None: unresolved)."""
    out: dict[str, float | None] = {}
    ref_s = offsets_s.get(reference)
    for v, t in truth_s.items():
        if v == reference:
            continue
        est = offsets_s.get(v)
        out[v] = None if est is None or ref_s is None else fps * ((est - ref_s) - (t - truth_s[reference]))
    return out


@dataclass(frozen=True)
class ArcSummary:
    offsets: int  # non-reference videos over all scenes
    resolved: int
    within_1: int  # |error| <= 1 frame
    from_1_to_2: int  # 1 < |error| <= 2 frames
    over_2: int  # |error| > 2 frames: the safety target says 0
    median_abs_frames: float | None  # over the resolved offsets
    max_abs_frames: float | None


def summarize(errors: list[float | None]) -> ArcSummary:
    got = [abs(e) for e in errors if e is not None]
    return ArcSummary(offsets=len(errors), resolved=len(got),
                      within_1=sum(e <= 1 for e in got), from_1_to_2=sum(1 < e <= 2 for e in got),
                      over_2=sum(e > 2 for e in got),
                      median_abs_frames=statistics.median(got) if got else None,
                      max_abs_frames=max(got) if got else None)
