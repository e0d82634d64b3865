"""The multi-view drone tracking datasets (Li, Albl et al.) -> a pose-free cue bundle.

Folder layout read by :func:`import_drone`::

    DIR/cameras.txt                 one line per camera, "camK - model"; the order defines the ids
    DIR/detections/camK.txt         header line, then "frame x y" (frames 1-based, px, distorted);
                                    x = y = 0 where the drone was not detected
    DIR/calibration/camK.json       "K-matrix" (3,3), "distCoeff" [k1,k2,p1,p2[,k3]], "fps",
                                    "resolution" [w, h]
    DIR/README.md                   optional: the ground-truth alpha/beta tables (see parse_gt_tables)

There are no camera orientations, so every camera gets its K and an identity cam_from_world, and
bundle.json marks each such video ``"pose_free": true`` (an optional key: format v1 readers that
do not know it still read the bundle; stages that need poses must check :func:`read_pose_free`).
Each camera has one track, the drone, and every pair of cameras pairs track 0 with track 0.

Ground truth: the README says frame i of the reference camera corresponds to frame
j = alpha * i + beta of another. i and j are taken as the detection files' frame numbers
(1-based), as in the dataset's own reconstruction code.
"""

from __future__ import annotations

import json
import logging
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo
from .atomic import write_json_atomic
from .bundle import POSE_FREE_KEY, read_gt_drift, write_bundle

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class DroneCamera:
    """One camera of the dataset, as read (detections still distorted)."""

    name: str
    K: np.ndarray  # (3,3) px
    dist: np.ndarray  # (4,) or (5,) OpenCV k1 k2 p1 p2 [k3]
    fps: float  # nominal frames per second (the dataset's fixed-rate remapping)
    width: int  # px
    height: int  # px
    frames: np.ndarray  # (M,) int, 1-based frame numbers of the detection file rows
    xy_px: np.ndarray  # (M,2) float64 distorted px, NaN where not detected


@dataclass(frozen=True)
class DroneGT:
    """Ground truth per camera in the time model t_global = offset_s + (1 + drift) * t_local."""

    reference: str
    offsets_s: dict[str, float]  # global time of each camera's local time 0 (reference: 0)
    drift_ppm: dict[str, float]  # (1 + drift) - 1, in parts per million (reference: 0)
    alpha: dict[str, float]  # the README's row of the reference: frames of camera per reference frame
    beta: dict[str, float]  # frames
    row_inconsistency_frames: float  # largest disagreement of the README's other rows with row 0


def read_camera_names(folder: Path) -> list[str]:
    path = folder / "cameras.txt"
    if path.is_file():
        names = [ln.split("-")[0].strip() for ln in path.read_text().splitlines() if ln.strip()]
    else:
        names = sorted(p.stem for p in (folder / "detections").glob("cam*.txt"))
    if not names:
        raise InputError(f"{folder}: no cameras (needs cameras.txt or detections/camK.txt)")
    return names


def read_drone_camera(folder: Path, name: str) -> DroneCamera:
    cpath = folder / "calibration" / f"{name}.json"
    dpath = folder / "detections" / f"{name}.txt"
    for p in (cpath, dpath):
        if not p.is_file():
            raise InputError(f"{p}: missing file")
    try:
        calib = json.loads(cpath.read_text())
        K = np.asarray(calib["K-matrix"], dtype=np.float64)
        dist = np.asarray(calib["distCoeff"], dtype=np.float64)
        fps = float(calib["fps"])
        width, height = (int(v) for v in calib["resolution"])
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{cpath}: not a drone-dataset calibration ({exc})") from None
    if K.shape != (3, 3) or dist.shape not in ((4,), (5,)) or not (math.isfinite(fps) and fps > 0):
        raise InputError(f"{cpath}: K must be 3x3 (got {K.shape}), distCoeff 4 or 5 values "
                         f"(got {dist.shape}), fps positive (got {fps})")
    try:
        det = np.loadtxt(dpath, skiprows=1, ndmin=2)
    except ValueError as exc:
        raise InputError(f"{dpath}: not 'frame x y' rows ({exc})") from None
    if det.shape[1] != 3 or len(det) == 0:
        raise InputError(f"{dpath}: needs rows 'frame x y', got shape {det.shape}")
    frames = np.rint(det[:, 0]).astype(np.int64)
    if frames.min() < 1:
        raise InputError(f"{dpath}: frame numbers must be 1-based, got {frames.min()}")
    xy = det[:, 1:3].copy()
    xy[(xy[:, 0] == 0) & (xy[:, 1] == 0)] = np.nan  # the dataset writes 0 0 for "not detected"
    # A few files repeat a frame number (and skip another); keep one row per frame, a detected
    # one when there is one.
    order = np.lexsort((~np.isfinite(xy[:, 0]), frames))
    frames, xy = frames[order], xy[order]
    first = np.r_[True, np.diff(frames) > 0]
    if not first.all():
        log.warning("%s: %d repeated frame numbers, kept one row each", dpath, int((~first).sum()))
    frames, xy = frames[first], xy[first]
    return DroneCamera(name, K, dist, fps, width, height, frames, xy)


def undistort_px(cam: DroneCamera) -> np.ndarray:
    """(M,2) detections with the lens distortion removed, in the same K's pixels (NaN kept; points
    the lens model cannot invert become NaN)."""
    from ..types import CameraCalibration
    from .calibration import undistort_points

    return undistort_points(CameraCalibration(cam.K, cam.dist, np.eye(4), (cam.width, cam.height)),
                            cam.xy_px)


def camera_to_bundle_parts(cam: DroneCamera) -> tuple[VideoInfo, CameraTrack, Tracks]:
    num_frames = int(cam.frames[-1])
    xy = np.full((1, num_frames, 2), np.nan)
    xy[0, cam.frames - 1] = undistort_px(cam)
    video = VideoInfo.constant_rate(cam.name, cam.width, cam.height, num_frames, cam.fps)
    return video, CameraTrack(cam.K, np.eye(4)), Tracks(xy)


# ---- ground truth ------------------------------------------------------------------------------


def parse_gt_tables(readme_text: str) -> tuple[np.ndarray, np.ndarray]:
    """The README's alpha and beta tables -> two (C,C) arrays [reference row, other camera]."""
    tables = []
    for title in ("alpha", "beta"):
        m = re.search(rf"#[^\n]*\({title}\)(.*?)(?:\n###|\Z)", readme_text, flags=re.S)
        if m is None:
            raise InputError(f"README has no table titled ({title})")
        rows = []
        for line in m.group(1).splitlines():
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) > 1 and re.fullmatch(r"-?\d+", cells[0]):
                rows.append([float(c) for c in cells[1:] if c])
        arr = np.asarray(rows, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
            raise InputError(f"README table ({title}) is not square: {arr.shape}")
        tables.append(arr)
    return tables[0], tables[1]


def pair_time_model(alpha: float, beta: float, fps_ref: float, fps_other: float) -> tuple[float, float]:
    """(offset_s, drift) of the other camera, with the reference at offset 0 and drift 0.

    Frame numbers n are 1-based, so local time is (n - 1) / fps. Frame i of the reference
    (global time g = (i - 1) / fps_ref) is frame j = alpha * i + beta of the other camera, whose
    local time is then tau = (alpha * (i - 1) + alpha + beta - 1) / fps_other. Solving
    g = offset_s + (1 + drift) * tau for all i gives the two numbers below.
    """
    one_plus_drift = fps_other / (alpha * fps_ref)
    offset_s = -(alpha + beta - 1.0) / (alpha * fps_ref)
    return offset_s, one_plus_drift - 1.0


def gt_from_tables(names: list[str], fps: dict[str, float], alpha: np.ndarray, beta: np.ndarray,
                   reference: int = 0) -> DroneGT:
    """Ground truth from the reference's row; other rows are used only to check consistency."""
    C = len(names)
    if alpha.shape != (C, C) or beta.shape != (C, C):
        raise InputError(f"README tables are {alpha.shape}, expected ({C},{C}) for cameras {names}")
    ref = names[reference]
    offsets, drifts = {}, {}
    for k, n in enumerate(names):
        o, d = pair_time_model(alpha[reference, k], beta[reference, k], fps[ref], fps[n])
        offsets[n], drifts[n] = (0.0, 0.0) if k == reference else (o, d)
    # Each row r maps a frame of camera r to frame alpha*i + beta of camera c; compare with what
    # the reference row implies (through the per-camera time models) over a 10,000-frame span.
    worst = 0.0
    for r, nr in enumerate(names):
        for frame_r in (1.0, 5000.0, 10000.0):
            g = offsets[nr] + (1 + drifts[nr]) * (frame_r - 1) / fps[nr]
            for c, nc in enumerate(names):
                j_row0 = 1 + (g - offsets[nc]) / (1 + drifts[nc]) * fps[nc]
                j_row = alpha[r, c] * frame_r + beta[r, c]
                worst = max(worst, abs(j_row - j_row0))
    return DroneGT(ref, offsets, {n: d * 1e6 for n, d in drifts.items()},
                   {n: float(alpha[reference, k]) for k, n in enumerate(names)},
                   {n: float(beta[reference, k]) for k, n in enumerate(names)}, float(worst))


# ---- the whole dataset -------------------------------------------------------------------------


def import_drone(folder: str | os.PathLike) -> tuple[CueBundle, DroneGT | None]:
    """Read the dataset folder into a pose-free cue bundle (and its ground truth when known)."""
    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"{root}: not a folder")
    names = read_camera_names(root)
    cams = [read_drone_camera(root, n) for n in names]
    videos, cameras, tracks = [], {}, {}
    for cam in cams:
        v, c, t = camera_to_bundle_parts(cam)
        videos.append(v)
        cameras[cam.name] = c
        tracks[cam.name] = t
    one = np.zeros((1, 2), dtype=np.int64)
    pairs = {(a, b): TrackPairs(a, b, one) for i, a in enumerate(names) for b in names[i + 1:]}
    gt = None
    readme = root / "README.md"
    if readme.is_file() and "(alpha)" in readme.read_text():
        alpha, beta = parse_gt_tables(readme.read_text())
        gt = gt_from_tables(names, {c.name: c.fps for c in cams}, alpha, beta)
    bundle = CueBundle(tuple(videos), cameras, tracks, pairs, gt.offsets_s if gt else None,
                       frozenset(names), gt.drift_ppm if gt else None)
    return bundle, gt


def write_drone_bundle(bundle: CueBundle, gt: DroneGT | None, folder: str | os.PathLike,
                       overwrite: bool = False) -> Path:
    """write_bundle (which marks bundle.pose_free's videos in bundle.json), then gt.json with the
    dataset's alpha/beta beside offsets and drift."""
    dest = write_bundle(bundle, folder, overwrite=overwrite)
    if gt is not None:
        write_json_atomic(gt_to_dict(gt), dest / "gt.json")
    return dest


def gt_to_dict(gt: DroneGT) -> dict:
    return {"offsets_s": gt.offsets_s, "drift_ppm": gt.drift_ppm, "reference": gt.reference,
            "time_model": "t_global = offset_s + (1 + drift_ppm * 1e-6) * t_local",
            "source": {"alpha": gt.alpha, "beta": gt.beta,
                       "convention": "frame i (1-based) of the reference <-> frame alpha*i+beta",
                       "row_inconsistency_frames": gt.row_inconsistency_frames}}


def read_pose_free(folder: str | os.PathLike) -> set[str]:
    """Names of the bundle's videos marked pose_free in bundle.json (their cam_from_world is a
    placeholder, only K is known)."""
    meta = json.loads((Path(folder) / "bundle.json").read_text())
    return {e["name"] for e in meta.get("videos", []) if isinstance(e, dict) and e.get(POSE_FREE_KEY)}


def read_gt_drift_ppm(folder: str | os.PathLike) -> dict[str, float] | None:
    """gt.json's optional drift_ppm (None when absent)."""
    path = Path(folder) / "gt.json"
    return read_gt_drift(path) if path.is_file() else None
