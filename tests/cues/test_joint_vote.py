"""Stage 0's joint vote on one set of cameras (cues/pairing/joint.py): two moving cameras' pairs need a
triangle of sure cameras, sure cameras are checked in three views, cameras fitted to the moving
points are checked against their own votes."""

from __future__ import annotations

import numpy as np

from vs_inspect.cues.config import CueConfig, GeometricPairConfig
import vs_inspect.cues.pairing.joint as joint_mod
import vs_inspect.cues.pairing.rules as rules_mod
import vs_inspect.cues.pairing.votes as votes_mod
from vs_inspect.cues.pairing.joint import JointChoice
from vs_inspect.cues.pairing.votes import GeometricPairStats
from vs_inspect.cues.pairing.kept_pairs import _add_joint_pairs
from vs_inspect.geometry.epipolar import look_at
from vs_inspect.cue_stats import CueStats, PairCueStats
from vs_inspect.json_records import to_json
from vs_inspect.types import CameraTrack, TrackPairs

from .stage0_fakes import K


def _as_json(pairing) -> dict:
    """A pairing's records as result.json's "cues" holds them (a stats-like dict)."""
    pairs = {f"{a}__{b}": to_json(PairCueStats(0, 0, 0, 0, v, pairing.transfer_new.get((a, b))))
             for (a, b), v in pairing.votes.items()}
    out = {"pairs": pairs, "geometric_peaks": pairing.status}
    if pairing.joint is not None:
        out["geometric_joint"] = to_json(pairing.joint)
    return out


def _cue_stats(stats: dict) -> CueStats:
    return CueStats.from_json({"camera_source": "estimated", **stats})


def _stats(delta_s: float, n: int = 12) -> GeometricPairStats:
    """n informative candidates (track i of a with track i of b), all voting for delta_s."""
    idx = np.stack([np.arange(n), np.arange(n)], 1)
    return GeometricPairStats(n, n, n, (delta_s,), (n,), None, np.array([delta_s]), np.array([float(n)]),
                              0.1, idx, np.full(n, delta_s), np.ones(n))


def _run(moving_b: bool, sure_c: bool):
    moving = CameraTrack(K, np.stack([look_at([6.0, 0.01 * t, 1.5], [0, 0, 1]) for t in range(50)]))
    static = CameraTrack(K, look_at([0.0, 6.0, 2.5], [0, 0, 1]))
    cams = {"a": moving, "b": moving if moving_b else static, "c": moving}
    offs = {"a": 0.0, "b": 0.4, "c": 1.0}
    found = {(u, v): (None, _stats(offs[v] - offs[u])) for u, v in (("a", "b"), ("a", "c"), ("b", "c"))}
    pairs = {k: TrackPairs(*k, np.zeros((0, 2), np.int64)) for k in found}
    joint = JointChoice(offs, 10.0, {"a": 5.0, "b": 5.0, "c": 5.0 if sure_c else 1.0})
    sure = {"a": True, "b": True, "c": sure_c}
    notes = []
    out, _, _, record, _ = _add_joint_pairs(pairs, found, joint, sure, cams, {}, {}, CueConfig(), notes)
    return {k: len(v.index) for k, v in out.items()}, [n.message for n in notes], {"geometric_joint": to_json(record)}


def test_two_sure_cameras_pair_unless_both_move():
    """Two sure cameras use their joint Δ when one is static; two moving ones need a third sure
    camera (their per-frame geometry lets wrong tracks fit one wrong offset). An unsure camera's
    pairs are never used."""
    used, msgs, stats = _run(moving_b=False, sure_c=False)
    assert used == {("a", "b"): 12, ("a", "c"): 0, ("b", "c"): 0}
    assert stats["geometric_joint"]["sure"] == ["a", "b"] and stats["geometric_joint"]["used"] == ["a", "b"]
    assert not any("camera(s) only" in m for m in msgs)
    used, msgs, stats = _run(moving_b=True, sure_c=False)
    assert used == {("a", "b"): 0, ("a", "c"): 0, ("b", "c"): 0}
    assert any("both cameras move and the joint vote is sure of 2 camera(s) only" in m for m in msgs), msgs
    assert stats["geometric_joint"]["used"] == []
    # with the third camera sure every pair is used
    for moving_b in (False, True):
        used, msgs, stats = _run(moving_b=moving_b, sure_c=True)
        assert used == {("a", "b"): 12, ("a", "c"): 12, ("b", "c"): 12}
        assert not any("camera(s) only" in m for m in msgs)
        assert stats["geometric_joint"]["used"] == ["a", "b", "c"]


def test_transfer_matches_join_both_source_pairs_in_video_order():
    """A confirmed camera's tracks that follow a trajectory are paired with both tracks the
    trajectory came from, in each pair's key order (the camera first or second)."""
    from vs_inspect.cues.pairing.kept_pairs import _add_transfer_pairs
    from vs_inspect.cues.pairing.transfer import TransferCheck, TransferLandscape, Trajectories

    # trajectories 0 and 1 from pair (a, c): tracks a3-c5 and a4-c6; the checked camera is b
    traj = Trajectories(np.zeros((2, 3)), np.zeros(2), np.array([0, 1]),
                        np.array([[0, 3, 5, 10], [0, 4, 6, 10]]), (("a", "c"),))
    land = TransferLandscape(np.zeros(1), np.ones(1), np.ones(1, np.int64), np.ones(1, np.int64), 0, 9.0,
                             np.array([[0, 7], [1, 8]]))
    pairs = {k: TrackPairs(*k, np.array([[1, 1]])) for k in (("a", "b"), ("a", "c"), ("b", "c"))}
    checks = {"b": TransferCheck("b", 0.0, land, True, "confirmed")}
    out, added = _add_transfer_pairs(pairs, checks, traj, ["a", "b", "c"], [])
    assert out[("a", "b")].index.tolist() == [[1, 1], [3, 7], [4, 8]]  # a's track, then b's
    assert out[("b", "c")].index.tolist() == [[1, 1], [7, 5], [8, 6]]  # b's track, then c's
    assert out[("a", "c")].index.tolist() == [[1, 1]]
    assert added[("a", "b")] == 2
    # an unconfirmed camera gets nothing
    checks = {"b": TransferCheck("b", 0.0, land, False, "they disagree")}
    out, added = _add_transfer_pairs(pairs, checks, traj, ["a", "b", "c"], [])
    assert all(len(v.index) == 1 for v in out.values())


def test_descriptor_pairs_are_checked_when_the_triangles_do_not_close(monkeypatch):
    """The triangle fallback with inconsistent peaks adds no geometric pair, and keeps only the
    descriptor pairs consistent at the joint vote's (unsure) offsets: wrong ones go, right ones
    stay (alone, unchecked descriptor pairs put cameras 88-1456 ms off, accepted)."""
    from types import SimpleNamespace

    from vs_inspect.cues.config import GeometricPairConfig
    from vs_inspect.cues.pairing.pairing import add_geometric_pairs
    from vs_inspect.types import Tracks

    from .test_transfer import _scene

    offsets = {"a": 0.0, "b": 0.42, "c": -0.3}
    infos, cams, xy, truth_ab, row_of = _scene(offsets)
    rng = np.random.default_rng(3)
    pairs = {}
    for u, v in (("a", "b"), ("a", "c"), ("b", "c")):
        right = np.array([[row_of[u][p], row_of[v][p]] for p in range(30)])
        wrong = np.stack([rng.integers(0, 60, 20), rng.integers(0, 60, 20)], 1)
        wrong = wrong[[tuple(w) not in {tuple(r) for r in right} for w in wrong]]
        pairs[(u, v)] = TrackPairs(u, v, np.concatenate([right, wrong]))
    vids = {n: SimpleNamespace(info=infos[n]) for n in "abc"}
    tracks = {n: Tracks(xy[n], None) for n in "abc"}
    cfg = CueConfig(geometric=GeometricPairConfig(joint_min_margin=1e9))  # no camera sure
    monkeypatch.setattr(joint_mod, "consistent_peaks", lambda *a, **k: (None, "inconsistent"))
    got = add_geometric_pairs(pairs, cams, tracks, vids, cfg, progress=False, estimated=True)
    out, voted, stats = got.pairs, got.voted, _as_json(got)
    messages = [n.message for n in got.notes]
    assert stats["geometric_peaks"] == "inconsistent"
    assert voted == {}  # no Δ chosen, so none is reported as voted
    # each pair and each video's null reason say why it got no geometric pair
    assert all(p["geometric_withheld"].startswith("the vote peaks of the camera pairs do not close")
               for p in stats["pairs"].values())
    why = _cue_stats(stats).geometric_refusal("c")
    # c's two pairs share the reason, which is given once
    assert why.startswith("Stage 0 gave a__c and b__c no geometric track pairs: the vote peaks"), why
    assert why.count("the vote peaks") == 1, why
    # and in a few words, for the offsets table (result.json's "unresolved_headline")
    assert _cue_stats(stats).headline("c") == (
        "vote peaks do not close the triangles")
    assert any("descriptor pairs kept only where consistent" in m for m in messages)
    for (u, v), tp in out.items():
        right = {(row_of[u][p], row_of[v][p]) for p in range(30)}
        kept = {tuple(x) for x in tp.index.tolist()}
        assert kept <= right, (u, v, kept - right)  # no wrong pair left, no geometric pair added
        assert len(kept) >= 15, (u, v, len(kept))
        assert stats["pairs"][f"{u}__{v}"]["descriptor_pairs_kept"] == len(kept)


def _sure_of_all(monkeypatch, offsets: dict[str, float], estimated: bool = True, cfg: CueConfig = CueConfig()):
    """Stage 0's geometric pairs of the transfer scene (cameras a, b, c, true geometry) with the
    joint vote replaced by one sure (margin 10) of every camera at `offsets`: (pairs, stats, stage
    events, the scene's rows of each point)."""
    got, row_of = _pairing(monkeypatch, offsets, estimated, cfg)
    return got.pairs, _as_json(got), [n.message for n in got.notes], row_of


def _pairing(monkeypatch, offsets: dict[str, float], estimated: bool = True, cfg: CueConfig = CueConfig()):
    """(the GeometricPairing of _sure_of_all, the scene's rows of each point)."""
    from types import SimpleNamespace

    from vs_inspect.cues.pairing.pairing import add_geometric_pairs
    from vs_inspect.types import Tracks

    from .test_transfer import _scene

    infos, cams, xy, _, row_of = _scene({"a": 0.0, "b": 0.42, "c": -0.3})
    pairs = {k: TrackPairs(*k, np.zeros((0, 2), np.int64)) for k in (("a", "b"), ("a", "c"), ("b", "c"))}
    monkeypatch.setattr(joint_mod, "joint_offsets", lambda *a, **k: JointChoice(dict(offsets), 30.0, dict.fromkeys(offsets, 10.0)))
    got = add_geometric_pairs(pairs, cams, {n: Tracks(xy[n], None) for n in "abc"},
                              {n: SimpleNamespace(info=infos[n]) for n in "abc"}, cfg,
                              progress=False, estimated=estimated)
    return got, row_of


def test_the_joint_record_keeps_its_checks_typed(monkeypatch):
    """The record of a refused set is read in memory (what the other camera models made of a
    video): its three-view checks are ThreeViewSummary records, not dicts."""
    from vs_inspect.cue_stats import ThreeViewSummary, refusal_texts

    got, _ = _pairing(monkeypatch, {"a": 0.0, "b": 0.42, "c": 0.2})
    assert all(isinstance(v, ThreeViewSummary) for v in got.joint.three_view.values())
    assert got.joint.refused_in_three_views() == ["a", "b", "c"]
    assert "three views" in refusal_texts({}, {}, got.joint, "c")[1]


def test_sure_cameras_that_see_each_others_points_keep_their_pairs(monkeypatch):
    out, stats, msgs, row_of = _sure_of_all(monkeypatch, {"a": 0.0, "b": 0.42, "c": -0.3})
    three_view = stats["geometric_joint"]["three_view"]
    assert all(v["passed"] and v["supporters"] >= 10 for v in three_view.values()), three_view
    assert stats["geometric_joint"]["used"] == ["a", "b", "c"]
    for (u, v), tp in out.items():
        right = {(row_of[u][p], row_of[v][p]) for p in range(30)}
        kept = {tuple(x) for x in tp.index.tolist()}
        assert len(kept & right) >= 15 and len(kept - right) <= 2, (u, v)


def test_sure_cameras_refuted_in_three_views_get_no_pairs(monkeypatch):
    """The joint vote sure of c at an offset 0.5 s off (as wrong cameras make it): every
    camera's check uses a pair with c, so all three are refused, with their numbers, and no
    geometric pair is added (not even by the triangle rule)."""
    out, stats, msgs, _ = _sure_of_all(monkeypatch, {"a": 0.0, "b": 0.42, "c": 0.2})
    joint = stats["geometric_joint"]
    assert not any(v["passed"] for v in joint["three_view"].values()), joint["three_view"]
    assert joint["sure"] == [] and joint["used"] == [] and stats["geometric_peaks"] == "joint"
    assert all(len(tp.index) == 0 for tp in out.values())
    assert any("geometric track pairs not used for a, b, c: the joint vote was sure" in m for m in msgs), msgs
    cue_stats = _cue_stats(stats)
    why = cue_stats.geometric_refusal("c")
    assert "sure of its offset (margin 10.0), but not in three views" in why and "+0.200 s" in why
    assert cue_stats.headline("c", "not connected; its pairs: ...") == "refuted in three views; not connected"


def test_a_sure_camera_with_a_rival_offset_says_how_far_apart_the_two_offsets_lie(monkeypatch):
    """The rival-offset rule's refusal (geometric_pairs.rival_offsets, replaced here) reaches the
    record with its few words: how far the three-view check's best offset lies from the joint one."""

    seen = {}

    def rivals(votes, joint, sure, best, bound_s, share):
        seen.update(best=best, joint=dict(joint.offsets_s))
        return {"c": "its three-view check follows more trajectories elsewhere: two offsets"}

    monkeypatch.setattr(rules_mod, "rival_offsets", rivals)
    out, stats, msgs, _ = _sure_of_all(monkeypatch, {"a": 0.0, "b": 0.42, "c": -0.3})
    joint = stats["geometric_joint"]
    apart = abs(seen["best"]["c"][0] - seen["joint"]["c"])
    assert joint["dissent_short"] == {"c": f"two offsets {apart:.2f} s apart, as a repeated motion gives"}
    assert "c" not in joint["sure"] and "c" not in joint["used"]
    cue_stats = _cue_stats(stats)
    assert cue_stats.headline("c") == joint["dissent_short"]["c"]
    assert cue_stats.geometric_refusal("c").startswith("Stage 0's joint vote chose its offset (margin 10.0), but "
                                                      "its three-view check follows more")


def test_cameras_from_a_calibration_are_not_checked_in_three_views(monkeypatch):
    """The check is of estimated cameras: a calibration's are used as given, so the joint vote's
    choice stands unchecked here."""
    out, stats, msgs, _ = _sure_of_all(monkeypatch, {"a": 0.0, "b": 0.42, "c": 0.2}, estimated=False)
    joint = stats["geometric_joint"]
    assert "three_view" not in joint and joint["sure"] == ["a", "b", "c"]
    assert not any("three views" in m for m in msgs)




def _lone_pair(monkeypatch, moving_b: bool, **geometric):
    """Stage 0's geometric pairs of two cameras (no triangle; the joint vote sure of neither):
    a static, b static or moving, the vote with three peaks and 12 supporters each, 3 descriptor
    pairs. Returns (pairs, stats, stage events)."""
    from types import SimpleNamespace

    from vs_inspect.cues.pairing.pairing import add_geometric_pairs

    static = CameraTrack(K, look_at([0.0, 6.0, 2.5], [0, 0, 1]))
    moving = CameraTrack(K, np.stack([look_at([6.0, 0.01 * t, 1.5], [0, 0, 1]) for t in range(50)]))
    cams = {"a": static, "b": moving if moving_b else static}
    index = np.stack([np.arange(36), np.arange(36)], 1)
    stats_ab = GeometricPairStats(900, 60, 36, (0.5, 1.3, -0.7), (12, 12, 12), np.repeat([0, 1, 2], 12))
    monkeypatch.setattr(votes_mod, "geometric_pairs", lambda *a, **k: (TrackPairs("a", "b", index, np.ones(36)), stats_ab))
    monkeypatch.setattr(joint_mod, "joint_offsets", lambda *a, **k: JointChoice({"a": 0.0, "b": 0.5}, 1.0,
                                                                         {"a": 1.0, "b": 1.0}))
    desc = np.array([[100, 100], [101, 101], [102, 102]])
    vids = {n: SimpleNamespace(info=SimpleNamespace(frame_interval_s=1 / 30)) for n in "ab"}
    tracks = {n: SimpleNamespace(xy=None) for n in "ab"}  # read by the vote only, replaced here
    got = add_geometric_pairs({("a", "b"): TrackPairs("a", "b", desc, np.ones(3))}, cams, tracks, vids,
                              CueConfig(geometric=GeometricPairConfig(**geometric)),
                              progress=False, estimated=True)
    return got.pairs, _as_json(got), [n.message for n in got.notes]


def test_a_lone_pair_with_a_moving_camera_keeps_only_its_descriptor_pairs(monkeypatch):
    """No triangle checks the vote peaks of a pair with a moving camera, whose per-frame geometry
    lets wrong tracks fit a wrong offset: its geometric pairs are withheld, with the reason, and
    the run's reason for the video says so. Two static cameras keep every peak's supporters."""
    out, stats, msgs = _lone_pair(monkeypatch, moving_b=True)
    assert stats["geometric_peaks"] == "no triangle"
    assert out[("a", "b")].index.tolist() == [[100, 100], [101, 101], [102, 102]]
    info = stats["pairs"]["a__b"]
    assert info["geometric_pairs"] == 0 and "+0.500, +1.300, -0.700 s" in info["geometric_withheld"]
    assert any(m.startswith("geometric track pairs not used for a__b: no triangle") for m in msgs), msgs
    cue_stats = _cue_stats(stats)
    assert cue_stats.geometric_refusal("b").startswith("Stage 0 gave a__b no geometric track pairs: no triangle")
    assert cue_stats.geometric_refusal("a") == cue_stats.geometric_refusal("b")
    assert cue_stats.headline("b") == "a moving camera's vote peaks, no triangle to check them"

    out, stats, msgs = _lone_pair(monkeypatch, moving_b=True, unchecked_moving=True)  # the rule before
    assert len(out[("a", "b")].index) == 39 and "geometric_withheld" not in stats["pairs"]["a__b"]
    out, stats, msgs = _lone_pair(monkeypatch, moving_b=False)
    assert len(out[("a", "b")].index) == 39 and not any("not used" in m for m in msgs)
    # ...marked unchecked (Stage 1 confirms their minimum with the 3 descriptor pairs alone)
    assert out[("a", "b")].unchecked.tolist() == [False] * 3 + [True] * 36
    assert stats["pairs"]["a__b"]["geometric_unchecked"] == 36
    assert _cue_stats(stats).geometric_refusal("b") is None
