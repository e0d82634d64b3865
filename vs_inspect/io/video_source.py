"""Opening a video: a file through PyAV (its frames' presentation timestamps) or a folder of
images, probed once into a VideoSource that carries its clock.

Frame k of a video is the k-th frame in presentation order; its local time is
``info.timestamps_s[k]``, taken from the container's presentation timestamps (PTS) and shifted so
that frame 0 is at 0.0. Variable-frame-rate video (phones) keeps its real frame times.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from ..errors import BadVideoName, InputError
from ..types import VideoInfo

log = logging.getLogger(__name__)

VIDEO_SUFFIXES = (".mp4", ".mov", ".avi", ".mkv", ".webm", ".m4v")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
CONSTANT_RATE_TOLERANCE = 0.05  # relative spread of frame spacing still called constant-rate

_AV_ERRORS = (av.FFmpegError, OSError, ValueError, EOFError, IndexError)


@dataclass(frozen=True)
class VideoSource:
    """An opened (probed) video: where it is and its clock."""

    path: Path  # a video file (mp4, mov, avi, mkv, webm) or a folder of images
    info: VideoInfo  # name = file stem (folder name for image folders); timestamps_s from the PTS
    # internal: PTS (stream time_base units) of frame k in presentation order, or None when the
    # frames are numbered by decode order (no usable PTS) or for image folders
    _pts: tuple[int, ...] | None = None
    _images: tuple[Path, ...] | None = None  # sorted image files of an image folder
    _keyframes: tuple[int, ...] | None = None  # frame indices of keyframes (seek targets)

    @property
    def is_image_folder(self) -> bool:
        return self._images is not None


# ---- opening ------------------------------------------------------------------------------


def _natural_key(p: Path):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", p.name)]


def _open_image_folder(path: Path, fps: float | None, name: str | None) -> VideoSource:
    images = sorted(
        (p for p in path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES),
        key=_natural_key,
    )
    if not images:
        raise InputError(f"{path}: folder has no images ({', '.join(IMAGE_SUFFIXES)})")
    if fps is None:
        raise InputError(f"{path}: a folder of images has no clock; give its frame rate (--fps)")
    if not (np.isfinite(fps) and fps > 0):
        raise InputError(f"{path}: fps must be positive, got {fps}")
    first = cv2.imread(str(images[0]), cv2.IMREAD_COLOR)
    if first is None:
        raise InputError(f"{images[0]}: not a readable image")
    h, w = first.shape[:2]
    info = VideoInfo.constant_rate(name or path.name, w, h, len(images), float(fps))
    return VideoSource(path, info, None, tuple(images))


def _nominal_rate(stream) -> float | None:
    for attr in ("average_rate", "guessed_rate", "base_rate"):
        try:
            r = getattr(stream, attr)
        except Exception:  # noqa: BLE001 - attribute may be unavailable for some demuxers
            r = None
        if r:
            return float(r)
    return None


def _decode_all(path: Path) -> tuple[list[int | None], int, int]:
    """Decode every frame; return (frame pts in output order, width, height)."""
    pts: list[int | None] = []
    width = height = 0
    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            stream.thread_type = "AUTO"
            for frame in container.decode(stream):
                pts.append(frame.pts)
                width, height = frame.width, frame.height
    except _AV_ERRORS as exc:
        raise InputError(f"{path}: corrupt or truncated video stream ({exc})") from None
    return pts, width, height



@dataclass(frozen=True)
class _Probe:
    """What demuxing a video file's packets (and decoding its first frame) tells."""

    time_base: Fraction | None  # the stream's PTS unit, seconds
    declared: int  # frames the container declares (0: unknown)
    stream_duration: int | None  # in time_base units
    container_duration_s: float | None
    rate: float | None  # the stream's nominal frame rate, frames per second
    pkt_pts: list[int | None]  # PTS of each frame's packet, in decode order
    key_pts: set[int]  # PTS of the keyframes' packets
    width: int  # px
    height: int  # px


def open_video(path, fps: float | None = None, name: str | None = None) -> VideoSource:
    """Probe a video file or image folder once and return its clock.

    Files: the packets are demuxed (no decoding) to read each frame's PTS; the first frame is
    decoded to check the stream; the whole stream is decoded only when the packets don't give a
    reliable frame count (missing PTS, or fewer packets than the container declares). ``fps``
    overrides nothing for files with timestamps; it is required for image folders and is used
    for files whose timestamps are unusable.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    from .names import check_video_name
    problem = check_video_name(name or (path.name if path.is_dir() else path.stem))
    if problem:
        raise BadVideoName(f"{path}: the video's name (its file name) {problem}; rename it")
    if path.is_dir():
        return _open_image_folder(path, fps, name)
    vname = name or path.stem
    probe = _probe_packets(path)
    pts_list, width, height = _frame_pts(path, probe)
    n = len(pts_list)
    time_base = probe.time_base
    have_pts = all(p is not None for p in pts_list) and time_base is not None
    ts, info_fps = _local_times(path, pts_list, have_pts, time_base, probe.rate, fps)
    if have_pts and n > 1:
        _check_span(path, pts_list, ts, time_base, probe.stream_duration, probe.container_duration_s)
    try:
        info = VideoInfo(vname, int(width), int(height), n, ts, info_fps)
    except ValueError as exc:
        raise InputError(f"{path}: {exc}") from None
    keyframes = None
    if have_pts and probe.key_pts:
        keyframes = tuple(k for k, p in enumerate(pts_list) if p in probe.key_pts)
    return VideoSource(path, info, tuple(int(p) for p in pts_list) if have_pts else None, None,
                       keyframes)


def _probe_packets(path: Path) -> _Probe:
    """Demux every packet of the video stream (decoding only the first frame)."""
    try:
        container = av.open(str(path))
    except _AV_ERRORS as exc:
        raise InputError(f"{path}: not a readable video ({exc})") from None
    with container:
        if not container.streams.video:
            raise InputError(f"{path}: has no video stream")
        stream = container.streams.video[0]
        time_base = stream.time_base
        declared = int(stream.frames or 0)
        stream_duration = stream.duration  # in time_base units, or None
        container_duration_s = container.duration / 1e6 if container.duration else None
        rate = _nominal_rate(stream)
        pkt_pts: list[int | None] = []
        key_pts: set[int] = set()
        first_frame = None
        try:
            for packet in container.demux(stream):
                if packet.size == 0 or packet.is_discard:
                    # flush packets (size 0) and samples an edit list hides are not frames
                    if packet.size and first_frame is None:
                        packet.decode()  # still feeds the decoder's references
                    continue
                if packet.is_corrupt:
                    raise InputError(
                        f"{path}: truncated or corrupt video stream (bad packet at byte {packet.pos})"
                    )
                pkt_pts.append(packet.pts)
                if packet.is_keyframe and packet.pts is not None:
                    key_pts.add(packet.pts)
                if first_frame is None:
                    frames = packet.decode()
                    if frames:
                        first_frame = frames[0]
        except _AV_ERRORS as exc:
            raise InputError(f"{path}: corrupt or truncated video stream ({exc})") from None
        if first_frame is None and pkt_pts:
            try:
                frames = stream.codec_context.decode(None)
                first_frame = frames[0] if frames else None
            except _AV_ERRORS:
                first_frame = None
        width = stream.codec_context.width or (first_frame.width if first_frame else 0)
        height = stream.codec_context.height or (first_frame.height if first_frame else 0)
    if not pkt_pts:
        raise InputError(f"{path}: video has zero frames")
    if first_frame is None:
        raise InputError(f"{path}: no frame could be decoded (corrupt or unsupported stream)")
    if first_frame is not None:
        width, height = first_frame.width, first_frame.height
        rotation = getattr(first_frame, "rotation", 0) or 0
        if rotation:
            log.warning("%s: the file asks players to rotate frames by %d°; vs_inspect works on "
                        "the frames as stored (%dx%d), calibrations must match that orientation",
                        path, rotation, width, height)
    return _Probe(time_base, declared, stream_duration, container_duration_s, rate, pkt_pts, key_pts,
                  width, height)


def _frame_pts(path: Path, probe: _Probe) -> tuple[list[int | None], int, int]:
    """(each frame's PTS in presentation order, width, height): the packets' when they are
    reliable, else the decoded frames'."""
    pkt_pts, declared, width, height = probe.pkt_pts, probe.declared, probe.width, probe.height
    reliable = (
        all(p is not None for p in pkt_pts)
        and len(set(pkt_pts)) == len(pkt_pts)
        and (declared == 0 or declared == len(pkt_pts))
    )
    pts_list: list[int | None] = sorted(pkt_pts) if reliable else []
    if not reliable:
        log.info("%s: packet timestamps not reliable (declared %d frames, %d packets); decoding fully",
                 path, declared, len(pkt_pts))
        pts_list, width, height = _decode_all(path)
        if not pts_list:
            raise InputError(f"{path}: video has zero decodable frames")
        if declared and len(pts_list) < declared:
            raise InputError(
                f"{path}: truncated video: the container declares {declared} frames, "
                f"only {len(pts_list)} decode"
            )
    if width <= 0 or height <= 0:
        raise InputError(f"{path}: video has no valid frame size ({width}x{height})")
    return pts_list, width, height


def _local_times(path: Path, pts_list: list[int | None], have_pts: bool, time_base: Fraction | None,
                 rate: float | None, fps: float | None) -> tuple[np.ndarray, float | None]:
    """(each frame's local time in seconds, the frame rate when constant, else None): from the
    PTS when they increase, else k / fps (the given fps, else the nominal rate)."""
    n = len(pts_list)
    ts = None
    if have_pts:
        ts = np.asarray([float(p * time_base) for p in pts_list], dtype=np.float64)
        ts = ts - ts[0]
        if n > 1 and not np.all(np.diff(ts) > 0):
            ts = None
    info_fps: float | None = None
    if ts is not None:
        if n > 1:
            d = np.diff(ts)
            med = float(np.median(d))
            if np.max(np.abs(d - med)) <= CONSTANT_RATE_TOLERANCE * med:
                info_fps = 1.0 / med
                if rate and abs(rate * med - 1.0) < 0.01:
                    info_fps = rate
        else:
            info_fps = rate or fps
    else:
        use = fps or rate
        if not use:
            raise InputError(f"{path}: frames have no usable timestamps and no frame rate; give --fps")
        log.warning("%s: frames have no usable timestamps; using k / %.4g fps", path, use)
        ts = np.arange(n) / float(use)
        info_fps = float(use)
    return ts, info_fps


def _check_span(path: Path, pts_list: list[int], ts: np.ndarray, time_base: Fraction,
                stream_duration: int | None, container_duration_s: float | None) -> None:
    """InputError when the frames cover less than 90% of the duration the stream declares (a
    warning when only the container declares one)."""
    span_s = float((pts_list[-1] - pts_list[0]) * time_base) + float(np.median(np.diff(ts)))
    if stream_duration and time_base is not None:
        declared_s = float(stream_duration * time_base)
        if span_s < 0.9 * declared_s - 1e-3:
            raise InputError(
                f"{path}: truncated video: the stream declares {declared_s:.2f} s, "
                f"frames cover only {span_s:.2f} s"
            )
    elif container_duration_s and span_s < 0.9 * container_duration_s - 0.5:
        log.warning("%s: frames cover %.2f s of the file's %.2f s: truncated?",
                    path, span_s, container_duration_s)
