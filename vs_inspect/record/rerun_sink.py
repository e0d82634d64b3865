"""RerunSink: every stage's hooks written to an explicit rr.RecordingStream saved to an .rrd file.

A thin adapter: it logs what the stages hand it (their results, and the views that
analysis/record_views.py computed for the recording) to the entity paths of io/recording.py.
The entity tree is documented in README.md ("Recordings"). The file is written through
io/atomic.atomic_path, so a file with the final name is always complete; abort() (or leaving a
`with` block by an exception) deletes the temporary file.

Frames, masks and tracks are kept (JPEG-compressed) until the offsets are known, then logged once
with both the per-video `frame` timeline and the global `time` timeline (seconds, after sync).
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from contextlib import ExitStack
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
from tqdm import tqdm

from .. import __version__
from ..io.atomic import json_default, atomic_path
from ..io.recording import (APPLICATION_ID, LOG_DECISIONS, META_BUNDLE, META_CONFIG, META_RECORDING,
                            META_RESULT, META_VIDEOS, RECORDING_FORMAT, RECORDING_VERSION, SYNC_GRAPH,
                            SYNC_OFFSETS, TIMELINE_EVENT, TIMELINE_FRAME, TIMELINE_ITERATION, TIMELINE_KEYFRAME_PAIR,
                            TIMELINE_OFFSET_MS, TIMELINE_TIME, WORLD_POINTS, camera_path,
                            camera_trail_path, check_entity_names, entity_name, log_path, pair_decision_path,
                            pair_epipolar_path, pair_landscape_path, pair_matches_path, solve_residual_path,
                            solve_weight_path, trajectory_path, video_asset_path, video_image_path,
                            video_mask_path, video_path, video_tracks_path)
from ..io.result import run_result_to_dict
from ..types import CameraTrack, CueBundle, PairLandscape, RunResult, SyncResult, VideoInfo
from .blueprint import blueprint
from .options import RecordOptions
from .sink import Sink

if TYPE_CHECKING:
    from ..analysis.record_views import PairRecordView, RunRecordView

log = logging.getLogger(__name__)

# colours (RGB): accepted / rejected / truth / instances
GREEN, RED, GREY, BLUE, ORANGE = (40, 180, 80), (220, 50, 50), (150, 150, 150), (60, 120, 230), (240, 150, 30)
PALETTE = np.array([(230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200), (245, 130, 48),
                    (145, 30, 180), (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212),
                    (0, 128, 128), (220, 190, 255), (170, 110, 40), (128, 0, 0)], dtype=np.uint8)
H264_LIKE = {"h264", "av1"}
GOOD_LINE_PX = 3.0  # an epipolar line passing this close to its point is drawn green


def instance_colors(instance: np.ndarray) -> np.ndarray:
    inst = np.asarray(instance, dtype=np.int64)
    out = PALETTE[np.mod(inst, len(PALETTE))].copy()
    out[inst < 0] = GREY
    return out


def _num(x: Any) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _fmt(x: Any, unit: str = "", prec: int = 4) -> str:
    v = _num(x)
    return "n/a" if v is None else f"{v:+.{prec}f}{unit}"


def _video_codec(path: str) -> str | None:
    try:
        import av
        with av.open(str(path)) as c:
            return c.streams.video[0].codec_context.name
    except Exception:  # noqa: BLE001 - any failure: not embeddable, fall back to JPEG frames
        return None


def _writer_error(path: Path, exc: BaseException) -> OSError:
    """An OSError naming the recording for a failure of rerun's file writer (which reports only
    "File-writer thread shut down prematurely"): a full disk or a read-only folder when so."""
    import errno
    import shutil
    folder = path.parent
    try:
        full = shutil.disk_usage(folder).free < 1 << 20
    except OSError:
        full = False
    if full:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    if not os.access(folder, os.W_OK):
        return OSError(errno.EACCES, os.strerror(errno.EACCES), str(path))
    return OSError(errno.EIO, f"writing the recording failed ({exc})", str(path))


def _timed(fn):
    """Adds the wall time of a hook to self.hook_s (the cost of recording, without the stages)."""
    import functools

    @functools.wraps(fn)
    def wrapper(self, *args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(self, *args, **kwargs)
        finally:
            self.hook_s += time.perf_counter() - t
    return wrapper


class _VideoBuffer:
    """What one video contributed before the offsets were known."""

    def __init__(self, info: VideoInfo, path: str | None):
        self.info = info
        self.path = path
        self.asset = False  # frames come from an rr.AssetVideo
        self.asset_timestamps_ns: np.ndarray | None = None
        self.jpeg: dict[int, bytes] = {}
        self.image_size: tuple[int, int] | None = None  # (w, h) of logged images
        self.masks: dict[int, np.ndarray] = {}


class RerunSink(Sink):
    """Writes a vs_inspect recording. Use as a context manager or call close()/abort()."""

    def __init__(self, path: str | os.PathLike, application_id: str = APPLICATION_ID,
                 options: RecordOptions | None = None, recording_id: str | None = None,
                 progress: bool = True):
        self.path = Path(path)
        self.options = options or RecordOptions()
        self.progress = progress
        # a hidden temporary file that becomes self.path when close() succeeds (io/atomic.py)
        self._file = ExitStack()
        self._tmp = self._file.enter_context(atomic_path(self.path))
        self._t0 = time.perf_counter()
        # a fresh recording id per run (unless given), so two runs opened together do not merge
        self.rec = rr.RecordingStream(application_id, recording_id=recording_id, send_properties=True)
        try:
            self.rec.save(str(self._tmp))
        except BaseException as exc:
            self._file.__exit__(type(exc), exc, exc.__traceback__)
            raise
        self._closed = False
        self._videos: dict[str, _VideoBuffer] = {}
        self._entities: dict[str, str] = {}  # entity path part -> video name (unique, see check_entity_names)
        self._world_cameras: dict[str, CameraTrack] | None = None
        self._bundle: CueBundle | None = None
        self._result: SyncResult | None = None
        self._view: RunRecordView | None = None
        self._summary: RunResult | None = None
        self._flushed_videos = False
        self._pairs_logged: list[str] = []
        self._events = 0
        self._cams_logged: set[str] = set()
        self.hook_s = 0.0
        self.stats: dict[str, float] = {}

    def image_frames(self, name: str) -> set[int] | None:
        """Frames of a video this sink holds an image of (None: the video is unknown)."""
        buf = self._videos.get(name)
        return set(buf.jpeg) if buf is not None else None

    # ---- Stage 0 hooks ----

    @_timed
    def video(self, info: VideoInfo, path: str | None) -> None:
        self._entities = check_entity_names([info.name], self._entities)  # before logging anything of it
        buf = self._videos.setdefault(info.name, _VideoBuffer(info, path))
        buf.info, buf.path = info, path
        o = self.options
        if o.frames and o.video_assets and path and Path(path).is_file() \
                and Path(path).stat().st_size <= o.max_asset_mb * 1e6 and _video_codec(path) in H264_LIKE:
            try:
                asset = rr.AssetVideo(path=path)
                ts = np.sort(asset.read_frame_timestamps_nanos())
                if len(ts) >= info.num_frames:
                    self.rec.log(video_asset_path(info.name), asset, static=True)
                    buf.asset, buf.asset_timestamps_ns = True, ts[: info.num_frames]
                    buf.image_size = (info.width, info.height)
            except Exception as exc:  # noqa: BLE001 - rerun could not parse it: use JPEG frames
                log.info("%s: not embedded as a video asset (%s); logging JPEG frames", info.name, exc)

    @_timed
    def video_frame(self, name: str, frame_index: int, image_bgr: np.ndarray) -> None:
        """Kept as given (analysis.record_views.record_frame sizes it), JPEG-encoded."""
        import cv2
        buf = self._videos.get(name)
        if not self.options.frames or buf is None or buf.asset:
            return
        img = np.asarray(image_bgr)
        ok, data = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(self.options.jpeg_quality)])
        if ok:
            buf.jpeg[int(frame_index)] = data.tobytes()
            buf.image_size = (img.shape[1], img.shape[0])

    @_timed
    def dynamic_mask(self, name: str, frame_index: int, instances: np.ndarray) -> None:
        """Kept as given (analysis.record_views.record_mask sizes it and picks its integer type)."""
        buf = self._videos.get(name)
        if not self.options.masks or buf is None:
            return
        buf.masks[int(frame_index)] = np.asarray(instances)

    @_timed
    def cameras(self, cameras: dict[str, CameraTrack], points_world: np.ndarray | None,
                colors: np.ndarray | None) -> None:
        self._world_cameras = dict(cameras)
        self._log_cameras_static(cameras, [b.info for b in self._videos.values()])
        if points_world is not None and len(points_world):
            pts = np.asarray(points_world, dtype=np.float32)
            cols = np.asarray(colors, dtype=np.uint8) if colors is not None else None
            self.rec.log(WORLD_POINTS, rr.Points3D(pts, colors=cols, radii=rr.Radius.ui_points(1.5)),
                         static=True)

    # ---- Stage 1 and 2 hooks ----

    @_timed
    def bundle(self, bundle: CueBundle) -> None:
        self._entities = check_entity_names([v.name for v in bundle.videos], self._entities)
        self._bundle = bundle
        for v in bundle.videos:
            buf = self._videos.setdefault(v.name, _VideoBuffer(v, None))
            buf.info = v
        self.rec.log(META_VIDEOS, rr.TextDocument(json.dumps({
            "videos": [{"name": v.name, "entity": entity_name(v.name), "width": v.width,
                        "height": v.height, "num_frames": v.num_frames, "fps": v.fps,
                        "duration_s": v.duration_s} for v in bundle.videos],
            "gt_offsets_s": bundle.gt_offsets_s}), media_type="text/plain"), static=True)
        if self.options.embed_bundle:
            from ..io.bundle_zip import bundle_to_zip_bytes
            raw = bundle_to_zip_bytes(bundle)
            self.rec.log(META_BUNDLE, rr.AnyValues(zip=np.frombuffer(raw, dtype=np.uint8)), static=True)
        self._log_cameras_static(self._world_cameras or bundle.cameras, list(bundle.videos))

    @_timed
    def pair_matches(self, a: str, b: str, frames_a: np.ndarray, frames_b: np.ndarray,
                     counts: np.ndarray) -> None:
        counts = np.asarray(counts, dtype=np.int64).reshape(len(frames_a), len(frames_b))
        base = pair_matches_path(a, b)
        self.rec.log(base, rr.SeriesLines(names=["descriptor matches per keyframe pair"]), static=True)
        if counts.size:
            self.rec.send_columns(base, [rr.TimeColumn(TIMELINE_KEYFRAME_PAIR, sequence=np.arange(counts.size))],
                                  rr.Scalars.columns(scalars=counts.ravel().astype(np.float64)))
            self.rec.log(f"{base}/grid", rr.Tensor(counts, dim_names=(f"keyframe of {a}", f"keyframe of {b}")),
                         static=True)
        # which frames the keyframe_pair index k stands for: a's frames_a[k // Kb], b's frames_b[k % Kb]
        self.rec.log(f"{base}/keyframes", rr.AnyValues(frames_a=np.asarray(frames_a, np.int64),
                                                       frames_b=np.asarray(frames_b, np.int64)), static=True)

    @_timed
    def pair_landscape(self, landscape: PairLandscape, view: PairRecordView | None = None) -> None:
        self._log_landscape(landscape, view)
        self._log_decision(landscape, view)
        if view is not None and view.sweep is not None:
            self._log_epipolar(landscape, view)

    @_timed
    def sync_result(self, result: SyncResult, view: RunRecordView | None = None) -> None:
        self._result, self._view = result, view
        if view is not None:
            self._log_graph(result, view)
        self._log_solve(result)
        if view is not None:
            self._log_offsets(result, view)
        self._flush_videos(result.offsets_s)
        if view is not None:
            self._log_trajectories(view)

    @_timed
    def stage_event(self, stage: str, message: str, **numbers: Any) -> None:
        self._events += 1
        extra = ", ".join(f"{k}={v}" for k, v in numbers.items())
        self.rec.reset_time()
        self.rec.set_time(TIMELINE_EVENT, sequence=self._events)
        self.rec.log(log_path(stage), rr.TextLog(f"{message}" + (f" ({extra})" if extra else ""),
                                                 level=rr.TextLogLevel.INFO))
        self.rec.reset_time()

    @_timed
    def run_summary(self, result: RunResult) -> None:
        self._summary = result

    # ---- finishing ----

    def close(self) -> None:
        if self._closed:
            return
        t_close = time.perf_counter()
        try:
            if not self._flushed_videos:
                self._flush_videos({})
            summary = self._summary
            if summary is None and self._result is not None:
                r = self._result
                gt = self._bundle.gt_offsets_s if self._bundle is not None else None
                summary = RunResult(r.reference, r.offsets_s, r.uncertainty_s, r.unresolved_reason,
                                    r.pairs, r.solver, r.solve_pairs, r.iterations, r.timings_s,
                                    gt_offsets_s=gt or None)
            if summary is not None:
                self.rec.log(META_RESULT, rr.TextDocument(json.dumps(run_result_to_dict(summary),
                                                                     default=json_default),
                                                          media_type="text/plain"), static=True)
            if summary is not None and summary.config is not None:
                self.rec.log(META_CONFIG, rr.TextDocument(json.dumps(summary.config, default=json_default),
                                                          media_type="text/plain"), static=True)
            self.rec.log(META_RECORDING, rr.TextDocument(json.dumps({
                "format": RECORDING_FORMAT, "version": RECORDING_VERSION,
                "vs_inspect_version": __version__, "rerun_version": rr.__version__,
                "has_result": summary is not None, "options": asdict(self.options),
                "pairs": self._pairs_logged}), media_type="text/plain"), static=True)
            names = list(self._videos) or (self._bundle.names if self._bundle else [])
            self.rec.send_blueprint(blueprint(names, self._pairs_logged, self._result),
                                    make_active=True, make_default=True)
            self.rec.flush()
            self.rec.disconnect()
            self._file.close()  # renames the temporary file to self.path
            self._closed = True
            self.stats = {"write_s": self.hook_s + time.perf_counter() - t_close,
                          "open_s": time.perf_counter() - self._t0,
                          "size_mb": self.path.stat().st_size / 1e6}
            log.info("wrote %s (%.1f MB, %.1f s of logging)", self.path, self.stats["size_mb"],
                     self.stats["write_s"])
        except RuntimeError as exc:  # rerun's file writer failed (it logs the OS error itself)
            self._abort(exc)
            raise _writer_error(self.path, exc) from None
        except BaseException as exc:
            self._abort(exc)
            raise

    def abort(self) -> None:
        """Stop writing and delete the temporary file; nothing that looks complete is left."""
        self._abort(None)

    def _abort(self, exc: BaseException | None) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.rec.disconnect()
        finally:
            err = exc or RuntimeError("recording aborted")  # atomic_path deletes on any error
            self._file.__exit__(type(err), err, err.__traceback__)

    # ---- internals: cameras ----

    def _scene_scale(self, cams: dict[str, CameraTrack]) -> float:
        C = np.concatenate([c.centers() for c in cams.values()])
        C = C[np.isfinite(C).all(1)]
        if len(C) < 2:
            return 1.0
        d = np.linalg.norm(C - np.median(C, axis=0), axis=1)
        return float(np.median(d)) or 1.0

    def _log_cameras_static(self, cams: dict[str, CameraTrack], videos: list[VideoInfo]) -> None:
        """Pinhole and (static) pose of each camera, once per camera."""
        if not cams:
            return
        dist = 0.08 * self._scene_scale(cams)
        for v in videos:
            cam = cams.get(v.name)
            if cam is None or v.name in self._cams_logged:
                continue
            self._cams_logged.add(v.name)
            base = camera_path(v.name)
            K0 = cam.K if cam.K.ndim == 2 else cam.K[0]
            self.rec.log(base, rr.Pinhole(image_from_camera=K0, resolution=[v.width, v.height],
                                          camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=dist),
                         static=True)
            if not cam.is_moving:
                T = cam.cam_from_world
                self.rec.log(base, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3],
                                                  relation=rr.TransformRelation.ChildFromParent), static=True)
            else:
                C = cam.centers()
                self.rec.log(camera_trail_path(v.name),
                             rr.LineStrips3D([C.astype(np.float32)], colors=[ORANGE]), static=True)

    def _log_moving_cameras(self, offsets: dict[str, float | None]) -> None:
        cams = self._world_cameras or (self._bundle.cameras if self._bundle else {})
        for name, buf in self._videos.items():
            cam = cams.get(name)
            if cam is None or not cam.is_moving:
                continue
            n = cam.num_pose_frames
            frames = np.arange(n)
            T = cam.pose_at(frames)
            idx = self._indexes(buf.info, frames, offsets.get(name))
            self.rec.send_columns(camera_path(name), idx,
                                  rr.Transform3D.columns(translation=T[:, :3, 3], mat3x3=T[:, :3, :3],
                                                         relation=[rr.TransformRelation.ChildFromParent] * n))

    # ---- internals: videos ----

    @staticmethod
    def _indexes(info: VideoInfo, frames: np.ndarray, offset_s: float | None) -> list:
        idx = [rr.TimeColumn(TIMELINE_FRAME, sequence=np.asarray(frames, dtype=np.int64))]
        if offset_s is not None and math.isfinite(offset_s):
            idx.append(rr.TimeColumn(TIMELINE_TIME, duration=info.timestamps_s[frames] + offset_s))
        return idx

    def _flush_videos(self, offsets: dict[str, float | None]) -> None:
        self._flushed_videos = True
        total = sum(len(b.jpeg) + len(b.masks) for b in self._videos.values())
        bar = tqdm(total=total, desc="recording frames", unit="frame", leave=False,
                   disable=not self.progress or total < 50)
        for name, buf in self._videos.items():
            info, ent = buf.info, video_path(name)
            off = offsets.get(name)
            self.rec.log(ent, rr.TextDocument(f"{name}: {info.width}x{info.height}, {info.num_frames} frames, "
                                              f"{info.duration_s:.2f} s, offset_s = {_fmt(off)}"), static=True)
            # image border in full-resolution pixels, so a view without frames still has extent
            W, H = info.width, info.height
            self.rec.log(f"{ent}/border", rr.LineStrips2D([[[0, 0], [W, 0], [W, H], [0, H], [0, 0]]],
                                                          colors=[GREY]), static=True)
            if buf.asset and buf.asset_timestamps_ns is not None:
                frames = np.arange(len(buf.asset_timestamps_ns))
                self.rec.send_columns(video_asset_path(name), self._indexes(info, frames, off),
                                      rr.VideoFrameReference.columns_nanos(buf.asset_timestamps_ns))
                if name in self._cams_logged:
                    # the same frames on the camera's image plane in 3D: references only, no copy
                    self.rec.log(f"{camera_path(name)}/image",
                                 rr.VideoFrameReference.from_fields(video_reference=video_asset_path(name)),
                                 static=True)
                    self.rec.send_columns(f"{camera_path(name)}/image",
                                          self._indexes(info, frames, off),
                                          rr.VideoFrameReference.columns_nanos(buf.asset_timestamps_ns))
            if buf.jpeg:
                w, h = buf.image_size
                self.rec.log(video_image_path(name), rr.Transform3D(scale=[W / w, H / h, 1.0]), static=True)
                frames = np.array(sorted(buf.jpeg), dtype=np.int64)
                for s in range(0, len(frames), 64):
                    fr = frames[s:s + 64]
                    self.rec.send_columns(video_image_path(name), self._indexes(info, fr, off),
                                          rr.EncodedImage.columns(blob=[buf.jpeg[int(k)] for k in fr],
                                                                  media_type=["image/jpeg"] * len(fr)))
                    bar.update(len(fr))
            if buf.masks:
                frames = np.array(sorted(buf.masks), dtype=np.int64)
                mh, mw = buf.masks[int(frames[0])].shape[:2]
                self.rec.log(video_mask_path(name), rr.Transform3D(scale=[W / mw, H / mh, 1.0]), static=True)
                for k in frames:
                    self.rec.reset_time()
                    self.rec.set_time(TIMELINE_FRAME, sequence=int(k))
                    if off is not None and math.isfinite(off):
                        self.rec.set_time(TIMELINE_TIME, duration=float(info.timestamps_s[k] + off))
                    self.rec.log(video_mask_path(name), rr.SegmentationImage(buf.masks[int(k)], opacity=0.4))
                    bar.update(1)
                self.rec.reset_time()
            self._log_tracks(name, info, off)
            buf.jpeg.clear()
            buf.masks.clear()
        bar.close()
        self._log_moving_cameras(offsets)

    def _log_tracks(self, name: str, info: VideoInfo, off: float | None) -> None:
        tv = self._view.tracks.get(name) if self._view is not None else None
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
        self.rec.send_columns(
            video_tracks_path(name), self._indexes(info, frames, off),
            rr.Points2D.columns(positions=np.concatenate(pos).astype(np.float32),
                                colors=np.concatenate(col)).partition(lengths))
        self.rec.log(video_tracks_path(name), rr.Points2D.from_fields(radii=[2.0]), static=True)

    # ---- internals: pairs ----

    def _log_landscape(self, land: PairLandscape, view: PairRecordView | None) -> None:
        base = pair_landscape_path(land.a, land.b)
        self._pairs_logged.append(f"{land.a}__{land.b}")
        ms = np.round(np.asarray(land.offsets_s) * 1000.0).astype(np.int64)
        e = np.asarray(land.energy, dtype=np.float64)
        ok = np.isfinite(e)
        color = GREEN if land.decision.accepted else RED
        self.rec.log(f"{base}/energy", rr.SeriesLines(colors=[color], names=["E(Δ)"], widths=[1.5]), static=True)
        if ok.any():
            self.rec.send_columns(f"{base}/energy", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[ok])],
                                  rr.Scalars.columns(scalars=e[ok]))
        mi = np.asarray(land.minima_idx, dtype=np.int64)
        self.rec.log(f"{base}/minima", rr.SeriesPoints(colors=[BLUE], names=["minima"], markers=["circle"],
                                                       marker_sizes=[4.0]), static=True)
        if len(mi):
            self.rec.send_columns(f"{base}/minima", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[mi])],
                                  rr.Scalars.columns(scalars=e[mi]))
        if math.isfinite(land.best_offset_s) and math.isfinite(land.best_energy):
            self.rec.log(f"{base}/chosen", rr.SeriesPoints(colors=[color], names=["chosen"],
                                                           markers=["diamond"], marker_sizes=[7.0]), static=True)
            self.rec.send_columns(f"{base}/chosen",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=[round(land.best_offset_s * 1000)])],
                                  rr.Scalars.columns(scalars=[land.best_energy]))
        if view is not None and view.true_offset_s is not None and view.true_energy is not None:
            self.rec.log(f"{base}/truth", rr.SeriesPoints(colors=[ORANGE], names=["true Δ"],
                                                          markers=["cross"], marker_sizes=[7.0]), static=True)
            self.rec.send_columns(f"{base}/truth",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=[round(view.true_offset_s * 1000)])],
                                  rr.Scalars.columns(scalars=[view.true_energy]))

    def _log_decision(self, land: PairLandscape, view: PairRecordView | None) -> None:
        d = land.decision
        verdict = "ACCEPTED" if d.accepted else "REJECTED"
        true = view.true_offset_s if view is not None else None
        minima = ", ".join(f"{land.offsets_s[i]:+.4f} s (E={land.energy[i]:.4g})" for i in land.minima_idx[:6])
        rows = [("chosen Δ_ab", f"{_fmt(land.best_offset_s, ' s')} ± {_fmt(land.uncertainty_s, ' s')}"),
                ("true Δ_ab", _fmt(true, " s") if true is not None else "unknown"),
                ("best energy", f"{land.best_energy:.6g}"),
                ("contrast", f"{d.contrast:.3f}"),
                ("2nd minimum depth ratio", f"{d.second_depth_ratio:.3f}"),
                ("significant minima", str(d.num_minima)),
                ("Pareto minima", str(d.num_pareto_minima)),
                ("at search range edge", str(d.at_range_edge)),
                ("track pairs", str(land.num_track_pairs)),
                ("residual", land.residual),
                ("robust scale", f"{land.robust_scale:.4g}")]
        md = (f"## {land.a} → {land.b}: {verdict}\n\n**reason:** {d.reason}\n\n| | |\n|---|---|\n"
              + "\n".join(f"| {k} | {v} |" for k, v in rows)
              + f"\n\n**minima (best first):** {minima or 'none'}\n")
        self.rec.log(pair_decision_path(land.a, land.b), rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN),
                     static=True)
        self.rec.reset_time()
        self._events += 1
        self.rec.set_time(TIMELINE_EVENT, sequence=self._events)
        self.rec.log(LOG_DECISIONS, rr.TextLog(
            f"{land.a}__{land.b} {verdict.lower()} Δ={_fmt(land.best_offset_s, ' s')}: {d.reason}",
            level=rr.TextLogLevel.INFO if d.accepted else rr.TextLogLevel.WARN))
        self.rec.reset_time()

    def _log_epipolar(self, land: PairLandscape, view: PairRecordView) -> None:
        sw = view.sweep
        buf = self._videos.get(land.a)
        base = pair_epipolar_path(land.a, land.b)
        va = buf.info if buf is not None else self._bundle.video(land.a)
        W, H = va.width, va.height
        self.rec.log(base, rr.TextDocument(
            f"frame {sw.frame_a} of {land.a} (τ = {sw.time_a_s:.3f} s). Lines: epipolar lines of "
            f"{land.b}'s paired points at τ − Δ; points: {land.a}'s points. Scrub `offset_ms`: lines pass "
            f"through the points only near the right Δ (chosen {_fmt(land.best_offset_s, ' s')})."),
            static=True)
        self.rec.log(f"{base}/border", rr.LineStrips2D([[[0, 0], [W, 0], [W, H], [0, H], [0, 0]]],
                                                       colors=[GREY]), static=True)
        if buf is not None and sw.frame_a in buf.jpeg:
            w, h = buf.image_size
            self.rec.log(f"{base}/image", rr.Transform3D(scale=[W / w, H / h, 1.0]), static=True)
            self.rec.log(f"{base}/image", rr.EncodedImage(contents=buf.jpeg[sw.frame_a],
                                                          media_type="image/jpeg"), static=True)
        elif buf is not None and buf.asset and buf.asset_timestamps_ns is not None:
            self.rec.log(f"{base}/image", rr.VideoFrameReference(
                nanoseconds=int(buf.asset_timestamps_ns[sw.frame_a]),
                video_reference=video_asset_path(land.a)), static=True)
        ms = np.round(sw.offsets_s * 1000).astype(np.int64)
        cols_inst = instance_colors(sw.instance)
        lines_pos, lines_col, line_len, pt_col = [], [], [], []
        for d in range(len(ms)):
            seg = sw.segments[d]
            ok = np.isfinite(seg).all((1, 2))
            dist = sw.distance_px[d]
            good = np.where(dist < GOOD_LINE_PX, 1, 0)
            c = np.where(good[:, None] == 1, np.array(GREEN), np.array(RED)).astype(np.uint8)
            c[~np.isfinite(dist)] = GREY
            lines_pos.append(seg[ok].reshape(-1, 2))
            lines_col.append(cols_inst[ok])
            line_len.append(int(ok.sum()))
            pt_col.append(c)
        # Each row: a list of 2-point strips -> partition LineStrips2D by strip count per offset.
        strips = np.concatenate(lines_pos).reshape(-1, 2, 2).astype(np.float32)  # (S,2,2): 2-point strips
        tcol = [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms)]
        if len(strips):
            self.rec.send_columns(f"{base}/lines", tcol,
                                  rr.LineStrips2D.columns(strips=strips,
                                                          colors=np.concatenate(lines_col)).partition(line_len))
        self.rec.send_columns(f"{base}/points_a", tcol,
                              rr.Points2D.columns(positions=np.tile(sw.points_a.astype(np.float32), (len(ms), 1)),
                                                  colors=np.concatenate(pt_col)).partition([len(sw.points_a)] * len(ms)))
        self.rec.log(f"{base}/points_a", rr.Points2D.from_fields(radii=[4.0]), static=True)
        med = view.sweep_median_px
        okm = np.isfinite(med)
        if okm.any():
            self.rec.log(f"{base}/median_distance_px", rr.SeriesLines(names=["median point-line distance (px)"],
                                                                      colors=[BLUE]), static=True)
            self.rec.send_columns(f"{base}/median_distance_px",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[okm])],
                                  rr.Scalars.columns(scalars=med[okm]))

    # ---- internals: Stage 2 ----

    def _log_graph(self, result: SyncResult, view: RunRecordView) -> None:
        ids, labels, cols, radii, P = [], [], [], [], []
        for v, off in result.offsets_s.items():
            ids.append(v)
            labels.append(f"{v}\n{_fmt(off, ' s')}" if off is not None else f"{v}\nunresolved")
            cols.append(BLUE if off is not None else GREY)
            radii.append(18.0)
            P.append(view.graph_xy[v])
        edges = []
        for p in result.pairs:
            mid = f"{p.a}__{p.b}"
            acc = p.decision.accepted
            ids.append(mid)
            labels.append(f"Δ={_fmt(p.best_offset_s, ' s', 3)}" if acc else f"✗ {p.decision.reason[:40]}")
            cols.append(GREEN if acc else RED)
            radii.append(5.0)
            P.append(view.graph_xy[mid])
            edges += [(p.a, mid), (mid, p.b)]
        self.rec.log(SYNC_GRAPH, rr.GraphNodes(ids, labels=labels, colors=cols, radii=radii, positions=P,
                                               show_labels=True), static=True)
        self.rec.log(SYNC_GRAPH, rr.GraphEdges(edges, graph_type=rr.GraphType.Undirected), static=True)

    def _log_solve(self, result: SyncResult) -> None:
        if not result.iterations:
            return
        its = np.arange(len(result.iterations), dtype=np.int64)
        R = np.array([it.residual_s for it in result.iterations], dtype=float) * 1000.0  # (I,E)
        Wt = np.array([it.weight for it in result.iterations], dtype=float)
        for e, (a, b) in enumerate(result.solve_pairs):
            tcol = [rr.TimeColumn(TIMELINE_ITERATION, sequence=its)]
            self.rec.send_columns(solve_residual_path(a, b), tcol, rr.Scalars.columns(scalars=R[:, e]))
            self.rec.send_columns(solve_weight_path(a, b), tcol, rr.Scalars.columns(scalars=Wt[:, e]))

    def _log_offsets(self, result: SyncResult, view: RunRecordView) -> None:
        rows = []
        for v, off in result.offsets_s.items():
            u = result.uncertainty_s.get(v)
            t = view.true_offsets_s.get(v)
            err = view.errors_ms.get(v)
            rows.append(f"| {v} | {_fmt(off)} | {_fmt(u, '', 4) if u is not None else '-'} | "
                        f"{_fmt(t) if t is not None else '-'} | "
                        f"{f'{err:.1f}' if err is not None and t is not None else '-'} | "
                        f"{result.unresolved_reason.get(v, '') if off is None else ''} |")
        md = (f"## Offsets (reference {result.reference}, solver {result.solver})\n\n"
              "| video | offset_s | ± s | true_s | error_ms | note |\n|---|---|---|---|---|---|\n" + "\n".join(rows))
        self.rec.log(SYNC_OFFSETS, rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN), static=True)

    def _log_trajectories(self, view: RunRecordView) -> None:
        for tj in view.trajectories:
            X = tj.points_world  # (P,T,3)
            ok = np.isfinite(X).all(-1)
            key = trajectory_path(tj.a, tj.b)
            cols = instance_colors(tj.instance)
            strips = [X[sg.track, sg.start:sg.stop].astype(np.float32) for sg in tj.segments]
            scol = [cols[sg.track] for sg in tj.segments]
            if strips:
                self.rec.log(key, rr.LineStrips3D(strips, colors=np.array(scol), radii=rr.Radius.ui_points(1.0)),
                             static=True)
            frames = np.flatnonzero(ok.any(0))
            lengths = [int(ok[:, k].sum()) for k in frames]
            pos = np.concatenate([X[ok[:, k], k] for k in frames]).astype(np.float32)
            pc = np.concatenate([cols[ok[:, k]] for k in frames])
            self.rec.send_columns(f"{key}/points", [rr.TimeColumn(TIMELINE_TIME, duration=tj.time_s[frames])],
                                  rr.Points3D.columns(positions=pos, colors=pc).partition(lengths))
            self.rec.log(f"{key}/points", rr.Points3D.from_fields(radii=[rr.Radius.ui_points(4.0)]), static=True)
