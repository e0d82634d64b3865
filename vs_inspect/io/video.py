"""Video input and output: files through PyAV (per-frame timestamps), folders of images, H.264 writer.

Frame k of a video is the k-th frame in presentation order; its local time is
``info.timestamps_s[k]``, taken from the container's presentation timestamps (PTS) and shifted so
that frame 0 is at 0.0. Variable-frame-rate video (phones) keeps its real frame times.

Every problem a user can fix (missing file, not a video, zero frames, truncated or corrupt stream)
is raised as :class:`vs_inspect.errors.InputError` naming the file.
"""

from __future__ import annotations

import bisect
import logging
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from ..errors import BadVideoName, InputError
from ..types import VideoInfo
from .. import signals
from .atomic import atomic_path

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

    n = len(pts_list)
    have_pts = all(p is not None for p in pts_list) and time_base is not None
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
    if have_pts and n > 1:
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
    try:
        info = VideoInfo(vname, int(width), int(height), n, ts, info_fps)
    except ValueError as exc:
        raise InputError(f"{path}: {exc}") from None
    keyframes = None
    if have_pts and key_pts:
        keyframes = tuple(k for k, p in enumerate(pts_list) if p in key_pts)
    return VideoSource(path, info, tuple(int(p) for p in pts_list) if have_pts else None, None,
                       keyframes)


# ---- reading frames --------------------------------------------------------------------------


def _scaled_size(w: int, h: int, max_side: int | None) -> tuple[int, int] | None:
    if max_side is None or max(w, h) <= max_side:
        return None
    s = max_side / max(w, h)
    return max(1, round(w * s)), max(1, round(h * s))


def downscale(img: np.ndarray, max_side: int | None) -> np.ndarray:
    """img (H,W[,3]) downscaled (INTER_AREA) so that its longer side is at most max_side px, as
    iter_frames and read_frames return it (contiguous; unchanged when already small enough)."""
    return _finish(img, max_side)


def _finish(img: np.ndarray, max_side: int | None) -> np.ndarray:
    size = _scaled_size(img.shape[1], img.shape[0], max_side)
    if size is not None:
        img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    return np.ascontiguousarray(img)


def _read_image(src: VideoSource, k: int, max_side: int | None) -> np.ndarray:
    p = src._images[k]
    img = cv2.imread(str(p), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(f"{p}: not a readable image")
    if img.shape[:2] != (src.info.height, src.info.width):
        raise InputError(
            f"{p}: image is {img.shape[1]}x{img.shape[0]}, the folder's first image is "
            f"{src.info.width}x{src.info.height}"
        )
    return _finish(img, max_side)


def _decoded_frames(src: VideoSource, container, stream) -> Iterator[tuple[int, object]]:
    """(frame index, av.VideoFrame) in presentation order, indices from the PTS when known."""
    index_of = {p: k for k, p in enumerate(src._pts)} if src._pts is not None else None
    k_next = 0
    for frame in container.decode(stream):
        signals.checkpoint()  # between frames (PyAV's decoder cannot be stopped halfway)
        if index_of is not None:
            k = index_of.get(frame.pts)
            if k is None:
                log.debug("%s: frame with unexpected pts %s skipped", src.path, frame.pts)
                continue
        else:
            k = k_next
        k_next = k + 1
        yield k, frame


def iter_frames(src: VideoSource, step: int = 1, max_side: int | None = None
                ) -> Iterator[tuple[int, np.ndarray]]:
    """Yield (frame index, H×W×3 uint8 BGR) for frames 0, step, 2*step, ...

    Frame k is the one whose local time is ``src.info.timestamps_s[k]``. With ``max_side`` the
    image is downscaled (INTER_AREA) so that its longer side is at most max_side px.
    """
    if step < 1:
        raise ValueError(f"step must be >= 1, got {step}")
    n = src.info.num_frames
    if src.is_image_folder:
        for k in range(0, n, step):
            signals.checkpoint()
            yield k, _read_image(src, k, max_side)
        return
    expected = list(range(0, n, step))
    pos = 0
    try:
        with av.open(str(src.path)) as container:
            stream = container.streams.video[0]
            stream.thread_type = "AUTO"
            for k, frame in _decoded_frames(src, container, stream):
                if pos >= len(expected):
                    break
                if k < expected[pos]:
                    continue
                if k > expected[pos]:
                    raise InputError(
                        f"{src.path}: frame {expected[pos]} could not be decoded (corrupt stream)"
                    )
                yield k, _finish(frame.to_ndarray(format="bgr24"), max_side)
                pos += 1
    except _AV_ERRORS as exc:
        raise InputError(f"{src.path}: corrupt or truncated video stream ({exc})") from None
    if pos < len(expected):
        raise InputError(
            f"{src.path}: truncated video: frame {expected[pos]} of {n} could not be decoded"
        )


def read_frames(src: VideoSource, indices: Sequence[int], max_side: int | None = None
                ) -> list[np.ndarray]:
    """The frames at the given indices (any order, repeats allowed) as H×W×3 uint8 BGR.

    Seeks to the keyframe before each wanted frame when that is far from the decoder's position,
    otherwise decodes forward; frames are matched by PTS, so the result is exact.
    """
    idx = [int(i) for i in indices]
    n = src.info.num_frames
    for i in idx:
        if not 0 <= i < n:
            raise IndexError(f"{src.path}: frame index {i} out of range (video has {n} frames)")
    if not idx:
        return []
    if src.is_image_folder:
        return [_read_image(src, i, max_side) for i in idx]
    wanted = sorted(set(idx))
    got: dict[int, np.ndarray] = {}
    if src._pts is None:
        # no PTS to seek by: one sequential pass
        got = _read_sequentially(src, wanted, max_side)
    else:
        got = _read_by_seeking(src, wanted, max_side)
    missing = [i for i in wanted if i not in got]
    if missing:
        raise InputError(f"{src.path}: frames {missing[:5]} could not be decoded (corrupt stream)")
    return [got[i] for i in idx]


_SEEK_GAP = 48  # decode forward instead of seeking when the next wanted frame is this close


def _should_seek(src: VideoSource, k: int, target: int) -> bool:
    """From frame k, is seeking to `target` quicker than decoding on? Yes when a keyframe lies
    after k and at or before target (with unknown keyframes: when target is far)."""
    if src._keyframes:
        j = bisect.bisect_right(src._keyframes, target) - 1
        return j >= 0 and src._keyframes[j] > k
    return target - k > _SEEK_GAP


def _read_by_seeking(src: VideoSource, wanted: list[int], max_side: int | None
                     ) -> dict[int, np.ndarray]:
    got: dict[int, np.ndarray] = {}
    index_of = {p: k for k, p in enumerate(src._pts)}
    try:
        with av.open(str(src.path)) as container:
            stream = container.streams.video[0]
            stream.thread_type = "AUTO"
            i = 0
            while i < len(wanted):
                i_before = i
                container.seek(src._pts[wanted[i]], stream=stream, backward=True, any_frame=False)
                first = True
                for frame in container.decode(stream):
                    signals.checkpoint()
                    k = index_of.get(frame.pts)
                    if k is None:
                        continue
                    if first and k > wanted[i]:
                        break  # the seek landed after the target: sequential pass below
                    first = False
                    if k < wanted[i]:
                        continue  # decoding from the keyframe towards the target
                    while i < len(wanted) and wanted[i] < k:
                        i += 1  # not seen in order (damaged stream): left to the pass below
                    if i < len(wanted) and wanted[i] == k:
                        got[k] = _finish(frame.to_ndarray(format="bgr24"), max_side)
                        i += 1
                    if i >= len(wanted) or _should_seek(src, k, wanted[i]):
                        break  # done, or seeking is quicker than decoding on: seek again
                if i == i_before:
                    break  # no progress from this seek: sequential pass below
    except _AV_ERRORS as exc:
        raise InputError(f"{src.path}: corrupt or truncated video stream ({exc})") from None
    rest = [w for w in wanted if w not in got]
    if rest:
        # seeking failed for some frames (files with a poor index): one sequential pass
        log.debug("%s: %d frames not reached by seeking; decoding sequentially", src.path, len(rest))
        got.update(_read_sequentially(src, rest, max_side))
    return got


def _read_sequentially(src: VideoSource, wanted: list[int], max_side: int | None) -> dict[int, np.ndarray]:
    """Frames of the sorted indices `wanted`, by decoding from the start up to the last one."""
    wset, got = set(wanted), {}
    for k, img in iter_frames(src, 1, max_side):
        if k in wset:
            got[k] = img
        if k >= wanted[-1]:
            break
    return got


# ---- writing ----------------------------------------------------------------------------------


class _Aborted(Exception):
    """Passed to the atomic writer when a VideoWriter is aborted (never raised to callers)."""


class VideoWriter:
    """H.264 MP4 (libx264, yuv420p) through PyAV; rerun's AssetVideo accepts it.

    Sizes are rounded up to even numbers (yuv420p needs them); odd-sized images are padded with
    black at the right/bottom. ``write(img, time_s)`` sets the frame's presentation time (variable
    frame rate); without time_s frame k is at k / fps. Frames go to a temporary file beside the
    target that is renamed on close, so no partial file looks complete; on an exception inside a
    ``with`` block the temporary file is removed.
    """

    TIME_BASE = Fraction(1, 90000)  # MPEG clock: 11 µs resolution for variable-rate timestamps

    def __init__(self, path, width: int, height: int, fps: float, crf: int = 20,
                 preset: str = "veryfast"):
        if width < 1 or height < 1:
            raise ValueError(f"width and height must be positive, got {width}x{height}")
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be positive, got {fps}")
        self.path = Path(path)
        self.width, self.height = int(width), int(height)
        self.enc_width, self.enc_height = self.width + self.width % 2, self.height + self.height % 2
        self.fps = float(fps)
        self.num_frames = 0
        self._last_pts = -1
        # the one atomic writer (io.atomic), held open from here until close() or abort()
        self._atomic = atomic_path(self.path, suffix=".mp4")
        self._tmp = self._atomic.__enter__()
        try:
            self._container = av.open(str(self._tmp), mode="w", format="mp4")
            rate = Fraction(self.fps).limit_denominator(1001 * 1000)
            stream = self._container.add_stream("libx264", rate=rate)
            stream.width, stream.height = self.enc_width, self.enc_height
            stream.pix_fmt = "yuv420p"
            stream.time_base = self.TIME_BASE
            stream.codec_context.time_base = self.TIME_BASE
            # no mbtree: with x264's macroblock-tree rate control, encoding the same frames again
            # in one process could give different files, depending on what was encoded before
            # (tests/synth/test_world_videos.py renders a scene twice and compares the files)
            # force-cfr with the nominal rate: the stream's own timing (SPS) says `fps`, not the
            # 1/90000 time base (rerun's viewer plays no H.264 whose SPS claims 90000 fps); the
            # frames keep their exact presentation times in the container
            stream.codec_context.framerate = rate
            stream.options = {"crf": str(int(crf)), "preset": preset,
                              "x264-params": "mbtree=0:force-cfr=1"}
            self._stream = stream
        except BaseException as exc:
            self._discard(exc)
            raise
        self._closed = False

    def write(self, image_bgr: np.ndarray, time_s: float | None = None) -> None:
        if self._closed:
            raise ValueError(f"{self.path}: writer is closed")
        img = np.asarray(image_bgr)
        if img.ndim == 2:
            img = np.repeat(img[:, :, None], 3, axis=2)
        if img.shape != (self.height, self.width, 3):
            raise ValueError(
                f"image must have shape ({self.height},{self.width},3), got {tuple(img.shape)}"
            )
        if img.dtype != np.uint8:
            raise ValueError(f"image must be uint8, got {img.dtype}")
        if (self.enc_width, self.enc_height) != (self.width, self.height):
            img = cv2.copyMakeBorder(img, 0, self.enc_height - self.height, 0,
                                     self.enc_width - self.width, cv2.BORDER_CONSTANT, value=0)
        t = self.num_frames / self.fps if time_s is None else float(time_s)
        pts = int(round(t / self.TIME_BASE))
        if pts <= self._last_pts:
            raise ValueError(f"{self.path}: frame times must increase (got {t:.6f} s after "
                             f"{float(self._last_pts * self.TIME_BASE):.6f} s)")
        signals.checkpoint()  # between frames
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(img), format="bgr24")
        frame.pts = pts
        frame.time_base = self.TIME_BASE
        for packet in self._stream.encode(frame):
            self._container.mux(packet)
        self._last_pts = pts
        self.num_frames += 1

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            for packet in self._stream.encode(None):
                self._container.mux(packet)
            self._container.close()
        except BaseException as exc:
            self._discard(exc)
            raise
        if self.num_frames == 0:
            exc = ValueError(f"{self.path}: no frames were written")
            self._discard(exc)
            raise exc
        self._atomic.__exit__(None, None, None)  # renamed into place with the usual file mode

    def _discard(self, exc: BaseException) -> None:
        """Remove the temporary file (atomic_path's cleanup on an error)."""
        self._atomic.__exit__(type(exc), exc, exc.__traceback__)

    def abort(self) -> None:
        """Stop without producing the file (the temporary file is removed)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._container.close()
        except _AV_ERRORS:
            pass
        self._discard(_Aborted(f"{self.path}: aborted"))

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            self.abort()
        else:
            self.close()
