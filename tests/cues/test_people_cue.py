"""The people cue from people already found (cameras_from_people): three asymmetric static
cameras of synthetic walkers with known offsets, one person labelled mirrored in one view, a
false person per view. Offsets, cameras, track pairs, and Stage 1 + 2 on the cue's bundle."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.cues.people_cue import PeopleCueConfig, cameras_from_people
from vs_inspect.geometry.epipolar import fundamental_from_cameras, project
from vs_inspect.geometry.offsets import OffsetGrid
from vs_inspect.geometry.two_view import sampson_px
from vs_inspect.sync.people_config import PeoplePairConfig
from vs_inspect.synth.people import ViewOptions, default_walkers, people_scene, ring_camera
from vs_inspect.types import VideoInfo

FPS = 10.0
OFFSETS = {"a": 0.0, "b": 1.23, "c": -0.64}
GRID = OffsetGrid(min_overlap_s=3.0, range_s=2.5)


def _scene():
    cams = (ring_camera("a", 0, np.array([[820.0, 0, 470], [0, 800, 275], [0, 0, 1]]), roll_deg=4, fps=FPS,
                        num_frames=80, offset_s=OFFSETS["a"]),
            ring_camera("b", 105, np.array([[1100.0, 0, 490], [0, 1130, 262], [0, 0, 1]]), distance=7, height=2.4,
                        roll_deg=-6, fps=FPS, num_frames=70, offset_s=OFFSETS["b"]),
            ring_camera("c", 230, np.array([[950.0, 0, 455], [0, 970, 280], [0, 0, 1]]), distance=6.5, height=3.3,
                        roll_deg=2, fps=FPS, num_frames=75, offset_s=OFFSETS["c"]))
    opts = {"a": ViewOptions(seed=1), "b": ViewOptions(seed=2, mirrored=(1,)), "c": ViewOptions(seed=3)}
    return people_scene(cams, default_walkers(), opts)


@pytest.fixture(scope="module")
def scene():
    return _scene()


@pytest.fixture(scope="module")
def cue(scene):
    infos = [VideoInfo.constant_rate(c.name, c.width, c.height, c.num_frames, c.fps) for c in scene.cameras]
    cfg = PeopleCueConfig(pairs=PeoplePairConfig(search_frames=16, max_hypotheses=6, candidates=2))
    return cameras_from_people(scene.views, infos, GRID, cfg)


def test_offsets_from_the_pairs(cue):
    assert all(p.accepted for p in cue.pairs), [p.reason for p in cue.pairs]
    assert cue.reference == "a" and not cue.refused
    for v, truth in OFFSETS.items():
        assert abs(cue.offsets_s[v] - truth) < 0.1 / FPS, (v, cue.offsets_s[v])


def test_cameras_give_the_true_epipolar_geometry(scene, cue):
    """Every pair's F from the cue's cameras fits points the true cameras project."""
    true = {c.name: c for c in scene.cameras}
    X = np.random.default_rng(4).uniform([-1.5, -1.5, 0.0], [1.5, 1.5, 1.8], (200, 3))
    for a, b in (("a", "b"), ("a", "c"), ("b", "c")):
        F = fundamental_from_cameras(cue.cameras[a].K, cue.cameras[a].cam_from_world, cue.cameras[b].K,
                                     cue.cameras[b].cam_from_world)
        xa = project(true[a].K, true[a].cam_from_world, X)
        xb = project(true[b].K, true[b].cam_from_world, X)
        assert np.median(sampson_px(F, xa, xb)) < 3.0, (a, b)
    assert max(cue.reprojection_px.values()) < 3.0


def test_track_pairs_join_the_same_landmark(scene, cue):
    L = len(cue.landmarks)
    for (a, b), tp in cue.track_pairs.items():
        ta, tb = scene.person_of_track[a], scene.person_of_track[b]
        person_a, person_b = tp.index[:, 0] // L, tp.index[:, 1] // L
        assert (ta[person_a] == tb[person_b]).all() and (ta[person_a] >= 0).all()
        # the person labelled mirrored in b: its left wrist pairs with b's right wrist track
        mirrored = (tb[person_b] == 1) if b == "b" else (ta[person_a] == 1) if a == "b" else np.zeros(len(tp.index), bool)
        same = tp.index[:, 0] % L == tp.index[:, 1] % L
        assert not same[mirrored & (np.array(cue.landmarks)[tp.index[:, 0] % L] != 0)].any()
        assert same[~mirrored].all()


def test_stage1_on_the_cue_bundle(cue):
    from vs_inspect.pipeline.stage12 import sync_bundle

    res = sync_bundle(cue.bundle(OFFSETS), progress=False)
    for v, truth in OFFSETS.items():
        assert res.offsets_s[v] is not None, res.unresolved_reason
        assert abs(res.offsets_s[v] - truth) < 0.2 / FPS


def test_recording(cue, tmp_path):
    import rerun as rr

    from tests.record.test_rerun_sink import rerun_verify
    from vs_inspect.record.people import log_people_cue

    path = tmp_path / "people.rrd"
    rec = rr.RecordingStream("vs_inspect_test", recording_id="people")
    rec.save(str(path))
    log_people_cue(rec, cue)
    rec.flush()
    rec.disconnect()
    assert path.stat().st_size > 10_000
    out = rerun_verify(path, tmp_path)
    assert out.returncode == 0, out.stderr
    assert rerun_verify(path, tmp_path).returncode == 0


def test_a_real_pair_of_webcams(shared_data):
    """caliscope's cam_2 and cam_3 (one person moving a board, seen about 90 degrees apart): the
    people cue alone times the pair within a frame of the recorded frame times."""
    from vs_inspect.bench.datasets import read_caliscope_frame_times
    from vs_inspect.cues.people_cue import find_people_cameras
    from vs_inspect.cues.people_detect import people_unavailable
    from vs_inspect.io.video import open_video

    if people_unavailable():
        pytest.skip(people_unavailable())
    root = shared_data / "caliscope_post_optimization"
    paths = [root / "calibration" / "extrinsic" / f"cam_{i}.mp4" for i in (2, 3)]
    if not all(p.is_file() for p in paths):
        pytest.skip(f"caliscope videos not in {root}")
    times = read_caliscope_frame_times(root)
    cue = find_people_cameras([open_video(p) for p in paths], OffsetGrid(min_overlap_s=1.0))
    (pair,) = cue.pairs
    assert pair.accepted, pair.reason
    truth = times["cam_3"][0] - times["cam_2"][0]
    frame = float(np.median(np.diff(times["cam_2"])))
    assert abs(pair.offset_s - truth) < frame, (pair.offset_s, truth)
    assert set(cue.cameras) == {"cam_2", "cam_3"} and not cue.refused


def test_camera_set_of_the_cue(cue):
    """Stage 0's camera source: the cue's cameras, its landmark tracks and pairs; every placed video timed."""
    from vs_inspect.cues.cameras.people import SOURCE, people_camera_set

    s = people_camera_set(cue)
    assert s.source == SOURCE and set(s.cameras) == set(OFFSETS) == set(s.used)
    assert set(s.pairs) == set(cue.track_pairs) and s.undistort == {}
    for v, t in s.tracks.items():
        assert t.xy.shape[1] == len(cue.people[v].times_s)
    assert any("placed by the people" in n.message for n in s.notes)


def test_people_replace_the_background_only_when_they_time_more(cue):
    import dataclasses
    import json

    from vs_inspect.cue_stats import CueStats
    from vs_inspect.cues.cameras.people import people_camera_set, wants_people
    from vs_inspect.cues.config import CueConfig
    from vs_inspect.pipeline.stage0 import _with_people

    background = people_camera_set(cue)
    none_timed = dataclasses.replace(background, used=frozenset(), source="estimated")
    assert wants_people(CueConfig(), none_timed, 3) and not wants_people(CueConfig(), background, 3)
    assert not wants_people(CueConfig(), none_timed, 1)  # the cue places static cameras only
    assert wants_people(CueConfig(people="only"), background, 3)
    assert not wants_people(CueConfig(people="off"), none_timed, 3)
    kept, rec = _with_people(none_timed, cue)
    assert kept.source != "estimated" and rec.kept and "people 3" in rec.why
    kept, rec = _with_people(dataclasses.replace(background, source="estimated"), cue)
    assert kept.source == "estimated" and not rec.kept
    # result.json keeps the record, a refused pair's too
    refused = dataclasses.replace(cue.pairs[0], offset_s=None, offset_std_s=None, reason="uncertain shift")
    _, rec = _with_people(none_timed, dataclasses.replace(cue, pairs=(refused,) + cue.pairs[1:]))
    stats = CueStats("x", 3, 0, 0, {}, {}, {}, {}, people=rec)
    back = CueStats.from_json(json.loads(json.dumps(stats.to_json())))
    assert back.people == rec and set(back.people.pairs) == {"a__b", "a__c", "b__c"}
    assert back.people.pairs["a__b"].offset_s is None


def test_recorded_through_the_sink(cue, tmp_path):
    from tests.record.test_rerun_sink import rerun_verify
    from vs_inspect.record.rerun_sink import RerunSink

    path = tmp_path / "people.rrd"
    with RerunSink(path) as sink:
        sink.people_cue(cue)
    out = rerun_verify(path, tmp_path)
    assert out.returncode == 0, out.stderr
    assert path.stat().st_size > 10_000


def test_the_moving_points_are_voted_on_near_the_people_offsets(cue):
    from vs_inspect.cues.cameras.people import people_grid

    grid = people_grid(cue, GRID, frames=2.0)
    assert grid.reference == "a" and grid.min_overlap_s == GRID.min_overlap_s
    for v, truth in OFFSETS.items():
        lo, hi = grid.video_window(v)
        assert lo <= cue.offsets_s[v] <= hi and hi - lo <= 4.0 / FPS + 1e-9
    lo, hi = grid.pair_window("b", "c")
    assert lo <= OFFSETS["c"] - OFFSETS["b"] <= hi


def test_a_pairs_moving_point_rows_and_landmark_rows_joined():
    from vs_inspect.cues.cameras.people import _joined
    from vs_inspect.types import TrackPairs

    moving = TrackPairs("a", "b", np.array([[0, 1], [2, 3]]), unchecked=np.array([True, False]),
                        chosen_at_offset_s=0.5)
    landmark = TrackPairs("a", "b", np.array([[0, 0], [1, 2]]))
    j = _joined("a", "b", moving, landmark, 10, 20)
    assert j.index.tolist() == [[0, 1], [2, 3], [10, 20], [11, 22]]
    assert j.unchecked is None and j.chosen_at_offset_s == 0.5 and j.weight is None
    alone = _joined("a", "b", None, landmark, 10, 20)
    assert alone.index.tolist() == [[10, 20], [11, 22]] and alone.chosen_at_offset_s is None
