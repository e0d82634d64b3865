import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.geometry.epipolar import (epipolar_residual, fundamental_from_cameras, look_at,
                                          project, relative_pose, skew)


def pose(R, t):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def test_skew_is_cross_product():
    v, w = np.array([1.0, -2.0, 3.0]), np.array([0.5, 4.0, -1.0])
    assert np.allclose(skew(v) @ w, np.cross(v, w))


def test_fundamental_of_pure_x_translation_is_horizontal_epipolar_lines():
    # K = I, b sits 1 unit to the right of a: epipolar lines are the rows y = const.
    K = np.eye(3)
    F = fundamental_from_cameras(K, np.eye(4), K, pose(np.eye(3), [-1.0, 0, 0]))
    # x_aᵀ F x_b = 0 <=> y_a = y_b; F ∝ [t]x with t = (1,0,0) -> only entries (1,2) and (2,1).
    expected = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]]) / np.sqrt(2)
    assert np.allclose(F, expected) or np.allclose(F, -expected)


def test_residual_exact_values_for_horizontal_lines():
    K = np.eye(3)
    F = fundamental_from_cameras(K, np.eye(4), K, pose(np.eye(3), [-1.0, 0, 0]))
    x_a, x_b = np.array([0.3, 0.5]), np.array([0.1, 0.2])
    # with F = [[0,0,0],[0,0,-1],[0,1,0]]/√2: x_aᵀFx_b = (y_b - y_a)/√2 (up to sign)
    # F x_b = (0, -1, y_b)/√2 -> |(Fx_b)_12|² = 1/2 ; Fᵀx_a = (0, 1, -y_a)/√2 -> 1/2
    d2 = (0.2 - 0.5) ** 2
    assert epipolar_residual(F, x_a, x_b, "algebraic") == pytest.approx(np.sqrt(d2 / 2))
    assert epipolar_residual(F, x_a, x_b, "sampson") == pytest.approx((d2 / 2) / (0.5 + 0.5))
    assert epipolar_residual(F, x_a, x_b, "symmetric") == pytest.approx((d2 / 2) * (2 + 2))
    cos = (d2 / 2) * (1 / ((0.3**2 + 0.5**2 + 1) * (0.5 + 0.2**2 / 2))
                      + 1 / ((0.5 + 0.5**2 / 2) * (0.1**2 + 0.2**2 + 1)))
    assert epipolar_residual(F, x_a, x_b, "cosine") == pytest.approx(cos)


def test_unknown_residual_is_an_error():
    with pytest.raises(ValueError, match="unknown residual"):
        epipolar_residual(np.eye(3), np.zeros(2), np.zeros(2), "l1")


@pytest.fixture
def asymmetric_two_view():
    """K_a != K_b, fx != fy, rotation off every axis, and points seen by both."""
    rng = np.random.default_rng(3)
    K_a = np.array([[910.0, 0, 655], [0, 870, 348], [0, 0, 1]])
    K_b = np.array([[620.0, 0, 300], [0, 690, 255], [0, 0, 1]])
    T_a = pose(Rotation.from_euler("xyz", [8, -13, 21], degrees=True).as_matrix(), [0.3, -0.2, 5.0])
    T_b = pose(Rotation.from_euler("xyz", [-17, 29, -9], degrees=True).as_matrix(), [-1.1, 0.4, 6.0])
    X = rng.uniform(-1, 1, size=(50, 3))
    return K_a, T_a, K_b, T_b, project(K_a, T_a, X), project(K_b, T_b, X)


@pytest.mark.parametrize("kind", ["sampson", "symmetric", "cosine", "algebraic"])
def test_asymmetric_fixture_true_correspondences_are_zero(asymmetric_two_view, kind):
    K_a, T_a, K_b, T_b, x_a, x_b = asymmetric_two_view
    F_ab = fundamental_from_cameras(K_a, T_a, K_b, T_b)
    assert np.max(epipolar_residual(F_ab, x_a, x_b, kind)) < 1e-9


def test_asymmetric_fixture_swapping_or_transposing_fails(asymmetric_two_view):
    K_a, T_a, K_b, T_b, x_a, x_b = asymmetric_two_view
    F_ab = fundamental_from_cameras(K_a, T_a, K_b, T_b)
    F_ba = fundamental_from_cameras(K_b, T_b, K_a, T_a)
    assert np.allclose(F_ba, F_ab.T) or np.allclose(F_ba, -F_ab.T)
    # Points in the wrong slots, or F transposed, must not satisfy the constraint.
    assert np.median(epipolar_residual(F_ab, x_b, x_a, "sampson")) > 1.0
    assert np.median(epipolar_residual(F_ab.T, x_a, x_b, "sampson")) > 1.0
    # Wrong intrinsics (K swapped) also fail.
    F_wrongK = fundamental_from_cameras(K_b, T_a, K_a, T_b)
    assert np.median(epipolar_residual(F_wrongK, x_a, x_b, "sampson")) > 1.0


def test_sampson_approximates_squared_point_to_line_distance(asymmetric_two_view):
    K_a, T_a, K_b, T_b, x_a, x_b = asymmetric_two_view
    F = fundamental_from_cameras(K_a, T_a, K_b, T_b)
    x_a_noisy = x_a + np.array([0.0, 2.0])  # 2 px off in a only
    l_a = np.einsum("ij,nj->ni", F, np.c_[x_b, np.ones(len(x_b))])
    dist2 = (np.sum(l_a[:, :2] * x_a_noisy, 1) + l_a[:, 2]) ** 2 / np.sum(l_a[:, :2] ** 2, 1)
    samp = epipolar_residual(F, x_a_noisy, x_b, "sampson")
    sym = epipolar_residual(F, x_a_noisy, x_b, "symmetric")
    assert np.all(samp <= dist2 + 1e-9)  # a lower bound of the one-sided distance here
    assert np.all(sym >= dist2 - 1e-9)
    assert np.median(dist2) > 0.1


def test_relative_pose_and_look_at():
    T = look_at([3.0, 0, 0], [0, 0, 0])
    # the target is straight ahead on the optical axis
    Xc = T[:3, :3] @ np.zeros(3) + T[:3, 3]
    assert np.allclose(Xc, [0, 0, 3])
    assert np.allclose(relative_pose(T, T), np.eye(4))
    # world up (+z) appears as image up (-y) in OpenCV's camera frame
    up = T[:3, :3] @ np.array([0, 0, 1.0])
    assert up[1] < -0.99


def test_project_marks_points_behind_camera_nan():
    K = np.eye(3)
    xy = project(K, np.eye(4), np.array([[0, 0, 2.0], [0, 0, -2.0]]))
    assert np.allclose(xy[0], [0, 0]) and np.isnan(xy[1]).all()
