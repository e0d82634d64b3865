import numpy as np
from scipy.spatial.transform import Rotation

from vs_inspect.geometry.timing import frame_brackets, interpolate_poses


def test_frame_brackets_exact_values():
    t = np.array([0.0, 0.1, 0.3, 0.4])
    k, w = frame_brackets(t, np.array([-0.01, 0.0, 0.05, 0.2, 0.4, 0.41]))
    assert k.tolist() == [-1, 0, 0, 1, 2, -1]
    assert np.allclose(w[1:5], [0.0, 0.5, 0.5, 1.0])


def test_interpolate_poses_midway_rotation_and_centre():
    T0, T1 = np.eye(4), np.eye(4)
    T1[:3, :3] = Rotation.from_euler("z", 40, degrees=True).as_matrix()
    T1[:3, 3] = -T1[:3, :3] @ np.array([2.0, 0, 0])  # centre at (2,0,0)
    mid = interpolate_poses(np.stack([T0, T1]), np.array([0]), np.array([0.5]))[0]
    assert np.allclose(Rotation.from_matrix(mid[:3, :3]).as_euler("xyz", degrees=True), [0, 0, 20])
    centre = -mid[:3, :3].T @ mid[:3, 3]
    assert np.allclose(centre, [1, 0, 0])
    assert np.isnan(interpolate_poses(np.stack([T0, T1]), np.array([-1]), np.array([0.0]))).all()
