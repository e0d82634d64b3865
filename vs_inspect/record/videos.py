"""Each video in the recording: its frames (an embedded H.264/AV1 file or JPEG images), moving-
region masks and tracks, held until the offsets are known and then logged once on both the
video's own `frame` timeline and the global `time` timeline; and one still frame on offset_ms,
so that the video views are not empty where the viewer opens.

Entities: videos/<v> (a description and the image border), videos/<v>/{video,image,mask,tracks},
videos/<v>/still/*, and world/cameras/<v>/image (an embedded video's frames on the image plane).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import rerun as rr
from tqdm import tqdm

from ..analysis.colours import instance_colors
from ..io.recording_paths import (
    TIMELINE_FRAME, TIMELINE_TIME, VIDEOS, camera_path, video_asset_path, video_image_path, video_mask_path,
    video_path, video_still_path, video_tracks_path,
)
from ..types import VideoInfo
from .context import RecordingContext, VideoBuffer
from .style import annotation_context, at_offset_ms, fmt, image_border, scaled_to

log = logging.getLogger(__name__)

H264_LIKE = {"h264", "av1"}
FRAMES_PER_BATCH = 64  # JPEG frames sent per send_columns call


def time_indexes(info: VideoInfo, frames: np.ndarray, offset_s: float | None) -> list:
    """The index columns of a video's frames: `frame`, and `time` when its offset is known."""
    idx = [rr.TimeColumn(TIMELINE_FRAME, sequence=np.asarray(frames, dtype=np.int64))]
    if offset_s is not None and math.isfinite(offset_s):
        idx.append(rr.TimeColumn(TIMELINE_TIME, duration=info.timestamps_s[frames] + offset_s))
    return idx


def decoded(jpeg: bytes, draw_order: float | None = None) -> rr.Image:
    """A JPEG as a decoded image. For images shown on the offset timeline: rerun 0.41's viewer
    shows no EncodedImage (JPEG) while the time cursor is at a negative value of a sequence
    timeline, and about half of the candidate offsets are negative; decoded images show."""
    import cv2
    bgr = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    return rr.Image(bgr, color_model="BGR", draw_order=draw_order)


def video_codec(path: str) -> str | None:
    """The codec name of an H.264/AV1 file rerun's viewer can play, else None (JPEG frames then).

    rerun 0.41's native viewer shows no frame of an H.264 stream whose own timing (the SPS's
    frame rate) is far from the container's frame rate, e.g. libx264 fed a 1/90000 time base
    (SPS: 90000 fps): its panels stay at the loading dots."""
    try:
        import av
        with av.open(str(path)) as c:
            s = c.streams.video[0]
            rate, sps_rate = s.average_rate or s.guessed_rate, s.codec_context.framerate
            if rate and sps_rate and not 0.5 <= float(sps_rate) / float(rate) <= 2.0:
                log.info("%s: H.264 timing says %s fps, the file %s fps: not embedded (rerun's "
                         "viewer cannot play it)", path, sps_rate, rate)
                return None
            return s.codec_context.name
    except Exception:  # noqa: BLE001 - any failure: not embeddable, fall back to JPEG frames
        return None


class VideoLog:
    """The videos' part of the recording."""

    def __init__(self, ctx: RecordingContext):
        self.ctx = ctx
        self.framed: set[str] = set()  # videos with images (JPEG frames or an embedded video)
        self.timed = False  # a video was logged on the time timeline (it had an offset)
        self.flushed = False
        self.still_frames: dict[str, int] = {}  # video -> frame an epipolar view shows (its still shows it too)

    def image_frames(self, name: str) -> set[int] | None:
        buf = self.ctx.videos.get(name)
        return set(buf.jpeg) if buf is not None else None

    def add_video(self, info: VideoInfo, path: str | None) -> None:
        """A video, embedded as an rr.AssetVideo when it is a file the viewer can play."""
        ctx, o = self.ctx, self.ctx.options
        buf = ctx.videos.setdefault(info.name, VideoBuffer(info, path))
        buf.info, buf.path = info, path
        if not (o.frames and o.video_assets and path and Path(path).is_file()
                and Path(path).stat().st_size <= o.max_asset_mb * 1e6 and video_codec(path) in H264_LIKE):
            return
        try:
            asset = rr.AssetVideo(path=path)
            ts = np.sort(asset.read_frame_timestamps_nanos())
            if len(ts) >= info.num_frames:
                ctx.rec.log(video_asset_path(info.name), asset, static=True)
                buf.asset, buf.asset_timestamps_ns = True, ts[: info.num_frames]
                self.framed.add(info.name)
                buf.image_size = (info.width, info.height)
        except Exception as exc:  # noqa: BLE001 - rerun could not parse it: use JPEG frames
            log.info("%s: not embedded as a video asset (%s); logging JPEG frames", info.name, exc)

    def add_bundle_video(self, info: VideoInfo) -> None:
        self.ctx.videos.setdefault(info.name, VideoBuffer(info, None)).info = info

    def add_frame(self, name: str, frame_index: int, image_bgr: np.ndarray) -> None:
        """Kept as given (analysis.record_views.record_frame sizes it), JPEG-encoded."""
        import cv2
        buf = self.ctx.videos.get(name)
        if not self.ctx.options.frames or buf is None or buf.asset:
            return
        img = np.asarray(image_bgr)
        ok, data = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(self.ctx.options.jpeg_quality)])
        if ok:
            buf.jpeg[int(frame_index)] = data.tobytes()
            buf.image_size = (img.shape[1], img.shape[0])
            self.framed.add(name)

    def add_mask(self, name: str, frame_index: int, instances: np.ndarray) -> None:
        """Kept as given (analysis.record_views.record_mask sizes it and picks its integer type)."""
        buf = self.ctx.videos.get(name)
        if self.ctx.options.masks and buf is not None:
            buf.masks[int(frame_index)] = np.asarray(instances)

    def flush(self, offsets: dict[str, float | None], on_camera: set[str]) -> None:
        """Everything held, at the offsets now known (a video without one: on `frame` only);
        on_camera: videos whose camera is in the 3D view (their embedded frames go on its image plane)."""
        ctx = self.ctx
        self.flushed = True
        # whether any video is on the time timeline (else the viewer opens on frame: see blueprint)
        self.timed = any(o is not None and math.isfinite(o) for o in offsets.values())
        total = sum(len(b.jpeg) + len(b.masks) for b in ctx.videos.values())
        bar = tqdm(total=total, desc="recording frames", unit="frame", leave=False,
                   disable=not ctx.progress or total < 50)
        max_id = max((int(m.max(initial=0)) for b in ctx.videos.values() for m in b.masks.values()), default=0)
        ctx.rec.log(VIDEOS, annotation_context(min(max(max_id, 1), 255)), static=True)
        for name, buf in ctx.videos.items():
            info, off = buf.info, offsets.get(name)
            ctx.rec.log(video_path(name), rr.TextDocument(
                f"{name}: {info.width}x{info.height}, {info.num_frames} frames, "
                f"{info.duration_s:.2f} s, offset_s = {fmt(off)}"), static=True)
            ctx.rec.log(f"{video_path(name)}/border", image_border(info.width, info.height), static=True)
            if buf.asset and buf.asset_timestamps_ns is not None:
                self._log_asset_frames(name, buf, off, name in on_camera)
            self._log_jpeg_frames(name, buf, off, bar)
            self._log_masks(name, buf, off, bar)
            self._log_tracks(name, info, off)
            self._log_still(name, buf)
            buf.jpeg.clear()
            buf.masks.clear()
        bar.close()

    def _log_asset_frames(self, name: str, buf: VideoBuffer, off: float | None, on_camera: bool) -> None:
        rec, info = self.ctx.rec, buf.info
        frames = np.arange(len(buf.asset_timestamps_ns))
        rec.send_columns(video_asset_path(name), time_indexes(info, frames, off),
                         rr.VideoFrameReference.columns_nanos(buf.asset_timestamps_ns))
        if on_camera:
            # the same frames on the camera's image plane in 3D: references only, no copy
            image = f"{camera_path(name)}/image"
            rec.log(image, rr.VideoFrameReference.from_fields(video_reference=video_asset_path(name)), static=True)
            rec.send_columns(image, time_indexes(info, frames, off),
                             rr.VideoFrameReference.columns_nanos(buf.asset_timestamps_ns))

    def _log_jpeg_frames(self, name: str, buf: VideoBuffer, off: float | None, bar: tqdm) -> None:
        if not buf.jpeg:
            return
        rec, info = self.ctx.rec, buf.info
        rec.log(video_image_path(name), scaled_to(info.width, info.height, buf.image_size), static=True)
        frames = np.array(sorted(buf.jpeg), dtype=np.int64)
        for s in range(0, len(frames), FRAMES_PER_BATCH):
            fr = frames[s:s + FRAMES_PER_BATCH]
            rec.send_columns(video_image_path(name), time_indexes(info, fr, off),
                             rr.EncodedImage.columns(blob=[buf.jpeg[int(k)] for k in fr],
                                                     media_type=["image/jpeg"] * len(fr)))
            bar.update(len(fr))

    def _log_masks(self, name: str, buf: VideoBuffer, off: float | None, bar: tqdm) -> None:
        if not buf.masks:
            return
        rec, info = self.ctx.rec, buf.info
        frames = np.array(sorted(buf.masks), dtype=np.int64)
        mh, mw = buf.masks[int(frames[0])].shape[:2]
        rec.log(video_mask_path(name), scaled_to(info.width, info.height, (mw, mh)), static=True)
        for k in frames:
            rec.reset_time()
            rec.set_time(TIMELINE_FRAME, sequence=int(k))
            if off is not None and math.isfinite(off):
                rec.set_time(TIMELINE_TIME, duration=float(info.timestamps_s[k] + off))
            rec.log(video_mask_path(name), rr.SegmentationImage(buf.masks[int(k)], opacity=0.4))
            bar.update(1)
        rec.reset_time()

    def _log_tracks(self, name: str, info: VideoInfo, off: float | None) -> None:
        view = self.ctx.view
        tv = view.tracks.get(name) if view is not None else None
        if tv is None:
            return
        seen = np.isfinite(tv.xy[..., 0]) & np.isfinite(tv.xy[..., 1])  # (N,T)
        frames = np.flatnonzero(seen.any(0))
        if len(frames) == 0:
            return
        cols = instance_colors(tv.instance)
        pos, col, lengths = [], [], []
        for k in frames:
            m = seen[:, k]
            pos.append(tv.xy[m, k])
            col.append(cols[m])
            lengths.append(int(m.sum()))
        self.ctx.rec.send_columns(
            video_tracks_path(name), time_indexes(info, frames, off),
            rr.Points2D.columns(positions=np.concatenate(pos).astype(np.float32),
                                colors=np.concatenate(col)).partition(lengths))
        self.ctx.rec.log(video_tracks_path(name), rr.Points2D.from_fields(radii=[2.0]), static=True)

    def _log_still(self, name: str, buf: VideoBuffer) -> None:
        """One frame of the video (the one its epipolar view shows, else the middle one) with its
        mask and tracks, at the smallest candidate offset on the offset timeline."""
        ctx = self.ctx
        if ctx.offset_ms_min is None:
            return
        frames = sorted(buf.jpeg) if buf.jpeg else (list(range(len(buf.asset_timestamps_ns)))
                                                     if buf.asset and buf.asset_timestamps_ns is not None else [])
        if not frames:
            return
        want = self.still_frames.get(name, frames[len(frames) // 2])
        k = min(frames, key=lambda f: abs(f - want))
        base = video_still_path(name)
        with at_offset_ms(ctx.rec, ctx.offset_ms_min):
            self._log_still_layers(name, buf, k)
            ctx.rec.log(base, rr.TextDocument(
                f"{name} frame {k} (τ = {buf.info.timestamps_s[k]:.3f} s): shown on the offset timeline; "
                "switch to `time` to play the synchronized videos"))

    def _log_still_layers(self, name: str, buf: VideoBuffer, k: int) -> None:
        """The still's image, mask and tracks at frame k, with draw orders below the live frames
        (-10), in case a view shows both."""
        rec, base, W, H = self.ctx.rec, video_still_path(name), buf.info.width, buf.info.height
        if buf.jpeg:
            rec.log(f"{base}/image", scaled_to(W, H, buf.image_size), static=True)
            rec.log(f"{base}/image", decoded(buf.jpeg[k], draw_order=-30.0))
        else:
            rec.log(f"{base}/image", rr.VideoFrameReference(
                nanoseconds=int(buf.asset_timestamps_ns[k]), video_reference=video_asset_path(name),
                draw_order=-30.0))
        if buf.masks:
            m = buf.masks[min(buf.masks, key=lambda f: abs(f - k))]
            rec.log(f"{base}/mask", scaled_to(W, H, (m.shape[1], m.shape[0])), static=True)
            rec.log(f"{base}/mask", rr.SegmentationImage(m, opacity=0.4, draw_order=-29.0))
        view = self.ctx.view
        tv = view.tracks.get(name) if view is not None else None
        if tv is not None and k < tv.xy.shape[1]:
            seen = np.isfinite(tv.xy[:, k]).all(-1)
            if seen.any():
                rec.log(f"{base}/tracks", rr.Points2D(tv.xy[seen, k].astype(np.float32),
                                                      colors=instance_colors(tv.instance[seen]),
                                                      radii=[rr.Radius.ui_points(2.5)], draw_order=-28.0))
