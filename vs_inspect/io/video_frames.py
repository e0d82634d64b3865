"""Reading a video's frames (H×W×3 uint8 BGR) by index: every step-th in order (iter_frames) or
any set, by seeking to keyframes (read_frames); frames are matched by PTS, so the result is exact.
"""

from __future__ import annotations

import bisect
import logging
from collections.abc import Iterator, Sequence

import av
import cv2
import numpy as np

from .. import signals
from ..errors import InputError
from .video_source import _AV_ERRORS, VideoSource

log = logging.getLogger(__name__)


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
