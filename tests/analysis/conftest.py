"""A clean synthetic scene (exact cameras, no noise, no wrong pairs) shared by the analysis tests."""

from __future__ import annotations

import dataclasses

import pytest

from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene


@pytest.fixture(scope="package")
def clean_bundle():
    """Three cameras (one moving, one at a variable frame rate), bundle with the true cameras."""
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=1, variable_rate=1, seconds=4.0,
                                          points_per_object=10, noise_px=0.0, wrong_fraction=0.0,
                                          pose_error_deg=0.0, no_match_pairs=0, all_wrong_pair=False,
                                          seed=5))
    return dataclasses.replace(scene.bundle, cameras=scene.true_cameras)
