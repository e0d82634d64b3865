"""result.json: version 2 (the drift model) written and read back; version 1 files still read."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.errors import InputError
from vs_inspect.io.result import read_run_result, run_result_to_dict, write_run_result
from vs_inspect.pipeline import RunConfig, run
from vs_inspect.sync.config import DriftConfig, SyncConfig
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

SMALL = CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=6.0, pairs_per_view_pair=150,
                       max_offset_s=1.0, no_match_pairs=0, all_wrong_pair=False, seed=3, drift_ppm=200.0)


@pytest.fixture(scope="module")
def drift_result():
    scene = make_cue_scene(SMALL)
    return scene, run(scene.bundle, RunConfig(sync=SyncConfig(drift=DriftConfig(enabled=True))), progress=False)


def test_v2_round_trip_with_drift(drift_result, tmp_path):
    scene, res = drift_result
    assert res.drift_ppm is not None and set(res.drift_ppm) == set(res.offsets_s)
    assert res.gt_drift_ppm == scene.bundle.gt_drift_ppm
    data = json.loads(write_run_result(res, tmp_path).read_text())
    assert data["version"] == 2 and data["time_model"] == "drift"
    assert set(data["drift_ppm"]) == set(data["offsets_s"]) == set(data["drift_std_ppm"])
    assert all(v is None or math.isfinite(v) for v in data["uncertainty_s"].values())
    accepted = [p for p in data["pairs"] if p["accepted"]]
    assert accepted and all({"rate", "drift_ppm", "drift_std_ppm", "pivot_s", "pivot_offset_s",
                             "rate_landscape"} <= set(p) for p in accepted)
    back = read_run_result(tmp_path)
    assert back.drift_ppm == res.drift_ppm and back.drift_std_ppm == res.drift_std_ppm
    rl, rl_back = res.pairs[0].rate_landscape, back.pairs[0].rate_landscape
    if rl is not None:
        assert np.allclose(rl.energy, rl_back.energy, equal_nan=True) and rl_back.energy.shape == rl.energy.shape
    assert run_result_to_dict(back) == data


def test_the_confirmation_of_unchecked_track_pairs_round_trips(drift_result, tmp_path):
    """A pair whose unchecked track pairs were checked keeps the others' landscape and minimum;
    a pair without the check has neither, and a confirm_energy of the wrong length is refused."""
    import dataclasses
    _, res = drift_result
    first = res.pairs[0]
    confirm = np.where(np.arange(len(first.offsets_s)) % 5 == 0, np.nan, np.linspace(1.0, 2.0, len(first.offsets_s)))
    pairs = (dataclasses.replace(first, confirm_energy=confirm, confirm_offset_s=0.125),) + tuple(res.pairs[1:])
    data = json.loads(write_run_result(dataclasses.replace(res, pairs=pairs), tmp_path).read_text())
    assert data["pairs"][0]["confirm_offset_s"] == 0.125
    assert all("confirm_offset_s" not in p for p in data["pairs"][1:])
    back = read_run_result(tmp_path)
    assert np.array_equal(back.pairs[0].confirm_energy, confirm, equal_nan=True)
    assert back.pairs[0].confirm_offset_s == 0.125 and back.pairs[1].confirm_energy is None
    assert run_result_to_dict(back) == data
    data["pairs"][0]["confirm_energy"] = data["pairs"][0]["confirm_energy"][:3]
    (tmp_path / "result.json").write_text(json.dumps(data))
    with pytest.raises(InputError, match="confirm_energy"):
        read_run_result(tmp_path)


def test_v1_file_still_reads(tmp_path):
    v1 = {"format": "vs-inspect-result", "version": 1, "reference": "a",
          "offsets_s": {"a": 0.0, "b": 1.5}, "uncertainty_s": {"a": 0.0, "b": 0.001}, "unresolved": {},
          "pairs": [{"a": "a", "b": "b", "offset_s": 1.5, "accepted": True, "reason": "ok",
                     "uncertainty_s": 0.001, "minima_offsets_s": [1.5]}],
          "solve": {"solver": "irls", "pairs": [["a", "b"]], "iterations": []}, "timings_s": {}}
    (tmp_path / "result.json").write_text(json.dumps(v1))
    r = read_run_result(tmp_path)
    assert r.offsets_s == {"a": 0.0, "b": 1.5} and r.drift_ppm is None
    assert r.pairs[0].rate == 1.0 and r.pairs[0].rate_landscape is None
    assert run_result_to_dict(r)["time_model"] == "constant"
    v9 = dict(v1, version=9)
    (tmp_path / "result.json").write_text(json.dumps(v9))
    with pytest.raises(InputError, match="version 9"):
        read_run_result(tmp_path)


def test_eval_prints_frames_and_ppm(tmp_path, capsys):
    (tmp_path / "result.json").write_text(json.dumps(
        {"version": 2, "reference": "a", "offsets_s": {"a": 0.0, "b": 1.01},
         "drift_ppm": {"a": 0.0, "b": 150.0}}))
    (tmp_path / "gt.json").write_text(json.dumps(
        {"offsets_s": {"a": 0.0, "b": 1.0}, "drift_ppm": {"a": 0.0, "b": 100.0}, "fps": {"a": 30.0, "b": 25.0}}))
    assert main(["eval", str(tmp_path / "result.json"), "--gt", str(tmp_path / "gt.json")]) == 0
    out = capsys.readouterr().out
    assert "offset +0.25 frames" in out  # 10 ms at 25 fps
    assert "drift +50.0 ppm" in out
    # a constant-offset result against a drifting truth: its drift error is the whole drift
    (tmp_path / "result.json").write_text(json.dumps({"reference": "a", "offsets_s": {"a": 0.0, "b": 1.0}}))
    assert main(["eval", str(tmp_path / "result.json"), "--gt", str(tmp_path / "gt.json")]) == 0
    out = capsys.readouterr().out
    assert "drift -100.0 ppm (constant-offset result" in out


def test_cue_stats_with_the_joint_vote_and_transfer_checks_round_trip():
    from vs_inspect.cue_stats import (CueStats, JointVoteRecord, PairCueStats, PairVoteSummary, TransferSummary,
                                      VideoCueStats)

    joint = {"origin": "a", "offsets_s": {"a": 0.0, "b": 1.25}, "score": 12.5, "margin": {"a": 7.1, "b": 1.3},
             "sure": ["a"], "used": ["a", "b"],
             "transfer": {"b": {"joint_offset_s": 1.25, "transfer_offset_s": 1.2667, "z": 9.2, "trajectories": 86,
                                "supporters": 13, "matches": 13, "confirmed": True, "reason": "confirmed",
                                "offsets_s": [1.2, 1.25], "share": [0.1, 0.5]}}}
    record = JointVoteRecord("a", {"a": 0.0, "b": 1.25}, 12.5, {"a": 7.1, "b": 1.3}, ("a",), ("a", "b"),
                             {"b": TransferSummary(1.25, 1.2667, 9.2, 86, 13, 13, True, "confirmed", (1.2, 1.25),
                                                   (0.1, 0.5))})
    videos = {n: VideoCueStats("v.mp4", "static", 0.1, 0.02, 10, 1, 12, 5) for n in "ab"}
    vote = PairVoteSummary(40, 12, 9, 3, (1.25, -0.5), (10, 4), geometric_joint_delta_s=1.25)
    c = CueStats("calibration", 2, 20, 5, videos, {"a__b": PairCueStats(3, 2, 1, 1, vote, 4)}, {}, {}, "joint",
                 None, record)
    d = json.loads(json.dumps(c.to_json()))
    assert d["geometric_joint"] == joint
    assert d["pairs"]["a__b"] == {"matches": 3, "snapped": 2, "instance_pairs": 1, "track_pairs": 1,
                                  "geometric_candidates": 40, "geometric_informative": 12, "geometric_pairs": 9,
                                  "geometric_new": 3, "geometric_peaks_s": [1.25, -0.5], "geometric_peak_votes": [10, 4],
                                  "geometric_joint_delta_s": 1.25, "transfer_new": 4}
    back = CueStats.from_json(d)
    assert back.geometric_joint == record and back.pairs == c.pairs and back.to_json() == d
    no_joint = CueStats("calibration", 2, 20, 5, videos, {"a__b": PairCueStats(3, 2, 1, 1)}, {}, {}).to_json()
    assert "geometric_joint" not in no_joint and CueStats.from_json(no_joint).geometric_joint is None
    assert CueStats.from_json(no_joint).pairs["a__b"].vote is None


def test_an_older_result_json_with_the_keys_of_removed_checks_is_read_and_those_keys_passed_over():
    """Stage 0 once kept more under "cues" (the moving points' fitted offsets checked against
    their votes, another camera model's disputes overruled); a reader takes such a result.json
    and leaves those keys out."""
    from vs_inspect.cue_stats import CueStats

    fallback = {"why": "weak", "used": True, "reference": "a",
                "pairs": {"b": {"coarse_offset_s": 0.5, "inlier_share": 0.4},
                          "joint_offsets": {"pairs": 3, "summed_share": 1.7,
                                            "moved": {"b": {"alone_s": 1.5, "together_s": 0.5}}},
                          "joint_fit": {"pairs": 3, "cost": 1.0}},
                "fitted_offsets_s": {"a": 0.0, "b": 0.5},
                "check": {"verdict": "confirmed", "tolerance_s": 0.1,
                          "pairs": {"a__b": {"fitted_s": 0.5, "voted_s": 0.51, "agrees": True}}, "refused": []}}
    sfm = {"features": "sift", "images": 4, "registered_images": 4, "registered_frames": {}, "image_pairs": [],
           "lens": {}, "fallback": fallback}
    old = {"camera_source": "estimated", "registered_cameras": 2, "tracks": 20, "track_pairs": 5,
           "videos": {}, "pairs": {}, "dropped": {}, "sfm": sfm,
           "geometric_joint": {"origin": "a", "offsets_s": {"a": 0.0, "b": 0.5}, "sure": ["a", "b"],
                               "overruled": {"b": "SIFT's model's vote peaks disagree; overruled"}}}
    assert CueStats.from_json(old).geometric_joint.sure == ("a", "b")
    back = CueStats.from_json(old).sfm.fallback
    assert set(back.pairs) == {"b"} and back.pairs["b"].coarse_offset_s == 0.5
    assert back.joint_fit.pairs == 3
    assert back.joint_offsets.summed_share == 1.7 and "joint_offsets" in back.to_json()["pairs"]
    assert not {"fitted_offsets_s", "check"} & set(back.to_json())
