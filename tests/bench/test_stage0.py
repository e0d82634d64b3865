"""vs-inspect bench-stage0: its options, the caliscope cut's truth and the VisualSync clips' names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vs_inspect.bench.arcs import DEFAULT_SET
from vs_inspect.bench.stage0 import camera_config, caliscope_truth, track_config, visualsync_truth
from vs_inspect.cli import build_parser


def _args(*argv):
    return build_parser().parse_args(["bench-stage0", *argv])


def test_each_benchmark_parses_its_options():
    a = _args("arcs")
    assert a.what == "arcs" and a.set == DEFAULT_SET and a.scenes is None and not a.calibrated
    assert camera_config(a).features == "auto"
    c = _args("caliscope", "--trials", "2", "--estimate", "--features", "sift", "--sfm-frames", "5", "20",
              "--klt-window", "21", "--no-anchor")
    assert (c.trials, c.estimate, c.board, c.data) == (2, True, False, None)
    cam, tr = camera_config(c), track_config(c)
    assert (cam.features, cam.static_frames, cam.moving_frames) == ("sift", 5, 20)
    assert (tr.win_size, tr.anchor_refine) == (21, False)
    assert _args("visualsync", "--scenes", "blenderbox").scenes == ["blenderbox"]
    assert _args("rendered", "--seeds", "4").seeds == [4]
    assert _args("speed").seconds == 10
    with pytest.raises(SystemExit):
        _args("arcs", "--set", "nonsense")
    with pytest.raises(SystemExit):
        _args("speed", "--features", "sift")  # camera options belong to the benchmarks that estimate


def test_caliscope_truth_is_each_cut_clips_first_frame_time():
    ft = {"cam_0": np.array([10.0, 10.2, 10.4]), "cam_1": np.array([10.05, 10.25, 10.45])}
    truth = caliscope_truth(ft, {"cam_0": 2, "cam_1": 0})
    assert truth == {"cam_0": 10.4, "cam_1": 10.05}
    # offset of cam_1 against cam_0 (DESIGN.md): its local time 0 is 0.35 s before cam_0's
    assert truth["cam_1"] - truth["cam_0"] == pytest.approx(-0.35)


def test_visualsync_truth_reads_the_start_frame_at_10_fps():
    names = ["blenderbox_cam10_12_140_0.mp4", "blenderbox_cam13_0_128_0.mp4"]
    assert visualsync_truth([Path("/clips") / n for n in names]) == {"blenderbox_cam10_12_140_0": 1.2,
                                                                      "blenderbox_cam13_0_128_0": 0.0}
    with pytest.raises(ValueError, match="not a VisualSync clip name"):
        visualsync_truth(["cam0.mp4"])
