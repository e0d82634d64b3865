"""Pose-free pair sync on a synthetic single moving point seen by two asymmetric cameras with a
known time shift and clock rate."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.geometry.two_view import sampson_px
from vs_inspect.sync.posefree import (PoseFreeConfig, estimate_pair, fit_at_time_map, fit_F_at_time_map,
                                      interpolate_track)

OFFSET_S = 3.217  # b started this long after a
DRIFT_B = 200e-6  # b's clock runs 200 ppm fast; a is the reference
NOISE_PX = 0.3
OFFSET_TOL_S = 0.004  # a tenth of a frame of the 25 fps camera
RATE_TOL_PPM = 30.0


def _world(g: np.ndarray) -> np.ndarray:
    """(N,3) a smooth, non-planar flight path (metres) at global times g (s)."""
    return np.c_[20 * np.sin(0.11 * g) + 5 * np.sin(0.37 * g),
                 8 * np.cos(0.13 * g) + 3 * np.sin(0.5 * g) - 4,
                 45 + 6 * np.sin(0.07 * g) + 2 * np.cos(0.29 * g)]


K_A = np.array([[900.0, 0, 640], [0, 880, 360], [0, 0, 1]])
K_B = np.array([[1500.0, 0, 955], [0, 1530, 540], [0, 0, 1]])
R_B = Rotation.from_rotvec(np.deg2rad(14) * np.array([0.3, -0.9, 0.2]) / np.linalg.norm([0.3, -0.9, 0.2])).as_matrix()
C_B = np.array([12.0, 1.5, -2.0])  # b's centre in a's frame


def _project(K, R, C, X):
    x = (X - C) @ R.T @ K.T
    return x[:, :2] / x[:, 2:]


def _scene(seed=0):
    rng = np.random.default_rng(seed)
    t_a = np.arange(0, 90, 1 / 30)
    t_b = np.arange(0, 80, 1 / 25)
    xy_a = _project(K_A, np.eye(3), np.zeros(3), _world(t_a)) + rng.normal(0, NOISE_PX, (len(t_a), 2))
    xy_b = _project(K_B, R_B, C_B, _world(OFFSET_S + (1 + DRIFT_B) * t_b)) + rng.normal(0, NOISE_PX, (len(t_b), 2))
    for xy in (xy_a, xy_b):  # missed detections, in runs
        for start in rng.integers(0, len(xy) - 40, 12):
            xy[start:start + rng.integers(5, 40)] = np.nan
    return t_a, xy_a, t_b, xy_b


FAST = PoseFreeConfig(top_k=2, fine_half_width_s=0.2)


def test_recovers_shift_and_rate():
    t_a, xy_a, t_b, xy_b = _scene()
    r = estimate_pair(t_a, xy_a, K_A, t_b, xy_b, K_B, FAST, offset_range_s=(-30.0, 30.0))
    assert r is not None
    assert abs(r.offset_s - OFFSET_S) < OFFSET_TOL_S
    assert abs(r.drift_ppm - DRIFT_B * 1e6) < RATE_TOL_PPM
    assert r.inlier_share > 0.95
    assert r.offset_std_s < OFFSET_TOL_S and r.drift_std_ppm < RATE_TOL_PPM
    # the landscape peaks at the true offset; the refined F explains the matches to the noise
    # (0.3 px per coordinate), and the pivot lies in the middle of the overlap (a's clock)
    assert abs(r.coarse_offsets_s[np.argmax(r.coarse_score)] - OFFSET_S) < 1.0
    assert r.median_sampson_px < 3 * NOISE_PX
    overlap = (max(t_a[0], OFFSET_S + t_b[0]), min(t_a[-1], OFFSET_S + (1 + DRIFT_B) * t_b[-1]))
    assert abs(r.pivot_s - 0.5 * sum(overlap)) < 2.0
    # F maps a's points to b's epipolar lines (not transposed): exact points have ~0 distance
    g = np.linspace(10, 60, 50)
    xa = _project(K_A, np.eye(3), np.zeros(3), _world(g))
    xb = _project(K_B, R_B, C_B, _world(g))
    assert np.median(sampson_px(r.F_ab, xa, xb)) < 1.0
    assert np.median(sampson_px(r.F_ab.T, xa, xb)) > 5.0


def test_constant_offset_model_keeps_rate_one_and_swapped_pair_flips_sign():
    t_a, xy_a, t_b, xy_b = _scene(1)
    r = estimate_pair(t_a, xy_a, K_A, t_b, xy_b, K_B, PoseFreeConfig(top_k=2, estimate_rate=False,
                      fine_half_width_s=0.2), offset_range_s=(-30.0, 30.0))
    assert r.rate == 1.0 and r.drift_std_ppm == 0.0  # no rate estimated, so none uncertain
    # 200 ppm over the overlap is a few ms: the constant model lands near the middle of the drift
    assert abs(r.offset_s - OFFSET_S) < 0.05
    s = estimate_pair(t_b, xy_b, K_B, t_a, xy_a, K_A, FAST, offset_range_s=(-30.0, 30.0))
    assert abs(s.offset_s + OFFSET_S * (1 - DRIFT_B)) < OFFSET_TOL_S  # in b's clock now
    assert abs(s.drift_ppm + DRIFT_B * 1e6) < RATE_TOL_PPM


def test_interpolate_track_linear_and_nan_where_a_neighbour_is_unseen():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    xy = np.array([[0.0, 0.0], [2.0, 4.0], [np.nan, np.nan], [6.0, 6.0]])
    out = interpolate_track(np.array([0.5, 1.0, 1.5, 2.5, 3.0, -0.1, 3.1]), t, xy)
    np.testing.assert_allclose(out[:2], [[1.0, 2.0], [2.0, 4.0]])
    assert np.isnan(out[2:4]).all()
    np.testing.assert_allclose(out[4], [6.0, 6.0])
    assert np.isnan(out[5:]).all()
    with pytest.raises(ValueError, match=r"shape \(4,2\)"):
        interpolate_track(np.zeros(1), t, xy[:3])


def test_F_at_a_fixed_time_map_fits_the_true_one_and_not_a_wrong_one():
    t_a, xy_a, t_b, xy_b = _scene(2)
    rate = 1 + DRIFT_B
    F, median_px, share = fit_F_at_time_map(t_a, xy_a, K_A, t_b, xy_b, K_B, OFFSET_S, rate)
    assert share > 0.95 and median_px < 3 * NOISE_PX
    g = np.linspace(10, 60, 50)  # the true geometry: exact points on their epipolar lines
    assert np.median(sampson_px(F, _project(K_A, np.eye(3), np.zeros(3), _world(g)),
                                _project(K_B, R_B, C_B, _world(g)))) < 1.0
    assert fit_at_time_map(t_a, xy_a, K_A, t_b, xy_b, K_B, OFFSET_S, rate) == (median_px, share)
    _, wrong_px, wrong_share = fit_F_at_time_map(t_a, xy_a, K_A, t_b, xy_b, K_B, OFFSET_S + 0.5, rate)
    assert wrong_share < share - 0.2 or wrong_px > 2 * median_px
    none, nan_px, zero = fit_F_at_time_map(t_a, xy_a, K_A, t_b, xy_b, K_B, 500.0, rate)  # no overlap
    assert none is None and np.isnan(nan_px) and zero == 0.0
