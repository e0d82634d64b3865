"""geometry/point_cloud.py: the static cloud cleaned and thinned by open3d, frustums as line sets."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.point_cloud import VOXELS_ACROSS, clean_point_cloud, frustum_lines


def test_strays_go_and_the_cloud_is_thinned_evenly():
    """A dense unit cube with five far strays: the strays are removed, the cube stays within its
    bounds, and it is thinned to about one point per voxel; colours follow their points."""
    rng = np.random.default_rng(0)
    cube = rng.uniform(0, 1, (20000, 3))
    strays = np.array([[5.0, 5, 5], [-4, 0, 0], [0, 6, 0], [0, 0, -7], [3, -3, 3]])
    pts = np.concatenate([cube, strays])
    cols = np.concatenate([np.full((20000, 3), 100, np.uint8), np.full((5, 3), 250, np.uint8)])
    out, out_cols = clean_point_cloud(pts, cols)
    assert out.min() >= 0.0 and out.max() <= 1.0  # no stray left
    assert 1000 < len(out) < 20000  # thinned: about 0.9/voxel of 1/200 of the extent each way
    assert out_cols.dtype == np.uint8 and (out_cols == 100).all()
    again, _ = clean_point_cloud(pts[::-1].copy(), cols[::-1].copy())
    np.testing.assert_allclose(again, out)  # the same cloud in another order: the same output
    voxel = 0.9 / VOXELS_ACROSS  # the robust extent of a unit cube is about 0.9
    d = np.linalg.norm(out[:, None] - out[None, :200], axis=2)
    d[np.arange(200), np.arange(200)] = np.inf
    assert d.min() > 0.5 * voxel  # no two points closer than about a voxel apart
    few, none = clean_point_cloud(strays, None)
    assert none is None and len(few) == 5  # too few to judge: left as they are
    with pytest.raises(ValueError, match=r"points must be \(N,3\), got \(4, 2\)"):
        clean_point_cloud(np.zeros((4, 2)))


def test_a_frustum_is_the_centre_and_the_image_corners_at_depth():
    K = np.array([[500.0, 0, 320], [0, 480.0, 240], [0, 0, 1]])
    R = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])  # turned about z
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, [0.1, 0.2, 3.0]
    pts, lines = frustum_lines(K, T, 640, 480, 2.0)
    centre = -R.T @ T[:3, 3]
    np.testing.assert_allclose(pts[0], centre)
    for corner, px in zip(pts[1:], [(0, 0), (640, 0), (640, 480), (0, 480)]):
        cam = R @ corner + T[:3, 3]
        assert cam[2] == pytest.approx(2.0)  # at the depth asked for
        np.testing.assert_allclose((K @ cam)[:2] / cam[2], px, atol=1e-9)  # projects to its corner
    assert lines.tolist() == [[0, 1], [0, 2], [0, 3], [0, 4], [1, 2], [2, 3], [3, 4], [4, 1]]
