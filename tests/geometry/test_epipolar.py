import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.geometry.epipolar import (clip_lines, epipolar_lines, epipolar_residual,
                                          fundamental_from_cameras, line_distance, look_at,
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
    dist2 = line_distance(epipolar_lines(F, x_b), x_a_noisy) ** 2
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


def test_epipolar_lines_of_b_pass_through_a_and_not_the_other_way(asymmetric_two_view):
    K_a, T_a, K_b, T_b, x_a, x_b = asymmetric_two_view
    F_ab = fundamental_from_cameras(K_a, T_a, K_b, T_b)
    l_a = epipolar_lines(F_ab, x_b)  # (N,3) in a
    assert l_a.shape == (len(x_b), 3)
    assert np.max(line_distance(l_a, x_a)) < 1e-9
    assert np.median(line_distance(epipolar_lines(F_ab, x_a), x_b)) > 1.0  # wrong direction
    # lines in b of a's points: the transpose
    assert np.max(line_distance(epipolar_lines(F_ab.T, x_a), x_b)) < 1e-9
    # broadcast: one F per offset against points (D,L,2)
    F_many = np.stack([F_ab, F_ab.T])
    got = epipolar_lines(F_many[:, None], np.stack([x_b, x_a]))
    np.testing.assert_allclose(got[0], l_a)


def test_line_distance_exact_values():
    # the line y = 2 (0·x + 1·y - 2 = 0, scaled by 3) and the point (5, 6): 4 px
    assert line_distance(np.array([0.0, 3.0, -6.0]), np.array([5.0, 6.0])) == pytest.approx(4.0)
    # x - y = 0 and (0, 2): √2
    assert line_distance(np.array([1.0, -1.0, 0.0]), np.array([0.0, 2.0])) == pytest.approx(np.sqrt(2))


def test_clip_lines_to_image():
    # horizontal line y = 100 and diagonal x = y in a 640x480 image; a line outside the image
    seg = clip_lines(np.array([[0.0, 1.0, -100.0], [1.0, -1.0, 0.0], [0.0, 1.0, 1000.0]]), 640, 480)
    np.testing.assert_allclose(sorted(seg[0, :, 0]), [0, 639])
    np.testing.assert_allclose(seg[0, :, 1], [100, 100])
    np.testing.assert_allclose(sorted(seg[1, :, 0]), [0, 479])
    assert np.isnan(seg[2]).all()


@pytest.mark.parametrize("call, message", [
    (lambda: epipolar_lines(np.eye(4)[:3], np.zeros(2)), r"F_ab must be \(\.\.\.,3,3\), got \(3, 4\)"),
    (lambda: epipolar_lines(np.eye(3), np.zeros((5, 3))), r"x_b must be \(\.\.\.,2\), got \(5, 3\)"),
    (lambda: epipolar_residual(np.eye(3)[:2], np.zeros(2), np.zeros(2)),
     r"F_ab must be \(\.\.\.,3,3\), got \(2, 3\)"),
    (lambda: epipolar_residual(np.eye(3), np.zeros(3), np.zeros(2)), r"x_a must be \(\.\.\.,2\), got \(3,\)"),
    (lambda: fundamental_from_cameras(np.eye(3), np.eye(4), np.eye(4), np.eye(4)),
     r"K_b must be \(\.\.\.,3,3\), got \(4, 4\)"),
    (lambda: fundamental_from_cameras(np.eye(3), np.eye(3), np.eye(3), np.eye(4)),
     r"a_from_world must be \(\.\.\.,4,4\), got \(3, 3\)"),
    (lambda: relative_pose(np.eye(4), np.eye(4)[:3]), r"b_from_world must be \(\.\.\.,4,4\), got \(3, 4\)"),
    (lambda: skew(np.zeros(4)), r"v must be \(\.\.\.,3\), got \(4,\)"),
    (lambda: project(np.eye(3), np.eye(4), np.zeros((7, 2))), r"X must be \(\.\.\.,3\), got \(7, 2\)"),
    (lambda: line_distance(np.zeros(2), np.zeros(2)), r"lines must be \(\.\.\.,3\), got \(2,\)"),
    (lambda: clip_lines(np.zeros((4, 2)), 640, 480), r"lines must be \(\.\.\.,3\), got \(4, 2\)"),
    (lambda: look_at(np.zeros(2), np.ones(3)), r"center must be \(3,\), got \(2,\)"),
])
def test_shape_errors_name_the_shape_received(call, message):
    with pytest.raises(ValueError, match=message):
        call()
