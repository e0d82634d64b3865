"""Qualisys QTM calibration export (``.qca.txt``, XML).

Conventions of the file, as QTM writes them and Pose2Sim's converter reads them:

- ``<intrinsic>`` focal lengths and principal point are in sensor subpixels, 64 per pixel of the
  marker image; the video's window (``<fov_video left top right bottom>``) gives the image size
  and shifts the principal point. Lens coefficients (``radialDistortion1..3``,
  ``tangentalDistortion1..2``) are on normalized coordinates, as OpenCV's k1 k2 k3 p1 p2.
- ``<transform>``: ``x y z`` is the camera centre in millimetres and ``r11..r33`` (by rows) the
  world -> camera rotation of a camera that looks along its -z axis with y up; OpenCV's camera
  (z forward, y down) is that frame turned half a turn about x.
- Cameras are named by ``serial``. A camera mounted on its side (``viewrotation`` other than 0)
  is refused: export the calibration with the view rotation applied.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from .. import atomic
from .camera import make_camera, rt_matrix
from .xml_safe import parse_xml

SUBPIXELS = 64.0  # QTM sensor coordinates per pixel
MM = 1000.0  # file millimetres per metre
_FLIP = np.diag([1.0, -1.0, -1.0])  # QTM camera frame (y up, looks along -z) <-> OpenCV


def _r(x) -> str:
    return repr(float(x))


def _f(el, key: str, where: str) -> float:
    v = el.get(key)
    try:
        return float(v)
    except (TypeError, ValueError):
        raise InputError(f"{where}: attribute {key}={v!r} is missing or not a number") from None


def read(path: Path):
    root = parse_xml(path, "Qualisys")
    cams = root.findall("cameras/camera")
    if root.tag != "calibration" or not cams:
        raise InputError(f"{path}: not a Qualisys calibration (expected <calibration><cameras>"
                         f"<camera ...>, found <{root.tag}>)")
    out = {}
    for i, cam in enumerate(cams):
        name = cam.get("serial") or f"camera_{i}"
        where = f"{path}: camera {name!r}"
        rot = cam.get("viewrotation", "0")
        if rot not in ("0", "0.0", ""):
            raise InputError(f"{where}: viewrotation={rot} (a camera mounted on its side) is not "
                             f"supported; export the calibration from QTM with rotation 0")
        tr, intr = cam.find("transform"), cam.find("intrinsic")
        if tr is None or intr is None:
            raise InputError(f"{where}: needs <transform> and <intrinsic>")
        fov = cam.find("fov_video")
        left = _f(fov, "left", where) if fov is not None else 0.0
        top = _f(fov, "top", where) if fov is not None else 0.0
        if fov is not None:
            size = (int(round(_f(fov, "right", where) - left + 1)),
                    int(round(_f(fov, "bottom", where) - top + 1)))
        else:
            size = (int(round((_f(intr, "sensorMaxU", where) - _f(intr, "sensorMinU", where)) / SUBPIXELS)) + 1,
                    int(round((_f(intr, "sensorMaxV", where) - _f(intr, "sensorMinV", where)) / SUBPIXELS)) + 1)
        fx, fy = _f(intr, "focalLengthU", where) / SUBPIXELS, _f(intr, "focalLengthV", where) / SUBPIXELS
        skew = _f(intr, "skew", where) / SUBPIXELS if intr.get("skew") else 0.0
        cx = _f(intr, "centerPointU", where) / SUBPIXELS - left
        cy = _f(intr, "centerPointV", where) / SUBPIXELS - top
        K = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]
        g = lambda k: _f(intr, k, where) if intr.get(k) else 0.0  # noqa: E731
        dist = [g("radialDistortion1"), g("radialDistortion2"), g("tangentalDistortion1"),
                g("tangentalDistortion2"), g("radialDistortion3")]
        R_file = np.array([[_f(tr, f"r{r}{c}", where) for c in (1, 2, 3)] for r in (1, 2, 3)])
        centre = np.array([_f(tr, k, where) for k in "xyz"]) / MM
        R = _FLIP @ R_file
        cal = make_camera(where, K, dist, rt_matrix(R, -R @ centre), size)
        out[name] = ([name], cal)
    return out


def write(cameras: dict, path: Path) -> list[Path]:
    """A .qca.txt holding the static cameras (world unit metres -> file millimetres)."""
    import xml.etree.ElementTree as ET
    root = ET.Element("calibration", source="vs-inspect", type="regular")
    cams = ET.SubElement(root, "cameras")
    for name, c in cameras.items():
        w, h = c.size
        cam = ET.SubElement(cams, "camera", active="1", serial=str(name), viewrotation="0")
        box = dict(left="0", top="0", right=str(w - 1), bottom=str(h - 1))
        for tag in ("fov_marker", "fov_marker_max", "fov_video", "fov_video_max"):
            ET.SubElement(cam, tag, **box)
        R_cv, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3]
        R_file = _FLIP @ R_cv
        centre = -R_cv.T @ t * MM
        attrs = {f"r{r + 1}{k + 1}": _r((R_file[r, k])) for r in range(3) for k in range(3)}
        attrs.update(x=_r((centre[0])), y=_r((centre[1])), z=_r((centre[2])))
        ET.SubElement(cam, "transform", **attrs)
        K, d = c.K, np.r_[c.dist, np.zeros(5)][:5]
        ET.SubElement(cam, "intrinsic", focalLengthU=_r(K[0, 0] * SUBPIXELS),
                      focalLengthV=_r(K[1, 1] * SUBPIXELS), centerPointU=_r(K[0, 2] * SUBPIXELS),
                      centerPointV=_r(K[1, 2] * SUBPIXELS), skew=_r(K[0, 1] * SUBPIXELS),
                      radialDistortion1=_r(d[0]), radialDistortion2=_r(d[1]),
                      radialDistortion3=_r(d[4]), tangentalDistortion1=_r(d[2]),
                      tangentalDistortion2=_r(d[3]), sensorMinU="0", sensorMinV="0",
                      sensorMaxU=_r((w - 1) * SUBPIXELS), sensorMaxV=_r((h - 1) * SUBPIXELS))
    ET.indent(root)
    text = "<?xml version='1.0' encoding='ASCII'?>\n" + ET.tostring(root, encoding="unicode") + "\n"
    return [atomic.write_text_atomic(text, path)]
