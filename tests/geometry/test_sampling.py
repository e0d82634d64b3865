"""A video's tracks and camera at local times: exact values on a small variable-rate clock,
the energy's rules (both frames seen, both poses known). That the energy reads the same numbers
is checked in tests/sync/test_landscape.py."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.geometry.sampling import (camera_at_frames, sample_video,
                                          tracks_between_frames)
from vs_inspect.geometry.timing import frame_brackets
from vs_inspect.types import CameraTrack

TS = np.array([0.0, 0.1, 0.3, 0.4])  # variable frame rate
K = np.array([[800.0, 0, 320], [0, 760, 240], [0, 0, 1]])


def moving_camera(valid=None) -> CameraTrack:
    T = np.tile(np.eye(4), (4, 1, 1))
    for k in range(4):
        R = Rotation.from_euler("z", 10.0 * k, degrees=True).as_matrix()
        T[k, :3, :3] = R
        T[k, :3, 3] = -R @ np.array([float(k), 0.0, 0.0])  # centre moves along x by 1 per frame
    return CameraTrack(K, T, valid)


def tracks() -> np.ndarray:
    xy = np.zeros((2, 4, 2))
    xy[0, :, 0] = [0.0, 10.0, 30.0, 40.0]
    xy[0, :, 1] = 5.0
    xy[1] = xy[0] + 100.0
    xy[1, 2] = np.nan  # not seen at frame 2
    return xy


def test_points_linear_between_frames_and_nan_outside_or_unseen():
    got = sample_video(TS, CameraTrack(K, np.eye(4)), tracks(), np.array([-0.01, 0.05, 0.2, 0.35, 0.4, 0.41]))
    np.testing.assert_allclose(got.xy[0, 1:5, 0], [5.0, 20.0, 35.0, 40.0])
    np.testing.assert_allclose(got.xy[0, 1:5, 1], 5.0)
    assert np.isnan(got.xy[0, [0, 5]]).all()
    # track 1 misses frame 2: every time that needs frame 2 is NaN
    assert np.isnan(got.xy[1, 2:5]).all() and got.xy[1, 1, 0] == pytest.approx(105.0)
    # a static camera is the same everywhere inside and NaN outside
    np.testing.assert_array_equal(got.valid, [False, True, True, True, True, False])
    np.testing.assert_array_equal(got.K[1:5], np.broadcast_to(K, (4, 3, 3)))
    np.testing.assert_array_equal(got.cam_from_world[1:5], np.broadcast_to(np.eye(4), (4, 4, 4)))
    assert np.isnan(got.K[0]).all() and np.isnan(got.cam_from_world[5]).all()


def test_rows_and_camera_only_and_tracks_only():
    got = sample_video(TS, None, tracks(), np.array([0.05]), rows=np.array([1]))
    assert got.xy.shape == (1, 1, 2) and got.K is None and got.valid.tolist() == [True]
    np.testing.assert_allclose(got.xy[0, 0], [105.0, 105.0])
    cam_only = sample_video(TS, moving_camera(), None, np.array([0.05, 0.2]))
    assert cam_only.xy.shape == (0, 2, 2) and cam_only.cam_from_world.shape == (2, 4, 4)


def test_moving_camera_midway_and_invalid_bracket():
    got = sample_video(TS, moving_camera(np.array([True, True, False, True])), tracks(),
                       np.array([0.05, 0.2, 0.35]))
    T = got.cam_from_world[0]  # halfway between frames 0 and 1
    assert Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)[2] == pytest.approx(5.0)
    np.testing.assert_allclose(-T[:3, :3].T @ T[:3, 3], [0.5, 0.0, 0.0], atol=1e-12)
    # frames 1-2 and 2-3 need frame 2's pose, which is unknown: camera and points NaN
    np.testing.assert_array_equal(got.valid, [True, False, False])
    assert np.isnan(got.cam_from_world[1:]).all() and np.isnan(got.K[1:]).all()
    assert np.isnan(got.xy[:, 1:]).all() and np.isfinite(got.xy[0, 0]).all()


def test_camera_at_frames_is_exact_and_marks_invalid_frames():
    cam = moving_camera(np.array([True, False, True, True]))
    got = camera_at_frames(cam, np.array([[0, 1], [2, 3]]))
    assert got.cam_from_world.shape == (2, 2, 4, 4)
    np.testing.assert_array_equal(got.cam_from_world[1, 1], cam.cam_from_world[3])
    np.testing.assert_array_equal(got.valid, [[True, False], [True, True]])
    assert np.isnan(got.cam_from_world[0, 1]).all()


@pytest.mark.parametrize("call, message", [
    (lambda: sample_video(TS, None, tracks(), np.zeros((2, 2))), r"query_s must be \(N,\), got \(2, 2\)"),
    (lambda: sample_video(TS, None, tracks()[:, :3], np.zeros(2)), r"xy must be \(N,4,2\) .* got \(2, 3, 2\)"),
    (lambda: tracks_between_frames(np.zeros((4, 2)), np.zeros(1, int), np.zeros(1)),
     r"xy must be \(N,N,2\), got \(4, 2\)"),
    (lambda: tracks_between_frames(tracks(), np.zeros(2, int), np.zeros(3)), r"k and w must have the same shape"),
    (lambda: camera_at_frames(moving_camera(), np.array([0.5])), r"frames must be integers, got float64"),
    (lambda: frame_brackets(np.zeros((2, 2)), np.zeros(1)), r"timestamps_s must be \(N,\), got \(2, 2\)"),
])
def test_shape_errors_name_the_shape_received(call, message):
    with pytest.raises(ValueError, match=message):
        call()
