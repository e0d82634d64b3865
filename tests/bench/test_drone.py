"""bench drone's per-camera errors (the slow full run is `vs-inspect bench drone`)."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.bench.drone import camera_errors
from vs_inspect.sync.drift import DriftSolution
from vs_inspect.types import CameraTrack, CueBundle, Tracks, VideoInfo


def test_camera_errors_in_frames_and_ppm():
    videos = (VideoInfo.constant_rate("r", 640, 480, 600, 60.0), VideoInfo.constant_rate("v", 640, 480, 300, 25.0))
    bundle = CueBundle(videos, {v.name: CameraTrack(np.eye(3) * [500, 500, 1], np.eye(4)) for v in videos},
                       {v.name: Tracks(np.zeros((1, v.num_frames, 2))) for v in videos}, {})
    sol = DriftSolution("r", {"r": 0.0, "v": 2.02}, {"r": 0.0, "v": 150.0}, {}, {}, {}, True)
    errs = camera_errors(sol, bundle, {"r": 0.0, "v": 2.0}, {"r": 0.0, "v": 50.0})
    e = errs["v"]
    assert e.offset_err_frames == pytest.approx(0.02 * 25)
    assert e.drift_err_ppm == pytest.approx(100.0)
    # worst at the last frame (local time 299/25 s): 20 ms + 100 ppm of 11.96 s, in 25 fps frames
    assert e.worst_err_frames == pytest.approx((0.02 + 100e-6 * 299 / 25) * 25)
    assert errs["r"].offset_err_frames == 0.0 and errs["r"].worst_err_frames == 0.0
    # a camera the solution left out has no error
    sol_r = DriftSolution("r", {"r": 0.0}, {"r": 0.0}, {}, {}, {}, True)
    assert camera_errors(sol_r, bundle, {"r": 0.0, "v": 2.0}, {"r": 0.0, "v": 50.0})["v"] is None
