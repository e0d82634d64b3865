"""Stage 0's acceptance rules and camera paths by name, in the order they apply, each with what it
does in one line. A run takes them all; `vs-inspect bench rules` leaves each out in turn to
measure what it is worth (BENCHMARKS.md)."""

from __future__ import annotations

import dataclasses

from ..sync.config import SyncConfig

RULES: dict[str, str] = {
    # the camera sets tried, in order, when the cameras are estimated
    "second_model": "XFeat's model is voted on when SIFT's cameras leave a video untrusted",
    "third_model": "ALIKED's model is voted on when the kept set still leaves a video untrusted",
    "joint_coarse_offsets": "the moving points' cameras are fitted at coarse offsets chosen with every pair at once",
    "two_point_cameras": "only two cameras from the moving points are refused (their F and offset share the same pairs)",
    "points_when_untrusted": "the moving points' cameras are voted on when no model's vote trusts any video",
    # the joint vote on one camera set
    "margin": "a camera is sure only when its joint offset beats every other choice by a summed z-score of 5",
    "three_view": "estimated cameras: a sure camera must see the other sure cameras' triangulated points",
    "rival_offset": "a sure camera with a rival offset in three views (a repeated motion) is not sure",
    "transfer": "an unsure camera is made sure when point transfer confirms its joint offset",
    "moving_pair_third": "two moving cameras' joint Δ needs a third sure camera",
    "descriptor_filter": "descriptor pairs are kept only where consistent at the joint Δ",
    "triangle_fallback": "when the joint vote is sure of fewer than two cameras, vote peaks that close every triangle decide",
    "lone_moving_pair": "a pair with a moving camera and no triangle keeps no geometric pairs",
    # Stage 1's checks of what Stage 0 handed over
    "unchecked_agree": "Stage 1: a pair with unchecked geometric pairs needs its other pairs' minimum to agree",
    "chosen_agree": "Stage 1: a minimum more than 2 frames from the Δ Stage 0 kept the pairs at is refused",
}

ALL = frozenset(RULES)


def stage1_config(sync: SyncConfig, rules: frozenset[str]) -> SyncConfig:
    """sync with Stage 1's checks of Stage 0's hand-over left out unless in rules."""
    d = sync.decision
    return dataclasses.replace(sync, decision=dataclasses.replace(
        d, unchecked_agree_frames=d.unchecked_agree_frames if "unchecked_agree" in rules else 0.0,
        chosen_agree_frames=d.chosen_agree_frames if "chosen_agree" in rules else 0.0))
