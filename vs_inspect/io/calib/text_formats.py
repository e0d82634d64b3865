"""Writers of the text calibration formats: the simple JSON, the OpenCV-style TOML of Pose2Sim,
anipose, FreeMoCap and caliscope, and a COLMAP text model. Their readers are in io/calibration.py.

Numbers are written with Python's repr (shortest exact form), so a file read back gives the same
floating-point values.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np  # noqa: I001
import cv2


def _a(x) -> str:
    return json.dumps(np.asarray(x, dtype=np.float64).tolist())


def _dist(c, n: int = 5) -> list[float]:
    d = np.r_[c.dist, np.zeros(n)]
    n = max(n, c.dist.size if np.any(c.dist[n:] != 0) else n)
    return d[:n].tolist()


def write_json(cameras: dict, path: Path) -> list[Path]:
    from ..atomic import write_json_atomic
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
    from ..atomic import write_text_atomic
    text = _toml_tables(cameras, lambda i, n: n if _bare(n) else json.dumps(n), ("fisheye = false",),
                        dist_n=4)
    return [write_text_atomic(text + "[metadata]\nadjusted = false\nerror = 0.0\n", path)]


def write_anipose(cameras: dict, path: Path) -> list[Path]:
    """anipose's calibration.toml: [cam_<i>] tables with a name, Rodrigues rotation."""
    from ..atomic import write_text_atomic
    text = _toml_tables(cameras, lambda i, n: f"cam_{i}")
    return [write_text_atomic(text + "[metadata]\nadjusted = false\nerror = 0.0\n", path)]


def write_freemocap(cameras: dict, path: Path) -> list[Path]:
    """FreeMoCap's camera_calibration.toml: anipose's layout, translation in millimetres."""
    from ..atomic import write_text_atomic
    text = _toml_tables(cameras, lambda i, n: f"cam_{i}", unit=1000.0)
    return [write_text_atomic(text + "[metadata]\ncharuco_square_size = 1.0\n"
                                     "world_unit = \"mm\"\n", path)]


def write_caliscope(cameras: dict, path: Path) -> list[Path]:
    """caliscope's camera_array.toml: [cameras.<i>] tables, rotation as a 3x3 matrix."""
    from ..atomic import write_text_atomic
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
    from ..atomic import write_text_atomic
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
