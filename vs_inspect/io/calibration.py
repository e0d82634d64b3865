"""A calibration applied to a run's videos: cameras mapped to videos (by name, else by order),
each fitted to its video's image size (a uniform scale, a crop of a few rows or columns, an
integer binning), tracks undistorted, and the cameras a run used written to its folder. The file
formats themselves are read and written in io/calib. Every problem is an InputError that says
what was found and what was expected.
"""

from __future__ import annotations

import logging
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..geometry.camera_model import scale_intrinsics, shift_principal_point, undistort_opencv
from .atomic import write_json_atomic
from ..types import CameraCalibration, CameraTrack
from .calib import read

log = logging.getLogger(__name__)

# ---- validation -------------------------------------------------------------------------------


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


def read_calibration_file(path) -> dict[str, tuple[list[str], CameraCalibration]]:
    """All cameras of a calibration file/folder: key -> (names it is known by, calibration).
    The format is told by the path (io/calib: COLMAP or EasyMocap folder, .json, .toml,
    .qca.txt, .xcp, intri.yml/extri.yml); pickles are refused unread."""
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
    K = scale_intrinsics(cal.K, sx, sy)
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
    K = shift_principal_point(cal.K, shift[0], shift[1])
    (log.warning if warn else log.debug)("%s: video %dx%d, calibration %dx%d: assumed a crop, %s",
                                         name, width, height, cw, ch, "; ".join(where))
    return replace(cal, K=K, size=(int(width), int(height)))


# ---- using a calibration ---------------------------------------------------------------------


def undistort_points(cal: CameraCalibration, xy: np.ndarray) -> np.ndarray:
    """(...,2) distorted px -> undistorted px with the calibration's K and lens (NaN stays NaN;
    geometry.camera_model.undistort_opencv)."""
    return undistort_opencv(cal.K, cal.dist, xy)


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


RUN_CAMERAS = "cameras.json"  # the cameras a run used, in its folder


def run_cameras(bundle, calibration=None, video_names: list[str] | None = None) -> tuple[dict, str]:
    """({video: CameraCalibration}, where they came from) of a run: the given calibration fitted to
    each video's size (with its lens), else the bundle's cameras (estimated, or imported; tracks
    already undistorted). Pose-free videos (no pose) are left out. video_names: every input of
    the run, so that the calibration maps to the videos as it did in the run."""
    sizes = {v.name: (v.width, v.height) for v in bundle.videos}
    if calibration is not None:
        cals = load_calibration(calibration, list(video_names or sizes))
        out = {}
        for n, c in cals.items():
            if n in bundle.cameras and n in sizes:
                out[n] = fit_to_video(c, *sizes[n], name=n, warn=False)  # warned once by the run
        return out, f"the calibration {calibration}, fitted to each video's image size"
    out = {}
    for n, cam in bundle.cameras.items():
        if n in bundle.pose_free:
            continue
        K = cam.K if cam.K.ndim == 2 else cam.K[0]
        if cam.K.ndim == 3 and np.abs(cam.K - K).max() > 1e-9:
            continue  # a zooming camera: not one K for the file
        out[n] = CameraCalibration(K=K.copy(), dist=np.zeros(5), cam_from_world=cam.cam_from_world.copy(),
                                   size=sizes.get(n))
    return out, "the cameras the run used (estimated from the videos, or from the cue bundle)"


def write_run_cameras(folder, bundle, calibration=None, video_names: list[str] | None = None
                      ) -> Path | None:
    """FOLDER/cameras.json (vs-inspect's JSON, which 'calib convert' turns into other tools'
    formats): the cameras a run used. None when no video has a posed camera."""
    cams, source = run_cameras(bundle, calibration, video_names)
    if not cams:
        return None
    data = {"cameras": {n: {"K": c.K.tolist(), "dist": c.dist.tolist(),
                            "cam_from_world": c.cam_from_world.tolist(),
                            "size": list(c.size) if c.size else None} for n, c in cams.items()},
            "source": source,
            "convert": "vs-inspect calib convert cameras.json OUT (e.g. Calib.toml, calibration.toml --to anipose)"}
    return write_json_atomic(data, Path(folder) / RUN_CAMERAS)
