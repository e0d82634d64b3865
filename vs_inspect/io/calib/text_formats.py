"""The text calibration formats: the simple JSON and the OpenCV-style TOML of Pose2Sim, anipose,
FreeMoCap and caliscope (read and written), and a COLMAP text model (written; read in colmap.py).

Numbers are written with Python's repr (shortest exact form), so a file read back gives the same
floating-point values.
"""

from __future__ import annotations

import json
import logging
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np  # noqa: I001
import cv2

from ...errors import InputError
from ..atomic import write_json_atomic, write_text_atomic
from ...types import CameraCalibration
from .camera import make_camera, rt_matrix, scaled_translation

log = logging.getLogger(__name__)


def _a(x) -> str:
    return json.dumps(np.asarray(x, dtype=np.float64).tolist())


def _dist(c, n: int = 5) -> list[float]:
    d = np.r_[c.dist, np.zeros(n)]
    n = max(n, c.dist.size if np.any(c.dist[n:] != 0) else n)
    return d[:n].tolist()


def write_json(cameras: dict, path: Path) -> list[Path]:
    data = {"cameras": {n: {"K": c.K.tolist(), "dist": c.dist.tolist(),
                            "cam_from_world": c.cam_from_world.tolist(),
                            "size": list(c.size) if c.size else None}
                        for n, c in cameras.items()}}
    return [write_json_atomic(data, path)]


def _toml_tables(cameras: dict, key, extra=(), rotation="rodrigues", unit=1.0, dist_n=5) -> str:
    lines = []
    for i, (n, c) in enumerate(cameras.items()):
        R, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3] * unit
        rot = cv2.Rodrigues(R)[0].ravel() if rotation == "rodrigues" else R
        lines += [f"[{key(i, n)}]", f"name = {json.dumps(str(n))}", f"size = {json.dumps(list(c.size))}",
                  f"matrix = {_a(c.K)}", f"distortions = {json.dumps(_dist(c, dist_n))}",
                  f"rotation = {_a(rot)}", f"translation = {_a(t)}", *extra, ""]
    return "\n".join(lines)


def write_pose2sim(cameras: dict, path: Path) -> list[Path]:
    """Pose2Sim's Calib*.toml: [<name>] tables, Rodrigues rotation, metres."""
    text = _toml_tables(cameras, lambda i, n: n if _bare(n) else json.dumps(n), ("fisheye = false",),
                        dist_n=4)
    return [write_text_atomic(text + "[metadata]\nadjusted = false\nerror = 0.0\n", path)]


def write_anipose(cameras: dict, path: Path) -> list[Path]:
    """anipose's calibration.toml: [cam_<i>] tables with a name, Rodrigues rotation."""
    text = _toml_tables(cameras, lambda i, n: f"cam_{i}")
    return [write_text_atomic(text + "[metadata]\nadjusted = false\nerror = 0.0\n", path)]


def write_freemocap(cameras: dict, path: Path) -> list[Path]:
    """FreeMoCap's camera_calibration.toml: anipose's layout, translation in millimetres."""
    text = _toml_tables(cameras, lambda i, n: f"cam_{i}", unit=1000.0)
    return [write_text_atomic(text + "[metadata]\ncharuco_square_size = 1.0\n"
                                     "world_unit = \"mm\"\n", path)]


def write_caliscope(cameras: dict, path: Path) -> list[Path]:
    """caliscope's camera_array.toml: [cameras.<i>] tables, rotation as a 3x3 matrix."""
    lines = []
    for i, (n, c) in enumerate(cameras.items()):
        lines += [f"[cameras.{i}]", f"cam_id = {i}", f"name = {json.dumps(str(n))}",
                  "rotation_count = 0", "ignore = false", f"size = {json.dumps(list(c.size))}",
                  f"matrix = {_a(c.K)}", f"distortions = {json.dumps(_dist(c))}",
                  f"translation = {_a(c.cam_from_world[:3, 3])}",
                  f"rotation = {_a(c.cam_from_world[:3, :3])}", ""]
    return [write_text_atomic("\n".join(lines), path)]


def _bare(name: str) -> bool:
    return bool(name) and all(ch.isalnum() or ch in "_-" for ch in name)


def write_colmap(cameras: dict, path: Path) -> list[Path]:
    """A COLMAP text model in the folder `path`: one OPENCV (or FULL_OPENCV) camera and one image
    named <video>.jpg per camera (COLMAP puts pixel centres at +0.5)."""
    from scipy.spatial.transform import Rotation
    path.mkdir(parents=True, exist_ok=True)
    cams, ims = ["# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]"], ["# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME"]
    for i, (n, c) in enumerate(cameras.items(), start=1):
        K, d = c.K, np.r_[c.dist, np.zeros(12)]
        base = [K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5]
        if np.any(d[4:] != 0):
            model, params = "FULL_OPENCV", base + list(d[:8])
        else:
            model, params = "OPENCV", base + list(d[:4])
        cams.append(" ".join([str(i), model, str(c.size[0]), str(c.size[1])] + [repr(float(p)) for p in params]))
        R, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3]
        x, y, z, w = Rotation.from_matrix(R).as_quat()
        ims.append(" ".join([str(i)] + [repr(float(v)) for v in (w, x, y, z, *t)] + [str(i), f"{n}.jpg"]))
        ims.append("")
    return [write_text_atomic("\n".join(cams) + "\n", path / "cameras.txt"),
            write_text_atomic("\n".join(ims) + "\n", path / "images.txt"),
            write_text_atomic("# 3D point list (empty)\n", path / "points3D.txt")]


# ---- readers ----------------------------------------------------------------------------------


def read_json(path: Path) -> dict[str, tuple[list[str], CameraCalibration]]:
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
        cal = make_camera(where, entry["K"], entry.get("dist"), entry["cam_from_world"], entry.get("size"))
        out[name] = ([name], cal)
    return out


def read_toml(path: Path) -> dict[str, tuple[list[str], CameraCalibration]]:
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
        cal = make_camera(where, t["matrix"], t.get("distortions"), rt_matrix(R, tvec), t.get("size"))
        out[key] = (names, cal)
    if not out:
        raise InputError(f"{path}: no camera tables (with 'matrix') found")
    meta = data.get("metadata")
    if isinstance(meta, dict) and "charuco_square_size" in meta:  # FreeMoCap: millimetres
        out = {k: (n, replace(c, cam_from_world=scaled_translation(c.cam_from_world, 1e-3)))
               for k, (n, c) in out.items()}
    return out
