"""Stage 1 by a worn camera's sightings (sync/sightings.py): a static camera a sees the wearer of a
moving camera b; with no track pair between them, the heads a found time the pair, Stage 2 takes
it like any pair, and heads that are not b's wearer give a null with the reason."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.pipeline.stage12 import sync_bundle
from vs_inspect.sync import sightings as sightings_mod
from vs_inspect.sync.config import SightingConfig, SyncConfig
from vs_inspect.types import CameraTrack, CueBundle, Tracks, VideoInfo

K = np.array([[400.0, 0, 320], [0, 400.0, 240], [0, 0, 1]])
TRUE_B_S = 0.8  # b's clip starts 0.8 s after a's (DESIGN.md: offset_s of b, a the reference)


def _centre_b(global_s):
    """b's wearer walks to and fro 5-7 m in front of a (head height 1.7 m)."""
    g = np.asarray(global_s, float)
    return np.stack([1.8 * np.sin(0.8 * g), 6.0 + np.cos(0.5 * g), 1.7 + 0.05 * np.sin(2.5 * g)], -1)


def _bundle(heads_of_b: bool = True, seed: int = 0) -> CueBundle:
    rng = np.random.default_rng(seed)
    va = VideoInfo("a", 640, 480, 100, np.arange(100) / 10.0, 10.0)
    vb = VideoInfo("b", 640, 480, 90, np.arange(90) / 10.0, 10.0)
    pose_a = look_at([0, 0, 1.6], [0, 6.0, 1.6])
    centres = _centre_b(vb.timestamps_s + TRUE_B_S)
    pose_b = np.stack([look_at(c, [0, 0, 1.6]) for c in centres])
    head = project(K, np.broadcast_to(pose_a, (100, 4, 4)), _centre_b(va.timestamps_s))
    head += rng.normal(0, 1.5, head.shape)
    if not heads_of_b:  # someone else, standing still where b's wearer never goes
        head = np.tile([100.0, 120.0], (100, 1)) + rng.normal(0, 1.5, (100, 2))
    head[rng.random(100) < 0.3] = np.nan  # frames without a detection
    empty = {n: Tracks(np.zeros((0, v.num_frames, 2)), np.zeros(0, np.int32)) for n, v in (("a", va), ("b", vb))}
    return CueBundle((va, vb), {"a": CameraTrack(K, pose_a), "b": CameraTrack(K, pose_b)}, empty, {},
                     gt_offsets_s={"a": 0.0, "b": TRUE_B_S}, heads={"a": head})


def test_sightings_time_a_pair_without_track_pairs():
    res = sync_bundle(_bundle(), progress=False)
    assert res.offsets_s["b"] == pytest.approx(TRUE_B_S, abs=0.05), res.unresolved_reason
    (land,) = res.pairs
    assert land.residual == "sighting" and land.decision.accepted and land.num_track_pairs == 0
    assert "a sees the person carrying b" in land.decision.reason
    # off: no cue at all between them
    off = sync_bundle(_bundle(), SyncConfig(sightings=SightingConfig(enabled=False)), progress=False)
    assert off.offsets_s["b"] is None


def test_heads_of_someone_else_leave_the_pair_null_with_the_reason():
    res = sync_bundle(_bundle(heads_of_b=False), progress=False)
    assert res.offsets_s["b"] is None
    assert "sightings of a camera's carrier" in res.unresolved_reason["b"], res.unresolved_reason


def test_too_few_sightings_are_refused():
    b = _bundle()
    head = b.heads["a"].copy()
    head[np.flatnonzero(np.isfinite(head[:, 0]))[6:]] = np.nan  # 6 detections left, 8 needed
    res = sync_bundle(dataclasses.replace(b, heads={"a": head}), progress=False)
    assert res.offsets_s["b"] is None and "need 8" in res.unresolved_reason["b"], res.unresolved_reason


def test_an_offset_rests_on_one_sighting_at_most():
    """a sees b's wearer, b sees c's: c's offset would chain two sightings (whose errors can add
    up), so c is null with the reason; with max_chain 2 it is resolved."""
    rng = np.random.default_rng(3)
    b2 = _bundle()
    TRUE_C_S = -0.5
    vc = VideoInfo("c", 640, 480, 80, np.arange(80) / 10.0, 10.0)

    def centre_c(global_s):  # c's wearer, between b's and a, in b's view
        g = np.asarray(global_s, float)
        return np.stack([0.8 * np.sin(1.1 * g + 1), 3.0 + 0.4 * np.cos(0.7 * g), 1.7 + 0.0 * g], -1)
    pose_c = np.stack([look_at(c, [0, 6.0, 1.6]) for c in centre_c(vc.timestamps_s + TRUE_C_S)])
    vb = b2.video("b")
    head_b = project(K, b2.cameras["b"].cam_from_world, centre_c(vb.timestamps_s + TRUE_B_S))
    head_b += rng.normal(0, 1.5, head_b.shape)
    bundle = CueBundle((*b2.videos, vc), {**b2.cameras, "c": CameraTrack(K, pose_c)},
                       {**b2.tracks, "c": Tracks(np.zeros((0, 80, 2)), np.zeros(0, np.int32))}, {},
                       gt_offsets_s={"a": 0.0, "b": TRUE_B_S, "c": TRUE_C_S}, heads={**b2.heads, "b": head_b})
    res = sync_bundle(bundle, progress=False)
    accepted = {(p.a, p.b) for p in res.pairs if p.decision.accepted}
    assert accepted == {("a", "b"), ("b", "c")}, [(p.a, p.b, p.decision.reason) for p in res.pairs]
    assert res.offsets_s["b"] == pytest.approx(TRUE_B_S, abs=0.05)
    assert res.offsets_s["c"] is None and "2 sightings of camera carriers in a chain" in res.unresolved_reason["c"]
    two = sync_bundle(bundle, SyncConfig(sightings=SightingConfig(max_chain=2)), progress=False)
    assert two.offsets_s["c"] == pytest.approx(TRUE_C_S, abs=0.1)


def test_the_benchmark_ablations_keep_a_sighting_pair():
    """The bench's filter-off ablation re-decides epipolar landscapes only, and its pair subsets
    may pick a pair that only a sighting timed."""
    from vs_inspect.bench.suite import without_filter
    from vs_inspect.pipeline.stage12 import solve_stage2

    b = _bundle()
    lands = list(sync_bundle(b, progress=False).pairs)
    kept = without_filter(lands)
    assert [p.decision for p in kept] == [p.decision for p in lands]
    assert solve_stage2(b, kept).offsets_s["b"] == pytest.approx(TRUE_B_S, abs=0.05)


@pytest.mark.parametrize("seed, viewer_is_pair_b", [(0, False), (1, False), (0, True)])
def test_a_head_beside_the_worn_camera_is_fitted_out_of_the_offset(seed, viewer_is_pair_b, monkeypatch):
    """The heads sit 12 px beside b's centre (the face is not the camera) and are seen mostly
    while the wearer walks one way: the counted peak comes out 1-1.5 frames late; the fit with one
    constant shift puts the offset back within a fifth of a frame, and the reason gives the shift.
    A window too narrow to hold the fit's minimum keeps the counted peak, with the reason. The
    viewer is the pair's a, or its b (videos in the other order: the pair is (b, a))."""
    b = _bundle(seed=seed)
    t = b.video("a").timestamps_s
    head = b.heads["a"] + np.array([12.0, 0.0])
    head[(t < 1.5) | (t > 4.5)] = np.nan  # seen from its turn at about 2 s on
    b = dataclasses.replace(b, heads={"a": head}, videos=b.videos[::-1] if viewer_is_pair_b else b.videos)
    b_after_a = lambda r: r.offsets_s["b"] - r.offsets_s["a"]  # noqa: E731
    monkeypatch.setattr(sightings_mod, "REFINE_FRAMES", 0)
    counted = sync_bundle(b, progress=False)
    monkeypatch.undo()
    assert b_after_a(counted) - TRUE_B_S >= 0.08, counted.offsets_s
    res = sync_bundle(b, progress=False)
    assert b_after_a(res) == pytest.approx(TRUE_B_S, abs=0.02), res.pairs[0].decision.reason
    (land,) = res.pairs
    assert (land.a, land.b) == (("b", "a") if viewer_is_pair_b else ("a", "b")) and land.decision.accepted
    assert land.best_offset_s == pytest.approx(-TRUE_B_S if viewer_is_pair_b else TRUE_B_S, abs=0.02)
    dx, dy = (float(v) for v in land.decision.reason.split("(a: (")[1].split(")")[0].replace(" px", "").split(","))
    assert (dx, dy) == pytest.approx((12.0, 0.0), abs=1.5), land.decision.reason
    monkeypatch.setattr(sightings_mod, "REFINE_FRAMES", 0.2)
    narrow = sync_bundle(b, progress=False)
    assert b_after_a(narrow) == pytest.approx(b_after_a(counted))
    assert "not refined" in narrow.pairs[0].decision.reason


def test_a_direction_without_heads_on_the_centre_gives_no_shift():
    """Both cameras 'move' (a's poses per frame), so b's heads are looked at too; they are someone
    else's, never on a's centre: the refit and its reason name a's shift only (no NaN)."""
    b = _bundle(seed=0)
    t = b.video("a").timestamps_s
    head = b.heads["a"] + np.array([12.0, 0.0])
    head[(t < 1.5) | (t > 4.5)] = np.nan
    pose_a = np.broadcast_to(b.cameras["a"].cam_from_world, (len(t), 4, 4)).copy()
    others = np.tile([600.0, 40.0], (b.video("b").num_frames, 1))  # b sees someone in a corner
    b = dataclasses.replace(b, heads={"a": head, "b": others},
                            cameras={**b.cameras, "a": CameraTrack(K, pose_a)})
    res = sync_bundle(b, progress=False)
    (land,) = res.pairs
    assert b.cameras["a"].is_moving and "b sees the person carrying a" in land.decision.reason
    assert res.offsets_s["b"] == pytest.approx(TRUE_B_S, abs=0.02), land.decision.reason
    assert "(a: (" in land.decision.reason and "b: (" not in land.decision.reason and "nan" not in land.decision.reason
