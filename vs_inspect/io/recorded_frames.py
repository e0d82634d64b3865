"""Video frames a recording carries: the JPEG frames Stage 0 logged and embedded video assets."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from .recording_paths import TIMELINE_FRAME, VIDEOS, video_image_path, video_path
from .rrd_chunks import _blob_bytes, _chunks, _column, _entity_rows, _last_row


def read_video_frames(path: str | Path, video: str) -> dict[int, np.ndarray]:
    """{frame index: BGR image} of the JPEG frames logged at video_image_path(video).

    Images are as logged (downscaled by default): multiply pixel coordinates by
    video width / image width to get full-resolution pixels. Empty when the video was logged as an
    embedded video asset or without frames.
    """
    import cv2

    out: dict[int, np.ndarray] = {}
    for rb in _entity_rows(Path(path), video_image_path(video)):
        frames, blobs = _column(rb, TIMELINE_FRAME), _column(rb, "EncodedImage:blob")
        for k, blob in zip(frames, blobs):
            if k is None or not blob:
                continue
            data = np.asarray(blob[0] if isinstance(blob[0], list) else blob, dtype=np.uint8)
            img = cv2.imdecode(data, cv2.IMREAD_COLOR)
            if img is not None:
                out[int(k)] = img
    return out


class RrdFrames:
    """Frames a recording carries: embedded H.264/AV1 assets (exact frames, decoded with PyAV) or
    downscaled JPEG frames (only the frames Stage 0 logged; the nearest one is used)."""

    def __init__(self, assets: dict[str, bytes], jpegs: dict[str, dict[int, bytes]],
                 sizes: dict[str, tuple[int, int]]):
        self.assets, self.jpegs, self.sizes = assets, jpegs, sizes
        self._tmp: dict[str, str] = {}
        self._dir = None

    def names(self) -> list[str]:
        return sorted(set(self.assets) | set(self.jpegs))

    def read(self, name: str, index: int, exact: bool = True) -> np.ndarray | None:
        """(H,W,3) uint8 BGR at full size of frame `index`, or None when the recording lacks it."""
        import cv2
        if name in self.assets:
            from .video import open_video, read_frames
            if name not in self._tmp:
                if self._dir is None:
                    self._dir = tempfile.TemporaryDirectory(prefix="vs-inspect-rrd-frames-")
                p = Path(self._dir.name) / f"{len(self._tmp)}.mp4"
                p.write_bytes(self.assets[name])
                self._tmp[name] = str(p)
            return read_frames(open_video(self._tmp[name]), [index])[0]
        frames = self.jpegs.get(name) or {}
        if not frames:
            return None
        if index in frames:
            k = index
        elif exact:
            return None
        else:
            keys = np.array(sorted(frames))
            k = int(keys[np.argmin(np.abs(keys - index))])
            gap = np.median(np.diff(keys)) if len(keys) > 1 else 1
            if abs(k - index) > max(1, gap / 2):
                return None
        img = cv2.imdecode(np.frombuffer(frames[k], np.uint8), cv2.IMREAD_COLOR)
        W, H = self.sizes.get(name, (img.shape[1], img.shape[0]))
        if (img.shape[1], img.shape[0]) != (W, H):
            img = cv2.resize(img, (W, H), interpolation=cv2.INTER_LINEAR)
        return img


def read_rrd_frames(path: str | Path, videos: list[tuple[str, int, int]]) -> RrdFrames:
    """The frames at video_asset_path (asset) and video_image_path (JPEG, `frame` timeline) of
    the given videos, as (name, width px, height px)."""
    by_ent = {video_path(name): name for name, _, _ in videos}
    assets: dict[str, bytes] = {}
    jpegs: dict[str, dict[int, bytes]] = {}
    for ch in _chunks(Path(path), [f"/{VIDEOS}/**"]):
        ent = str(ch.entity_path).lstrip("/")
        base, _, leaf = ent.rpartition("/")
        if base not in by_ent or leaf not in ("video", "image"):
            continue
        name = by_ent[base]
        rb = ch.to_record_batch()
        cols = rb.schema.names
        if leaf == "video":
            col = next((c for c in cols if c.endswith("AssetVideo:blob")), None)
            row = _last_row(rb.column(col)) if col else None
            if row is not None:
                assets[name] = _blob_bytes(row)
        else:
            col = next((c for c in cols if c.endswith("EncodedImage:blob")), None)
            if col is None or TIMELINE_FRAME not in cols:
                continue
            fr, blobs = rb.column(TIMELINE_FRAME), rb.column(col)
            for i in range(len(fr)):
                if fr[i].is_valid and blobs[i].is_valid:
                    jpegs.setdefault(name, {})[int(fr[i].as_py())] = _blob_bytes(blobs[i])
    sizes = {name: (int(w), int(h)) for name, w, h in videos}
    return RrdFrames(assets, jpegs, sizes)
