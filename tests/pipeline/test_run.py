"""pipeline.run: a cue bundle or videos in, one RunResult out, written as result.json (v2)."""

from __future__ import annotations

import dataclasses
import json
from types import SimpleNamespace

import numpy as np
import pytest

from vs_inspect.io.bundle import read_bundle, write_bundle
from vs_inspect.io.result import read_run_result, run_result_to_dict, write_run_result
from vs_inspect.io.video import VideoWriter
from vs_inspect.pipeline import RunConfig, run, sync_bundle
from vs_inspect.record.sink import NullSink
from vs_inspect.sync.config import LandscapeConfig, SyncConfig
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.result_types import RunInputs, RunResult
from vs_inspect.types import first_clause

SMALL = CueSceneConfig(cameras=3, moving=1, variable_rate=1, seconds=4.0, pairs_per_view_pair=100,
                       max_offset_s=1.0, seed=4)


def _detail(why: str) -> str:
    """A null's technical account, after its plain sentence (pipeline.reasons.with_plain_reason)."""
    plain, sep, detail = why.partition(". In detail: ")
    assert sep and plain, why
    return detail


class SummarySink(NullSink):
    def __init__(self):
        self.summaries = []

    def run_summary(self, result):
        self.summaries.append(result)


@pytest.fixture(scope="module")
def scene():
    return make_cue_scene(SMALL)


def test_bundle_in_run_result_out(scene, tmp_path):
    sink = SummarySink()
    cfg = RunConfig(sync=SyncConfig(landscape=LandscapeConfig(residual="symmetric")))
    folder = write_bundle(scene.bundle, tmp_path / "bundle")
    result = run(folder, cfg, sink, progress=False)
    direct = sync_bundle(scene.bundle, cfg.sync, progress=False)
    assert result.offsets_s == direct.offsets_s and result.reference == direct.reference
    assert {v: _detail(w) for v, w in result.unresolved.items()} == direct.unresolved_reason
    assert all(w.startswith(result.unresolved_headline[v] + ". ") for v, w in result.unresolved.items())
    assert result.solver == "irls"
    assert result.gt_offsets_s == scene.bundle.gt_offsets_s
    assert result.config == cfg.to_dict() and result.cues is None
    assert result.inputs == RunInputs(bundle=str(folder))
    assert list(result.timings_s) == ["stage1_s", "stage2_s", "total_s"]
    assert sink.summaries == [result]
    # result.json (v2: constant-offset runs add only "time_model") and back
    path = write_run_result(result, tmp_path)
    assert path == tmp_path / "result.json"
    data = json.loads(path.read_text())
    assert {"format", "version", "reference", "offsets_s", "uncertainty_s", "unresolved", "pairs",
            "unresolved_headline", "solve", "timings_s", "config", "input", "gt_offsets_s",
            "time_model"} == set(data)
    assert data["time_model"] == "constant"
    assert run_result_to_dict(read_run_result(tmp_path)) == data


def test_cue_bundle_object_and_recorded_inputs(scene):
    said = RunInputs(scene="somewhere", cues="true cue bundle")
    result = run(scene.bundle, progress=False, recorded_inputs=said)
    assert isinstance(result, RunResult) and result.inputs == said
    assert result.offsets_s == sync_bundle(scene.bundle, progress=False).offsets_s


def test_bundle_with_video_arguments_is_an_error(scene):
    from vs_inspect.errors import InputError
    with pytest.raises(InputError, match="apply to videos"):
        run(scene.bundle, fps=10.0, progress=False)


def _moving_disk_video(path, shift_frames: int) -> None:
    """A textured static background and a bright disk moving across it, 10 fps."""
    rng = np.random.default_rng(0)
    bg = (rng.random((240, 320)) * 120).astype(np.uint8)
    bg = np.repeat(bg[:, :, None], 3, axis=2)
    yy, xx = np.mgrid[:240, :320]
    with VideoWriter(path, 320, 240, 10.0) as w:
        for k in range(30):
            t = k + shift_frames
            img = bg.copy()
            img[(xx - (60 + 6 * t)) ** 2 + (yy - (100 + 2 * t)) ** 2 < 35 ** 2] = 250
            w.write(img)


def test_videos_in_and_the_unreadable_one_is_null_with_its_reason(tmp_path):
    a, b, c = tmp_path / "a.mp4", tmp_path / "b.mp4", tmp_path / "c.mp4"
    _moving_disk_video(a, 0)
    _moving_disk_video(b, 3)
    c.write_bytes(b"not a video")
    cal = tmp_path / "cal.json"
    cams = {}
    for i, n in enumerate("abc"):
        T = np.eye(4)
        T[0, 3] = -0.5 * i
        cams[n] = {"K": [[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]], "cam_from_world": T.tolist(),
                   "size": [320, 240]}
    cal.write_text(json.dumps(cams))
    sink = SummarySink()
    result = run([a, b, c], sink=sink, calibration=cal, bundle_out=tmp_path / "out" / "cues",
                 progress=False, truth_offsets_s={"a": 0.0, "b": 0.3, "c": 1.0})
    assert list(result.offsets_s)[:2] == ["a", "b"] and result.offsets_s["c"] is None
    # the truth given (--gt) is the cue bundle's and the result's, for the videos with cues
    assert result.gt_offsets_s == {"a": 0.0, "b": 0.3}
    assert read_bundle(tmp_path / "out" / "cues").gt_offsets_s == {"a": 0.0, "b": 0.3}
    assert result.unresolved_headline["c"].startswith("the video could not be read")
    assert _detail(result.unresolved["c"]).startswith("could not be opened")
    assert result.cues is not None and "c" in result.cues.dropped
    assert set(result.cues.videos) == {"a", "b"}
    assert result.inputs == RunInputs(bundle=str(tmp_path / "out" / "cues"),
                                      videos={"a": str(a), "b": str(b), "c": str(c)})
    assert "stage0_total_s" in result.timings_s and "stage0_with_io_s" in result.timings_s
    assert list(result.timings_s)[-3:] == ["stage1_s", "stage2_s", "total_s"]
    assert read_bundle(tmp_path / "out" / "cues").names == ["a", "b"]
    assert sink.summaries == [result]
    data = run_result_to_dict(result)
    assert data["cues"]["dropped"]["c"] == _detail(result.unresolved["c"])
    assert run_result_to_dict(read_run_result(write_run_result(result, tmp_path / "out"))) == data


def _calibration(path, names, sizes=None) -> None:
    cams = {}
    for i, n in enumerate(names):
        T = np.eye(4)
        T[0, 3] = -0.5 * i
        cams[n] = {"K": [[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]], "cam_from_world": T.tolist(),
                   "size": list((sizes or {}).get(n, (320, 240)))}
    path.write_text(json.dumps(cams))


def _blank_video(path, shift_frames: int) -> None:
    """A bright disk moving over a uniform background: nothing for a reconstruction to match."""
    yy, xx = np.mgrid[:120, :160]
    with VideoWriter(path, 160, 120, 10.0) as w:
        for k in range(20):
            t = k + shift_frames
            img = np.full((120, 160, 3), 90, np.uint8)
            img[(xx - (30 + 4 * t)) ** 2 + (yy - (50 + t)) ** 2 < 15 ** 2] = 250
            w.write(img)


def test_no_video_gets_a_camera_and_result_json_still_says_why_for_each(tmp_path, capsys):
    """Stage 0 estimates no camera at all: `sync` still writes result.json, every offset null
    (the reference's too) with Stage 0's reason, and exits 2."""
    from vs_inspect.cli import main

    paths = [tmp_path / f"v{i}.mp4" for i in range(3)]
    for p, s in zip(paths, (0, 2, 3)):
        _blank_video(p, s)
    out = tmp_path / "out"
    code = main(["sync", *map(str, paths), "--out", str(out), "--no-progress", "--no-rrd"])
    assert code == 2
    res = json.loads((out / "result.json").read_text())
    assert res["version"] == 2 and res["reference"] == "v0"
    assert res["offsets_s"] == {"v0": None, "v1": None, "v2": None}
    assert res["uncertainty_s"] == {"v0": None, "v1": None, "v2": None}
    for n in ("v0", "v1", "v2"):
        assert _detail(res["unresolved"][n]).startswith("no reconstruction"), res["unresolved"][n]
        assert _detail(res["unresolved"][n]).startswith(res["cues"]["dropped"][n])
    assert res["unresolved"]["v0"].endswith("no video could be used, so even the reference has no offset")
    # in the user's terms (what the offsets table prints): what was missing, in one sentence (blank
    # videos: nothing moves), and the whole account after it
    for n, why in res["unresolved"].items():
        head = res["unresolved_headline"][n]
        assert head.startswith("nothing moving was found in it") and why.startswith(head + ". In detail: "), head
    assert res["pairs"] == [] and set(res["input"]["videos"]) == {"v0", "v1", "v2"}
    assert "bundle" not in res["input"]  # no cue bundle was extracted
    printed = capsys.readouterr().out
    assert "null" in printed and res["unresolved_headline"]["v1"] in printed
    assert res["unresolved"]["v1"] not in printed  # the whole reason is in result.json


def test_sync_with_one_readable_video_writes_result_json(tmp_path):
    from vs_inspect.cli import main

    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    _blank_video(a, 0)
    b.write_bytes(b"not a video")
    out = tmp_path / "out"
    assert main(["sync", str(a), str(b), "--out", str(out), "--no-progress", "--no-rrd"]) == 2
    res = json.loads((out / "result.json").read_text())
    assert res["offsets_s"] == {"a": None, "b": None}
    assert res["unresolved_headline"]["a"] == "no other video could be read, so there is nothing to synchronize it with"
    assert _detail(res["unresolved"]["a"]) == ("the only readable video: there is no other video to synchronize "
                                               "it with; no video could be used, so even the reference has no offset")
    assert _detail(res["unresolved"]["b"]).startswith("could not be opened")


@pytest.mark.parametrize("reference", [None, "a"])
def test_reference_without_camera_gives_its_place_to_a_video_with_one(tmp_path, reference):
    """The default (first) or chosen reference gets no camera (calibration made for another
    image size): the next video with a camera is the reference, and a's reason says so."""
    a, b, c = tmp_path / "a.mp4", tmp_path / "b.mp4", tmp_path / "c.mp4"
    for p, s in ((a, 0), (b, 0), (c, 3)):
        _moving_disk_video(p, s)
    cal = tmp_path / "cal.json"
    _calibration(cal, ["a", "b", "c"], {"a": (100, 100)})
    config = RunConfig.from_dict({"sync": {"solve": {"reference": reference}}})
    result = run([a, b, c], config, calibration=cal, progress=False)
    assert result.reference == "b" and result.offsets_s["a"] is None
    assert "nor a uniform scale" in result.unresolved["a"]
    assert result.unresolved["a"].endswith("it cannot be the reference, so b is the reference instead")
    assert [(p.a, p.b) for p in result.pairs] == [("b", "c")]
    # these blank disks give no tracks, so b-c is not accepted: b's 0 was measured against nothing
    assert not result.pairs[0].decision.accepted and result.offsets_s["b"] is None
    assert _detail(result.unresolved["b"]).startswith("the reference, but no accepted pair links it")
    # the run's settings are recorded as given
    assert result.config["sync"]["solve"]["reference"] == reference


def test_an_unresolved_video_stage0_was_unsure_of_says_why_first():
    """A video whose pairs had no track pairs because Stage 0's joint vote was unsure of it (and
    point transfer did not confirm it) gets that reason before its pairs' ones; a sure video's
    reason and a dropped video's are left as they are."""
    from vs_inspect.pipeline.run import _run_result
    from ..cue_records import cue_stats, joint
    from vs_inspect.result_types import SyncResult

    sync = SyncResult("a", {"a": 0.0, "b": 0.5, "c": None, "d": None}, {}, {
        "c": "not connected to the reference 'a' through accepted pairs; its pairs: a__c: no cross-view track pairs",
        "d": "not connected"}, (), (), ())
    vote = joint({"a": 9.0, "b": 7.0, "c": 1.3, "d": 6.0}, used=("a", "b", "d"),
                 transfer={"c": {"reason": "they disagree", "confirmed": False}})
    stats = cue_stats("calibration", dropped={"e": "could not be read"}, joint_vote=vote, registered=4)
    r = _run_result(sync, stats, RunInputs(), RunConfig(), None, {})
    assert _detail(r.unresolved["c"]).startswith("Stage 0's joint vote was not sure of its offset (margin 1.3), "
                                                 "so it got no geometric track pairs (they disagree); not connected")
    assert _detail(r.unresolved["d"]) == "not connected" and _detail(r.unresolved["e"]) == "could not be read"
    # in the user's terms: what was missing and what to try (the calibration is given already)
    assert r.unresolved_headline["c"] == ("its offset could not be confirmed by a third camera; try a rough "
                                          "offset window (--range-s or --around) or another camera that sees the same motion")
    assert r.unresolved_headline["e"].startswith("the video could not be read")


def test_an_unresolved_videos_pairs_that_share_a_reason_say_it_once():
    """Stage 0's withheld geometric pairs and Stage 1's pair decisions: a reason that several of a
    video's pairs share is given once, with the pairs named together (the 720p timing scene's
    reasons had repeated one sentence three times each, 840-1065 characters)."""
    from vs_inspect.pipeline.run import _run_result
    from vs_inspect.sync.stage2 import with_its_pairs as _with_its_pairs
    from ..cue_records import cue_stats, withheld
    from vs_inspect.result_types import SyncResult

    why = "the vote peaks of the camera pairs do not close the triangles"
    pairs = {k: withheld(why) for k in ("a__c", "b__c", "c__d")}
    stats = cue_stats(pairs=pairs, peaks="inconsistent", registered=4)
    sync = SyncResult("a", {"a": 0.0, "b": 0.5, "c": None, "d": 0.2}, {}, {"c": "not connected"}, (), (), ())
    r = _run_result(sync, stats, RunInputs(), RunConfig(), None, {})
    assert _detail(r.unresolved["c"]) == f"Stage 0 gave a__c, b__c and c__d no geometric track pairs: {why}; not connected"
    assert r.unresolved_headline == {"c": "its offset could not be confirmed by a third camera; try giving a "
                                          "calibration (--calib), a rough offset window (--range-s or --around) or another "
                                          "camera that sees the same motion"}
    assert stats.headline("c", "not connected") == "vote peaks unchecked; not connected"  # the few words

    def land(a, b, reason):  # the fields _with_its_pairs reads of a PairLandscape
        return SimpleNamespace(a=a, b=b, decision=SimpleNamespace(reason=reason))

    lands = [land("a", "c", "no cross-view track pairs"), land("b", "c", "too few track pairs: only 3"),
             land("c", "d", "no cross-view track pairs"), land("a", "b", "accepted")]
    assert _with_its_pairs(lands, "c", "not connected") == (
        "not connected; its pairs: a__c and c__d: no cross-view track pairs; b__c: too few track pairs: only 3")
    five = [land("c", f"v{i}", f"reason {i}") for i in range(5)]
    assert _with_its_pairs(five, "c", "x").endswith("c__v2: reason 2; and 2 more reason(s)")


def test_an_unresolved_video_the_joint_vote_was_sure_of_alone_with_one_other_says_so():
    """Sure of only two cameras, the joint vote's Δ between them is confirmed by no triangle: each
    unresolved video's reason says that, not that the vote was unsure of it."""
    from vs_inspect.pipeline.run import _run_result
    from ..cue_records import cue_stats, joint
    from vs_inspect.result_types import SyncResult

    sync = SyncResult("a", {"a": None, "b": None, "c": None}, {}, {
        "a": "the reference, but no accepted pair links it", "b": "not connected",
        "c": "not connected"}, (), (), ())
    stats = cue_stats(joint_vote=joint({"a": 6.9, "b": 5.3, "c": 0.2}, sure=("a", "b")))
    r = _run_result(sync, stats, RunInputs(), RunConfig(), None, {})
    assert _detail(r.unresolved["b"]).startswith("Stage 0's joint vote was sure of its offset (margin 5.3) but of 2 "
                                                 "camera(s) only, so no triangle of sure cameras confirmed it")
    assert _detail(r.unresolved["c"]).startswith("Stage 0's joint vote was not sure of its offset (margin 0.2)")
    # in the user's terms, the same for the three: no third camera confirmed them
    unconfirmed = ("its offset could not be confirmed by a third camera; try giving a calibration (--calib), a "
                   "rough offset window (--range-s or --around) or another camera that sees the same motion")
    assert r.unresolved_headline == dict.fromkeys("abc", unconfirmed)
    # the few words of each cause stay apart (CueStats.headline)
    alone = "sure of 2 camera(s) only, no triangle to confirm it"
    assert [stats.headline(n, "not connected") for n in "bc"] == [
        f"{alone}; not connected", "joint vote unsure of it (margin 0.2); not connected"]


def test_an_unresolved_video_whose_own_pair_contradicted_the_joint_vote_says_so():
    """The joint vote chose a's offset, but a pair of a's voted elsewhere (dissent): a's reason
    says so; the videos it was used for keep their offsets."""
    from vs_inspect.pipeline.run import _run_result
    from ..cue_records import cue_stats, joint
    from vs_inspect.result_types import SyncResult

    sync = SyncResult("b", {"a": None, "b": 0.0, "c": 0.4, "d": -0.2}, {}, {
        "a": "the reference, but no accepted pair links it"}, (), (), ())
    why = "its pairs vote for other offsets than the joint choice: a__b has 0.23 of its top peak's votes"
    vote = joint({"a": 6.1, "b": 33.0, "c": 36.5, "d": 19.6}, sure=("b", "c", "d"), used=("b", "c", "d"),
                 dissent={"a": why})
    stats = cue_stats(joint_vote=vote, registered=4)
    r = _run_result(sync, stats, RunInputs(), RunConfig(), None, {})
    assert _detail(r.unresolved["a"]).startswith(f"Stage 0's joint vote chose its offset (margin 6.1), but {why}, so "
                                                 "it got no geometric track pairs; the reference, but no accepted pair")
    assert r.unresolved_headline["a"].startswith("its offset could not be confirmed by a third camera")
    assert r.offsets_s == {"a": None, "b": 0.0, "c": 0.4, "d": -0.2} and set(r.unresolved) == {"a"}


def test_a_null_reason_names_what_the_other_camera_models_made_of_the_video():
    """A video Stage 0's kept camera model placed but did not time: its reason in the run ends with
    what the other models tried made of it (CueStats.other_models_note); a video Stage 0 dropped
    already carries that in its own reason."""
    from vs_inspect.pipeline.run import _run_result
    from vs_inspect.camera_stats import SfmRecord
    from vs_inspect.cue_stats import CueStats
    from vs_inspect.result_types import SyncResult

    note = "XFEAT's model registered it, but its set was not kept (its joint vote trusted 2 video(s))"
    sfm = SfmRecord("sift", 3, 3, {}, (), {}, other_models={"c": note, "d": "not this"})
    stats = CueStats("estimated", 3, 0, 0, {}, {}, {"d": "no camera (also tried: ...)"}, {}, sfm=sfm)
    sync = SyncResult("a", {"a": 0.0, "b": 0.5, "c": None}, {"a": 0.0, "b": 0.01, "c": None},
                      {"c": "no cross-view track pairs"}, (), (("a", "b"),), ())
    res = _run_result(sync, stats, RunInputs(videos={n: n for n in "abcd"}), RunConfig(), None, {})
    assert _detail(res.unresolved["c"]) == f"no cross-view track pairs (other camera models tried: {note})"
    assert _detail(res.unresolved["d"]) == "no camera (also tried: ...)" and res.offsets_s["d"] is None
    assert "b" not in res.unresolved
    assert res.unresolved_headline["d"].startswith("its camera could not be placed from the background")
    # Stage 0's few words (CueStats.headline): the kept model's cause, Stage 1 and 2's, the other
    # models' (models that say what the kept one says are named together)
    stats = dataclasses.replace(stats, sfm=dataclasses.replace(stats.sfm, kept_model="SIFT's model", other_models_headline={
        "c": {"XFEAT's model": "two offsets 1.22 s apart", "ALIKED's model": "refuted in three views"},
        "d": {"XFEAT's model": "no camera", "ALIKED's model": "no camera", "the moving points' cameras": "x"}}))
    assert {n: stats.headline(n, why) for n, why in (("c", "no cross-view track pairs"), ("d", None))} == {
        "c": ("no cross-view track pairs; other camera models: XFEAT's model: two offsets 1.22 s apart; "
              "ALIKED's model: refuted in three views"),
        "d": ("SIFT's model: no camera; other camera models: XFEAT's model and ALIKED's model: the same; "
              "the moving points' cameras: x")}
