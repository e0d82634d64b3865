"""Two-view triangulation: exact DLT on an asymmetric rig, and the one filter (reprojection,
cheirality, ray angle)."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.geometry.triangulate import (projection_matrix, reprojection_error, triangulate_dlt,
                                             triangulate_track_pair)

K_A = np.array([[900.0, 0, 640], [0, 880, 360], [0, 0, 1]])
K_B = np.array([[700.0, 0, 500], [0, 720, 390], [0, 0, 1]])
T_A = look_at(np.array([6.0, -2.0, 1.5]), np.array([0.0, 0.2, 1.0]))
T_B = look_at(np.array([-3.0, 5.5, 2.5]), np.array([0.3, -0.1, 0.8]))


def test_dlt_recovers_points_exactly():
    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, size=(50, 3)) + [0, 0, 1]
    x_a, x_b = project(K_A, T_A, X), project(K_B, T_B, X)
    P_a, P_b = projection_matrix(K_A, T_A), projection_matrix(K_B, T_B)
    Y = triangulate_dlt(P_a, P_b, x_a, x_b)
    np.testing.assert_allclose(Y, X, atol=1e-8)
    err, depth = reprojection_error(P_a, Y, x_a)
    assert err.max() < 1e-6 and (depth > 0).all()
    # NaN in, NaN out
    x_a[3] = np.nan
    assert np.isnan(triangulate_dlt(P_a, P_b, x_a, x_b)[3]).all()


def test_filter_keeps_exact_points_and_drops_misses_behind_and_parallel():
    X = np.array([[0.0, 0.0, 1.0], [0.5, -0.3, 1.2], [0.2, 0.1, 0.9], [-0.4, 0.4, 1.1]])
    x_a, x_b = project(K_A, T_A, X), project(K_B, T_B, X)
    x_b[1] += [0.0, 10.0]  # b's point 10 px off: the rays miss each other
    x_a[2] = np.nan  # not seen in a
    got = triangulate_track_pair(K_A, T_A, x_a, K_B, T_B, x_b)
    assert got.kept.tolist() == [True, False, False, True]
    np.testing.assert_allclose(got.points_world[[0, 3]], X[[0, 3]], atol=1e-8)
    assert np.isnan(got.points_world[[1, 2]]).all()
    assert got.reprojection_px[1] > 4.0 and np.isnan(got.reprojection_px[2])
    # a point 2 m behind a (in front of b): its pixels still define rays that meet there
    # exactly, but a cannot have seen it (cheirality)
    X_behind = -T_A[:3, :3].T @ T_A[:3, 3] - 2.0 * T_A[2, :3]
    pixel = [(P @ np.append(X_behind, 1.0))[:2] / (P @ np.append(X_behind, 1.0))[2]
             for P in (projection_matrix(K_A, T_A), projection_matrix(K_B, T_B))]
    behind = triangulate_track_pair(K_A, T_A, pixel[0], K_B, T_B, pixel[1])
    assert not behind.kept
    assert behind.reprojection_px < 1e-6
    # a second camera next to a: rays nearly parallel, depth undetermined
    T_near = look_at(np.array([6.0, -1.95, 1.5]), np.array([0.0, 0.2, 1.0]))
    near = triangulate_track_pair(K_A, T_A, x_a[:1], K_A, T_near, project(K_A, T_near, X[:1]))
    assert not near.kept[0]
    assert triangulate_track_pair(K_A, T_A, x_a[:1], K_A, T_near, project(K_A, T_near, X[:1]),
                                  min_ray_angle_deg=0.0).kept[0]


@pytest.mark.parametrize("call, message", [
    (lambda: projection_matrix(np.eye(4), np.eye(4)), r"K must be \(\.\.\.,3,3\), got \(4, 4\)"),
    (lambda: triangulate_dlt(np.eye(4)[:3], np.eye(3), np.zeros(2), np.zeros(2)),
     r"P_b must be \(\.\.\.,3,4\), got \(3, 3\)"),
    (lambda: triangulate_dlt(np.eye(4)[:3], np.eye(4)[:3], np.zeros(3), np.zeros(2)),
     r"x_a must be \(\.\.\.,2\), got \(3,\)"),
    (lambda: reprojection_error(np.eye(4)[:3], np.zeros((5, 2)), np.zeros((5, 2))),
     r"X must be \(\.\.\.,3\), got \(5, 2\)"),
    (lambda: triangulate_track_pair(K_A, T_A[:3], np.zeros(2), K_B, T_B, np.zeros(2)),
     r"cam_from_world must be \(\.\.\.,4,4\), got \(3, 4\)"),
])
def test_shape_errors_name_the_shape_received(call, message):
    with pytest.raises(ValueError, match=message):
        call()


@pytest.mark.parametrize("at", ["a", "b"])
def test_over_time_reads_the_other_video_at_the_same_global_moment(at):
    """A point moving in 3D seen by two static cameras with different clocks and frame rates:
    triangulated at either video's frames it lands on its true positions."""
    from vs_inspect.geometry.triangulate import triangulate_over_time
    from vs_inspect.types import CameraTrack

    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    cam_a, cam_b = CameraTrack(K, look_at([6.0, 0, 1.5], [0, 0, 1])), CameraTrack(K, look_at([0, 6.0, 2.0], [0, 0, 1]))
    def path(t):  # global time -> 3D
        return np.stack([np.sin(t), np.cos(0.7 * t), 1.0 + 0.3 * t], -1)
    ts_a, ts_b = np.arange(40) / 20.0, np.arange(50) / 25.0
    off_a, off_b = 0.1, 0.5  # b's local 0 is 0.4 s after a's
    xy_a = project(K, cam_a.cam_from_world, path(ts_a + off_a))[None]
    xy_b = project(K, cam_b.cam_from_world, path(ts_b + off_b))[None]
    tri, g = triangulate_over_time(ts_a, cam_a, xy_a, off_a, ts_b, cam_b, xy_b, off_b, np.array([[0, 0]]), at=at)
    assert np.allclose(g, (ts_a + off_a) if at == "a" else (ts_b + off_b))
    ok = tri.kept[0]
    assert ok.sum() >= 20  # the overlap of the two videos
    # the other video is read linearly between its frames: the error is the path's curvature at most
    assert np.abs(tri.points_world[0, ok] - path(g[ok])).max() < 0.01
