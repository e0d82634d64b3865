"""Point transfer: the 3D trajectories of two synchronized cameras find a third camera's offset
and its tracks (static and hand-held third camera), and refuse when its tracks follow nothing."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.cues.pairing.transfer import (candidate_offsets, check_in_three_views, confirm_offset, transfer_landscape, triangulate_pairs)
from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.geometry.offsets import OffsetGrid
from vs_inspect.types import CameraTrack, TrackPairs, VideoInfo

K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
FPS = {"a": 25.0, "b": 30.0, "c": 24.0}
T = 120


def _motion(rng, n, t):
    """(n, len(t), 3) points wandering in a 2 m box above the floor."""
    start = rng.uniform([-1, -1, 0.3], [1, 1, 1.7], (n, 3))
    vel = rng.normal(0, 0.5, (n, 3))
    freq = rng.uniform(0.3, 1.2, (n, 1))
    phase = rng.uniform(0, 6.3, (n, 1))
    wobble = 0.5 * np.sin(freq * t[None, :] * 6.28 + phase)[..., None] * rng.normal(0, 1, (n, 1, 3))
    return start[:, None, :] + vel[:, None, :] * 0.4 * t[None, :, None] + wobble


def _scene(offsets, c_moving=False, seed=0, points=30, distractors=30):
    """Cameras a, b, c around the box; each sees the same points (rows shuffled) plus its own
    distractors; offset_s[v] is the global time of v's local time 0 (DESIGN.md)."""
    rng = np.random.default_rng(seed)
    cams = {"a": CameraTrack(K, look_at([6.0, 0.0, 1.5], [0, 0, 1])),
            "b": CameraTrack(K, look_at([0.0, 6.0, 2.5], [0, 0, 1]))}
    if c_moving:
        path = np.stack([look_at([-6.0 + 0.01 * k, -3.0 + 0.02 * k, 2.0], [0, 0, 1]) for k in range(T)])
        cams["c"] = CameraTrack(K, path)
    else:
        cams["c"] = CameraTrack(K, look_at([-6.0, -3.0, 2.0], [0, 0, 1]))
    ts = {v: np.arange(T) / FPS[v] for v in "abc"}
    seeds = rng.integers(0, 2**31, points)
    # a continuous motion of each point, sampled at each video's own moments
    fine_t = np.linspace(-4.0, 10.0, 2801)
    X = _motion(np.random.default_rng(seeds[0]), points, fine_t)

    def at(Xs, times):
        idx = np.clip(np.rint((times - fine_t[0]) / (fine_t[1] - fine_t[0])).astype(int), 0, len(fine_t) - 1)
        return Xs[:, idx]

    xy, perm = {}, {}
    for v in "abc":
        g = ts[v] + offsets[v]
        Xv = at(X, g)
        cam = cams[v]
        P = project(cam.K, cam.cam_from_world, Xv)
        own = _motion(rng, distractors, fine_t)
        Pd = project(cam.K, cam.cam_from_world, at(own, g))
        perm[v] = rng.permutation(points)
        xy[v] = np.concatenate([P[perm[v]], Pd]) + rng.normal(0, 0.3, (points + distractors, T, 2))
        for n in range(len(xy[v])):  # each track seen for part of the video
            s = rng.integers(0, T // 3)
            xy[v][n, :s] = np.nan
            xy[v][n, s + rng.integers(40, T):] = np.nan
    infos = {v: VideoInfo(v, 640, 480, T, ts[v], FPS[v]) for v in "abc"}
    row_of = {v: {int(p): r for r, p in enumerate(perm[v])} for v in "abc"}  # point -> row
    truth_ab = np.array([[row_of["a"][p], row_of["b"][p]] for p in range(points)])
    return infos, cams, xy, truth_ab, row_of


@pytest.mark.parametrize("c_moving", [False, True])
@pytest.mark.parametrize("offset_c", [-0.9, 0.35])
def test_the_third_cameras_offset_and_tracks_are_found(c_moving, offset_c):
    offsets = {"a": 0.0, "b": 0.42, "c": offset_c}
    infos, cams, xy, truth_ab, row_of = _scene(offsets, c_moving)
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    assert traj.num_trajectories >= 20
    grid = candidate_offsets(traj, infos["c"], 0.5 / FPS["c"])
    land = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], grid, radius_px=3.0)
    assert land.offset_s == pytest.approx(offset_c, abs=1.0 / FPS["c"])
    assert land.z > 5
    # most samples inside c's video land on their track (a wrong pose of c loses about half)
    assert land.support[land.best] / land.overlap[land.best] > 0.6
    # every match pairs c's track with the same physical point the trajectory came from
    point_of_c = {r: p for p, r in row_of["c"].items()}
    point_of_a = {r: p for p, r in row_of["a"].items()}
    right = [point_of_c.get(int(j)) == point_of_a[int(traj.source[t, 1])] for t, j in land.matches]
    assert len(right) >= 15 and np.mean(right) >= 0.95
    chk = confirm_offset("c", offset_c + 0.5 / FPS["c"], land, 1 / FPS["c"], 2.0, 5.0, 8)
    assert chk.confirmed, chk.reason


def test_tracks_that_follow_nothing_give_no_clear_peak_and_are_refused():
    offsets = {"a": 0.0, "b": 0.42, "c": 0.2}
    infos, cams, xy, truth_ab, _ = _scene(offsets)
    rng = np.random.default_rng(1)
    # c's tracks scrambled in time: still moving points, none following a trajectory
    xy_c = xy["c"][:, rng.permutation(T)]
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    grid = candidate_offsets(traj, infos["c"], 0.5 / FPS["c"])
    land = transfer_landscape(traj, infos["c"], cams["c"], xy_c, grid, radius_px=3.0)
    chk = confirm_offset("c", 0.2, land, 1 / FPS["c"], 2.0, 5.0, 8)
    assert not chk.confirmed
    assert "transfer" in chk.reason or "trajector" in chk.reason


def test_a_joint_offset_away_from_the_transfer_peak_is_refused_with_both_numbers():
    offsets = {"a": 0.0, "b": 0.42, "c": 0.35}
    infos, cams, xy, truth_ab, _ = _scene(offsets)
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    land = transfer_landscape(traj, infos["c"], cams["c"], xy["c"],
                              candidate_offsets(traj, infos["c"], 0.5 / FPS["c"]), radius_px=3.0)
    chk = confirm_offset("c", 0.35 + 5 / FPS["c"], land, 1 / FPS["c"], 2.0, 5.0, 8)
    assert not chk.confirmed
    assert "disagree" in chk.reason and "+0.35" in chk.reason


def test_nothing_to_transfer_gives_an_empty_landscape():
    infos, cams, xy, truth_ab, _ = _scene({"a": 0.0, "b": 0.42, "c": 0.0})
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab[:0])},
                             {"a": 0.0, "b": 0.42})
    assert traj.num_trajectories == 0
    land = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], np.linspace(-1, 1, 5), 3.0)
    assert land.offset_s is None and len(land.matches) == 0
    chk = confirm_offset("c", 0.0, land, 1 / FPS["c"], 2.0, 5.0, 8)
    assert not chk.confirmed and "no trajectory" in chk.reason


def test_tracks_near_the_projections_but_never_within_the_radius_give_an_empty_landscape():
    # tracks within reach of the projections (the radius plus the largest step of a track) but
    # none within the radius make an empty set of hits, which must not raise IndexError
    infos, cams, xy, truth_ab, _ = _scene({"a": 0.0, "b": 0.42, "c": 0.2})
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    jumper = np.full((1, T, 2), np.nan)
    jumper[0, :2] = [[-5000.0, 0.0], [-5000.0, 10000.0]]  # a 10000 px step: every track within reach
    xy_c = np.concatenate([xy["c"] + 2000.0, jumper])  # and none near a projection
    land = transfer_landscape(traj, infos["c"], cams["c"], xy_c, candidate_offsets(traj, infos["c"], 0.5 / FPS["c"]),
                              radius_px=3.0)
    assert land.offset_s is None and len(land.matches) == 0 and not land.support.any()
    assert not confirm_offset("c", 0.2, land, 1 / FPS["c"], 2.0, 5.0, 8).confirmed


def test_many_offsets_thin_the_samples_and_still_find_the_offset(monkeypatch):
    import vs_inspect.cues.pairing.transfer as transfer

    offsets = {"a": 0.0, "b": 0.42, "c": 0.35}
    infos, cams, xy, truth_ab, _ = _scene(offsets)
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    grid = candidate_offsets(traj, infos["c"], 0.5 / FPS["c"])
    full = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], grid, radius_px=3.0)
    monkeypatch.setattr(transfer, "MAX_BRACKETS", len(grid) * len(traj.time_s) // 3)
    thin = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], grid, radius_px=3.0, min_hits=3)
    assert thin.overlap.max() < 0.4 * full.overlap.max()  # a quarter of the samples
    assert thin.offset_s == pytest.approx(0.35, abs=1.0 / FPS["c"]) and thin.z > 5


@pytest.mark.parametrize("c_moving", [False, True])
def test_a_right_camera_at_its_offset_passes_in_three_views_a_wrong_camera_or_offset_does_not(c_moving):
    offsets = {"a": 0.0, "b": 0.42, "c": 0.35}
    infos, cams, xy, truth_ab, _ = _scene(offsets, c_moving)
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    right = check_in_three_views("c", 0.35, traj, infos["c"], cams["c"], xy["c"], 3.0, 5, 4, 1 / 3)
    assert right.passed and right.supporters >= 15 and right.trajectories == traj.num_trajectories
    assert "agrees in three views" in right.reason
    # c's camera on the other side of the scene (as a wrong reconstruction puts it), same tracks
    wrong_cam = CameraTrack(K, look_at([-3.0, 6.0, 4.0], [0, 0, 1]))
    bad = check_in_three_views("c", 0.35, traj, infos["c"], wrong_cam, xy["c"], 3.0, 5, 4, 1 / 3)
    assert not bad.passed and bad.supporters < 4
    assert f"{bad.supporters} of the {traj.num_trajectories} trajectories" in bad.reason
    assert "disagrees in three views" in bad.reason
    late = check_in_three_views("c", 0.35 + 0.5, traj, infos["c"], cams["c"], xy["c"], 3.0, 5, 4, 1 / 3)
    assert not late.passed and late.supporters < right.supporters / 4
    assert late.best_supporters >= right.supporters - 2 and late.best_offset_s == pytest.approx(0.35, abs=1 / 24)
    assert f"{late.best_supporters} at " in late.reason
    assert late.summary().passed is False and late.summary().joint_offset_s == 0.85


def test_candidate_offsets_honour_the_range_and_the_window():
    """Point transfer searches only the offsets the run allows: --range-s and --min-overlap-s
    bound its candidates; an --around window holds its choice (the z-score's median stays the
    whole range's): around the truth it is found, a window that leaves it out cannot find it."""
    offsets = {"a": 0.0, "b": 0.42, "c": -0.9}
    infos, cams, xy, truth_ab, _ = _scene(offsets)
    traj = triangulate_pairs(infos, cams, xy, {("a", "b"): TrackPairs("a", "b", truth_ab)},
                             {"a": 0.0, "b": 0.42})
    step = 0.5 / FPS["c"]
    free = candidate_offsets(traj, infos["c"], step)
    ranged = candidate_offsets(traj, infos["c"], step, OffsetGrid(range_s=0.5), "a")
    assert free.min() < -0.5 and free.max() > 0.5
    assert ranged.min() >= -0.5 - 1e-9 and ranged.max() <= 0.5 + 1e-9
    land = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], ranged, radius_px=3.0)
    assert land.offset_s is None or abs(land.offset_s - (-0.9)) > 0.3  # the truth is outside the range
    window = OffsetGrid(windows_s=(("c", -1.2, -0.6),), reference="a")
    grid = candidate_offsets(traj, infos["c"], step, window, "a")
    assert np.array_equal(grid, free)  # the window does not crop the candidates
    land = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], grid, radius_px=3.0,
                              allowed=window.within_window("a", "c", grid))
    assert land.offset_s == pytest.approx(-0.9, abs=1.0 / FPS["c"])
    away = OffsetGrid(windows_s=(("c", 0.0, 0.6),), reference="a")
    land = transfer_landscape(traj, infos["c"], cams["c"], xy["c"], grid, radius_px=3.0,
                              allowed=away.within_window("a", "c", grid))
    assert land.offset_s is None or 0.0 - 1e-9 <= land.offset_s <= 0.6 + 1e-9
