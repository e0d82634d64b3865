"""Camera models in one place: intrinsics fitted to another image size, and the two lens models
vs_inspect undistorts points with (OpenCV's k1 k2 p1 p2 k3 of a calibration, COLMAP's camera of an
estimated model), each with its inverse. Pixel coordinates follow OpenCV: integer coordinates at
pixel centres. Pure numpy/OpenCV (COLMAP's lens through pycolmap's camera), no I/O.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from ._shapes import check_shape

log = logging.getLogger(__name__)

UNDISTORT_ITERATIONS = 500  # strong barrel distortion converges slowly near the corners
UNDISTORT_CHECK_PX = 0.05  # a re-distorted point must land this close to the input, else NaN


def scale_points(xy: np.ndarray, sx: float, sy: float) -> np.ndarray:
    """(...,2) px of the image resized by (sx, sy), pixel centres kept: x' = (x + 0.5) s - 0.5."""
    xy = check_shape("xy", np.asarray(xy, np.float64), (2,))
    return (xy + 0.5) * np.array([sx, sy]) - 0.5


def scale_intrinsics(K: np.ndarray, sx: float, sy: float) -> np.ndarray:
    """(3,3) K of the image resized by (sx, sy), pixel centres kept: c' = (c + 0.5) s - 0.5."""
    K = np.array(check_shape("K", K, (3, 3), batched=False), dtype=np.float64)
    K[0, 0] *= sx
    K[0, 1] *= sx
    K[1, 1] *= sy
    K[0, 2] = (K[0, 2] + 0.5) * sx - 0.5
    K[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
    return K


def shift_principal_point(K: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """(3,3) K of the image cropped by dx columns and dy rows at its left and top."""
    K = np.array(check_shape("K", K, (3, 3), batched=False), dtype=np.float64)
    K[0, 2] -= dx
    K[1, 2] -= dy
    return K


def undistort_opencv(K: np.ndarray, dist: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(...,2) distorted px -> undistorted px with the same K (OpenCV's lens model, dist (5,)
    k1 k2 p1 p2 k3); NaN stays NaN.

    OpenCV's iterative inversion runs to convergence (its default 5 iterations leave tenths of a
    pixel at the corners of a wide-angle webcam). A point where the lens cannot be inverted (the
    re-distorted point misses it by more than UNDISTORT_CHECK_PX) becomes NaN."""
    xy = np.asarray(xy, dtype=np.float64)
    check_shape("xy", xy, (2,))
    K = check_shape("K", np.asarray(K, np.float64), (3, 3), batched=False)
    dist = np.asarray(dist, np.float64)
    if not np.any(dist != 0):
        return xy.copy()
    out = np.full_like(xy, np.nan)
    flat = xy.reshape(-1, 2)
    ok = np.all(np.isfinite(flat), axis=1)
    if ok.any():
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, UNDISTORT_ITERATIONS, 1e-10)
        und = cv2.undistortPoints(flat[ok].reshape(-1, 1, 2), K, dist, R=np.eye(3), P=K,
                                  criteria=crit).reshape(-1, 2)
        rays = np.c_[und, np.ones(len(und))] @ np.linalg.inv(K).T
        back = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, dist)[0].reshape(-1, 2)
        miss = np.linalg.norm(back - flat[ok], axis=1) > UNDISTORT_CHECK_PX
        if miss.any():
            log.debug("undistort_opencv: %d of %d points outside the lens model's valid region",
                      int(miss.sum()), len(miss))
            und[miss] = np.nan
        out.reshape(-1, 2)[ok] = und
    return out


@dataclass(frozen=True)
class Lens:
    """An estimated lens: a COLMAP camera model at the SfM images' resolution (result.json's
    cues.sfm.lens keeps it as plain data). With the camera's pinhole K at full resolution it
    undistorts any full-resolution image point as the tracks were."""

    model: str  # COLMAP's model name, e.g. "SIMPLE_RADIAL"
    params: tuple[float, ...]  # its parameters at SfM resolution
    width: int  # SfM image size, px
    height: int
    sfm_scale: float  # SfM px per full-resolution px

    def to_json(self) -> dict:
        return {"model": self.model, "params": [float(p) for p in self.params], "width": int(self.width),
                "height": int(self.height), "sfm_scale": float(self.sfm_scale)}

    @staticmethod
    def from_json(d: dict) -> Lens:
        return Lens(str(d["model"]), tuple(float(p) for p in d["params"]), int(d["width"]), int(d["height"]),
                    float(d["sfm_scale"]))

    def colmap_camera(self):
        """The pycolmap.Camera of this lens."""
        from ..signals import import_pycolmap

        return import_pycolmap().Camera(model=self.model, width=self.width, height=self.height,
                                        params=list(self.params))

    def undistort(self, K: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """(...,2) full-resolution px through the lens -> pinhole px of K (3,3); NaN stays NaN."""
        def through(K, p):
            norm = np.asarray(self.colmap_camera().cam_from_img((p + 0.5) * self.sfm_scale))  # COLMAP: centres at +0.5
            return norm[:, :2] * [K[0, 0], K[1, 1]] + [K[0, 2], K[1, 2]]
        return _finite_points(K, xy, through)

    def distort(self, K: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """The inverse of undistort: (...,2) pinhole px of K -> full-resolution px through the lens."""
        def back(K, p):
            rays = np.column_stack([(p - [K[0, 2], K[1, 2]]) / [K[0, 0], K[1, 1]], np.ones(len(p))])
            return np.asarray(self.colmap_camera().img_from_cam(rays, check_cheirality=False)) / self.sfm_scale - 0.5
        return _finite_points(K, xy, back)


def _finite_points(K: np.ndarray, xy: np.ndarray, fn) -> np.ndarray:
    """fn(K, (M,2) finite points) -> (M,2) over the finite points of xy (...,2); NaN elsewhere."""
    K = check_shape("K", np.asarray(K, np.float64), (3, 3), batched=False)
    xy = check_shape("xy", np.asarray(xy, np.float64), (2,))
    flat = xy.reshape(-1, 2)
    ok = np.isfinite(flat).all(1)
    out = np.full_like(flat, np.nan)
    if ok.any():
        out[ok] = fn(K, flat[ok])
    return out.reshape(xy.shape)
