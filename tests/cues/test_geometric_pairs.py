"""Track pairs from epipolar consistency: static and hand-held cameras (one or both moving), points
moving in 3D."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.cues.pairing.joint import JointChoice, consistent_peaks, joint_offsets
from vs_inspect.cues.pairing.rules import joint_vote_share, rival_offsets
from vs_inspect.cues.pairing.votes import GeometricPairStats, consistent_at, epipolar_extent, geometric_pairs, supporters
from vs_inspect.geometry.epipolar import fundamental_from_cameras, look_at, project
from vs_inspect.geometry.offsets import OffsetGrid
from vs_inspect.types import CameraTrack, VideoInfo

K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
FPS = 25.0


def _scene(offset_s: float, seed: int = 0, points: int = 40, distractors: int = 40):
    """Cameras a and b, tracks of the same 3D points (b's order shuffled) plus unrelated tracks.

    Global time of a's frame k is k/FPS; of b's frame k is k/FPS + offset_s (DESIGN.md)."""
    rng = np.random.default_rng(seed)
    cam_a = CameraTrack(K, look_at([6.0, 0.0, 1.5], [0, 0, 1]))
    cam_b = CameraTrack(K, look_at([0.0, 6.0, 2.5], [0, 0, 1]))
    T = 100
    t_glob = np.arange(T + 80) / FPS - 40 / FPS  # global times covering both videos

    def trajectories(n):
        start = rng.uniform([-1, -1, 0.3], [1, 1, 1.7], (n, 3))
        vel = rng.normal(0, 0.6, (n, 3))
        freq = rng.uniform(0.5, 1.5, (n, 1))
        phase = rng.uniform(0, 6.3, (n, 1))
        wobble = 0.4 * np.sin(freq * t_glob[None, :] * 6.28 + phase)[..., None] * rng.normal(0, 1, (n, 1, 3))
        return start[:, None, :] + vel[:, None, :] * t_glob[None, :, None] * 0.5 + wobble

    X = trajectories(points)
    X_other = trajectories(distractors)

    def view(cam, Xs, shift_s):
        idx = np.rint((np.arange(T) / FPS + shift_s - t_glob[0]) * FPS).astype(int)
        return project(cam.K, cam.cam_from_world, Xs[:, idx])

    xy_a = np.concatenate([view(cam_a, X, 0.0), view(cam_a, X_other[: distractors // 2], 0.0)])
    perm = rng.permutation(points)
    xy_b = np.concatenate([view(cam_b, X, offset_s)[perm],
                           view(cam_b, X_other[distractors // 2:], offset_s)])
    xy_a += rng.normal(0, 0.3, xy_a.shape)
    xy_b += rng.normal(0, 0.3, xy_b.shape)
    # tracks are seen for a part of the video only
    for xy in (xy_a, xy_b):
        for n in range(len(xy)):
            s = rng.integers(0, T // 2)
            xy[n, :s] = np.nan
            xy[n, s + rng.integers(25, T // 2):] = np.nan
    truth = {int(np.nonzero(perm == i)[0][0]): i for i in range(points)}  # b index -> a index
    ts = np.arange(T) / FPS
    info_a = VideoInfo("a", 640, 480, T, ts, FPS)
    info_b = VideoInfo("b", 640, 480, T, ts, FPS)
    return info_a, info_b, cam_a, cam_b, xy_a, xy_b, {v: k for k, v in truth.items()}


@pytest.mark.parametrize("offset_s", [-0.6, 0.0, 0.84])
def test_pairs_are_the_same_points_and_the_top_peak_is_the_offset(offset_s):
    info_a, info_b, cam_a, cam_b, xy_a, xy_b, a_to_b = _scene(offset_s)
    tp, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b)
    # Δ_ab = offset_b - offset_a; a's time is b's time + Δ
    assert st.peaks_s[0] == pytest.approx(offset_s, abs=1.5 / FPS)
    correct = sum(a_to_b.get(int(i)) == int(j) for i, j in tp.index)
    assert correct >= 25, (correct, len(tp.index))
    # the top peak's supporters are nearly all right (other peaks carry the rest)
    assert st.peak_votes[0] > 2 * max(st.peak_votes[1:] + (0,))


def test_moving_camera_with_per_frame_poses_pairs_with_a_static_one():
    rng = np.random.default_rng(3)
    cam_a = CameraTrack(K, look_at([6.0, 0.0, 1.5], [0, 0, 1]))
    T, n, shift = 100, 40, 8  # b starts 8 frames after a: Δ_ab = +8 / FPS
    poses = np.stack([look_at([0.015 * t, 6.0 - 0.01 * t, 2.5] + rng.normal(0, 0.02, 3), [0, 0, 1])
                      for t in range(T)])
    cam_b = CameraTrack(K, poses)
    t_glob = np.arange(T + shift)
    start = rng.uniform([-1, -1, 0.3], [1, 1, 1.7], (2 * n, 3))
    vel = rng.normal(0, 0.02, (2 * n, 3))
    phase = rng.uniform(0, 6.3, (2 * n, 1))
    X = start[:, None] + vel[:, None] * t_glob[None, :, None] \
        + 0.4 * np.sin(0.2 * t_glob[None, :] + phase)[..., None] * rng.normal(0, 1, (2 * n, 1, 3))
    xy_a = project(cam_a.K, cam_a.cam_from_world, X[:n, :T]) + rng.normal(0, 0.3, (n, T, 2))
    perm = rng.permutation(n)
    Xb = np.concatenate([X[:n][perm], X[n:]])[:, shift:shift + T]  # b's frame q = global q + shift
    xy_b = np.stack([project(K, poses[q], Xb[:, q]) for q in range(T)], 1) + rng.normal(0, 0.3, (2 * n, T, 2))
    ts = np.arange(T) / FPS
    info_a, info_b = VideoInfo("a", 640, 480, T, ts, FPS), VideoInfo("b", 640, 480, T, ts, FPS)
    a_of_b = {j: int(perm[j]) for j in range(n)}
    tp, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b)
    assert st.peaks_s[0] == pytest.approx(shift / FPS, abs=1.5 / FPS)
    top = tp.index[st.pair_peak == 0]
    right = sum(a_of_b.get(int(j)) == int(i) for i, j in top)
    assert right >= 30 and right >= 0.9 * len(top), (right, len(top))
    # the same pair the other way round: the moving camera first, Δ negated, the same pairs
    tp2, st2 = geometric_pairs("b", "a", info_b, info_a, cam_b, cam_a, xy_b, xy_a)
    assert st2.peaks_s[0] == pytest.approx(-st.peaks_s[0])
    assert {tuple(x) for x in tp2.index[:, ::-1].tolist()} == {tuple(x) for x in tp.index.tolist()}


def _two_moving(shift: int, seed: int = 5, n: int = 40):
    """Two hand-held cameras (per-frame poses, turning and walking) seeing n moving points plus n
    that only b sees; b's frame q is global frame q + shift, a's frame q is global q."""
    rng = np.random.default_rng(seed)
    T = 100
    poses_a = np.stack([look_at([6.0 - 0.02 * t, 0.5 * np.sin(0.05 * t), 1.5] + rng.normal(0, 0.02, 3),
                                [0.3 * np.sin(0.07 * t), 0, 1]) for t in range(T)])
    poses_b = np.stack([look_at([0.03 * t - 1.5, 6.0 - 0.01 * t, 2.5] + rng.normal(0, 0.02, 3),
                                [0, 0.3 * np.cos(0.06 * t), 1]) for t in range(T)])
    t_glob = np.arange(T + abs(shift) + 1)
    start = rng.uniform([-1, -1, 0.3], [1, 1, 1.7], (2 * n, 3))
    vel = rng.normal(0, 0.02, (2 * n, 3))
    phase = rng.uniform(0, 6.3, (2 * n, 1))
    X = start[:, None] + vel[:, None] * t_glob[None, :, None] \
        + 0.4 * np.sin(0.2 * t_glob[None, :] + phase)[..., None] * rng.normal(0, 1, (2 * n, 1, 3))
    Xa = X[:n, :T]
    perm = rng.permutation(n)
    Xb = np.concatenate([X[:n][perm], X[n:]])[:, shift:shift + T]
    xy_a = np.stack([project(K, poses_a[q], Xa[:, q]) for q in range(T)], 1) + rng.normal(0, 0.3, (n, T, 2))
    xy_b = np.stack([project(K, poses_b[q], Xb[:, q]) for q in range(T)], 1) + rng.normal(0, 0.3, (2 * n, T, 2))
    ts = np.arange(T) / FPS
    info_a, info_b = VideoInfo("a", 640, 480, T, ts, FPS), VideoInfo("b", 640, 480, T, ts, FPS)
    return info_a, info_b, poses_a, poses_b, xy_a, xy_b, {j: int(perm[j]) for j in range(n)}


def test_two_moving_cameras_pair_with_their_per_frame_poses():
    shift = 8  # Δ_ab = +8 / FPS
    info_a, info_b, poses_a, poses_b, xy_a, xy_b, a_of_b = _two_moving(shift)
    cam_a, cam_b = CameraTrack(K, poses_a), CameraTrack(K, poses_b)
    tp, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b)
    assert st.peaks_s[0] == pytest.approx(shift / FPS, abs=1.5 / FPS)
    top = tp.index[st.pair_peak == 0]
    right = sum(a_of_b.get(int(j)) == int(i) for i, j in top)
    assert right >= 30 and right >= 0.9 * len(top), (right, len(top))
    # the other way round: Δ negated, nearly the same pairs (the interpolated camera is then b,
    # so the peak may move by a grid step or two)
    tp2, st2 = geometric_pairs("b", "a", info_b, info_a, cam_b, cam_a, xy_b, xy_a)
    assert st2.peaks_s[0] == pytest.approx(-shift / FPS, abs=1.5 / FPS)
    assert len({tuple(x) for x in tp2.index[:, ::-1].tolist()} & {tuple(x) for x in top.tolist()}) >= 0.9 * len(top)
    # the true pairs are consistent at the true Δ and not 1 s away; a's pose at b's moments
    # matters: with a held at its first pose most true pairs no longer fit
    true = np.array([[a_of_b[j], j] for j in range(len(a_of_b))])
    args = (2.0, 0.8, 8)
    at_truth = consistent_at(info_a, info_b, cam_a, cam_b, xy_a, xy_b, true, shift / FPS, *args)
    away = consistent_at(info_a, info_b, cam_a, cam_b, xy_a, xy_b, true, shift / FPS + 1.0, *args)
    frozen = consistent_at(info_a, info_b, CameraTrack(K, poses_a[0]), cam_b, xy_a, xy_b, true,
                           shift / FPS, *args)
    assert at_truth.mean() >= 0.9 and away.mean() <= 0.2 and frozen.mean() <= 0.5, \
        (at_truth.mean(), away.mean(), frozen.mean())


def test_no_motion_gives_nothing():
    info_a, info_b, cam_a, cam_b, xy_a, xy_b, _ = _scene(0.0)
    still_a = np.repeat(np.nanmedian(xy_a, axis=1, keepdims=True), info_a.num_frames, 1)
    still_b = np.repeat(np.nanmedian(xy_b, axis=1, keepdims=True), info_b.num_frames, 1)
    tp, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, still_a, still_b)
    assert len(tp.index) == 0 and st.candidates == 0


def test_sweep_counts_motion_across_epipolar_lines_only():
    cam_a = CameraTrack(K, look_at([6.0, 0.0, 1.5], [0, 0, 1]))
    cam_b = CameraTrack(K, look_at([0.0, 6.0, 2.5], [0, 0, 1]))
    F = fundamental_from_cameras(cam_a.K, cam_a.cam_from_world, cam_b.K, cam_b.cam_from_world)
    e_b = np.linalg.svd(F)[2][-1]  # F e_b = 0
    x0 = np.array([300.0, 200.0])
    toward = (e_b[:2] / e_b[2]) - x0
    toward /= np.linalg.norm(toward)
    across = np.array([-toward[1], toward[0]])
    steps = np.linspace(0, 30, 20)[:, None]
    along_track = x0 + steps * toward
    across_track = x0 + steps * across
    sweep = epipolar_extent(np.stack([along_track, across_track]), e_b)
    assert sweep[0] < 0.5
    assert sweep[1] == pytest.approx(30, abs=1.0)



def test_consistent_peaks_close_every_triangle():
    # true offsets: a 0, b 0.5, c -0.3, d 1.0; the top peak of b__c is wrong (a repeated motion)
    peaks = {("a", "b"): ((0.5, 1.9), (40, 30)),
             ("a", "c"): ((-0.3, 0.8), (35, 33)),
             ("b", "c"): ((2.0, -0.8), (50, 20)),
             ("a", "d"): ((1.0,), (30,)), ("b", "d"): ((0.5,), (30,)), ("c", "d"): ((1.3,), (30,))}
    assert consistent_peaks(peaks, 0.05) == ({("a", "b"): 0, ("a", "c"): 0, ("b", "c"): 1, ("a", "d"): 0,
                                              ("b", "d"): 0, ("c", "d"): 0}, "chosen")
    # two cameras: no triangle, nothing to choose
    assert consistent_peaks({("a", "b"): ((0.5, 1.9), (40, 30))}, 0.05) == (None, "no triangle")
    # no combination closes: some peaks are wrong
    bad = dict(peaks)
    bad[("b", "c")] = ((2.0, 3.0), (50, 20))
    assert consistent_peaks(bad, 0.05) == (None, "inconsistent")


def test_consistent_peaks_near_tie_decided_by_closure():
    # the peaks of rendered seed 1 (true Δ: a-b -0.740, a-c 0.472, b-c 1.211): a__b's top peak
    # has 81 votes against 78 for the right one; both close within 0.12 s, the right one by 17 ms
    # against 58 ms. A fourth camera d (one clear peak per pair, at the truth) gives three more
    # triangles, so that several closing choices are not a lone triangle's chance closures.
    peaks = {("a", "b"): ((-0.675, -0.75, -0.6333), (81, 78, 73)),
             ("a", "c"): ((0.4833, 0.4417, 0.5417), (166, 141, 124)),
             ("b", "c"): ((1.2167, 1.3, 1.1333), (225, 160, 154)),
             ("a", "d"): ((0.9,), (100,)), ("b", "d"): ((1.64,), (100,)), ("c", "d"): ((0.428,), (100,))}
    chosen, status = consistent_peaks(peaks, 0.12)
    assert status == "chosen"
    assert chosen == {("a", "b"): 1, ("a", "c"): 0, ("b", "c"): 0, ("a", "d"): 0, ("b", "d"): 0, ("c", "d"): 0}
    # a clear vote lead is not overturned by a better closure
    clear = dict(peaks)
    clear[("a", "b")] = ((-0.675, -0.75, -0.6333), (160, 78, 73))
    assert consistent_peaks(clear, 0.12)[0][("a", "b")] == 0
    # the same three cameras alone: one triangle, too weak a check
    three = {k: v for k, v in peaks.items() if "d" not in k}
    assert consistent_peaks(three, 0.12) == (None, "one triangle")


def test_consistent_peaks_refuse_a_lone_triangle_closed_by_chance():
    """Three cameras give one triangle, which wrong peaks close by chance. The demo with only
    cam0, cam2 and hand-held cam3 (calibration): two choices close it, with cam2 0.26 and 0.21 s
    off (its pair with cam3 has no right peak); taking one reported cam2 192 ms off. The run's
    peaks, in s (true Δ: -1.119, -0.211, 0.908)."""
    peaks = {("cam0", "cam2"): ((-1.175, -0.8583, -0.9083), (160, 153, 140)),
             ("cam0", "cam3"): ((-0.2083, 1.025, 0.9333), (163, 107, 96)),
             ("cam2", "cam3"): ((-0.825, -0.7167, 0.6917), (99, 98, 91))}
    assert consistent_peaks(peaks, 0.1) == (None, "one triangle")
    # the demo with cam0, cam1 and cam3, estimated cameras: one choice closes, on cam0__cam1's
    # peaks of 7-9 votes, and put cam1 and cam3 1.14 s off (true Δ: 0.375, -0.211, -0.586)
    unique = {("cam0", "cam1"): ((1.558, 1.317, 1.792), (9, 8, 7)),
              ("cam0", "cam3"): ((7.55, 7.125, 0.925), (30, 29, 23)),
              ("cam1", "cam3"): ((-1.842, -0.575, -3.117), (75, 53, 50))}
    assert consistent_peaks(unique, 0.1) == (None, "one triangle")


def _votes(peaks: dict[float, int], lo: float = -3.0, hi: float = 3.0, step: float = 0.02,
           seed: int = 0) -> GeometricPairStats:
    """A pair's vote histogram: chance votes everywhere plus the given peaks (Δ -> votes)."""
    rng = np.random.default_rng(seed)
    offs = np.round(np.arange(lo, hi + step / 2, step), 6)
    v = rng.poisson(2.0, len(offs)).astype(float)
    for d, n in peaks.items():
        v[np.argmin(np.abs(offs - d))] += n
    return GeometricPairStats(0, int(v.sum()), 0, (), (), None, offs, v, 0.03)


def test_joint_offsets_closes_the_pairs_where_a_single_pair_would_pick_a_false_peak():
    # true offsets: a 0, b 0.5, c -0.3; a__b's false peak (a repeated motion) is the higher one
    found = {("a", "b"): _votes({1.9: 30, 0.5: 24}, seed=1),
             ("a", "c"): _votes({-0.3: 25, 0.8: 12}, seed=2),
             ("b", "c"): _votes({-0.8: 22, 2.0: 15}, seed=3)}
    choice = joint_offsets(found, 0.1)
    assert choice is not None
    assert choice.offsets_s["a"] == 0.0
    assert choice.offsets_s["b"] == pytest.approx(0.5, abs=0.021)
    assert choice.offsets_s["c"] == pytest.approx(-0.3, abs=0.021)
    assert all(m > 3 for m in choice.margin.values()), choice.margin
    # a camera whose pairs carry no peak at all is not preferred anywhere: its margin is small
    flat = dict(found)
    flat[("a", "c")] = _votes({}, seed=4)
    flat[("b", "c")] = _votes({}, seed=5)
    weak = joint_offsets(flat, 0.1)
    assert weak.margin["c"] < 3 < weak.margin["b"]
    # two cameras: nothing to close
    assert joint_offsets({("a", "b"): found[("a", "b")]}, 0.1) is None


def test_supporters_are_one_to_one_with_the_least_residual():
    st = GeometricPairStats(5, 5, 0, (), (), None, np.array([0.0, 0.1]), np.array([3.0, 2.0]), 0.05,
                            np.array([[1, 7], [1, 8], [2, 7], [3, 9], [4, 9]]),
                            np.array([0.5, 0.52, 0.48, 0.5, 1.5]), np.array([1.0, 0.5, 0.2, 1.0, 0.1]))
    got = {tuple(x) for x in supporters(st, 0.5).tolist()}
    # (4, 9) votes elsewhere; 1-8 and 2-7 beat 1-7 (total residual 0.7 against 1.0 + nothing)
    assert got == {(1, 8), (2, 7), (3, 9)}
    assert len(supporters(st, -2.0)) == 0
    flipped = st.swapped()
    assert {tuple(x) for x in supporters(flipped, -0.5).tolist()} == {(8, 1), (7, 2), (9, 3)}


def test_consistent_at_keeps_the_same_points_at_the_right_offset_only():
    info_a, info_b, cam_a, cam_b, xy_a, xy_b, a_to_b = _scene(0.4)
    right = np.array([[i, j] for i, j in a_to_b.items()])
    wrong = np.stack([right[:, 0], np.roll(right[:, 1], 1)], 1)
    ok = consistent_at(info_a, info_b, cam_a, cam_b, xy_a, xy_b, right, 0.4, 2.0, 0.8, 8)
    assert ok.mean() > 0.8
    assert consistent_at(info_a, info_b, cam_a, cam_b, xy_a, xy_b, wrong, 0.4, 2.0, 0.8, 8).mean() < 0.1
    assert consistent_at(info_a, info_b, cam_a, cam_b, xy_a, xy_b, right, -0.4, 2.0, 0.8, 8).mean() < 0.2


def test_points_near_the_epipole_do_not_vote():
    """b also sees points next to a's camera (a head-worn camera's wearer, seen by the other
    wearer): they sit near the epipole, where every epipolar line passes, so any track
    of a fits them at some offset. Such moments are not counted; the true pairs still vote."""
    from dataclasses import replace

    from vs_inspect.cues.pairing.votes import VOTE

    shift = 8
    info_a, info_b, poses_a, poses_b, xy_a, xy_b, a_of_b = _two_moving(shift)
    rng = np.random.default_rng(11)
    T = info_b.num_frames
    centers_a = np.stack([-p[:3, :3].T @ p[:3, 3] for p in poses_a])  # a's centre, its frame q
    near = rng.uniform(-0.15, 0.15, (10, 1, 3))
    heads = centers_a[np.clip(np.arange(T) + shift, 0, T - 1)][None] + near  # at b's moments
    xy_heads = np.stack([project(K, poses_b[q], heads[:, q]) for q in range(T)], 1)
    xy_b = np.concatenate([xy_b, xy_heads + rng.normal(0, 0.3, xy_heads.shape)])
    head_rows = set(range(len(xy_b) - 10, len(xy_b)))
    cam_a, cam_b = CameraTrack(K, poses_a), CameraTrack(K, poses_b)
    off = replace(VOTE, epipole_margin_tau=0.0)
    _, st_off = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b, off)
    tp, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b)
    def head_votes(stats):  # (votes of pairs with a head track, the most at one offset)
        h = np.isin(stats.cand_index[:, 1], list(head_rows))
        _, n = np.unique(np.round(stats.cand_offset_s[h] * FPS), return_counts=True)
        return int(h.sum()), int(n.max(initial=0))

    # counted, every head fits every track of a at the offset that puts a's camera beside it
    voted_off, most_off = head_votes(st_off)
    voted, most = head_votes(st)
    assert voted_off >= 50 and most_off >= 50 and voted <= 10 and most <= 3, (voted_off, most_off, voted, most)
    assert st.peaks_s[0] == pytest.approx(shift / FPS, abs=1.5 / FPS)
    top = tp.index[st.pair_peak == 0]
    assert sum(a_of_b.get(int(j)) == int(i) for i, j in top) >= 30


def _voted(counts: dict[float, int]) -> GeometricPairStats:
    """A pair whose informative candidates vote for the given Δ_ab (s -> votes), each a peak."""
    offs = np.concatenate([np.full(n, d) for d, n in counts.items()])
    peaks = sorted(counts, key=lambda d: -counts[d])
    return GeometricPairStats(len(offs), len(offs), 0, tuple(peaks), tuple(counts[d] for d in peaks),
                              None, None, None, 0.03, np.zeros((len(offs), 2), np.int64), offs,
                              np.ones(len(offs)))


def test_joint_vote_share_is_the_votes_at_the_delta_over_the_top_peak():
    st = _voted({-0.9: 100, 0.3: 20})
    assert joint_vote_share(st, 0.3) == pytest.approx(0.2)
    assert joint_vote_share(st, 0.32) == pytest.approx(0.2)  # within the halfwidth
    assert joint_vote_share(st, -0.9) == 1.0
    assert joint_vote_share(st, 2.0) == 0.0
    assert joint_vote_share(GeometricPairStats(0, 0, 0, (), ()), 0.0) == 1.0  # no votes: no dissent


def _one_candidate(y_a: np.ndarray, y_b: np.ndarray, min_share: float):
    """_consistency on one track pair under epipolar lines y_a = y_b (two cameras side by side),
    at three offsets: a's frame q - 1, q, q + 1 for b's frame q (-1 where a has no frame).
    Returns (number of consistent offsets, best offset index)."""
    from vs_inspect.cues.pairing.vote_kernels import _consistency

    Ta, Tb = len(y_a), len(y_b)
    xa = np.stack([np.full(Ta, 100.0), y_a], 1)[None]  # (1,Ta,2)
    xb = np.stack([np.full(Tb, 300.0), y_b], 1)[None]
    G = np.array([[0.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # x_aᵀ G x_b = y_b - y_a
    G = np.broadcast_to(G, (1, Tb, 3, 3)).copy()
    e = np.broadcast_to([1.0, 0.0, 0.0], (1, Tb, 3)).copy()  # epipoles at infinity
    k = np.arange(Tb)[None, :] + np.arange(-1, 2)[:, None]
    k = np.where((k >= 0) & (k <= Ta - 2), k, -1).astype(np.int64)
    w = np.zeros(k.shape)
    n, best, _ = _consistency(xa, xb, np.zeros(1, np.int64), np.zeros(1, np.int64), G, e, e, k, w,
                              4.0, 8, min_share, 2, 8.0, 1, 0.0)
    return int(n[0]), int(best[0])


def test_consistency_counts_a_pair_at_the_share_and_the_frame_count_it_needs_exactly():
    """The vote's pruning (only the moments both tracks are seen, left once the share cannot be
    reached) must not refuse a pair that meets the bars exactly."""
    y = 10.0 * np.arange(13)  # b's point sweeps 120 px across the horizontal epipolar lines
    y_b = y[:12]
    assert _one_candidate(y, y_b, 0.75) == (1, 1)  # a's frame q at b's frame q: every moment fits
    # 9 of 12 moments fit, the 3 misses first: the share is 0.75 exactly, consistent
    y_a = y.copy()
    y_a[[0, 1, 2]] += 50.0
    assert _one_candidate(y_a, y_b, 0.75) == (1, 1)
    y_a[5] += 50.0  # 8 of 12: refused
    assert _one_candidate(y_a, y_b, 0.75) == (0, -1)
    # a seen on frames 0-8 only: 8 moments of b meet it (frames 0-7 interpolate to 8), min_frames
    short = y.copy()
    short[9:] = np.nan
    assert _one_candidate(short, y_b, 0.75) == (1, 1)
    short[8] = np.nan  # 7 moments: too few
    assert _one_candidate(short, y_b, 0.75) == (0, -1)


def test_a_camera_with_a_rival_offset_in_three_views_and_in_its_votes_is_not_sure():
    """The joint vote puts the hand-held d one period of a repeated
    motion off (+2.317 s; truth +1.100 s); its pairs also vote for the truth, and its three-view
    check follows more trajectories there (21 against 16)."""
    joint = JointChoice({"a": 0.0, "b": 1.1, "c": -1.1, "d": 2.317}, 128.0, {"a": 39.0, "b": 36.0, "c": 5.4, "d": 8.7})
    found = {("a", "b"): _voted({1.1: 500}), ("a", "c"): _voted({-1.1: 300}), ("b", "c"): _voted({-2.2: 220}),
             ("a", "d"): _voted({2.283: 37, 1.1: 23}), ("b", "d"): _voted({1.217: 67, 0.0: 47}),
             ("c", "d"): _voted({3.417: 27, 2.2: 24})}
    sure = dict.fromkeys("abcd", True)
    best = {"d": (1.1, 21, 16)}
    out = rival_offsets(found, joint, sure, best, 0.2, 0.3)
    assert list(out) == ["d"]
    assert "follows 21 trajectories at +1.100 s against 16 at its joint offset +2.317 s" in out["d"]
    assert "a__d 0.62" in out["d"] and "b__d 0.70" in out["d"] and "c__d 0.89" in out["d"]
    # one pair that all but rules the rival out keeps it sure
    ruled_out = {**found, ("c", "d"): _voted({3.417: 27, 2.2: 3})}
    assert rival_offsets(ruled_out, joint, sure, best, 0.2, 0.3) == {}
    # a rival as near as a peak's own width, or with fewer trajectories than the joint offset, is none
    assert rival_offsets(found, joint, sure, {"d": (2.15, 21, 16)}, 0.2, 0.3) == {}
    assert rival_offsets(found, joint, sure, {"d": (1.1, 16, 16)}, 0.2, 0.3) == {}
    # only sure cameras are judged, against the other sure cameras' pairs
    assert rival_offsets(found, joint, {**sure, "d": False}, best, 0.2, 0.3) == {}
    assert list(rival_offsets(ruled_out, joint, {**sure, "c": False}, best, 0.2, 0.3)) == ["d"]


def test_the_vote_searches_only_the_offsets_the_run_allows():
    """Stage 0's vote obeys --range-s, --min-overlap-s and --around as Stage 1 does: outside the
    range the true offset gets no vote; a window holds the peaks (the votes span the range, for
    their z-scores)."""
    info_a, info_b, cam_a, cam_b, xy_a, xy_b, _ = _scene(0.84)
    _, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b, grid=OffsetGrid(range_s=0.5))
    assert st.vote_offsets_s is None or np.abs(st.vote_offsets_s).max() <= 0.5 + 1e-9
    assert all(abs(p - 0.84) > 0.2 for p in st.peaks_s)
    span = info_a.timestamps_s[-1] - info_a.timestamps_s[0]
    _, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b, grid=OffsetGrid(min_overlap_s=2.0))
    assert np.abs(st.vote_offsets_s).max() <= span - 2.0 + 1e-9
    window = OffsetGrid(windows_s=(("b", 0.6, 1.1),), reference="a")
    _, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b, grid=window)
    assert st.vote_offsets_s.min() < 0.0 and st.window_s == (0.6, 1.1)
    assert st.peaks_s[0] == pytest.approx(0.84, abs=1.5 / FPS)
    assert all(0.6 - 1e-9 <= p <= 1.1 + 1e-9 for p in st.peaks_s)
    # the pair the other way round (Δ_ba = −Δ_ab) is held to the same window
    _, st = geometric_pairs("b", "a", info_b, info_a, cam_b, cam_a, xy_b, xy_a, grid=window)
    assert st.window_s == (-1.1, -0.6)
    assert all(-1.1 - 1e-9 <= p <= -0.6 + 1e-9 for p in st.peaks_s)
    # away from the truth, no peak at it
    _, st = geometric_pairs("a", "b", info_a, info_b, cam_a, cam_b, xy_a, xy_b,
                            grid=OffsetGrid(windows_s=(("b", -0.6, 0.3),), reference="a"))
    assert all(-0.6 - 1e-9 <= p <= 0.3 + 1e-9 for p in st.peaks_s)
