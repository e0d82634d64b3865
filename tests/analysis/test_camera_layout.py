"""The scene's scale and the 3D view's eye, from cameras placed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.analysis.camera_layout import eye_behind, scene_scale
from vs_inspect.types import CameraTrack

K = np.array([[500.0, 0, 320], [0, 480.0, 240], [0, 0, 1]])


def at(centre, R=np.eye(3)) -> np.ndarray:
    """cam_from_world (4,4) of a camera with rotation R whose centre is at `centre` (world)."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = -R @ np.asarray(centre, float)
    return T


def test_scene_scale_is_the_median_distance_from_the_cameras_mean():
    cams = {"a": CameraTrack(K, at([0, 0, 0])), "b": CameraTrack(K, at([2, 0, 0])),
            "c": CameraTrack(K, at([1, 3, 0]))}
    # mean (1, 1, 0): distances √2, √2, 2
    assert scene_scale(cams) == pytest.approx(np.sqrt(2.0))


def test_a_moving_camera_counts_once_by_its_mean_centre():
    path = np.stack([at([10, 0, 0]), at([12, 0, 0]), at([14, 0, 0])])  # mean centre (12, 0, 0)
    cams = {"still": CameraTrack(K, at([2, 0, 0])), "moving": CameraTrack(K, path)}
    assert scene_scale(cams) == pytest.approx(5.0)


def test_scene_scale_is_one_without_a_spread():
    assert scene_scale({}) == 1.0
    assert scene_scale({"a": CameraTrack(K, at([4, 5, 6]))}) == 1.0
    assert scene_scale({"a": CameraTrack(K, at([1, 1, 1])), "b": CameraTrack(K, at([1, 1, 1]))}) == 1.0


def test_eye_of_cameras_looking_the_same_way_is_behind_and_above_them():
    # both look along +z with image y down: forward (0,0,1), up (0,-1,0); centre 0, spread 1
    cams = {"a": CameraTrack(K, at([-1, 0, 0])), "b": CameraTrack(K, at([1, 0, 0]))}
    position, target, up = eye_behind(cams)
    assert target == pytest.approx([0.0, 0.0, 1.0])  # one spread ahead of the centre
    assert position == pytest.approx([0.0, -1.2, -1.0])  # two spreads behind, 1.2 above the target
    assert up == pytest.approx([0.0, -1.0, 0.0])


def test_eye_of_a_ring_of_cameras_looks_at_its_centre():
    turn = np.diag([-1.0, 1.0, -1.0])  # 180° about y: looks along -z
    cams = {"a": CameraTrack(K, at([0, 0, -2])), "b": CameraTrack(K, at([0, 0, 2], turn))}
    position, target, up = eye_behind(cams)
    assert target == pytest.approx([0.0, 0.0, 0.0])
    assert position == pytest.approx([0.0, -2.4, -4.0])  # along the first camera's forward, spread 2
    assert up == pytest.approx([0.0, -1.0, 0.0])


def test_no_eye_without_cameras():
    assert eye_behind({}) is None
