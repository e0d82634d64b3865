"""Stage 0's choice of cameras when none are given (cues/cameras/choice.py): the moving points'
cameras refused alone in pairs; later camera models tried, kept or not."""

from __future__ import annotations

import numpy as np

from vs_inspect.cues.config import CueConfig
from vs_inspect.geometry.epipolar import look_at
from vs_inspect.types import CameraTrack, TrackPairs

from tests.cue_records import joint
from vs_inspect.camera_stats import MovingPointsCameras, SfmRecord
from vs_inspect.cue_stats import CueStats
from vs_inspect.cues.pairing.pairing import GeometricPairing
from vs_inspect.cues.records import Note

from .stage0_fakes import K


def _as_json(cams) -> dict:
    """A camera set's records as result.json's "cues" holds them (a stats-like dict)."""
    return {"camera_source": cams.source, "dropped": dict(cams.dropped), "sfm": cams.sfm.to_json()}


def _moving_point_cameras(monkeypatch, names, config: CueConfig = CueConfig(), calls: list | None = None):
    """_estimate of the moving points' cameras (from_tracks) when the background reconstruction
    registers nothing and the moving points give a static camera for every video. Returns
    (cameras, stats); calls: where each fit's keyword arguments are noted."""
    from types import SimpleNamespace

    import vs_inspect.cues.cameras.moving_points as pairwise_mod
    from vs_inspect.cues.cameras.sfm import CameraEstimate
    from vs_inspect.cues.cameras.model_or_points import _estimate

    no_model = "no reconstruction: too few matches"
    est = CameraEstimate({}, dict.fromkeys(names, no_model), None, None, len(names), 0, "sift")
    fitted = {n: CameraTrack(K, look_at([6.0 * np.cos(i), 6.0 * np.sin(i), 2.0], [0, 0, 1]))
              for i, n in enumerate(names)}
    details = {n: {"coarse_offset_s": 0.1 * i} for i, n in enumerate(names) if i}
    def fit(*a, **k):
        if calls is not None:
            calls.append(k)
        return dict(fitted), {}, details

    monkeypatch.setattr(pairwise_mod, "cameras_from_tracks", fit)
    info = SimpleNamespace(width=640, height=480, num_frames=50)
    vids = {n: SimpleNamespace(sfm_frames=None, info=info, camera_motion="static", frame_features=None,
                               register_masks=None, xy_full=np.zeros((0, 50, 2)),
                               instance=np.zeros(0, np.int64)) for n in names}
    pairs = {(a, b): TrackPairs(a, b, np.zeros((0, 2), np.int64)) for a, b in zip(names, names[1:])}
    got = _estimate(vids, config, pairs, est, from_tracks=True)
    return got.cameras, _as_json(got)


def test_the_moving_points_cameras_get_the_configs_joint_choice(monkeypatch):
    """Their coarse offsets are chosen with every pair at once unless the config says each with
    the reference alone."""
    from vs_inspect.cues.config import CameraConfig

    calls = []
    _moving_point_cameras(monkeypatch, ["a", "b", "c"], calls=calls)
    _moving_point_cameras(monkeypatch, ["a", "b", "c"], CueConfig(camera=CameraConfig(fallback_joint_offsets=False)),
                          calls=calls)
    assert [c["joint"] for c in calls] == [True, False]


def test_two_cameras_from_the_moving_points_alone_are_refused(monkeypatch):
    """Their F and their offset come from the same track pairs and nothing checks them: no
    camera, each video says why."""
    cams, stats = _moving_point_cameras(monkeypatch, ["a", "b"])
    assert cams == {}
    fb = stats["sfm"]["fallback"]
    assert fb["used"] is False and "only two cameras came out" in fb["why"]
    for n in "ab":
        assert stats["dropped"][n].startswith("no reconstruction: too few matches; from the moving points: "
                                              "only two cameras came out"), stats["dropped"][n]
    # in a few words, both causes are kept (e.g. "only 2 track pairs" as the second)
    head = CueStats.from_json(stats).headline("a")
    assert head.startswith("no reconstruction: too few matches; from the moving points: only two cameras came out")
    # three are used, and so are two when the config asks for them
    cams, stats = _moving_point_cameras(monkeypatch, ["a", "b", "c"])
    assert set(cams) == {"a", "b", "c"} and stats["sfm"]["fallback"]["used"] is True
    from vs_inspect.cues.config import CameraConfig
    cams, stats = _moving_point_cameras(monkeypatch, ["a", "b"], CueConfig(
        camera=CameraConfig(fallback_unchecked_pair=True)))
    assert set(cams) == {"a", "b"} and stats["sfm"]["fallback"]["pairs"]["b"]["coarse_offset_s"] == 0.1


def _two_camera_models(monkeypatch, trusted: dict[str, set], second_allowed: bool = True,
                       second_fails: bool = False, registered: dict[str, str] | None = None,
                       config: CueConfig = CueConfig(), joints: dict | None = None):
    """camera_choice.estimated_cameras on three videos with camera models ("sift" first, "xfeat"
    second, "aliked" third when `trusted` names it, else none; the moving points' cameras, when
    `trusted` names "moving points", are used) whose pairing trusts the videos of `trusted`; each
    model has a camera for the videos `registered` names for it (default: all). joints: a model's
    joint vote record (CueStats' geometric_joint) as its vote leaves it.
    Returns (kept set, stats, sink, the kinds of the sets voted on, in order)."""
    import dataclasses
    from types import SimpleNamespace

    import vs_inspect.cues.cameras.sfm as cameras_mod
    import vs_inspect.cues.cameras.choice as ex
    from vs_inspect.cues.cameras.camera_set import CameraSet

    class Models:
        def __init__(self, *args, **kwargs):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            pass

        def first(self):
            return SimpleNamespace(features="sift", cameras=dict.fromkeys("abc"))

        def second(self):
            assert second_allowed, "the second model was asked for"
            if second_fails:
                raise RuntimeError("XFeat ran out of memory")
            return SimpleNamespace(features="xfeat")

        third_skipped = None

        def third(self):
            assert second_allowed, "the third model was asked for"
            if "aliked" in trusted:
                return SimpleNamespace(features="aliked")
            self.third_skipped = "ALIKED's model not tried: large images"
            return None

    seen = []

    def estimate(vids, cfg, pairs, est, from_tracks=False, grid=None, rules=None, kept=None):
        kind = ex.MOVING_POINTS if from_tracks else est.features
        sfm = SfmRecord(kind, 3, 3, {}, (), {})
        if from_tracks:  # the moving points' cameras, used when the test's trusted names them
            sfm = dataclasses.replace(sfm, fallback=MovingPointsCameras("none trusted", kind in trusted))
            if kind not in trusted:
                return CameraSet({}, {}, None, None, {}, sfm=sfm)
        names = (registered or {}).get(kind, "".join(vids))
        dropped = {n: f"{kind} matched too little; the moving points' cameras refused" for n in vids if n not in names}
        return CameraSet({n: CameraTrack(K, look_at([6.0, 0, 2.0], [0, 0, 1])) for n in names}, {}, None, None, {},
                         dropped, sfm=sfm)

    def vote(cams, vids, all_pairs, cfg, progress, estimated, grid=None, **kept):
        kind = cams.sfm.features
        seen.append(kind)
        pairing = GeometricPairing({}, {}, {}, "joint", {}, {}, joints.get(kind) if joints else None)
        return dataclasses.replace(cams, pairs={}, used=frozenset(trusted[kind]), pairing=pairing,
                                   notes=(Note("cues", f"voted on {kind}"),))

    monkeypatch.setattr(cameras_mod, "CameraModels", Models)
    monkeypatch.setattr(ex, "_estimate", estimate)
    monkeypatch.setattr(ex, "vote_on_cameras", vote)
    info = SimpleNamespace(width=640, height=480, num_frames=50)
    vids = {n: SimpleNamespace(sfm_frames=None, info=info, camera_motion="static", frame_features=None,
                               register_masks=None) for n in "abc"}
    kept = ex.estimated_cameras(vids, config, {}, {}, progress=False)
    return kept, _as_json(kept), SimpleNamespace(messages=[n.message for n in kept.notes]), seen


def test_second_camera_model_is_kept_when_its_joint_vote_trusts_more_videos(monkeypatch):
    kept, stats, sink, seen = _two_camera_models(monkeypatch, {"sift": {"a", "b"}, "xfeat": {"a", "b", "c"}})
    assert kept.used == {"a", "b", "c"} and stats["sfm"]["features"] == "xfeat"
    assert seen == ["sift", "xfeat"]
    assert stats["sfm"]["models"] == [{"features": "sift", "cameras": 3, "trusted": ["a", "b"], "kept": False},
                                      {"features": "xfeat", "cameras": 3, "trusted": ["a", "b", "c"], "kept": True}]
    # only the kept set's reports reach the sink, then the choice
    assert sink.messages[0] == "voted on xfeat" and "voted on sift" not in sink.messages
    assert sink.messages[-1] == ("camera models: XFEAT's kept; the joint vote trusted 2 video(s) on SIFT's, "
                                 "3 video(s) on XFEAT's")


def test_first_camera_model_is_kept_on_a_tie_and_alone_when_it_trusts_every_video(monkeypatch):
    kept, stats, sink, _ = _two_camera_models(monkeypatch, {"sift": {"a", "b"}, "xfeat": {"b", "c"}})
    assert stats["sfm"]["features"] == "sift" and [m["kept"] for m in stats["sfm"]["models"]] == [True, False]
    assert "voted on sift" in sink.messages and "voted on xfeat" not in sink.messages
    kept, stats, sink, seen = _two_camera_models(monkeypatch, {"sift": {"a", "b", "c"}}, second_allowed=False)
    assert seen == ["sift"] and "models" not in stats["sfm"]
    assert sink.messages == ["voted on sift"]


def test_third_camera_model_is_tried_when_the_kept_set_leaves_a_video_untrusted(monkeypatch):
    kept, stats, _, seen = _two_camera_models(
        monkeypatch, {"sift": {"a"}, "xfeat": {"a", "b"}, "aliked": {"a", "b", "c"}})
    assert kept.used == {"a", "b", "c"} and stats["sfm"]["features"] == "aliked"
    assert seen == ["sift", "xfeat", "aliked"]
    assert [(m["features"], m["kept"]) for m in stats["sfm"]["models"]] == [
        ("sift", False), ("xfeat", False), ("aliked", True)]
    # a third set trusting no more than the kept one is not kept
    kept, stats, _, _ = _two_camera_models(monkeypatch, {"sift": {"a"}, "xfeat": {"a", "b"}, "aliked": {"b", "c"}})
    assert stats["sfm"]["features"] == "xfeat" and kept.used == {"a", "b"}
    # when XFeat's set trusts every video, ALIKED's is not tried
    _, stats, _, seen = _two_camera_models(monkeypatch, {"sift": {"a"}, "xfeat": {"a", "b", "c"}, "aliked": set()})
    assert seen == ["sift", "xfeat"] and stats["sfm"]["features"] == "xfeat"
    assert "models_skipped" not in stats["sfm"]
    # a third model skipped says why, in result.json and to the recording, after the choice
    _, stats, sink, seen = _two_camera_models(monkeypatch, {"sift": {"a"}, "xfeat": {"a", "b"}})
    assert seen == ["sift", "xfeat"]
    assert stats["sfm"]["models_skipped"] == "ALIKED's model not tried: large images"
    assert sink.messages[-1] == "ALIKED's model not tried: large images"


def test_a_video_without_a_camera_says_what_every_model_made_of_it(monkeypatch):
    # SIFT's set (kept on the tie) has no camera for c, XFeat's registered it, ALIKED's did not
    kept, stats, _, _ = _two_camera_models(monkeypatch, {"sift": {"a", "b"}, "xfeat": {"a"}, "aliked": {"b"}},
                                           registered={"sift": "ab", "xfeat": "abc", "aliked": "ab"})
    assert stats["sfm"]["features"] == "sift" and "c" not in kept.cameras
    assert stats["dropped"] == {"c": (
        "sift matched too little; the moving points' cameras refused (also tried: XFEAT's model registered it, "
        "but its set was not kept (its joint vote trusted 1 video(s)); ALIKED's model: aliked matched too little)")}
    # the same in a few words (a trusted video gets none)
    assert stats["sfm"]["other_models_headline"] == {"c": {"XFEAT's model": "not trusted",
                                                           "ALIKED's model": "aliked matched too little"}}
    assert stats["sfm"]["kept_model"] == "SIFT's model"
    # with one model tried (XFeat's failed, ALIKED's skipped), the reason is the model's own
    _, stats, _, seen = _two_camera_models(monkeypatch, {"sift": {"a", "b"}}, registered={"sift": "ab"},
                                           second_fails=True)
    assert seen == ["sift"]
    assert stats["dropped"] == {"c": "sift matched too little; the moving points' cameras refused"}


def test_a_video_placed_but_not_timed_says_what_the_other_models_made_of_it(monkeypatch):
    """Every model places c, none is trusted for it: the kept set's record says, for c, why each
    other model's joint vote left it out, e.g. a rival offset (not the first model's vote alone);
    a trusted video gets no such note."""
    rival = ("its three-view check follows 55 trajectories at -1.217 s against 45 at its joint offset "
             "+0.000 s: two offsets, as a repeated motion gives")
    joints = {"xfeat": joint({"a": 9.0, "b": 8.0, "c": 7.5}, sure=("a", "b"), used=("a", "b"),
                             dissent={"c": rival}, dissent_short={"c": "two offsets 1.22 s apart"})}
    kept, stats, _, _ = _two_camera_models(monkeypatch, {"sift": {"a", "b"}, "xfeat": {"a", "b"}, "aliked": {"a"}},
                                           joints=joints)
    assert stats["sfm"]["features"] == "sift" and set(kept.cameras) == {"a", "b", "c"} and "c" not in kept.used
    note = stats["sfm"]["other_models"]["c"]
    assert note == ("XFEAT's model registered it, but its set was not kept (its joint vote trusted 2 video(s); "
                    "for this one: Stage 0's joint vote chose its offset (margin 7.5), but " + rival + ", so it got "
                    "no geometric track pairs); ALIKED's model registered it, but its set was not kept (its joint "
                    "vote trusted 1 video(s))")
    assert set(stats["sfm"]["other_models"]) == {"c"} and stats["dropped"] == {}
    assert stats["sfm"]["other_models_headline"] == {"c": {"XFEAT's model": "two offsets 1.22 s apart",
                                                           "ALIKED's model": "not trusted"}}
    # the typed record the run reads it from
    assert CueStats.from_json(stats).other_models_note("c") == note
    assert CueStats.from_json(stats).other_models_note("a") is None
    # one model tried: nothing to say
    _, stats, _, _ = _two_camera_models(monkeypatch, {"sift": {"a", "b"}}, second_fails=True)
    assert "other_models" not in stats["sfm"] and "other_models_headline" not in stats["sfm"]


def test_a_second_camera_model_that_fails_leaves_the_first_standing(monkeypatch):
    kept, stats, sink, seen = _two_camera_models(monkeypatch, {"sift": {"a", "b"}}, second_fails=True)
    assert kept.used == {"a", "b"} and seen == ["sift"]
    why = "the second camera model failed (RuntimeError: XFeat ran out of memory); SIFT's kept"
    # the third model is still asked for (here it is skipped)
    assert stats["sfm"]["models_failed"] == why
    assert sink.messages == ["voted on sift", why, "ALIKED's model not tried: large images"]


def test_the_moving_points_cameras_are_tried_when_no_model_is_trusted_for_any_video(monkeypatch):
    """Every model placed the cameras and the joint vote trusted nothing on any: the moving points'
    own cameras are tried last and kept when the vote trusts a video on them."""
    kept, stats, sink, seen = _two_camera_models(
        monkeypatch, {"sift": set(), "xfeat": set(), "aliked": set(), "moving points": {"a", "b"}},
        registered={"moving points": "ab"})
    assert seen == ["sift", "xfeat", "aliked", "moving points"]
    assert stats["sfm"]["features"] == "moving points" and kept.used == {"a", "b"}
    assert [(m["features"], m["kept"]) for m in stats["sfm"]["models"]] == [
        ("sift", False), ("xfeat", False), ("aliked", False), ("moving points", True)]
    assert sink.messages[-1] == ("camera models: the moving points' kept; the joint vote trusted 0 video(s) on "
                                 "SIFT's, 0 video(s) on XFEAT's, 0 video(s) on ALIKED's, 2 video(s) on the moving "
                                 "points'")
    # the video they have no camera for says what the models made of it
    assert stats["dropped"]["c"].startswith("moving points matched too little")
    assert "SIFT's model registered it, but its set was not kept" in stats["dropped"]["c"]
    # trusted on none of them either: the first model's set stays, the attempt is listed
    _, stats, _, seen = _two_camera_models(monkeypatch, {"sift": set(), "xfeat": set(), "moving points": set()})
    assert stats["sfm"]["features"] == "sift" and seen[-1] == "moving points"
    assert [m["features"] for m in stats["sfm"]["models"]] == ["sift", "xfeat", "moving points"]
    # not used (they explained the points worse): not listed
    _, stats, _, seen = _two_camera_models(monkeypatch, {"sift": set(), "xfeat": set()})
    assert [m["features"] for m in stats["sfm"]["models"]] == ["sift", "xfeat"]
    # a model trusted for some video: not tried
    _, stats, _, seen = _two_camera_models(monkeypatch, {"sift": {"a"}, "xfeat": set(), "moving points": {"a", "b"}})
    assert "moving points" not in seen and stats["sfm"]["features"] == "sift"


def test_the_record_says_when_sifts_static_images_had_asift_features(monkeypatch):
    """result.json's cues.sfm names the static cameras' features of SIFT's model (ASIFT by default,
    CameraConfig.asift_per_view), and says nothing of them with COLMAP's SIFT alone."""
    from vs_inspect.cues.config import CameraConfig

    _, stats = _moving_point_cameras(monkeypatch, ["a", "b", "c"])
    assert stats["sfm"]["features"] == "sift"
    assert stats["sfm"]["static_images"] == "ASIFT, 300 features per simulated view"
    _, stats = _moving_point_cameras(monkeypatch, ["a", "b", "c"], CueConfig(camera=CameraConfig(asift_per_view=0)))
    assert "static_images" not in stats["sfm"]
    # every camera moving: no static image had any
    from types import SimpleNamespace

    from vs_inspect.cues.cameras.model_or_points import _estimate
    from vs_inspect.cues.cameras.sfm import CameraEstimate

    est = CameraEstimate({}, dict.fromkeys("ab", "no reconstruction"), None, None, 2, 0, "sift")
    vids = {n: SimpleNamespace(camera_motion="moving") for n in "ab"}
    stats = _as_json(_estimate(vids, CueConfig(), {}, est))
    assert stats["sfm"]["features"] == "sift" and "static_images" not in stats["sfm"]
