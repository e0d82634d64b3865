"""The small rendered scene the video benchmarks' tests run (rendered once per test process)."""

from __future__ import annotations

import json

import pytest

from vs_inspect.bench.videos import VideoSet
from vs_inspect.synth.videos import render_unless_cached
from vs_inspect.synth.world import SceneConfig

# 4 static cameras, 4 s of 320x240 at 15 fps, offsets within ±0.4 s: a small scene (its run with
# the calibration takes seconds; measured: every offset within 0.5 frame)
SMALL = SceneConfig(cameras=4, moving=0, seconds=4.0, same_length=True, width=320, height=240,
                    fps=15.0, max_offset_s=0.4, seed=2)


@pytest.fixture(scope="session")
def small(tmp_path_factory) -> VideoSet:
    """SMALL rendered, with its calibration given to the run (and kept as the true cameras)."""
    folder = tmp_path_factory.mktemp("small_scene")
    render_unless_cached(folder, SMALL, progress=False)
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    calib = folder / "calibration.json"
    return VideoSet("small", tuple(sorted(folder.glob("cam*.mp4"))), truth, dict.fromkeys(truth, 15.0),
                    calib, calib)
