"""Cameras from the moving points' own two-view geometry (cues/cameras/moving_points.py), on exact synthetic
tracks of two static cameras."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import vs_inspect.cues.cameras.moving_points as pairwise
from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.types import TrackPairs, VideoInfo

FOCAL_PX = 500.0
TRUE_OFFSET_S = 0.8  # Δ_rv = offset_v - offset_r


def two_views(n_points: int = 50, frames: int = 60, fps: float = 10.0):
    """(xy_r, info_r, xy_v, info_v, index): points moving smoothly in a 2 m box, seen by two
    static cameras 60° apart; video v starts TRUE_OFFSET_S later on the common clock."""
    rng = np.random.default_rng(3)
    K = np.array([[FOCAL_PX, 0, 319.5], [0, FOCAL_PX, 239.5], [0, 0, 1]])
    cams = [look_at(np.array([4 * np.cos(a), 4 * np.sin(a), 1.0]), np.zeros(3)) for a in (0.0, np.pi / 3)]
    centre = rng.uniform(-0.6, 0.6, (n_points, 1, 3))
    amp = rng.uniform(0.2, 0.5, (n_points, 1, 3))
    freq = rng.uniform(0.5, 2.0, (n_points, 1, 3))
    phase = rng.uniform(0, 2 * np.pi, (n_points, 1, 3))
    info_r = VideoInfo.constant_rate("r", 640, 480, frames, fps)
    info_v = VideoInfo.constant_rate("v", 640, 480, frames, fps)

    def at(g):  # (N,G,3) positions at global times g
        return centre + amp * np.sin(freq * g[None, :, None] + phase)

    xy_r = project(K, cams[0], at(info_r.timestamps_s))
    xy_v = project(K, cams[1], at(info_v.timestamps_s + TRUE_OFFSET_S))
    index = np.stack([np.arange(n_points), np.arange(n_points)], 1)
    return xy_r, info_r, xy_v, info_v, index


def test_search_pair_finds_the_offset_and_a_consistent_F():
    xy_r, info_r, xy_v, info_v, index = two_views()
    g = pairwise.search_pair(xy_r, info_r, xy_v, info_v, index)
    assert g is not None
    assert abs(g.offset_s - TRUE_OFFSET_S) < 1e-6  # on the 0.1 s frame grid
    assert g.inlier_share > 0.95
    A, B, _ = pairwise.aligned_correspondences(xy_r, info_r, xy_v, info_v, index, g.offset_s)
    lines = np.c_[A, np.ones(len(A))] @ g.F  # F_rv: x_rᵀ F x_v = 0, so v's epipolar line of x_r is x_rᵀ F
    dist = np.abs(np.sum(lines * np.c_[B, np.ones(len(B))], 1)) / np.hypot(lines[:, 0], lines[:, 1])
    assert np.median(dist) < 0.5


def test_search_pair_survives_opencv_raising(monkeypatch):
    """OpenCV 5's USAC asserted (cv2.error) on degenerate samples of real tracks; one
    offset's failure must not end the search."""
    xy_r, info_r, xy_v, info_v, index = two_views()
    real = cv2.findFundamentalMat
    calls = {"n": 0}

    def every_third_raises(*args):
        calls["n"] += 1
        if calls["n"] % 3 == 0:
            raise cv2.error("(-215:Assertion failed) !model.empty() in function 'setModelParameters'")
        return real(*args)

    monkeypatch.setattr(pairwise.cv2, "findFundamentalMat", every_third_raises)
    g = pairwise.search_pair(xy_r, info_r, xy_v, info_v, index)
    assert calls["n"] > 3
    assert g is not None and g.inlier_share > 0.5


RING_STARTS_S = (0.0, 0.3, 0.7, 1.1)  # start of each video on the common clock


def ring_of_views(focals=(450.0, 520.0, 600.0, 680.0), frames: int = 80, fps: float = 10.0):
    """Four static cameras about 90° apart around moving points (a rig like caliscope's), each
    with its own focal and start time: (names, infos, xy, pairs, cameras)."""
    rng = np.random.default_rng(5)
    n = 60
    centre = rng.uniform(-0.6, 0.6, (n, 1, 3))
    amp = rng.uniform(0.2, 0.5, (n, 1, 3))
    freq = rng.uniform(0.5, 2.0, (n, 1, 3))
    phase = rng.uniform(0, 2 * np.pi, (n, 1, 3))
    names = [f"c{i}" for i in range(4)]
    infos, xy, cams = {}, {}, {}
    for i, name in enumerate(names):
        ang = i * np.pi / 2 + 0.2 * i
        pose = look_at(np.array([4 * np.cos(ang), 4 * np.sin(ang), 1.0 + 0.4 * i]),
                       np.array([0.2 * i - 0.3, 0.1 * i, 0.1 * i]))
        K = np.array([[focals[i], 0, 319.5], [0, focals[i], 239.5], [0, 0, 1]])
        infos[name] = VideoInfo.constant_rate(name, 640, 480, frames, fps)
        g = infos[name].timestamps_s + RING_STARTS_S[i]
        xy[name] = project(K, pose, centre + amp * np.sin(freq * g[None, :, None] + phase))
        cams[name] = (K, pose)
    index = np.stack([np.arange(n), np.arange(n)], 1)
    pairs = {(a, b): TrackPairs(a, b, index) for ia, a in enumerate(names) for b in names[ia + 1:]}
    return names, infos, xy, pairs, cams


def test_joint_fit_recovers_the_focals_that_single_pairs_cannot():
    """Per pair, a focal from F is ill-posed when the optical axes nearly meet; fitted to all six
    pairs at once, every camera's focal comes back and the track pairs fit to a fraction of a px."""
    names, infos, xy, pairs, truth = ring_of_views()
    moving = {n: False for n in names}
    cams, reasons, details = pairwise.cameras_from_tracks("c0", infos, xy, pairs, moving)
    assert not reasons and set(cams) == set(names)
    for i, v in enumerate(names[1:], 1):  # coarse offsets Δ_0v = start_v - start_0, on the 0.1 s grid
        assert abs(details[v]["coarse_offset_s"] - RING_STARTS_S[i]) < 1e-6
    fit = details["joint_fit"]
    assert fit["median_px_after"] < 0.1 < fit["median_px_before"]
    for n in names:
        assert abs(cams[n].K[0, 0] / truth[n][0][0, 0] - 1) < 0.03, (n, cams[n].K[0, 0])
    # relative rotations as the true ones (the reconstruction is in c0's frame, up to scale)
    for n in names[1:]:
        R_true = truth[n][1][:3, :3] @ truth["c0"][1][:3, :3].T
        R = cams[n].cam_from_world[:3, :3]
        assert np.degrees(np.arccos(np.clip((np.trace(R @ R_true.T) - 1) / 2, -1, 1))) < 1.0
    coarse = {v: details[v]["coarse_offset_s"] for v in names[1:]}
    fitted_px, n_pairs = pairwise.epipolar_fit_px(cams, infos, xy, pairs, coarse)
    assert n_pairs == 6 and fitted_px < 0.1
    unrefined, _, _ = pairwise.cameras_from_tracks("c0", infos, xy, pairs, moving, refine=False)
    assert pairwise.epipolar_fit_px(unrefined, infos, xy, pairs, coarse)[0] > 10 * fitted_px


def test_cameras_that_leave_the_track_pairs_off_their_lines_are_not_returned():
    """The joint fit must bring the median track pair within the tolerance (a fraction of the
    image diagonal); on 0.5 px noise it leaves about 0.3 px, so a tolerance below that refuses
    every camera with the reason, and the default accepts them."""
    names, infos, xy, pairs, _ = ring_of_views()
    rng = np.random.default_rng(0)
    noisy = {n: v + rng.normal(0, 0.5, v.shape) for n, v in xy.items()}
    moving = {n: False for n in names}
    cams, reasons, details = pairwise.cameras_from_tracks("c0", infos, noisy, pairs, moving)
    assert set(cams) == set(names) and not reasons
    left = details["joint_fit"]["median_px_after"]
    assert 0.05 < left < 1.0
    strict = 0.5 * left / np.hypot(640, 480)
    cams, reasons, _ = pairwise.cameras_from_tracks("c0", infos, noisy, pairs, moving, max_median_fraction=strict)
    assert cams == {} and set(reasons) == set(names)
    assert all("from the epipolar lines" in why for why in reasons.values())


def _curve(peaks: dict[float, float], lo: float = -3.0, hi: float = 3.0, step: float = 0.1,
           floor: float = 0.3) -> pairwise.OffsetCurve:
    """An OffsetCurve on a step grid from lo to hi: share `floor` but at the given {offset: share}."""
    offsets = np.round(np.arange(lo, hi + step / 2, step), 6)
    share = np.full(len(offsets), floor)
    for d, s in peaks.items():
        share[np.argmin(np.abs(offsets - d))] = s
    return pairwise.OffsetCurve(offsets, step, share, np.full(len(offsets), 500), (np.eye(3),) * len(offsets))


def _offsets(curves, chosen: dict[str, int]) -> dict[str, float]:
    """joint_coarse_offsets' grid indices on the reference "r"'s curves, as offsets in seconds."""
    return {v: float(curves[("r", v)].offsets_s[k]) for v, k in chosen.items()}


def test_joint_coarse_offsets_close_the_triangle_where_one_pair_alone_peaks_wrong():
    """r-a alone peaks 1.5 s from the truth; r-b and a-b agree on the truth only with a's second
    peak: summed over the triangle, the truth wins."""
    curves = {("r", "a"): _curve({2.0: 0.62, 0.5: 0.55}),  # truth Δ_ra 0.5
              ("r", "b"): _curve({1.0: 0.60}),  # truth Δ_rb 1.0
              ("a", "b"): _curve({0.5: 0.58})}  # Δ_ab = Δ_rb − Δ_ra
    got, score = pairwise.joint_coarse_offsets("r", curves)
    assert _offsets(curves, got) == pytest.approx({"a": 0.5, "b": 1.0}) and score == pytest.approx(0.55 + 0.60 + 0.58)
    # without the pair between a and b there is nothing to close: no joint choice
    assert pairwise.joint_coarse_offsets("r", {k: v for k, v in curves.items() if k != ("a", "b")}) is None
    # a pair keyed the other way round is read as Δ_ba = Δ_ra − Δ_rb
    flipped = curves | {("a", "b"): _curve({-0.5: 0.58})}
    del flipped[("a", "b")]
    flipped[("b", "a")] = _curve({-0.5: 0.58})
    assert _offsets(flipped, pairwise.joint_coarse_offsets("r", flipped)[0]) == pytest.approx({"a": 0.5, "b": 1.0})


def test_offset_curve_reads_the_nearest_grid_offset_and_nan_off_the_grid():
    c = _curve({0.5: 0.9}, lo=0.0, hi=1.0)
    assert c.at(np.array([0.5, 0.54, 0.46])) == pytest.approx([0.9, 0.9, 0.9])
    assert np.isnan(c.at(np.array([1.2, -0.2]))).all()
    assert c.at(np.array([[0.0, 1.0]])).shape == (1, 2)


def test_cameras_from_tracks_moves_a_camera_whose_pair_with_the_reference_peaks_wrong(monkeypatch):
    """On the ring of four views, c1's curve with the reference is given a false peak 1 s from the
    truth, above the truth's: alone it would be chosen; with the other pairs' curves the truth is, and details say so."""
    names, infos, xy, pairs, _ = ring_of_views()
    moving = {n: False for n in names}
    real = pairwise.offset_curve
    false_peak = RING_STARTS_S[1] + 1.0

    def with_a_false_peak(xy_a, info_a, xy_b, info_b, index, **kw):
        curve = real(xy_a, info_a, xy_b, info_b, index, **kw)
        if info_a.name == "c0" and info_b.name == "c1":
            share = curve.share.copy()
            share[np.argmin(np.abs(curve.offsets_s - false_peak))] = 1.0
            share[np.argmin(np.abs(curve.offsets_s - RING_STARTS_S[1]))] = 0.9  # exact tracks: 1.0
            curve = pairwise.OffsetCurve(curve.offsets_s, curve.step_s, share, curve.count, curve.F)
        return curve

    monkeypatch.setattr(pairwise, "offset_curve", with_a_false_peak)
    alone = pairwise.search_pair(xy["c0"], infos["c0"], xy["c1"], infos["c1"], pairs[("c0", "c1")].index)
    assert alone.offset_s == pytest.approx(false_peak)
    cams, reasons, details = pairwise.cameras_from_tracks("c0", infos, xy, pairs, moving)
    assert not reasons and set(cams) == set(names)
    for i, v in enumerate(names[1:], 1):
        assert details[v]["coarse_offset_s"] == pytest.approx(RING_STARTS_S[i])
    assert details["joint_offsets"]["pairs"] == 6
    assert details["joint_offsets"]["moved"] == {"c1": {"alone_s": pytest.approx(false_peak),
                                                        "together_s": pytest.approx(RING_STARTS_S[1])}}
    assert details["joint_fit"]["median_px_after"] < 0.1


def test_joint_coarse_offsets_on_a_grid_too_large_to_score_whole_refines_a_coarser_one():
    """Over max_grid combinations, every k-th offset is scored, then each camera refined on its
    full grid: the same answer as the full search here."""
    curves = {("r", "a"): _curve({2.0: 0.62, 0.5: 0.55, 0.6: 0.5, 0.4: 0.5}),
              ("r", "b"): _curve({1.0: 0.60, 0.9: 0.5, 1.1: 0.5}),
              ("a", "b"): _curve({0.5: 0.58, 0.4: 0.5, 0.6: 0.5})}
    full = pairwise.joint_coarse_offsets("r", curves)
    coarse = pairwise.joint_coarse_offsets("r", curves, max_grid=400)  # 61 x 61 offsets: every 4th
    assert _offsets(curves, full[0]) == pytest.approx({"a": 0.5, "b": 1.0})
    assert coarse[0] == full[0] and coarse[1] == pytest.approx(full[1])


def test_offset_curve_searches_only_the_offsets_the_run_allows():
    from vs_inspect.geometry.offsets import OffsetGrid

    xy_r, info_r, xy_v, info_v, index = two_views()
    curve = pairwise.offset_curve(xy_r, info_r, xy_v, info_v, index, grid=OffsetGrid(range_s=0.5))
    assert curve is None or np.abs(curve.offsets_s).max() <= 0.5 + 1e-9
    window = OffsetGrid(windows_s=(("v", 0.5, 1.2),), reference="r")
    curve = pairwise.offset_curve(xy_r, info_r, xy_v, info_v, index, grid=window)
    assert curve.offsets_s.min() >= 0.5 - 1e-9 and curve.offsets_s.max() <= 1.2 + 1e-9
    assert curve.offsets_s[int(np.argmax(curve.share))] == pytest.approx(TRUE_OFFSET_S, abs=1e-6)
