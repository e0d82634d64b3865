"""Synchronized mosaic video: every input side by side on the global timeline.

Global time g = local time τ + offset_s[v] (DESIGN.md). For each output frame at g each video
shows its frame nearest to τ = g - offset_s[v]; a dark tile where the video has no frame at g
(before its start or after its end, by more than half a frame) or has no offset. The global time
is printed on the mosaic, each tile carries the video's name, offset and local time.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from tqdm import tqdm

from ..io.video import VideoSource, VideoWriter, iter_frames
from ..types import VideoInfo

log = logging.getLogger(__name__)

BLANK_BGR = (28, 28, 28)
HEADER_PX = 34  # height of the global-time strip at the top


@dataclass(frozen=True)
class MosaicPlan:
    """Which frame each video shows at each output time."""

    times_s: np.ndarray  # (G,) global times of the output frames, seconds
    frame_index: np.ndarray  # (V,G) int, frame of video v shown at times_s[g]; -1 = blank tile
    names: tuple[str, ...]  # (V,) video names, in tile order
    offsets_s: tuple[float | None, ...]  # (V,) offset of each video, None = unresolved


def plan_mosaic(infos: Sequence[VideoInfo], offsets_s: Sequence[float | None], fps: float
                ) -> MosaicPlan:
    """Output times span every resolved video; nearest frame per video and time."""
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps}")
    resolved = [(i, o) for i, o in enumerate(offsets_s) if o is not None]
    if not resolved:
        raise ValueError("no video has an offset: nothing to put on a common timeline")
    start = min(infos[i].timestamps_s[0] + o for i, o in resolved)
    end = max(infos[i].timestamps_s[-1] + o for i, o in resolved)
    G = int(math.floor((end - start) * fps + 1e-9)) + 1
    g = start + np.arange(G) / fps
    idx = np.full((len(infos), G), -1, dtype=np.int64)
    for i, o in resolved:
        ts = infos[i].timestamps_s
        tau = g - o
        k = np.clip(np.searchsorted(ts, tau), 1, max(len(ts) - 1, 1))
        if len(ts) > 1:
            k = np.where(np.abs(tau - ts[k - 1]) <= np.abs(ts[k] - tau), k - 1, k)
        else:
            k = np.zeros_like(k)
        half = 0.5 * (infos[i].frame_interval_s if math.isfinite(infos[i].frame_interval_s) else 1 / fps)
        inside = (tau >= ts[0] - half) & (tau <= ts[-1] + half)
        idx[i] = np.where(inside, k, -1)
    return MosaicPlan(g, idx, tuple(v.name for v in infos), tuple(offsets_s))


def grid_shape(n: int) -> tuple[int, int]:
    """(rows, cols): one row up to 3 videos, else a near-square grid."""
    if n <= 3:
        return 1, n
    cols = math.ceil(math.sqrt(n))
    return math.ceil(n / cols), cols


def _text(img: np.ndarray, s: str, org: tuple[int, int], scale: float = 0.5,
          color=(255, 255, 255)) -> None:
    (w, h), base = cv2.getTextSize(s, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    x, y = org
    cv2.rectangle(img, (x - 3, y - h - 3), (x + w + 3, y + base + 1), (0, 0, 0), -1)  # backing
    cv2.putText(img, s, org, cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1, cv2.LINE_AA)


def _fit(img: np.ndarray, w: int, h: int) -> np.ndarray:
    """Letterbox img into a w×h tile."""
    tile = np.empty((h, w, 3), np.uint8)
    tile[:] = BLANK_BGR
    s = min(w / img.shape[1], h / img.shape[0])
    nw, nh = max(1, round(img.shape[1] * s)), max(1, round(img.shape[0] * s))
    small = cv2.resize(img, (nw, nh), interpolation=cv2.INTER_AREA)
    y0, x0 = (h - nh) // 2, (w - nw) // 2
    tile[y0:y0 + nh, x0:x0 + nw] = small
    return tile


def render_frame(tiles: Sequence[np.ndarray | None], labels: Sequence[tuple[str, str]],
                 header: str, tile_w: int, tile_h: int) -> np.ndarray:
    """One mosaic frame: a header strip, then the tiles in a grid (None = blank tile).

    labels: per tile (top line, bottom line) of text.
    """
    rows, cols = grid_shape(len(tiles))
    out = np.empty((HEADER_PX + rows * tile_h, cols * tile_w, 3), np.uint8)
    out[:] = BLANK_BGR
    _text(out, header, (8, HEADER_PX - 11), 0.65)
    for i, (img, (top, bottom)) in enumerate(zip(tiles, labels)):
        r, c = divmod(i, cols)
        y, x = HEADER_PX + r * tile_h, c * tile_w
        tile = _fit(img, tile_w, tile_h) if img is not None else None
        if tile is None:
            tile = np.empty((tile_h, tile_w, 3), np.uint8)
            tile[:] = BLANK_BGR
        out[y:y + tile_h, x:x + tile_w] = tile
        cv2.rectangle(out, (x, y), (x + tile_w - 1, y + tile_h - 1), (90, 90, 90), 1)
        _text(out, top, (x + 6, y + 18))
        _text(out, bottom, (x + 6, y + tile_h - 8), 0.45, (200, 230, 255))
    return out


class _Cursor:
    """Sequential reader that hands out frame k (k never decreasing) decoding each frame once."""

    def __init__(self, src: VideoSource, max_side: int):
        self._it: Iterator[tuple[int, np.ndarray]] = iter_frames(src, 1, max_side)
        self._k, self._img = -1, None

    def get(self, k: int) -> np.ndarray:
        while self._k < k:
            self._k, self._img = next(self._it)
        return self._img

    def close(self) -> None:
        close = getattr(self._it, "close", None)
        if close:
            close()


def write_mosaic(path, sources: Sequence[VideoSource], offsets_s: Sequence[float | None],
                 fps: float, tile_width: int = 480, reasons: Sequence[str | None] | None = None,
                 progress: bool = True) -> MosaicPlan:
    """Write the synchronized mosaic of `sources` to an H.264 MP4 at `path`; return its plan."""
    infos = [s.info for s in sources]
    plan = plan_mosaic(infos, offsets_s, fps)
    tile_w = int(tile_width) - int(tile_width) % 2
    aspect = max(v.height / v.width for v in infos)
    tile_h = int(round(tile_w * aspect))
    tile_h += tile_h % 2
    rows, cols = grid_shape(len(sources))
    W, H = cols * tile_w, HEADER_PX + rows * tile_h
    cursors = [_Cursor(s, max(tile_w, tile_h)) if o is not None else None
               for s, o in zip(sources, offsets_s)]
    reasons = list(reasons) if reasons is not None else [None] * len(sources)
    try:
        with VideoWriter(path, W, H, fps) as vw:
            for gi in tqdm(range(len(plan.times_s)), desc="mosaic", unit="frame",
                           disable=not progress, leave=False):
                g = float(plan.times_s[gi])
                tiles, labels = [], []
                for v, (info, off) in enumerate(zip(infos, offsets_s)):
                    k = int(plan.frame_index[v, gi])
                    if off is None:
                        tiles.append(None)
                        labels.append((f"{info.name}: unresolved",
                                       (reasons[v] or "no offset")[:60]))
                        continue
                    top = f"{info.name}  offset {off:+.3f} s"
                    if k < 0:
                        tiles.append(None)
                        labels.append((top, f"no frame at g = {g:.3f} s"))
                    else:
                        tiles.append(cursors[v].get(k))
                        labels.append((top, f"frame {k}  local {info.timestamps_s[k]:.3f} s"))
                vw.write(render_frame(tiles, labels, f"global time g = {g:8.3f} s", tile_w, tile_h),
                         gi / fps)
    finally:
        for c in cursors:
            if c is not None:
                c.close()
    log.info("wrote %s: %d frames at %.3g fps, %dx%d", path, len(plan.times_s), fps, W, H)
    return plan
