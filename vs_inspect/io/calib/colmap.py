"""COLMAP models (text or binary, read with pycolmap) as calibrations: one static camera per
video, images mapped to videos by the stem of their name or their parent folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np  # noqa: I001  (numpy before pycolmap: see ENVIRONMENT.md)

from ...errors import InputError
from ...signals import import_pycolmap
from ...types import CameraCalibration
from .camera import make_camera


# COLMAP camera model -> (fx, fy, cx, cy, OpenCV dist) from its params
def _colmap_intrinsics(model: str, p: np.ndarray):
    if model == "SIMPLE_PINHOLE":
        return p[0], p[0], p[1], p[2], np.zeros(5)
    if model == "PINHOLE":
        return p[0], p[1], p[2], p[3], np.zeros(5)
    if model == "SIMPLE_RADIAL":
        return p[0], p[0], p[1], p[2], np.array([p[3], 0, 0, 0, 0])
    if model == "RADIAL":
        return p[0], p[0], p[1], p[2], np.array([p[3], p[4], 0, 0, 0])
    if model == "OPENCV":
        return p[0], p[1], p[2], p[3], np.array([p[4], p[5], p[6], p[7], 0])
    if model == "FULL_OPENCV":  # k1 k2 p1 p2 k3 k4 k5 k6: OpenCV's rational model order
        return p[0], p[1], p[2], p[3], np.asarray(p[4:12])
    return None


def read_colmap(path: Path) -> dict[str, tuple[list[str], CameraCalibration]]:
    pycolmap = import_pycolmap()  # keeps our SIGTERM handler (glog replaces it)

    try:
        rec = pycolmap.Reconstruction(str(path))
    except Exception as exc:  # noqa: BLE001 - pycolmap raises plain RuntimeError/ValueError
        raise InputError(f"{path}: not a readable COLMAP model ({exc})") from None
    images = sorted(rec.images.values(), key=lambda im: im.name)
    images = [im for im in images if im.has_pose]
    if not images:
        raise InputError(f"{path}: COLMAP model has no registered images")
    # group images by the video they belong to: stem of the name, or its parent folder
    groups: dict[str, list] = {}
    for im in images:
        p = Path(im.name)
        key = p.stem if p.parent == Path(".") else p.parent.name
        groups.setdefault(key, []).append(im)
    out = {}
    for key, ims in groups.items():
        where = f"{path}: image {ims[0].name!r}"
        poses = [np.vstack([im.cam_from_world().matrix(), [0, 0, 0, 1]]) for im in ims]
        spread = max(np.abs(P - poses[0]).max() for P in poses)
        if spread > 1e-6 * max(1.0, np.abs(poses[0]).max()) and len(ims) > 1:
            raise InputError(
                f"{path}: the {len(ims)} images of {key!r} have different poses (a moving camera); "
                f"import one image per static camera"
            )
        cam = ims[0].camera if ims[0].has_camera_ptr() else rec.cameras[ims[0].camera_id]
        model = cam.model_name if hasattr(cam, "model_name") else str(cam.model).split(".")[-1]
        intr = _colmap_intrinsics(model, np.asarray(cam.params, dtype=np.float64))
        if intr is None:
            raise InputError(f"{where}: COLMAP camera model {model} is not supported "
                             f"(use PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV or FULL_OPENCV)")
        fx, fy, cx, cy, dist = intr
        # COLMAP puts the centre of the top-left pixel at (0.5, 0.5); OpenCV at (0, 0)
        K = np.array([[fx, 0, cx - 0.5], [0, fy, cy - 0.5], [0, 0, 1]])
        cal = make_camera(where, K, dist, poses[0], (cam.width, cam.height))
        out[key] = ([key, Path(ims[0].name).stem], cal)
    return out
