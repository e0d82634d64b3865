"""Video sets with true offsets and their runs through pipeline.run: the truths, the errors, and
a small rendered scene end to end (its run folder, its errors, the accuracy suite's rows)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.bench.suite import PlanOptions, run_videos
from vs_inspect.bench.videos import (VideoSet, caliscope_truth, clip_set, clip_truth, offset_errors_s,
                                     run_set, summarize)
from vs_inspect.errors import InputError
from vs_inspect.pipeline.config import RunConfig

def test_caliscope_truth_is_each_cut_clips_first_frame_time():
    ft = {"cam_0": np.array([10.0, 10.2, 10.4]), "cam_1": np.array([10.05, 10.25, 10.45])}
    truth = caliscope_truth(ft, {"cam_0": 2, "cam_1": 0})
    assert truth == {"cam_0": 10.4, "cam_1": 10.05}
    # offset of cam_1 against cam_0 (DESIGN.md): its local time 0 is 0.35 s before cam_0's
    assert truth["cam_1"] - truth["cam_0"] == pytest.approx(-0.35)


def test_clip_truth_reads_the_start_frame_at_10_fps(shared_data):
    names = ["blenderbox_cam10_12_140_0.mp4", "blenderbox_cam13_0_128_0.mp4"]
    assert clip_truth([Path("/clips") / n for n in names]) == {"blenderbox_cam10_12_140_0": 1.2,
                                                               "blenderbox_cam13_0_128_0": 0.0}
    with pytest.raises(InputError, match="not a VisualSync clip name"):
        clip_truth(["cam0.mp4"])
    vs = clip_set(shared_data, "fencing1")
    assert vs.name == "clips/fencing1" and len(vs.videos) == 3 and vs.calibration is None
    assert set(vs.fps.values()) == {10.0} and set(vs.truth_s) == {p.stem for p in vs.videos}
    with pytest.raises(InputError, match="fewer than 2 clips"):
        clip_set(shared_data, "no_such_scene")


def test_errors_against_the_results_reference_in_the_slower_videos_frames():
    truth = {"cam0": 0.0, "cam1": 0.5, "cam2": -1.0}
    # cam1 is the reference used; cam2 1/30 s late against it, cam0 unresolved
    err = offset_errors_s("cam1", {"cam0": None, "cam1": 0.0, "cam2": -1.5 + 1 / 30}, truth)
    assert err["cam0"] is None and err["cam2"] == pytest.approx(1 / 30) and "cam1" not in err
    assert offset_errors_s("cam0", {"cam0": None, "cam1": 0.0, "cam2": 0.0}, truth) == {"cam1": None, "cam2": None}
    s = summarize([0.2, -0.9, 1.5, -2.5, None, 36.6], [0.01, -0.03, 0.05, -0.08, None, 1.2])
    assert (s.offsets, s.resolved, s.within_1, s.from_1_to_2, s.over_2) == (6, 5, 2, 1, 2)
    assert s.median_abs_frames == pytest.approx(1.5) and s.max_abs_frames == pytest.approx(36.6)
    assert s.median_abs_ms == pytest.approx(50.0) and s.max_abs_ms == pytest.approx(1200.0)
    empty = summarize([None, None], [None, None])
    assert (empty.resolved, empty.over_2, empty.median_abs_frames, empty.max_abs_ms) == (0, 0, None, None)


@pytest.mark.timeout(900)
def test_a_run_folder_holds_what_a_user_run_gives_and_the_errors(small, tmp_path):
    run = run_set(small, RunConfig(), tmp_path / "run")
    assert (tmp_path / "run" / "result.json").is_file() and (tmp_path / "run" / "cues" / "bundle.json").is_file()
    written = json.loads((tmp_path / "run" / "result.json").read_text())
    assert written["gt_offsets_s"] == small.truth_s  # the truth is kept in the result
    off, ref, truth = written["offsets_s"], written["reference"], small.truth_s
    assert ref == run.result.reference and set(run.errors_s) == set(truth) - {ref}
    for v, e in run.errors_s.items():  # the errors are the written result's (measured: 0.08-0.5 frame)
        assert e == pytest.approx((off[v] - off[ref]) - (truth[v] - truth[ref]), abs=1e-9)
        assert run.errors_frames[v] == pytest.approx(15.0 * e) and abs(run.errors_frames[v]) < 2.0


def run_a100(vs: VideoSet) -> float:
    """A@100 of a plain `vs-inspect sync`-style run of the set (pipeline.run, default settings)."""
    from vs_inspect.eval.metrics import evaluate_offsets
    from vs_inspect.pipeline import run

    res = run(list(vs.videos), calibration=vs.calibration, progress=False)
    return evaluate_offsets(res.offsets_s, vs.truth_s, res.reference).a100


@pytest.mark.timeout(900)
def test_the_accuracy_suites_video_rows_come_from_the_run_and_its_bundle(small):
    rows = run_videos(small, "rendered/small", "rendered", PlanOptions(residuals=("sampson",), pair_seeds=(0,)))
    by = {(r.method, r.variant): r for r in rows}
    default = by[("vs_inspect", "default")]
    assert default.unresolved == 0 and default.videos == 4 and not default.error
    assert default.a100 == pytest.approx(run_a100(small), abs=1e-6)  # the run's own offsets, scored
    assert math.isfinite(default.stage0_s) and default.stage0_s > 0 and math.isfinite(default.stage1_s)
    # the ablations ran on the cue bundle the run wrote, and the exact cameras give the same cues
    assert {("vs_inspect", "solver=ls"), ("vs_inspect", "filter=off"), ("vs_inspect", "stage1-only"),
            ("vs_inspect", "pairs=rst/seed=0"), ("vs_inspect", "cameras=true")} <= set(by)
    assert by[("vs_inspect", "cameras=true")].a100 == pytest.approx(default.a100, abs=1e-6)
    assert not by[("motion-xcorr", "default")].error and not by[("ransac-inlier", "default")].error
