"""Imported camera calibration: COLMAP models, a simple JSON, and the OpenCV-style TOML of
multi-camera mocap tools (caliscope, anipose, Pose2Sim). Cameras are mapped to videos by name,
else by order; every problem is an InputError that says what was found and what was expected.

Supported files (``load_calibration(path, video_names)``):

- COLMAP model folder (``cameras.txt/images.txt`` or ``cameras.bin/images.bin``, read with
  pycolmap). Images map to videos by name: the image name's stem or its parent folder equals the
  video name (``cam0.jpg``, ``cam0/000001.jpg``); several images of one video must share one pose
  (a static camera). Camera models SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV and
  FULL_OPENCV are converted to OpenCV distortion.
- JSON: ``{"<video name>": {"K": 3x3, "dist": [k1, k2, p1, p2, ...], "cam_from_world": 4x4,
  "size": [width, height]}}`` (``dist`` and ``size`` optional).
- TOML: tables with ``matrix`` (3x3), ``distortions``, ``rotation`` (3x3 matrix as caliscope
  writes, or a Rodrigues 3-vector as anipose and Pose2Sim write; world -> camera), ``translation``
  (world -> camera) and ``size`` ([width, height]); either top level (``[cam_0]``) or under
  ``[cameras.N]`` (caliscope). Tables without ``matrix`` (``[metadata]``) are ignored.
"""

from __future__ import annotations

import json
import logging
import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np  # noqa: I001  (numpy before pycolmap: see ENVIRONMENT.md)
import cv2

from ..errors import InputError
from ..signals import import_pycolmap
from ..types import CameraTrack

log = logging.getLogger(__name__)

_DIST_LENGTHS = (0, 4, 5, 8, 12, 14)  # OpenCV accepts these numbers of distortion coefficients


@dataclass(frozen=True)
class CameraCalibration:
    """One camera's intrinsics, lens distortion and pose (OpenCV conventions)."""

    K: np.ndarray  # (3,3) px, at the image size `size`
    dist: np.ndarray  # (k,) OpenCV order k1 k2 p1 p2 [k3 [k4 k5 k6 ...]], zeros if none
    cam_from_world: np.ndarray  # (4,4) or (T,4,4) per frame (moving camera), x_cam = R X + t
    size: tuple[int, int] | None  # (width, height) px the calibration was made at; None = unknown


# ---- validation -------------------------------------------------------------------------------


def _make(where: str, K, dist, cam_from_world, size) -> CameraCalibration:
    """Build a CameraCalibration, raising InputError naming `where` for every bad field."""
    try:
        K = np.asarray(K, dtype=np.float64)
        dist = np.asarray([] if dist is None else dist, dtype=np.float64).reshape(-1)
        T = np.asarray(cam_from_world, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: calibration values are not numbers ({exc})") from None
    if K.shape != (3, 3):
        raise InputError(f"{where}: K must be 3x3, got shape {K.shape}")
    if T.shape[-2:] == (3, 4):
        bottom = np.broadcast_to([0.0, 0, 0, 1], T.shape[:-2] + (1, 4))
        T = np.concatenate([T, bottom], axis=-2)
    if T.shape[-2:] != (4, 4) or T.ndim not in (2, 3) or (T.ndim == 3 and len(T) == 0):
        raise InputError(f"{where}: cam_from_world must be 4x4 or a list of 4x4 (one per frame), "
                         f"got shape {T.shape}")
    for name, a in (("K", K), ("distortion", dist), ("cam_from_world", T)):
        if not np.all(np.isfinite(a)):
            raise InputError(f"{where}: {name} has NaN or inf values")
    if abs(np.linalg.det(K)) < 1e-9 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"{where}: K is singular or has a non-positive focal length: {K.tolist()}")
    if not np.allclose(K[2], [0, 0, 1], atol=1e-9):
        raise InputError(f"{where}: the last row of K must be [0, 0, 1], got {K[2].tolist()}")
    if dist.size not in _DIST_LENGTHS:
        raise InputError(
            f"{where}: {dist.size} distortion coefficients; OpenCV takes {_DIST_LENGTHS[1:]}"
        )
    if dist.size == 0:
        dist = np.zeros(5)
    R = T[..., :3, :3]
    err = np.abs(R @ np.swapaxes(R, -1, -2) - np.eye(3)).max()
    if err > 1e-4 or np.any(np.linalg.det(R) <= 0) or not np.allclose(T[..., 3, :], [0, 0, 0, 1]):
        raise InputError(f"{where}: cam_from_world is not a rigid transform (|RRᵀ-I| = {err:.2g})")
    if size is not None:
        try:
            w, h = (int(s) for s in size)
        except (TypeError, ValueError):
            raise InputError(f"{where}: size must be [width, height], got {size!r}") from None
        if w < 1 or h < 1:
            raise InputError(f"{where}: size must be positive, got {size!r}")
        size = (w, h)
    return CameraCalibration(K, dist, T, size)


def _rt(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.asarray(t, dtype=np.float64).reshape(3)
    return T


# ---- name matching ----------------------------------------------------------------------------


def _tokens(name: str) -> list:
    """Lower-case letter runs and integers: 'Cam_01' -> ['cam', 1] (so cam_01 == cam1)."""
    return [int(t) if t.isdigit() else t for t in re.findall(r"[a-z]+|\d+", name.lower())]


def _contains(hay: list, needle: list) -> bool:
    n = len(needle)
    return n > 0 and any(hay[i:i + n] == needle for i in range(len(hay) - n + 1))


def match_names(camera_names: dict[str, list[str]], video_names: list[str], source) -> dict[str, str]:
    """Map each video to a camera key.

    camera_names: camera key -> names it is known by (section key, its `name` field, ...).
    By name: exact, or the video name contains the camera's name as whole tokens
    (``cam_0`` matches ``session2_cam_0`` and ``cam0`` but not ``cam_01``... unless equal as
    numbers, ``cam_01`` == ``cam1``). If no video matches by name and the counts are equal, by
    order. Anything else is an InputError listing both sides.
    """
    keys = list(camera_names)
    listing = f"cameras in the calibration: {keys}; videos: {list(video_names)}"
    if not video_names:
        raise InputError(f"{source}: no videos to map the calibration to")
    if not keys:
        raise InputError(f"{source}: the calibration has no cameras")
    found: dict[str, str] = {}
    unmatched: list[str] = []
    for v in video_names:
        vt = _tokens(v)
        exact = [k for k in keys if any(_tokens(n) == vt for n in camera_names[k])]
        if len(exact) == 1:
            found[v] = exact[0]
            continue
        part = [k for k in keys if any(_contains(vt, _tokens(n)) for n in camera_names[k])]
        if len(part) > 1:  # keep the most specific (longest) names only
            best = max(max(len(_tokens(n)) for n in camera_names[k]) for k in part)
            part = [k for k in part if max(len(_tokens(n)) for n in camera_names[k]) == best]
        if len(part) == 1:
            found[v] = part[0]
        elif len(part) > 1:
            raise InputError(f"{source}: video {v!r} matches several cameras {part}; {listing}")
        else:
            unmatched.append(v)
    if not unmatched:
        used = list(found.values())
        dup = sorted({k for k in used if used.count(k) > 1})
        if dup:
            raise InputError(f"{source}: several videos map to the same camera {dup}; {listing}")
        extra = [k for k in keys if k not in used]
        if extra:
            log.info("%s: cameras %s have no video and are not used", source, extra)
        return found
    if not found and len(keys) == len(video_names):
        log.warning("%s: camera names do not match the videos; mapping by order (%s)", source,
                    ", ".join(f"{v}->{k}" for v, k in zip(video_names, keys)))
        return dict(zip(video_names, keys))
    if len(keys) != len(video_names):
        raise InputError(
            f"{source}: {len(keys)} cameras for {len(video_names)} videos and the names do not "
            f"match (no camera for {unmatched}); {listing}"
        )
    raise InputError(f"{source}: no camera named like videos {unmatched}; {listing}")


# ---- formats ----------------------------------------------------------------------------------


def _load_json(path: Path) -> dict[str, tuple[list[str], CameraCalibration]]:
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise InputError(f"{path}: not valid JSON ({type(exc).__name__}: {exc})") from None
    if isinstance(data, dict) and isinstance(data.get("cameras"), dict):
        data = data["cameras"]
    if not isinstance(data, dict) or not data:
        raise InputError(f"{path}: expected {{\"<video name>\": {{\"K\": ..., \"cam_from_world\": ...}}}}")
    out = {}
    for name, entry in data.items():
        where = f"{path}: camera {name!r}"
        if not isinstance(entry, dict):
            raise InputError(f"{where}: expected an object with K, dist, cam_from_world")
        missing = [k for k in ("K", "cam_from_world") if k not in entry]
        if missing:
            raise InputError(f"{where}: missing {missing} (has {sorted(entry)})")
        cal = _make(where, entry["K"], entry.get("dist"), entry["cam_from_world"], entry.get("size"))
        out[name] = ([name], cal)
    return out


def _load_toml(path: Path) -> dict[str, tuple[list[str], CameraCalibration]]:
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    tables: list[tuple[str, list[str], dict]] = []
    if isinstance(data.get("cameras"), dict):  # caliscope: [cameras.0], [cameras.1], ...
        for key, t in data["cameras"].items():
            if isinstance(t, dict) and "matrix" in t:
                named = [str(t["name"])] if t.get("name") is not None else []
                tables.append((f"cam_{key}", named + [f"cam_{key}", f"cam{key}"], t))
    for key, t in data.items():
        if key != "cameras" and isinstance(t, dict) and "matrix" in t:
            names = ([str(t["name"])] if t.get("name") is not None else []) + [key]
            tables.append((key, names, t))
    out = {}
    for key, names, t in tables:
        where = f"{path}: [{key}]"
        if t.get("ignore") is True:
            log.info("%s: marked ignore = true, skipped", where)
            continue
        if t.get("fisheye") is True:
            raise InputError(f"{where}: fisheye cameras are not supported")
        missing = [k for k in ("matrix", "rotation", "translation") if k not in t]
        if missing:
            raise InputError(f"{where}: missing {missing} (has {sorted(t)})")
        try:
            rot = np.asarray(t["rotation"], dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError(f"{where}: rotation is not numeric") from None
        if rot.shape == (3,) or rot.shape == (3, 1) or rot.shape == (1, 3):
            if not np.all(np.isfinite(rot)):
                raise InputError(f"{where}: rotation has NaN or inf values")
            R = cv2.Rodrigues(rot.reshape(3, 1))[0]  # anipose / Pose2Sim: Rodrigues vector
        elif rot.shape == (3, 3):
            R = rot  # caliscope: matrix
        else:
            raise InputError(f"{where}: rotation must be a 3x3 matrix or a Rodrigues 3-vector, "
                             f"got shape {rot.shape}")
        try:
            tvec = np.asarray(t["translation"], dtype=np.float64).reshape(3)
        except (TypeError, ValueError):
            raise InputError(f"{where}: translation must be 3 numbers, got {t['translation']!r}") from None
        cal = _make(where, t["matrix"], t.get("distortions"), _rt(R, tvec), t.get("size"))
        out[key] = (names, cal)
    if not out:
        raise InputError(f"{path}: no camera tables (with 'matrix') found")
    meta = data.get("metadata")
    if isinstance(meta, dict) and "charuco_square_size" in meta:  # FreeMoCap: millimetres
        out = {k: (n, replace(c, cam_from_world=_scaled(c.cam_from_world, 1e-3)))
               for k, (n, c) in out.items()}
    return out


def _scaled(T: np.ndarray, s: float) -> np.ndarray:
    T = T.copy()
    T[..., :3, 3] *= s
    return T


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


def _load_colmap(path: Path, video_names: list[str]) -> dict[str, tuple[list[str], CameraCalibration]]:
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
        cal = _make(where, K, dist, poses[0], (cam.width, cam.height))
        out[key] = ([key, Path(ims[0].name).stem], cal)
    return out


def read_calibration_file(path) -> dict[str, tuple[list[str], CameraCalibration]]:
    """All cameras of a calibration file/folder: key -> (names it is known by, calibration).
    The format is told by the path (io/calib: COLMAP or EasyMocap folder, .json, .toml,
    .qca.txt, .xcp, intri.yml/extri.yml); pickles are refused unread."""
    from .calib import read
    return read(path)


def load_calibration(path, video_names: list[str],
                     video_sizes: dict[str, tuple[int, int]] | None = None
                     ) -> dict[str, CameraCalibration]:
    """One calibration per video name (see the module docstring for formats and matching).

    With ``video_sizes`` ({name: (width, height)}) each calibration is fitted to its video:
    K scaled when the video is a uniformly scaled version of the calibrated size, InputError
    ("calibration for other cameras") when the sizes don't agree.
    """
    cams = read_calibration_file(path)
    mapping = match_names({k: names for k, (names, _) in cams.items()}, list(video_names), path)
    out = {v: cams[k][1] for v, k in mapping.items()}
    if video_sizes:
        out = {v: fit_to_video(c, *video_sizes[v], name=f"{path}: {v}") if v in video_sizes else c
               for v, c in out.items()}
    return out


CROP_MAX_FRACTION = 0.02  # a video this much smaller than its calibration (per side) is a crop
ENCODER_BLOCK_PX = 16  # codecs pad sides to multiples of this and crop the padding at right/bottom


def fit_to_video(cal: CameraCalibration, width: int, height: int, name: str = "camera",
                 warn: bool = True) -> CameraCalibration:
    """The calibration at a video's resolution: unchanged; K scaled for a uniformly resized or
    integer-binned video (pixel centres kept: c' = (c + 0.5) s - 0.5); the principal point
    shifted for a crop of at most CROP_MAX_FRACTION of a side. Both with one warning saying
    what was assumed (warn=False: logged at debug level, for a second fit of the same video).
    Other sizes are an InputError."""
    if cal.size is None or cal.size == (width, height):
        return cal if cal.size is not None else replace(cal, size=(int(width), int(height)))
    cw, ch = cal.size
    dw, dh = cw - width, ch - height
    if 0 <= dw <= CROP_MAX_FRACTION * cw and 0 <= dh <= CROP_MAX_FRACTION * ch:
        return _cropped(cal, width, height, name, warn)
    sx, sy = width / cw, height / ch
    if abs(sx - sy) > 2.0 / min(cw, ch) * max(sx, sy):
        raise InputError(
            f"{name}: video is {width}x{height} but the calibration was made at {cw}x{ch}, "
            f"neither a crop of at most {CROP_MAX_FRACTION:.0%} of a side nor a uniform scale: "
            f"calibration for other cameras?"
        )
    K = cal.K.copy()
    K[0, 0] *= sx
    K[0, 1] *= sx
    K[1, 1] *= sy
    K[0, 2] = (K[0, 2] + 0.5) * sx - 0.5
    K[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
    binned = round(1 / sx) if sx < 1 and abs(cw / width - round(cw / width)) < 1e-9 \
        and abs(ch / height - round(ch / height)) < 1e-9 else None
    how = f"binned by {binned}" if binned else f"resized by {sx:.4g}"
    (log.warning if warn else log.debug)("%s: video %dx%d, calibration %dx%d: assumed the video is %s (focal lengths and "
                "principal point scaled)", name, width, height, cw, ch, how)
    return replace(cal, K=K, size=(int(width), int(height)))


def _cropped(cal: CameraCalibration, width: int, height: int, name: str, warn: bool = True
             ) -> CameraCalibration:
    """K of a video cropped from the calibrated size: a few rows/columns removed. An encoder's
    padding (side a multiple of ENCODER_BLOCK_PX, less than a block removed) is cut at the right
    and bottom (principal point kept); any other crop is taken as centred (shifted by half)."""
    cw, ch = cal.size
    shift, where = [], []
    for side, d, full in (("columns", cw - width, cw), ("rows", ch - height, ch)):
        if d == 0:
            shift.append(0.0)
        elif full % ENCODER_BLOCK_PX == 0 and d < ENCODER_BLOCK_PX:
            shift.append(0.0)
            where.append(f"{d} {side} cut at the {'right' if side == 'columns' else 'bottom'} "
                         f"(encoder padding; principal point kept)")
        else:
            shift.append(d / 2)
            where.append(f"{d} {side} cut evenly from both sides (principal point moved by "
                         f"{d / 2:g} px)")
    K = cal.K.copy()
    K[0, 2] -= shift[0]
    K[1, 2] -= shift[1]
    (log.warning if warn else log.debug)("%s: video %dx%d, calibration %dx%d: assumed a crop, %s",
                                         name, width, height, cw, ch, "; ".join(where))
    return replace(cal, K=K, size=(int(width), int(height)))


# ---- using a calibration ---------------------------------------------------------------------


UNDISTORT_ITERATIONS = 500  # strong barrel distortion converges slowly near the corners
UNDISTORT_CHECK_PX = 0.05  # re-distorted point must land this close to the input, else NaN


def undistort_points(cal: CameraCalibration, xy: np.ndarray) -> np.ndarray:
    """(...,2) distorted px -> undistorted px with the same K; NaN stays NaN.

    OpenCV's iterative inversion is run to convergence (its default 5 iterations leave errors
    of tenths of a pixel at the corners of a wide-angle webcam). Points where the lens model
    cannot be inverted (outside its valid region, the re-distorted point misses the input by
    more than UNDISTORT_CHECK_PX) become NaN.
    """
    xy = np.asarray(xy, dtype=np.float64)
    if xy.shape[-1:] != (2,):
        raise ValueError(f"xy must have shape (...,2), got {xy.shape}")
    if not np.any(cal.dist != 0):
        return xy.copy()
    out = np.full_like(xy, np.nan)
    flat = xy.reshape(-1, 2)
    ok = np.all(np.isfinite(flat), axis=1)
    if ok.any():
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, UNDISTORT_ITERATIONS, 1e-10)
        und = cv2.undistortPoints(flat[ok].reshape(-1, 1, 2), cal.K, cal.dist, R=np.eye(3),
                                  P=cal.K, criteria=crit).reshape(-1, 2)
        Kinv = np.linalg.inv(cal.K)
        rays = np.c_[und, np.ones(len(und))] @ Kinv.T
        back = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), cal.K, cal.dist)[0].reshape(-1, 2)
        miss = np.linalg.norm(back - flat[ok], axis=1) > UNDISTORT_CHECK_PX
        if miss.any():
            log.debug("undistort_points: %d of %d points outside the lens model's valid region",
                      int(miss.sum()), len(miss))
            und[miss] = np.nan
        out.reshape(-1, 2)[ok] = und
    return out


def to_camera_track(cal: CameraCalibration) -> CameraTrack:
    """The static CameraTrack of a calibration (tracks must be undistorted with it first)."""
    return CameraTrack(K=cal.K.copy(), cam_from_world=cal.cam_from_world.copy())


def rig_to_json(rig) -> dict:
    """The simple calibration JSON (io/calibration.py) plus how each camera was placed."""
    cams = {n: {"K": c.K.tolist(), "dist": c.dist.tolist(), "cam_from_world": c.cam_from_world.tolist(),
                "size": list(c.size)} for n, c in rig.cameras.items()}
    board = {n: {"views": rig.intrinsics[n].views, "rms_px": round(rig.intrinsics[n].rms_px, 4)}
             for n in rig.intrinsics}
    for n, (a, rp) in rig.links.items():
        board[n].update(placed_from=a, coarse_offset_s=round(rp.offset_s, 4),
                        median_reprojection_px=round(rp.median_px, 3), pairings=rp.pairings,
                        inliers=rp.inliers)
    return {"cameras": cams, "board": board, "unregistered": dict(rig.unregistered),
            "world": "the frame of the first placed camera, metres"}
