"""The arc scenes' names, per-offset errors in frames and the safety count."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.bench.arcs import (DEFAULT_SET, SCENE_SETS, PairTruth, camera_errors_px, fit_body_points, frame_errors,
                                   judge_pairs, parse_scene, summarize)
from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.types import CameraCalibration
from vs_inspect.types import CameraTrack


def test_parse_scene_and_its_rendering_settings():
    sc = parse_scene("a60_c4m1_s12")
    assert (sc.arc_deg, sc.cameras, sc.moving, sc.seed) == (60.0, 4, 1, 12)
    cfg = sc.scene_config()
    assert (cfg.arc_deg, cfg.cameras, cfg.moving, cfg.seed, cfg.seconds) == (60.0, 4, 1, 12, 6.0)
    assert (cfg.width, cfg.height, cfg.fps) == (640, 480, 30.0)


def test_a_mixed_rate_scene_draws_each_cameras_rate():
    sc = parse_scene("a45_c5m2_s76_mixed")
    assert (sc.arc_deg, sc.cameras, sc.moving, sc.seed, sc.mixed_rates) == (45.0, 5, 2, 76, True)
    assert sc.scene_config().fps is None  # drawn per camera by the renderer
    assert not parse_scene("a45_c5m2_s76").mixed_rates


@pytest.mark.parametrize("name, says", [("a60_c4m1", "not a scene name"), ("a0_c4m1_s1", "outside 1-360"),
                                        ("a60_c2m2_s1", "one of them static"), ("a60_c1m0_s1", "at least 2"),
                                        ("a60_c4m1_s1_mix", "not a scene name")])
def test_parse_scene_refuses_bad_names(name, says):
    with pytest.raises(ValueError, match=says):
        parse_scene(name)


def test_the_scene_sets_share_no_seed():
    seeds = {k: {parse_scene(n).seed for n in names} for k, names in SCENE_SETS.items()}
    for a in seeds:
        for b in seeds:
            assert a == b or not seeds[a] & seeds[b], (a, b)
    for k in SCENE_SETS:
        if k.startswith("seeds-"):
            lo, hi = map(int, k.removeprefix("seeds-").split("-"))
            assert seeds[k] == set(range(lo, hi + 1)), k
    assert seeds["mixed-rates"] == set(range(70, 82))
    assert DEFAULT_SET in SCENE_SETS
    # every set after the first mixes arcs and cameras as seeds 10-21 do
    later = ("seeds-22-33", "seeds-34-45", "seeds-46-57", "seeds-58-69", "mixed-rates")
    kinds = {k: sorted(n.rsplit("_s", 1)[0] for n in SCENE_SETS[k]) for k in ("seeds-10-21",) + later}
    assert all(kinds[k] == kinds["seeds-10-21"] for k in later)
    assert all(parse_scene(n).mixed_rates == (k == "mixed-rates") for k, names in SCENE_SETS.items() for n in names)


def test_frame_errors_against_the_results_reference():
    truth = {"cam0": 0.0, "cam1": 0.5, "cam2": -1.0}
    # cam1 is the reference used; cam2 one frame late against it, cam0 unresolved
    offsets = {"cam0": None, "cam1": 0.0, "cam2": -1.5 + 1 / 30}
    err = frame_errors("cam1", offsets, truth, fps=30.0)
    assert err["cam0"] is None
    assert err["cam2"] == pytest.approx(1.0)
    assert "cam1" not in err
    # a reference without an offset leaves nothing resolved
    assert frame_errors("cam0", offsets, truth, fps=30.0) == {"cam1": None, "cam2": None}


def test_frame_errors_with_each_videos_rate_count_the_slower_videos_frames():
    truth = {"cam0": 0.0, "cam1": 0.5, "cam2": -1.0}
    offsets = {"cam0": 0.0, "cam1": 0.5 + 0.1, "cam2": -1.0 - 0.1}  # each 0.1 s off
    err = frame_errors("cam0", offsets, truth, {"cam0": 60.0, "cam1": 24.0, "cam2": 50.0})
    assert err["cam1"] == pytest.approx(2.4)  # in 24 fps frames (cam1 is the slower)
    assert err["cam2"] == pytest.approx(-5.0)  # in 50 fps frames (the reference is faster)


def test_summarize_counts_the_offsets_over_two_frames():
    s = summarize([0.2, -0.9, 1.5, -2.5, None, 36.6])
    assert (s.offsets, s.resolved, s.within_1, s.from_1_to_2, s.over_2) == (6, 5, 2, 1, 2)
    assert s.median_abs_frames == pytest.approx(1.5)
    assert s.max_abs_frames == pytest.approx(36.6)
    empty = summarize([None, None])
    assert (empty.resolved, empty.over_2, empty.median_abs_frames) == (0, 0, None)


def _turned(T: np.ndarray, deg: float) -> np.ndarray:
    """cam_from_world turned by deg about the camera's own y axis."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    out = T.copy()
    out[:3] = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ T[:3]
    return out


def test_camera_errors_are_zero_for_the_true_cameras_and_grow_with_a_turn():
    """Points moving through the view of two static cameras and a hand-held one (per-frame
    poses, 60 of its 90 frames not valid); a camera turned by two degrees leaves its pairs'
    true points off their epipolar lines, the others not."""
    rng = np.random.default_rng(1)
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    g = np.linspace(-1.0, 4.0, 601)
    start = rng.uniform(-1, 1, (40, 3)) * [1.5, 1.5, 0.5]
    velocity = rng.uniform(-1, 1, (40, 3)) * 0.4
    points = start[:, None] + velocity[:, None] * g[None, :, None]  # (M,G,3)
    static = {n: look_at(np.array(c), np.zeros(3)) for n, c in (("a", (0, -6, 1.5)), ("b", (5, -3, 1.5)))}
    fps, frames = 30.0, 90
    hand = np.stack([look_at(np.array([-4 + 0.01 * k, -4.0, 1.5]), np.zeros(3)) for k in range(frames)])
    truth = {n: CameraCalibration(K, np.zeros(5), T, (640, 480)) for n, T in static.items()}
    truth["c"] = CameraCalibration(K, np.zeros(5), hand, (640, 480))
    stamps = {n: np.arange(frames) / fps for n in truth}
    offsets = {"a": 0.0, "b": 0.4, "c": 0.1}
    valid = np.ones(frames, bool)
    valid[:60] = False
    exact = {n: CameraTrack(K, cal.cam_from_world) for n, cal in truth.items()}
    unsure = hand.copy()
    unsure[:60] = [_turned(T, 5.0) for T in hand[:60]]  # wrong poses where not valid: never used
    exact["c"] = CameraTrack(K, unsure, valid)
    got = camera_errors_px(exact, truth, stamps, offsets, g, points)
    assert set(got) == {("a", "b"), ("a", "c"), ("b", "c")}
    assert max(got.values()) < 1e-6
    turned = dict(exact, b=CameraTrack(K, _turned(static["b"], 2.0)))
    off = camera_errors_px(turned, truth, stamps, offsets, g, points)
    assert off[("a", "b")] > 1.0 and off[("b", "c")] > 1.0 and off[("a", "c")] < 1e-6
    # the points are undistorted as the tracks were: a shift there is an error too
    shifted = camera_errors_px(exact, truth, stamps, offsets, g, points, undistort={"a": lambda xy: xy + [0.0, 3.0]})
    assert shifted[("a", "b")] > 0.5 and shifted[("b", "c")] < 1e-6
    # a camera with no estimate is left out
    assert set(camera_errors_px({"a": exact["a"], "b": exact["b"]}, truth, stamps, offsets, g, points)) == {("a", "b")}


def _moving_body(spin: float, speed: float, height: float):
    """world_from_body(g) (G,4,4): a body turning about its vertical axis while it walks."""
    def pose(g):
        g = np.asarray(g, np.float64)
        c, s = np.cos(spin * g), np.sin(spin * g)
        W = np.zeros((len(g), 4, 4))
        W[:, 0, 0], W[:, 0, 1], W[:, 1, 0], W[:, 1, 1] = c, -s, s, c
        W[:, 2, 2] = W[:, 3, 3] = 1.0
        W[:, :3, 3] = np.stack([speed * g - 1.0, 0.3 * np.sin(g), np.full_like(g, height)], 1)
        return W
    return pose


def test_track_pairs_are_judged_against_the_true_body_points():
    """Tracks that are exact projections of points on two moving bodies, seen by a static and a
    hand-held camera: each track is traced to its body point; a pair of one point is the same
    point, a pair of two points (on one body or two) is not, and a track that jumps from one
    point to another halfway follows no body point."""
    rng = np.random.default_rng(3)
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    frames, fps = 60, 30.0
    g = 0.5 + np.arange(frames) / fps
    bodies = [_moving_body(0.8, 0.6, 1.0), _moving_body(-0.5, 0.4, 0.4)]
    on_body = [rng.uniform(-0.25, 0.25, (6, 3)) for _ in bodies]
    static = look_at(np.array([0.0, -6.0, 1.5]), np.array([0.0, 0.0, 0.8]))
    hand = np.stack([look_at(np.array([5.0 - 0.02 * k, -3.0, 1.6]), np.array([0.0, 0.0, 0.8])) for k in range(frames)])

    def tracks(cams):
        cams = np.broadcast_to(cams, (frames, 4, 4))
        out = []
        for W, pts in zip((f(g) for f in bodies), on_body):
            X = np.einsum("tij,mj->mti", W[:, :3, :3], pts) + W[None, :, :3, 3]  # (M,T,3)
            out.append(np.stack([project(K, cams[t], X[:, t]) for t in range(frames)], 1))
        return np.concatenate(out)  # (12,T,2): body 0's points, then body 1's

    xa, xb = tracks(static), tracks(hand)
    xa[2, :20] = np.nan  # unseen for a while: still its point
    jumped = np.concatenate([xa[0, :30], xa[1, 30:]])  # slides from point 0 to point 1
    short = np.full((frames, 2), np.nan)
    short[:5] = xa[3, :5]  # too short to say
    xa = np.concatenate([xa, jumped[None], short[None]])
    fit_a = fit_body_points(xa, g, K, static, bodies)
    fit_b = fit_body_points(xb, g, K, hand, bodies)
    assert list(fit_a.body[:12]) == [0] * 6 + [1] * 6 and list(fit_b.body) == [0] * 6 + [1] * 6
    assert np.allclose(fit_a.point_body[:6], on_body[0], atol=1e-3)
    assert np.allclose(fit_b.point_body[6:], on_body[1], atol=1e-3)
    assert fit_a.residual_px[:12].max() < 1e-3
    assert fit_a.body[12] == -1 and fit_a.residual_px[12] > 1.5  # the slid track
    assert fit_a.body[13] == -1 and np.isinf(fit_a.residual_px[13])  # the short one
    same = np.stack([np.arange(12), np.arange(12)], 1)
    assert judge_pairs(same, fit_a, fit_b) == PairTruth(12, 0, 0)
    # another point of body 0, a point of body 1, and two pairs with a track that follows no point
    got = judge_pairs(np.array([[0, 1], [0, 7], [12, 0], [13, 3]]), fit_a, fit_b)
    assert (got.same_point, got.other_point, got.not_rigid, got.total) == (0, 2, 2, 4)
