"""EasyMocap calibration: ``intri.yml`` and ``extri.yml`` (OpenCV FileStorage YAML), side by side.

``names``: the camera names. ``intri.yml``: ``K_<name>`` (3x3, px) and ``dist_<name>`` (1x5,
OpenCV k1 k2 p1 p2 k3); optional ``H_<name>``/``W_<name>`` image size. ``extri.yml``: ``R_<name>``
(Rodrigues vector) or ``Rot_<name>`` (3x3) and ``T_<name>`` (3x1), world -> camera, in the unit
of the calibration board (metres in EasyMocap's examples). Either file, or the folder holding
both, can be given. Without a stored image size the size is left unknown (no size check).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np  # noqa: I001
import cv2

from ...errors import InputError
from .. import atomic
from .camera import make_camera, rt_matrix

INTRI, EXTRI = "intri.yml", "extri.yml"


def pair_paths(path: Path) -> tuple[Path, Path]:
    folder = path if path.is_dir() else path.parent
    stem = "" if path.is_dir() else path.name[: -len(INTRI)] if path.name.endswith(INTRI) else \
        path.name[: -len(EXTRI)] if path.name.endswith(EXTRI) else ""
    intri, extri = folder / f"{stem}{INTRI}", folder / f"{stem}{EXTRI}"
    missing = [p.name for p in (intri, extri) if not p.is_file()]
    if missing:
        raise InputError(f"{path}: an EasyMocap calibration needs {intri.name} and {extri.name} "
                         f"side by side; missing {missing} in {folder}")
    return intri, extri


def _open(path: Path):
    text = path.read_bytes()[:64]
    if not text.lstrip().startswith(b"%YAML"):
        raise InputError(f"{path}: not an OpenCV FileStorage YAML file (no %YAML header)")
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except cv2.error as exc:
        raise InputError(f"{path}: OpenCV cannot read it ({str(exc).strip().splitlines()[-1]})") from None
    if not fs.isOpened():
        raise InputError(f"{path}: OpenCV cannot read it")
    return fs


def _names(fs, path: Path) -> list[str]:
    node = fs.getNode("names")
    if node.empty() or not node.isSeq():
        raise InputError(f"{path}: no 'names' list of cameras")
    return [node.at(i).string() or str(int(node.at(i).real())) for i in range(node.size())]


def _mat(fs, key: str, path: Path, required: bool = True):
    node = fs.getNode(key)
    if node.empty():
        if required:
            raise InputError(f"{path}: no {key}")
        return None
    m = node.mat()
    if m is None:
        raise InputError(f"{path}: {key} is not an OpenCV matrix")
    return np.asarray(m, dtype=np.float64)


def read(path: Path):
    intri_p, extri_p = pair_paths(path)
    fi, fe = _open(intri_p), _open(extri_p)
    try:
        names = _names(fi, intri_p)
        out = {}
        for n in names:
            where = f"{intri_p.parent}: camera {n!r}"
            K = _mat(fi, f"K_{n}", intri_p)
            dist = _mat(fi, f"dist_{n}", intri_p, required=False)
            rot = _mat(fe, f"Rot_{n}", extri_p, required=False)
            if rot is None:
                rvec = _mat(fe, f"R_{n}", extri_p).reshape(-1)
                if rvec.size != 3:
                    raise InputError(f"{extri_p}: R_{n} must be a Rodrigues 3-vector")
                rot = cv2.Rodrigues(rvec.reshape(3, 1))[0]
            T = _mat(fe, f"T_{n}", extri_p).reshape(-1)
            H, W = fi.getNode(f"H_{n}"), fi.getNode(f"W_{n}")
            size = None if H.empty() or W.empty() else (int(W.real()), int(H.real()))
            dist = None if dist is None else dist.reshape(-1)
            out[n] = ([n], make_camera(where, K, dist, rt_matrix(rot, T), size))
        return out
    finally:
        fi.release()
        fe.release()


def write(cameras: dict, path: Path) -> list[Path]:
    """intri.yml and extri.yml in the folder `path` (created)."""
    path.mkdir(parents=True, exist_ok=True)
    written = []
    for fname, kind in ((INTRI, "intri"), (EXTRI, "extri")):
        with atomic.atomic_path(path / fname, suffix=".yml") as tmp:
            fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
            fs.startWriteStruct("names", cv2.FileNode_SEQ)
            for n in cameras:
                fs.write("", str(n))
            fs.endWriteStruct()
            for n, c in cameras.items():
                if kind == "intri":
                    fs.write(f"K_{n}", c.K)
                    fs.write(f"dist_{n}", np.r_[c.dist, np.zeros(5)][: max(5, c.dist.size)].reshape(1, -1))
                    fs.write(f"H_{n}", int(c.size[1]))
                    fs.write(f"W_{n}", int(c.size[0]))
                else:
                    R, t = c.cam_from_world[:3, :3], c.cam_from_world[:3, 3]
                    fs.write(f"R_{n}", cv2.Rodrigues(R)[0].reshape(3, 1))
                    fs.write(f"Rot_{n}", R)
                    fs.write(f"T_{n}", t.reshape(3, 1))
            fs.release()
        written.append(path / fname)
    return written
