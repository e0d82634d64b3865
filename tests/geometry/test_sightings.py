"""A worn camera seen by another (geometry/sightings.py): the head camera a sees, against camera
b's centre projected at b's time t − Δ, gives a landscape whose peak is the true offset."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.geometry.sightings import sighting_landscape, sighting_peak, sighting_shift_fit

K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])


def _centre_b(global_s):
    """b's wearer walking to and fro 6 m in front of a."""
    return np.stack([1.5 * np.sin(0.9 * global_s), 6.0 + 0.5 * np.cos(0.4 * global_s),
                     1.7 + 0.05 * np.sin(3 * global_s)], -1)


def _scene(true_offset_s: float, seed: int = 0, head_shift_px=(0.0, 0.0)):
    """a: a slowly turning camera at the origin; b: a wearer walking to and fro 6 m in front of it
    (10 fps each; b's clip starts true_offset_s after a's, DESIGN.md's convention); the heads a
    finds lie head_shift_px from b's projected centre."""
    rng = np.random.default_rng(seed)
    ts_a = np.arange(80) / 10.0
    ts_b = np.arange(90) / 10.0
    pose_a = np.stack([look_at([0, 0, 1.6], [np.sin(0.05 * t), 6.0, 1.6]) for t in ts_a])

    pose_b = np.stack([look_at(c, [0, 0, 1.6]) for c in _centre_b(ts_b + true_offset_s)])
    head = project(K, pose_a, _centre_b(ts_a)) + head_shift_px + rng.normal(0, 1.0, (len(ts_a), 2))
    head[rng.random(len(ts_a)) < 0.3] = np.nan  # not detected
    other = rng.random(len(ts_a)) < 0.15  # someone else detected
    head[other] = rng.uniform([0, 0], [640, 480], (other.sum(), 2))
    return ts_a, pose_a, ts_b, pose_b, head


@pytest.mark.parametrize("true_offset_s", [-1.5, 0.0, 0.7])
def test_the_sighting_landscape_peaks_at_the_true_offset(true_offset_s):
    ts_a, pose_a, ts_b, pose_b, head = _scene(true_offset_s)
    grid = np.arange(-3.0, 3.0 + 1e-9, 0.05)
    land = sighting_landscape(head, ts_a, K, pose_a, np.ones(len(ts_a), bool), ts_b, pose_b,
                              np.ones(len(ts_b), bool), grid, radius_px=10.0)
    peak, lo, hi, rival = sighting_peak(land.offsets_s, land.near, exclude_s=0.3)
    assert abs(peak - true_offset_s) <= 0.05 + 1e-9, peak
    assert land.near[lo] == land.near[hi] == land.near.max()
    assert land.near[lo] >= 0.6 * land.moments[lo] and rival <= 0.5 * land.near[lo], (land.near[lo], rival)
    at = lambda s: land.median_px[np.argmin(np.abs(land.offsets_s - s))]  # noqa: E731
    assert at(peak) < 8.0 and at(peak) < 0.25 * min(at(peak - 0.5), at(peak + 0.5))


def test_the_peak_is_the_middle_of_its_plateau_and_the_rival_lies_beyond_the_exclusion():
    offsets = np.arange(10) * 0.1
    near = np.array([0, 3, 1, 5, 9, 9, 9, 2, 0, 4])
    peak, lo, hi, rival = sighting_peak(offsets, near, exclude_s=0.25)
    assert (lo, hi) == (4, 6) and peak == pytest.approx(0.5)
    assert rival == 4  # beyond 0.25 s of 0.5: 0.0-0.2 s (0, 3, 1) and 0.8-0.9 s (0, 4)



def test_invalid_poses_and_frames_outside_b_are_not_counted():
    ts_a, pose_a, ts_b, pose_b, head = _scene(0.0)
    valid_b = np.ones(len(ts_b), bool)
    valid_b[:45] = False  # b has no pose in its first half
    grid = np.array([0.0, 20.0])  # 20 s: b's clip ends long before
    land = sighting_landscape(head, ts_a, K, pose_a, np.ones(len(ts_a), bool), ts_b, pose_b, valid_b, grid, 10.0)
    detected = np.isfinite(head[:, 0])
    assert land.moments[0] == detected[45:].sum() and land.moments[1] == 0 and np.isnan(land.median_px[1])


def test_bad_shapes_are_named():
    ts_a, pose_a, ts_b, pose_b, head = _scene(0.0)
    with pytest.raises(ValueError, match=r"head_xy_a must be \(80,2\), got \(79, 2\)"):
        sighting_landscape(head[:-1], ts_a, K, pose_a, np.ones(80, bool), ts_b, pose_b, np.ones(90, bool),
                           np.zeros(1), 10.0)
    with pytest.raises(ValueError, match="radius_px must be positive"):
        sighting_landscape(head, ts_a, K, pose_a, np.ones(80, bool), ts_b, pose_b, np.ones(90, bool), np.zeros(1), 0)


def test_a_constant_shift_between_head_and_camera_is_fitted_out_of_the_offset():
    """Heads 15 px to the side of b's centre (the face is not the camera): the counted peak is
    about 2 frames off; the fit with one constant shift, from the heads near the centre at that
    peak, finds the true offset and the shift."""
    true_s = 0.4
    ts_a, pose_a, ts_b, pose_b, head = _scene(true_s, head_shift_px=(15.0, -3.0))
    ones_a, ones_b = np.ones(len(ts_a), bool), np.ones(len(ts_b), bool)
    fine = np.arange(true_s - 0.3, true_s + 0.3 + 1e-9, 0.01)
    land = sighting_landscape(head, ts_a, K, pose_a, ones_a, ts_b, pose_b, ones_b, fine, 10.0)
    peak_s = sighting_peak(fine, land.near, exclude_s=0.3)[0]
    assert abs(peak_s - true_s) > 0.15, peak_s  # what the shift does to the count
    fit = sighting_shift_fit(head, ts_a, K, pose_a, ones_a, ts_b, pose_b, ones_b, fine, peak_s, 25.0)
    best = int(np.argmin(fit.sum_sq_px2 / fit.moments))
    assert abs(fine[best] - true_s) <= 0.02, fine[best]
    assert fit.shift_px[best] == pytest.approx([15.0, -3.0], abs=1.0)
    # the chosen heads are b's wearer's (no one else's), and most of those detected
    wearer = np.linalg.norm(head - project(K, pose_a, _centre_b(ts_a)) - (15.0, -3.0), axis=1) < 6
    assert not (fit.chosen & ~wearer).any() and fit.chosen.sum() >= 0.5 * wearer.sum()
    assert (fit.moments <= fit.chosen.sum()).all()


def test_the_shift_fit_counts_only_posed_moments_and_names_a_bad_radius():
    ts_a, pose_a, ts_b, pose_b, head = _scene(0.0)
    valid_b = np.ones(len(ts_b), bool)
    valid_b[:45] = False
    fit = sighting_shift_fit(head, ts_a, K, pose_a, np.ones(len(ts_a), bool), ts_b, pose_b, valid_b,
                             np.array([0.0, 20.0]), 0.0, 10.0)
    assert not fit.chosen[:45].any() and fit.moments[0] == fit.chosen.sum() > 0
    assert fit.moments[1] == 0 and np.isnan(fit.sum_sq_px2[1]) and np.isnan(fit.shift_px[1]).all()
    with pytest.raises(ValueError, match="radius_px must be positive"):
        sighting_shift_fit(head, ts_a, K, pose_a, np.ones(80, bool), ts_b, pose_b, valid_b, np.zeros(1), 0.0, -1.0)
