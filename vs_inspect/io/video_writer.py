"""Writing H.264 MP4 video (libx264 through PyAV), atomically: no partial file looks complete."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from .. import signals
from .atomic import atomic_path
from .video_source import _AV_ERRORS


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
