"""The calibration formats vs-inspect reads and writes: a registry of (reader, writer) per format.

``read(path)`` picks the reader from the path (folder, suffix, content); ``write(cameras, path,
fmt)`` writes one of the formats (``fmt`` None: from the suffix). Every reader returns
``{key: (names the camera is known by, CameraCalibration)}`` in OpenCV conventions (x right,
y down, z forward; K in pixels, pixel centres at integers; cam_from_world world -> camera) and,
where the file's unit is known, a world in metres.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ...errors import InputError
from . import colmap, easymocap, qualisys, text_formats, vicon


@dataclass(frozen=True)
class CalibrationFormat:
    name: str
    suffixes: tuple[str, ...]  # file endings it is recognized by ("" for a folder)
    read: Callable | None
    write: Callable | None  # (cameras, path) -> written files
    folder: bool = False  # written as a folder of files
    moving: bool = False  # can hold per-frame poses
    max_dist: int = 5  # distortion coefficients it stores
    summary: str = ""


FORMATS: dict[str, CalibrationFormat] = {f.name: f for f in (
    CalibrationFormat("json", (".json",), text_formats.read_json, text_formats.write_json, moving=True,
                      max_dist=14, summary="vs-inspect's JSON: K, dist, cam_from_world, size per camera"),
    CalibrationFormat("pose2sim", (".toml",), text_formats.read_toml, text_formats.write_pose2sim,
                      summary="Pose2Sim Calib.toml (metres)"),
    CalibrationFormat("anipose", (".toml",), text_formats.read_toml, text_formats.write_anipose,
                      summary="anipose calibration.toml"),
    CalibrationFormat("freemocap", (".toml",), text_formats.read_toml, text_formats.write_freemocap,
                      summary="FreeMoCap camera_calibration.toml (millimetres)"),
    CalibrationFormat("caliscope", (".toml",), text_formats.read_toml, text_formats.write_caliscope,
                      summary="caliscope camera_array.toml"),
    CalibrationFormat("qualisys", (".qca.txt", ".qca"), qualisys.read, qualisys.write,
                      summary="Qualisys QTM .qca.txt (millimetres)"),
    CalibrationFormat("vicon", (".xcp",), vicon.read, vicon.write, max_dist=8,
                      summary="Vicon .xcp (millimetres)"),
    CalibrationFormat("easymocap", ("intri.yml", "extri.yml"), easymocap.read,
                      easymocap.write, folder=True, summary="EasyMocap intri.yml + extri.yml folder"),
    CalibrationFormat("colmap", ("",), colmap.read_colmap, text_formats.write_colmap, folder=True,
                      max_dist=8, summary="COLMAP text model folder (cameras.txt, images.txt)"),
)}

_PICKLE = (".pickle", ".pkl", ".pck", ".npy", ".npz")


def _refuse_pickle(path: Path) -> None:
    head = path.read_bytes()[:2] if path.is_file() else b""
    if path.suffix.lower() in _PICKLE or (len(head) == 2 and head[0] == 0x80 and head[1] <= 5):
        raise InputError(
            f"{path}: a Python pickle (or NumPy) file is never loaded: unpickling runs code from the "
            f"file. Convert it where you trust it, e.g. python -c \"import pickle, json; "
            f"d = pickle.load(open('{path.name}', 'rb')); ...\" writing "
            f"{{\"<video>\": {{\"K\": 3x3, \"dist\": [...], \"cam_from_world\": 4x4, \"size\": [w, h]}}}} "
            f"to a .json file, or export a .toml from the tool that made it")


def detect(path: Path) -> str:
    """The format name of an existing calibration file or folder (InputError if none)."""
    if not path.exists():
        raise InputError(f"{path}: no such calibration file or folder")
    if path.is_dir():
        has = {p.name for p in path.iterdir()}
        if {"cameras.txt", "images.txt"} <= has or {"cameras.bin", "images.bin"} <= has:
            return "colmap"
        if any(n.endswith(easymocap.INTRI) for n in has) and any(n.endswith(easymocap.EXTRI) for n in has):
            return "easymocap"
        raise InputError(f"{path}: a folder must be a COLMAP model (cameras.txt/images.txt or "
                         f".bin) or an EasyMocap calibration (intri.yml and extri.yml)")
    _refuse_pickle(path)
    name = path.name.lower()
    for f in FORMATS.values():
        if f.name in ("anipose", "freemocap", "caliscope", "colmap"):
            continue  # .toml is read by one reader for all of them
        if any(s and name.endswith(s) for s in f.suffixes):
            return f.name
    known = sorted({s for f in FORMATS.values() for s in f.suffixes if s.startswith(".")})
    raise InputError(f"{path}: unknown calibration format (known: a COLMAP or EasyMocap folder, "
                     f"{', '.join(known)})")


def read(path) -> dict:
    """{key: (names, CameraCalibration)} of a calibration file or folder."""
    path = Path(path)
    return FORMATS[detect(path)].read(path)


def read_named(path) -> dict:
    """{camera name: CameraCalibration}: each camera under the first name its file gives it."""
    cams = read(path)
    firsts = [names[0] if names else k for k, (names, _) in cams.items()]
    if len(set(firsts)) < len(firsts):
        return {k: c for k, (_, c) in cams.items()}
    return {n: c for n, (_, c) in zip(firsts, cams.values())}


def format_for_output(path: Path, fmt: str | None) -> CalibrationFormat:
    if fmt is not None:
        if fmt not in FORMATS:
            raise InputError(f"--to {fmt}: unknown format; one of {sorted(FORMATS)}")
        return FORMATS[fmt]
    name = path.name.lower()
    for f in FORMATS.values():
        if any(s.startswith(".") and name.endswith(s) for s in f.suffixes):
            return f
    raise InputError(f"{path}: cannot tell the format from the name; give --to "
                     f"({', '.join(sorted(FORMATS))})")


def write(cameras: dict, path, fmt: str | None = None) -> list[Path]:
    """Write {name: CameraCalibration} (sizes known) in a format; the files written."""
    path = Path(path)
    f = format_for_output(path, fmt)
    for n, c in cameras.items():
        if c.size is None:
            raise InputError(f"camera {n!r}: its image size is unknown; {f.name} files store it "
                             f"(give it with --size WIDTH HEIGHT)")
        if c.cam_from_world.ndim == 3 and not f.moving:
            raise InputError(f"camera {n!r} has one pose per frame (a moving camera); only the "
                             f"json format holds those")
        if np.any(c.dist[f.max_dist:] != 0):
            raise InputError(f"camera {n!r} has {c.dist.size} distortion coefficients; the "
                             f"{f.name} format stores {f.max_dist}")
    return f.write(cameras, path)
