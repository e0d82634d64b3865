"""bench drift's error bookkeeping (the full run is `vs-inspect bench drift`)."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.bench.drift_cues import DriftSceneRow, end_errors, summarize
from vs_inspect.result_types import SyncResult
from vs_inspect.types import CameraTrack, CueBundle, Tracks, VideoInfo


def _bundle():
    videos = (VideoInfo.constant_rate("r", 64, 48, 101, 10.0), VideoInfo.constant_rate("v", 64, 48, 201, 20.0))
    return CueBundle(videos, {v.name: CameraTrack(np.eye(3), np.eye(4)) for v in videos},
                     {v.name: Tracks(np.zeros((1, v.num_frames, 2))) for v in videos}, {},
                     {"r": 0.0, "v": 1.0}, gt_drift_ppm={"r": 0.0, "v": 200.0})


def test_end_error_counts_the_drift_over_the_video():
    b = _bundle()
    const = SyncResult("r", {"r": 0.0, "v": 1.0}, {}, {}, (), (), ())
    ends, derr = end_errors(const, b)
    # exact at local time 0, but 200 ppm of the last frame's 10 s short at the end
    assert ends["v"] == pytest.approx(200e-6 * 10.0 * 1e3)
    assert derr["v"] == pytest.approx(-200.0)
    drift = SyncResult("r", {"r": 0.0, "v": 1.0}, {}, {}, (), (), (), drift_ppm={"r": 0.0, "v": 200.0})
    ends, derr = end_errors(drift, b)
    assert ends["v"] == pytest.approx(0.0, abs=1e-9) and derr["v"] == pytest.approx(0.0)


def test_summary_has_both_models():
    rows = [DriftSceneRow("s", "drift", {"v": 1.0}, {"v": 2.0}, {"v": 10.0}, 1.0),
            DriftSceneRow("s", "constant", {"v": 3.0}, {"v": None}, {"v": None}, 1.0)]
    text = summarize(rows).splitlines()
    assert text[1].split()[:3] == ["drift", "1", "1.00"] and text[2].split()[:3] == ["constant", "1", "3.00"]
