"""Vicon camera calibration (``.xcp``, XML: ``<Cameras><Camera ...><KeyFrames><KeyFrame .../>``).

Conventions of the file:

- ``<Camera>``: ``DEVICEID`` (and ``NAME``, ``USERID``) name the camera; ``SENSOR_SIZE`` is the
  image size in pixels; ``PIXEL_ASPECT_RATIO`` gives fy = fx / ratio; ``SKEW`` K[0,1].
- ``<KeyFrame>``: ``FOCAL_LENGTH`` and ``PRINCIPAL_POINT`` in pixels; ``POSITION`` the camera
  centre in millimetres; ``ORIENTATION`` a quaternion ``x y z w`` whose rotation matrix is the
  world -> camera rotation of a camera looking along +z with y down (as OpenCV).
- Lens: ``VICON_RADIAL="k1 k2"`` (on pixel offsets from the principal point) or
  ``VICON_RADIAL2="<model> dcx dcy k1 k2 k3"`` (on offsets from the distortion centre divided
  by the focal length). Both map a distorted image point to its undistorted place; OpenCV's
  model goes the other way, so OpenCV rational coefficients (k1 k2 k3 k4 k5 k6) are fitted to the Vicon
  mapping over the image, and the fit's worst residual is logged.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ...errors import InputError
from .. import atomic
from .camera import make_camera, rt_matrix
from .xml_safe import parse_xml

log = logging.getLogger(__name__)
MM = 1000.0
FIT_WARN_PX = 0.5  # warn when OpenCV's radial model reproduces Vicon's lens worse than this


def _r(x) -> str:
    return repr(float(x))


def quat_xyzw_to_matrix(q) -> np.ndarray:
    x, y, z, w = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_to_quat_xyzw(R) -> np.ndarray:
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(R).as_quat()  # x y z w


def _nums(el, key: str, n: int | None, where: str) -> list[float]:
    v = el.get(key)
    try:
        out = [float(t) for t in (v or "").split()]
    except ValueError:
        raise InputError(f"{where}: {key}={v!r} is not numbers") from None
    if not out or (n is not None and len(out) != n):
        raise InputError(f"{where}: {key}={v!r}: expected {n or 'some'} numbers")
    return out


def fit_opencv_radial(K: np.ndarray, size, centre_px, k_vicon, scale_px: float) -> tuple[np.ndarray, float]:
    """OpenCV rational lens coefficients (k1 k2 p1=0 p2=0 k3 k4 k5 k6) whose forward model best
    matches Vicon's undistortion x_u = c + (x_d - c)(1 + k1 r² + k2 r⁴ + k3 r⁶),
    r = |x_d - c| / scale_px, over a grid of the image; and the worst residual in pixels.

    OpenCV: n_d = n_u (1 + a1 ρ² + a2 ρ⁴ + a3 ρ⁶) / (1 + b1 ρ² + b2 ρ⁴ + b3 ρ⁶), ρ = |n_u|,
    fitted linearly as n_d - n_u = n_u (a1 ρ² + ...) - n_d (b1 ρ² + ...): a ratio of
    polynomials inverts Vicon's polynomial far better than a polynomial does.
    """
    import cv2
    w, h = size
    gx, gy = np.meshgrid(np.linspace(0, w - 1, 41), np.linspace(0, h - 1, 41))
    xd = np.c_[gx.ravel(), gy.ravel()]
    c = np.asarray(centre_px, dtype=np.float64)
    r2 = (((xd - c) / scale_px) ** 2).sum(1)
    k = np.r_[k_vicon, np.zeros(3)][:3]
    xu = c + (xd - c) * (1 + k[0] * r2 + k[1] * r2 ** 2 + k[2] * r2 ** 3)[:, None]
    pp = K[:2, 2]
    f = np.array([K[0, 0], K[1, 1]])
    nu, nd = (xu - pp) / f, (xd - pp) / f
    rho2 = (nu ** 2).sum(1)[:, None]
    cols = [nu * rho2 ** p for p in (1, 2, 3)] + [-nd * rho2 ** p for p in (1, 2, 3)]
    A = np.stack([col.reshape(-1) for col in cols], axis=1)
    b = (nd - nu).reshape(-1)
    a1, a2, a3, b1, b2, b3 = np.linalg.lstsq(A, b, rcond=None)[0]
    dist = np.array([a1, a2, 0.0, 0.0, a3, b1, b2, b3])
    Kn = K.copy()
    Kn[0, 1] = 0.0
    back = cv2.projectPoints(np.c_[nu, np.ones(len(nu))], np.zeros(3), np.zeros(3), Kn, dist)[0]
    resid = np.abs(back.reshape(-1, 2) - (nd * f + pp)).max()
    return dist, float(resid)


def read(path: Path):
    root = parse_xml(path, "Vicon")
    cams = root.findall("Camera")
    if root.tag != "Cameras" or not cams:
        raise InputError(f"{path}: not a Vicon calibration (expected <Cameras><Camera ...>, "
                         f"found <{root.tag}>)")
    out = {}
    for i, cam in enumerate(cams):
        name = cam.get("DEVICEID") or cam.get("NAME") or f"camera_{i}"
        names = [name] + [cam.get(k) for k in ("NAME", "USERID") if cam.get(k)]
        where = f"{path}: camera {name!r}"
        kf = cam.find("KeyFrames/KeyFrame")
        if kf is None:
            raise InputError(f"{where}: no <KeyFrames><KeyFrame> (an uncalibrated camera)")
        w, h = (int(round(v)) for v in _nums(cam, "SENSOR_SIZE", 2, where))
        fx = _nums(kf, "FOCAL_LENGTH", 1, where)[0]
        ratio = _nums(cam, "PIXEL_ASPECT_RATIO", 1, where)[0] if cam.get("PIXEL_ASPECT_RATIO") else 1.0
        skew = _nums(cam, "SKEW", 1, where)[0] if cam.get("SKEW") else 0.0
        if ratio <= 0:
            raise InputError(f"{where}: PIXEL_ASPECT_RATIO must be positive, got {ratio}")
        cx, cy = _nums(kf, "PRINCIPAL_POINT", 2, where)
        K = np.array([[fx, skew, cx], [0, fx / ratio, cy], [0, 0, 1]])
        R = quat_xyzw_to_matrix(_nums(kf, "ORIENTATION", 4, where))
        centre = np.array(_nums(kf, "POSITION", 3, where)) / MM
        dist = np.zeros(5)
        if kf.get("VICON_RADIAL2"):
            parts = kf.get("VICON_RADIAL2").split()
            try:
                vals = [float(t) for t in parts[1:]]
            except ValueError:
                raise InputError(f"{where}: VICON_RADIAL2={kf.get('VICON_RADIAL2')!r} is not "
                                 f"'<model> dcx dcy k1 k2 k3'") from None
            if len(vals) < 3:
                raise InputError(f"{where}: VICON_RADIAL2 needs '<model> dcx dcy k1 [k2 [k3]]'")
            centre_px, kv, scale = vals[:2], vals[2:5], fx
        elif kf.get("VICON_RADIAL"):
            centre_px, kv, scale = (cx, cy), _nums(kf, "VICON_RADIAL", None, where)[:3], 1.0
        else:
            kv = []
        if any(v != 0 for v in kv):
            dist, resid = fit_opencv_radial(K, (w, h), centre_px, kv, scale)
            (log.warning if resid > FIT_WARN_PX else log.info)(
                "%s: Vicon lens model converted to OpenCV's rational model (worst difference %.3g px)",
                where, resid)
        out[name] = (names, make_camera(where, K, dist, rt_matrix(R, -R @ centre), (w, h)))
    return out


def write(cameras: dict, path: Path) -> list[Path]:
    """An .xcp holding the static cameras; lens as VICON_RADIAL2 fitted to OpenCV's k1 k2 k3."""
    import xml.etree.ElementTree as ET
    root = ET.Element("Cameras", NAME="", VERSION="1.0")
    for i, (name, c) in enumerate(cameras.items()):
        w, h = c.size
        K = c.K
        cam = ET.SubElement(root, "Camera", DEVICEID=str(name), NAME=str(name), USERID=str(i + 1),
                            PIXEL_ASPECT_RATIO=_r(K[0, 0] / K[1, 1]), SENSOR_SIZE=f"{w} {h}",
                            SKEW=_r((K[0, 1])), TYPE="VIDEO")
        kfs = ET.SubElement(cam, "KeyFrames")
        R, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3]
        centre = -R.T @ t * MM
        q = matrix_to_quat_xyzw(R)
        radial = _opencv_to_vicon_radial2(c, name)
        ET.SubElement(kfs, "KeyFrame", FOCAL_LENGTH=_r((K[0, 0])), FRAME="0",
                      ORIENTATION=" ".join(_r((v)) for v in q),
                      POSITION=" ".join(_r((v)) for v in centre),
                      PRINCIPAL_POINT=f"{_r(K[0, 2])} {_r(K[1, 2])}", VICON_RADIAL2=radial)
    ET.indent(root)
    text = '<?xml version="1.0" encoding="UTF-8" standalone="no" ?>\n' + ET.tostring(root, encoding="unicode") + "\n"
    return [atomic.write_text_atomic(text, path)]


def _opencv_to_vicon_radial2(c, name: str = "camera") -> str:
    """Vicon's undistortion (k1 k2 k3 about the principal point, r in focal lengths) fitted to
    OpenCV's model of the camera."""
    import cv2
    K = c.K
    pp, f = K[:2, 2], K[0, 0]
    if not np.any(c.dist != 0):
        return f"ThirdOrderRadial {_r(pp[0])} {_r(pp[1])} 0 0 0"
    w, h = c.size
    gx, gy = np.meshgrid(np.linspace(0, w - 1, 41), np.linspace(0, h - 1, 41))
    xd = np.c_[gx.ravel(), gy.ravel()]
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    radial = c.dist.copy()
    radial[2:4] = 0.0  # Vicon's model has no tangential terms
    xu = cv2.undistortPoints(xd.reshape(-1, 1, 2), K, radial, P=K, criteria=crit).reshape(-1, 2)
    if np.any(c.dist[2:4] != 0):
        full = cv2.undistortPoints(xd.reshape(-1, 1, 2), K, c.dist, P=K, criteria=crit).reshape(-1, 2)
        log.warning("camera %r: Vicon's lens model has no tangential terms; p1 p2 dropped (points "
                    "move by up to %.2g px)", name, float(np.abs(full - xu).max()))
    d = (xd - pp)
    r2 = (d ** 2).sum(1) / f ** 2
    A = np.concatenate([(d * r2[:, None] ** p).reshape(-1, 1) for p in (1, 2, 3)], axis=1)
    k = np.linalg.lstsq(A, (xu - xd).reshape(-1), rcond=None)[0]
    return f"ThirdOrderRadial " + " ".join(_r(v) for v in (*pp, *k))
