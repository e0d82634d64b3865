"""3D geometry drawn with the cameras, through open3d: the static point cloud of a reconstruction
cleaned of stray points and thinned to an even density, and a camera's frustum as a line set.
Pure geometry (open3d's point cloud and line set), no I/O.
"""

from __future__ import annotations

import logging

import numpy as np

from ._shapes import check_shape

OUTLIER_NEIGHBOURS = 20  # neighbours whose mean distance a point is judged by
OUTLIER_STD_RATIO = 2.0  # a point whose mean distance is beyond mean + this many std is a stray
VOXELS_ACROSS = 200  # the cloud's robust extent over this is the voxel size it is thinned to

log = logging.getLogger(__name__)


def clean_point_cloud(points: np.ndarray, colors: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray | None]:
    """(points (M,3), colors (M,3) uint8 or None) of points (N,3) (colors (N,3) uint8): stray points
    removed (open3d's statistical outlier removal) and the rest averaged per voxel of 1/VOXELS_ACROSS
    of the cloud's robust extent (5th-95th percentile), sorted so that the same input gives the
    same output. Fewer than OUTLIER_NEIGHBOURS + 1 points, or any points where open3d cannot be
    loaded, are returned as they are (finite ones only)."""
    points = check_shape("points", np.asarray(points, np.float64), (None, 3), batched=False)
    if colors is not None:
        check_shape("colors", np.asarray(colors), (len(points), 3), batched=False)
    points_ok = np.isfinite(points).all(1)
    points, colors = points[points_ok], None if colors is None else np.asarray(colors)[points_ok]
    if len(points) <= OUTLIER_NEIGHBOURS:
        return points, colors
    try:
        import open3d as o3d
    except (ImportError, OSError) as exc:  # open3d needs libusb at import time
        log.warning("static points kept as they are: open3d cannot be loaded (%s)", exc)
        return points, colors
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    if colors is not None:
        cloud.colors = o3d.utility.Vector3dVector(colors.astype(np.float64) / 255.0)
    cloud, _ = cloud.remove_statistical_outlier(OUTLIER_NEIGHBOURS, OUTLIER_STD_RATIO)
    kept = np.asarray(cloud.points)
    extent = float(np.max(np.percentile(kept, 95, axis=0) - np.percentile(kept, 5, axis=0))) if len(kept) else 0.0
    if extent > 0:
        cloud = cloud.voxel_down_sample(extent / VOXELS_ACROSS)
    out = np.asarray(cloud.points)
    order = np.lexsort(out.T[::-1])
    out_colors = None if colors is None else np.clip(np.round(np.asarray(cloud.colors) * 255), 0, 255).astype(np.uint8)
    return out[order], None if out_colors is None else out_colors[order]


def frustum_lines(K: np.ndarray, cam_from_world: np.ndarray, width: int, height: int, depth: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(points (5,3) world: the camera centre, then the image corners (0,0), (w,0), (w,h), (0,h) at
    `depth` in front of it; lines (8,2) int: centre to each corner and round the image) of one
    camera, open3d's camera line set without its axes."""
    import open3d as o3d

    K = check_shape("K", np.asarray(K, np.float64), (3, 3), batched=False)
    T = check_shape("cam_from_world", np.asarray(cam_from_world, np.float64), (4, 4), batched=False)
    lines = o3d.geometry.LineSet.create_camera_visualization(int(width), int(height), K, T, float(depth))
    return np.asarray(lines.points)[:5].copy(), np.asarray(lines.lines)[:8].astype(np.int64)
