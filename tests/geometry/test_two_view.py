"""Two-view geometry from correspondences (geometry/two_view.py), on an asymmetric pair: K_a ≠ K_b,
fx ≠ fy, a rotation off every axis, so that swapping a and b or transposing F fails."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.geometry.epipolar import fundamental_from_cameras, project, relative_pose
from vs_inspect.geometry.two_view import (essential_from_fundamental, essential_ransac, focal_from_fundamental,
                                          fundamental_ransac, nearest_calibrated_fundamental, normalized_points,
                                          pose_from_essential, pose_from_fundamental, sampson_px,
                                          signed_sampson_px)


def pose(R, t):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


K_A = np.array([[910.0, 0, 655], [0, 870, 348], [0, 0, 1]])
K_B = np.array([[620.0, 0, 300], [0, 690, 255], [0, 0, 1]])
T_A = pose(Rotation.from_euler("xyz", [8, -13, 21], degrees=True).as_matrix(), [0.3, -0.2, 5.0])
T_B = pose(Rotation.from_euler("xyz", [-17, 29, -9], degrees=True).as_matrix(), [-1.1, 0.4, 6.0])


def views(n: int = 200, K_a=K_A, K_b=K_B, noise_px: float = 0.0, seed: int = 3):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 3))
    x_a, x_b = project(K_a, T_A, X), project(K_b, T_B, X)
    return x_a + rng.normal(0, noise_px, x_a.shape), x_b + rng.normal(0, noise_px, x_b.shape)


def unit(F):
    F = F / np.linalg.norm(F)
    return F * np.sign(F.flat[np.argmax(np.abs(F))])


def test_fundamental_ransac_is_F_ab_of_the_cameras():
    x_a, x_b = views(noise_px=0.2)
    F, inliers = fundamental_ransac(x_a, x_b, threshold_px=1.0)
    true = fundamental_from_cameras(K_A, T_A, K_B, T_B)
    assert np.abs(unit(F) - unit(true)).max() < 2e-3
    assert inliers.mean() > 0.95
    assert np.median(sampson_px(F, x_a, x_b)) < 0.5
    # x_aᵀ F_ab x_b = 0: transposed, or read with a and b swapped, it does not hold
    assert np.median(sampson_px(F.T, x_a, x_b)) > 5.0
    assert np.median(sampson_px(F, x_b, x_a)) > 5.0


def test_fundamental_ransac_of_too_few_points_is_none_and_bad_shapes_are_named():
    F, inliers = fundamental_ransac(np.zeros((3, 2)), np.zeros((3, 2)), 1.0)
    assert F is None and inliers.shape == (3,) and not inliers.any()
    with pytest.raises(ValueError, match=r"x_b must be \(10,2\), got \(9, 2\)"):
        fundamental_ransac(np.zeros((10, 2)), np.zeros((9, 2)), 1.0)
    with pytest.raises(ValueError, match="unknown robust method"):
        fundamental_ransac(np.zeros((10, 2)), np.zeros((10, 2)), 1.0, method="lmeds")


def test_pose_from_fundamental_is_b_from_a_with_unit_baseline():
    x_a, x_b = views()
    F = fundamental_from_cameras(K_A, T_A, K_B, T_B)
    got = pose_from_fundamental(F, K_A, K_B, x_a, x_b)
    true = relative_pose(T_B, T_A)  # b_from_a: x_b = R x_a + t
    assert np.allclose(got[:3, :3], true[:3, :3], atol=1e-6)
    assert np.allclose(got[:3, 3], true[:3, 3] / np.linalg.norm(true[:3, 3]), atol=1e-6)
    # the other way round it is a_from_b, not b_from_a
    back = pose_from_fundamental(F.T, K_B, K_A, x_b, x_a)
    assert np.allclose(back[:3, :3], true[:3, :3].T, atol=1e-6)
    assert not np.allclose(back[:3, :3], true[:3, :3], atol=1e-2)


def test_essential_of_the_true_F_holds_in_normalized_coordinates_and_is_calibrated():
    x_a, x_b = views(50)
    F = fundamental_from_cameras(K_A, T_A, K_B, T_B)
    E = essential_from_fundamental(F, K_A, K_B)
    n_a, n_b = normalized_points(x_a, K_A), normalized_points(x_b, K_B)
    h_a, h_b = np.c_[n_a, np.ones(len(n_a))], np.c_[n_b, np.ones(len(n_b))]
    assert np.abs(np.sum(h_a * (h_b @ E.T), axis=1)).max() < 1e-9
    s = np.linalg.svd(E, compute_uv=False)
    assert s[0] == pytest.approx(s[1], rel=1e-9) and s[2] < 1e-9 * s[0]
    # the intrinsics swapped do not give an essential matrix
    s_wrong = np.linalg.svd(essential_from_fundamental(F, K_B, K_A), compute_uv=False)
    assert abs(s_wrong[0] - s_wrong[1]) > 0.05 * s_wrong[0]


def test_nearest_calibrated_F_keeps_a_calibrated_F_and_calibrates_a_perturbed_one():
    F = fundamental_from_cameras(K_A, T_A, K_B, T_B)
    assert np.abs(unit(nearest_calibrated_fundamental(F, K_A, K_B)) - unit(F)).max() < 1e-9
    noisy = F + 0.05 * np.linalg.norm(F) * np.random.default_rng(1).normal(size=(3, 3))
    s = np.linalg.svd(essential_from_fundamental(nearest_calibrated_fundamental(noisy, K_A, K_B), K_A, K_B),
                      compute_uv=False)
    assert s[0] == pytest.approx(s[1], rel=1e-9) and s[2] < 1e-9 * s[0]


def test_focal_from_fundamental_finds_the_shared_focal():
    f = 800.0
    K_a = np.array([[f, 0, 640], [0, f, 360], [0, 0, 1]])
    K_b = np.array([[f, 0, 600], [0, f, 330], [0, 0, 1]])
    F = fundamental_from_cameras(K_a, T_A, K_b, T_B)
    got = focal_from_fundamental(F, np.array([640.0, 360]), np.array([600.0, 330]), 1280.0)
    assert abs(got - f) / f < 0.02  # the search's step is 1.8 %


def test_essential_ransac_and_pose_of_normalized_points():
    x_a, x_b = views()
    n_a, n_b = normalized_points(x_a, K_A), normalized_points(x_b, K_B)
    E, inliers = essential_ransac(n_a, n_b, threshold=1e-3)
    assert inliers.mean() > 0.95
    T = pose_from_essential(E, n_a, n_b, inliers)
    assert np.allclose(T[:3, :3], relative_pose(T_B, T_A)[:3, :3], atol=1e-4)


def test_signed_sampson_squares_to_the_sampson_distance():
    x_a, x_b = views(30, noise_px=2.0)
    F = fundamental_from_cameras(K_A, T_A, K_B, T_B)
    h_a, h_b = np.c_[x_a, np.ones(30)], np.c_[x_b, np.ones(30)]
    signed = signed_sampson_px(F, h_a, h_b)
    assert np.allclose(np.abs(signed), sampson_px(F, x_a, x_b), rtol=1e-9)
    assert (signed > 0).any() and (signed < 0).any()
