"""geometry/camera_model.py: intrinsics fitted to another image size, and the lenses' round trips."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.camera_model import (Lens, scale_intrinsics, scale_points, shift_principal_point,
                                              undistort_opencv)

K = np.array([[800.0, 0.5, 639.5], [0.0, 790.0, 359.5], [0.0, 0.0, 1.0]])


def test_scaled_intrinsics_keep_pixel_centres():
    """Halving a 1280x720 image: the centre pixel's centre (639.5, 359.5) maps to (319.5, 179.5),
    focal lengths and skew halve; a point and K scale alike, so the ray through it is unchanged."""
    half = scale_intrinsics(K, 0.5, 0.5)
    np.testing.assert_allclose(half, [[400.0, 0.25, 319.5], [0.0, 395.0, 179.5], [0, 0, 1]])
    x = np.array([100.0, 600.0])
    ray = np.linalg.solve(K, np.r_[x, 1.0])
    ray_half = np.linalg.solve(half, np.r_[scale_points(x, 0.5, 0.5), 1.0])
    np.testing.assert_allclose(ray_half, ray, atol=1e-12)
    np.testing.assert_allclose(scale_points(np.array([[0.0, 0.0]]), 2.0, 3.0), [[0.5, 1.0]])


def test_a_crop_moves_the_principal_point():
    np.testing.assert_allclose(shift_principal_point(K, 4.0, 8.0)[:2, 2], [635.5, 351.5])
    with pytest.raises(ValueError, match=r"K must be \(3,3\), got \(2, 3\)"):
        shift_principal_point(K[:2], 1.0, 1.0)


def test_opencv_lens_round_trip():
    """Points distorted by OpenCV's model come back to where they were; NaN stays NaN, and a lens
    of zeros leaves the points as they are."""
    import cv2

    dist = np.array([-0.2, 0.05, 0.001, -0.002, 0.0])
    und = np.array([[100.0, 80.0], [640.0, 360.0], [1100.0, 650.0]])
    rays = np.c_[und, np.ones(3)] @ np.linalg.inv(K).T
    distorted = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, dist)[0].reshape(-1, 2)
    xy = np.concatenate([distorted, [[np.nan, 1.0]]])
    got = undistort_opencv(K, dist, xy)
    np.testing.assert_allclose(got[:3], und, atol=1e-6)
    assert np.isnan(got[3]).all()
    np.testing.assert_array_equal(undistort_opencv(K, np.zeros(5), xy[:3]), xy[:3])
    with pytest.raises(ValueError, match=r"xy must be \(\.\.\.,2\), got \(3, 3\)"):
        undistort_opencv(K, dist, np.zeros((3, 3)))


def test_colmap_lens_json_round_trip():
    lens = Lens("SIMPLE_RADIAL", (300.0, 320.0, 180.0, -0.05), 640, 360, 0.5)
    assert Lens.from_json(lens.to_json()) == lens
    Kf = np.array([[600.0, 0, 639.5], [0, 600.0, 359.5], [0, 0, 1]])
    xy = np.array([[5.0, 5.0], [1270.0, 710.0]])
    np.testing.assert_allclose(lens.distort(Kf, lens.undistort(Kf, xy)), xy, atol=1e-6)
