"""RerunSink: every stage's hooks written to an explicit rr.RecordingStream saved to an .rrd file.

A thin adapter: it logs what the stages hand it (their results, and the views that
analysis/record_views.py computed for the recording) to the entity paths of io/recording.py.
The entity tree is documented in README.md ("Recordings"). The file is written through
io/atomic.atomic_path, so a file with the final name is always complete; abort() (or leaving a
`with` block by an exception) deletes the temporary file.

Frames, masks and tracks are kept (JPEG-compressed) until the offsets are known, then logged once
with both the per-video `frame` timeline and the global `time` timeline (seconds, after sync).
Landscapes and epipolar views live on the `offset_ms` timeline, on which the viewer opens; so that
the video and 3D views are not empty there, each video's still frame and each moving camera's
middle pose are also logged once at the smallest candidate offset of the run.
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

from .. import __version__, palette, signals
from ..io.atomic import json_default, atomic_path
from ..io.recording import (APPLICATION_ID, CUES_THREE_VIEW, CUES_TRANSFER, GUIDE, LOG_DECISIONS, META_BUNDLE, META_CONFIG,
                            META_RECORDING, META_RESULT, META_VIDEOS, RECORDING_FORMAT,
                            RECORDING_VERSION, SYNC_GRAPH, SYNC_LOOPS, SYNC_OFFSETS, SYNC_PAIRS,
                            VIDEOS, TIMELINE_EVENT, TIMELINE_FRAME, TIMELINE_ITERATION, TIMELINE_KEYFRAME_PAIR,
                            TIMELINE_OFFSET_MS, TIMELINE_TIME, WORLD_POINTS, camera_labels_path,
                            camera_path, camera_trail_path, check_entity_names, entity_name, log_path, pair_decision_path,
                            pair_epipolar_path, pair_landscape_path, pair_matches_path, pair_rate_landscape_path, pair_votes_path,
                            irls_residual_path, irls_weight_path, solve_residual_path,
                            solve_weight_path, three_view_path, trajectory_path, transfer_path, video_asset_path, video_image_path,
                            video_mask_path, video_path, video_still_path,
                            video_tracks_path)
from ..analysis.camera_layout import eye_behind, scene_scale
from ..analysis.colours import GREY, PALETTE, RAMP, distance_colors, distance_ramp_px, instance_colors
from ..analysis.display_names import display_names as short_names_of, legend_lines
from ..analysis.record_views import over_range
from ..analysis.run_result import run_result_from_sync
from ..io.result import run_result_to_dict
from ..types import CameraTrack, CueBundle, PairLandscape, RunResult, SyncResult, VideoInfo
from .blueprint import MAX_PAIR_CONTAINERS, blueprint, pair_order
from ..analysis.record_options import RecordOptions
from .sink import Sink

if TYPE_CHECKING:
    from ..analysis.record_views import PairRecordView, RunRecordView

log = logging.getLogger(__name__)

# Colours: vs_inspect.palette, shared with the report (green and red mean only accepted/rejected).
ACCEPTED, REJECTED = palette.ACCEPTED, palette.REJECTED
MINIMA = palette.OTHER_MINIMA
TRUTH = palette.TRUTH_ON_DARK  # the viewer's background is dark
APPEARANCE_ONLY = GREY  # a pair's landscape without its unchecked track pairs
WINDOW = palette.SOLVED  # the --around window of a pair's Δ
H264_LIKE = {"h264", "av1"}
FRUSTUM_SCALE = 0.3  # frustum depth as a share of the cameras' spread around their median


def annotation_context(max_id: int = 255) -> "rr.AnnotationContext":
    """Mask ids: 0 is the static background (transparent), k ≥ 1 is moving instance k in PALETTE."""
    classes = [rr.AnnotationInfo(id=0, label="static background", color=(0, 0, 0, 0))]
    classes += [rr.AnnotationInfo(id=k, label=f"instance {k}", color=tuple(int(c) for c in PALETTE[k % len(PALETTE)]))
                for k in range(1, max_id + 1)]
    return rr.AnnotationContext(classes)


def _offset_ms(offsets_s) -> np.ndarray:
    """Candidate offsets (D,) s as the offset_ms timeline's integer milliseconds."""
    return np.round(np.asarray(offsets_s, np.float64) * 1000.0).astype(np.int64)


def _num(x: Any) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _fmt(x: Any, unit: str = "", prec: int = 4) -> str:
    v = _num(x)
    return "n/a" if v is None else f"{v:+.{prec}f}{unit}"


def _decoded(jpeg: bytes, draw_order: float | None = None) -> rr.Image:
    """A JPEG as a decoded image. For images shown on the offset timeline: rerun 0.41's viewer
    shows no EncodedImage (JPEG) while the time cursor is at a negative value of a sequence
    timeline, and about half of the candidate offsets are negative; decoded images show."""
    import cv2
    bgr = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    return rr.Image(bgr, color_model="BGR", draw_order=draw_order)


def _video_codec(path: str) -> str | None:
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
        signals.checkpoint()  # every hook is a safe point to stop at
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
        self._timed_videos = False  # a video was logged on the time timeline (it had an offset)
        self._summary: RunResult | None = None
        self._flushed_videos = False
        self._pairs_logged: list[str] = []
        self._transfer_logged: list[str] = []  # cameras whose point-transfer check was logged
        self._three_view_logged: list[str] = []  # cameras whose three-view check was logged
        self._votes_logged: list[str] = []  # "a__b" of the pairs whose geometric votes were logged
        self._pair_views: dict[str, set[str]] = {}  # "a__b" -> views with data ("landscape", "epipolar")
        self._sweep_frames: dict[str, int] = {}  # video -> frame shown by an epipolar view of it
        self._offset_ms_min: int | None = None  # smallest candidate offset logged (offset_ms)
        self._offset_ms_max: int | None = None
        self._notes: list[str] = []  # stage events, repeated in the guide
        self._eye: tuple | None = None  # 3D view's (position, look target, up), world
        self._events = 0
        self._cams_logged: set[str] = set()
        self._labels: dict[str, str] | None = None  # display_names of the videos so far
        self._framed: set[str] = set()  # videos with images (JPEG frames or an embedded video)
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
                    self._framed.add(info.name)
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
            self._framed.add(name)

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

    def _extend_offset_range(self, ms: np.ndarray) -> None:
        """Widen the range of candidate offsets logged on offset_ms (the stills are logged at its
        start, and the viewer opens on that timeline when it is not empty)."""
        if len(ms):
            lo, hi = int(np.min(ms)), int(np.max(ms))
            self._offset_ms_min = lo if self._offset_ms_min is None else min(lo, self._offset_ms_min)
            self._offset_ms_max = hi if self._offset_ms_max is None else max(hi, self._offset_ms_max)

    def _on_offsets(self, path: str, style, ms: np.ndarray, values: np.ndarray) -> None:
        """A static series style and its values (D,) at ms (D,) on the offset_ms timeline (Stage 0's
        votes and point transfer: a run that stops before Stage 1 still gets its stills there)."""
        self.rec.log(path, style, static=True)
        self._extend_offset_range(ms)
        if len(ms):
            self.rec.send_columns(path, [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms)],
                                  rr.Scalars.columns(scalars=np.asarray(values, np.float64)))

    @_timed
    def pair_votes(self, a: str, b: str, offsets_s: np.ndarray, votes: np.ndarray, z: np.ndarray,
                   chosen_s: float | None) -> None:
        base = pair_votes_path(a, b)
        self._votes_logged.append(f"{a}__{b}")
        offsets_s, z = np.asarray(offsets_s, np.float64), np.asarray(z, np.float64)
        ms = _offset_ms(offsets_s)
        self._on_offsets(f"{base}/z", rr.SeriesLines(names=[f"{a}→{b}"], widths=[1.2]), ms, z)
        self._on_offsets(f"{base}/count", rr.SeriesLines(names=[f"{a}→{b} votes"], widths=[1.0]), ms, votes)
        if chosen_s is not None and len(ms):
            i = int(np.argmin(np.abs(offsets_s - chosen_s)))
            self._on_offsets(f"{base}/chosen", rr.SeriesPoints(colors=[ACCEPTED], markers=["diamond"], marker_sizes=[6.0],
                                                               names=[f"{a}→{b} kept"]),
                             _offset_ms([chosen_s]), z[i:i + 1])

    @_timed
    def transfer_landscape(self, camera: str, offsets_s: np.ndarray, share: np.ndarray,
                           joint_offset_s: float, transfer_offset_s: float | None, confirmed: bool) -> None:
        base = transfer_path(camera)
        self._transfer_logged.append(camera)
        offsets_s, share = np.asarray(offsets_s, np.float64), np.asarray(share, np.float64)
        ms = _offset_ms(offsets_s)
        color = ACCEPTED if confirmed else REJECTED
        mark = "✓" if confirmed else "✗"
        self._on_offsets(f"{base}/share", rr.SeriesLines(colors=[color], widths=[1.5],
                                                         names=[f"{mark} {camera}: samples on their track"]), ms, share)
        for what, at, colour, marker in (("joint", joint_offset_s, palette.SOLVED, "circle"),
                                         ("peak", transfer_offset_s, color, "diamond")):
            if at is None or not len(ms):
                continue
            i = int(np.argmin(np.abs(offsets_s - at)))
            self._on_offsets(f"{base}/{what}", rr.SeriesPoints(colors=[colour], markers=[marker], marker_sizes=[6.0],
                                                               names=[f"{camera}: {what} offset"]),
                             _offset_ms([at]), share[i:i + 1])

    @_timed
    def three_view_landscape(self, camera: str, offsets_s: np.ndarray, supporters: np.ndarray,
                             joint_offset_s: float, passed: bool) -> None:
        base = three_view_path(camera)
        offsets_s, supporters = np.asarray(offsets_s, np.float64), np.asarray(supporters, np.float64)
        if not len(offsets_s):
            return
        self._three_view_logged.append(camera)
        ms = _offset_ms(offsets_s)
        color = ACCEPTED if passed else REJECTED
        self._on_offsets(f"{base}/supporters", rr.SeriesLines(
            colors=[color], widths=[1.5], names=[f"{'✓' if passed else '✗'} {camera}: trajectories followed"]),
            ms, supporters)
        i = int(np.argmin(np.abs(offsets_s - joint_offset_s)))
        self._on_offsets(f"{base}/joint", rr.SeriesPoints(colors=[palette.SOLVED], markers=["circle"], marker_sizes=[6.0],
                                                           names=[f"{camera}: joint offset"]),
                         _offset_ms([joint_offset_s]), supporters[i:i + 1])

    @_timed
    def pair_landscape(self, landscape: PairLandscape, view: PairRecordView | None = None) -> None:
        self._log_landscape(landscape, view)
        if landscape.rate_landscape is not None:
            self._log_rate_landscape(landscape, view)
        self._log_decision(landscape, view)
        if view is not None and view.sweep is not None:
            self._log_epipolar(landscape, view)

    @_timed
    def sync_result(self, result: SyncResult, view: RunRecordView | None = None) -> None:
        self._result, self._view = result, view
        if view is not None:
            self._log_graph(result, view)
            self._log_loops(view)
        self._log_solve(result)
        self._flush_videos(result.offsets_s)
        if view is not None:
            self._log_trajectories(view)

    @_timed
    def stage_event(self, stage: str, message: str, **numbers: Any) -> None:
        self._events += 1
        extra = ", ".join(f"{k}={v}" for k, v in numbers.items())
        self._notes.append(f"{stage}: {message}" + (f" ({extra})" if extra else ""))
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
                summary = run_result_from_sync(r, gt)
            self._log_final_offsets()
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
                "pairs": self._pairs_logged, "labels": self.display_names()}), media_type="text/plain"),
                static=True)
            names = list(self._videos) or (self._bundle.names if self._bundle else [])
            if not self._pairs_logged and self._notes and self._offset_ms_min is not None:
                # a run that stopped in Stage 0 has no pair decisions on offset_ms, where the
                # viewer opens: its events (why each camera was refused) go there too
                self.rec.reset_time()
                self.rec.set_time(TIMELINE_OFFSET_MS, sequence=self._offset_ms_min)
                for note in self._notes:
                    self.rec.log(log_path("stage0"), rr.TextLog(note, level=rr.TextLogLevel.INFO))
                self.rec.reset_time()
            self._log_pairs_table()
            self._log_guide(names)
            self.rec.send_blueprint(self.blueprint(names), make_active=True, make_default=True)
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

    def blueprint(self, names: list[str]):
        """The default blueprint of what was logged so far (record/blueprint.py)."""
        timeline = (TIMELINE_OFFSET_MS if self._offset_ms_min is not None else
                    TIMELINE_TIME if self._timed_videos else TIMELINE_FRAME)
        rng = (self._offset_ms_min, self._offset_ms_max) if self._offset_ms_min is not None else None
        # a pair logged without a finite energy or an epipolar view gets its decision alone (the
        # blueprint assumes both for a pair it is not told about, and would open on empty views)
        views = {k: self._pair_views.get(k, set()) for k in self._pairs_logged}
        return blueprint(names, self._pairs_logged, self._result, views, timeline,
                         has_loops=bool(self._view is not None and self._view.triangles), range_ms=rng,
                         sizes={n: (b.info.width, b.info.height) for n, b in self._videos.items()},
                         eye=self._eye, transfer_origin=CUES_TRANSFER if self._transfer_logged else None,
                         three_view_origin=CUES_THREE_VIEW if self._three_view_logged else None,
                         votes_logged=self._votes_logged,
                         show_world=bool(self._world_cameras) or self._bundle is not None,
                         offsets_logged=self._summary is not None, labels=self.display_names(),
                         with_frames=self._framed)

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

    def _truth(self) -> dict[str, float] | None:
        """The true offsets when the run knows them (its cue bundle's, or the run summary's)."""
        if self._bundle is not None and self._bundle.gt_offsets_s:
            return self._bundle.gt_offsets_s
        return self._summary.gt_offsets_s if self._summary is not None else None

    def display_names(self) -> dict[str, str]:
        """Video -> the short name panel titles and legends draw it by (analysis.display_names),
        from every video the run was given, in their order."""
        names = list(self._videos) or (self._bundle.names if self._bundle else [])
        if self._labels is None or list(self._labels) != names:
            self._labels = short_names_of(names)
        return self._labels

    def _camera_color(self, name: str) -> tuple[int, int, int]:
        names = list(self._videos) or (self._bundle.names if self._bundle else [])
        return palette.category(names.index(name) if name in names else len(names))

    def _log_cameras_static(self, cams: dict[str, CameraTrack], videos: list[VideoInfo]) -> None:
        """Pinhole and (static) pose of each camera, once per camera; a labelled point at each
        camera's centre (the middle pose of a moving one), in the camera's colour."""
        if not cams:
            return
        dist = FRUSTUM_SCALE * scene_scale(cams)
        new = False
        for v in videos:
            cam = cams.get(v.name)
            if cam is None or v.name in self._cams_logged:
                continue
            self._cams_logged.add(v.name)
            new = True
            base = camera_path(v.name)
            K0 = cam.K if cam.K.ndim == 2 else cam.K[0]
            self.rec.log(base, rr.Pinhole(image_from_camera=K0, resolution=[v.width, v.height],
                                          camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=dist,
                                          color=self._camera_color(v.name), line_width=rr.Radius.ui_points(1.5)),
                         static=True)
            if not cam.is_moving:
                T = cam.cam_from_world
                self.rec.log(base, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3],
                                                  relation=rr.TransformRelation.ChildFromParent), static=True)
            else:
                C = cam.centers()
                self.rec.log(camera_trail_path(v.name),
                             rr.LineStrips3D([C[np.isfinite(C).all(1)].astype(np.float32)],
                                             colors=[self._camera_color(v.name)],
                                             radii=rr.Radius.ui_points(1.5),
                                             labels=[f"{self.display_names().get(v.name, v.name)} path"]),
                             static=True)
        if new:
            self._eye = eye_behind(cams)
            names = [n for n in self._cams_logged if n in cams]
            centres, labels, colors = [], [], []
            for n in sorted(names, key=lambda n: list(cams).index(n)):
                C = cams[n].centers()
                C = C[np.isfinite(C).all(1)]
                if len(C):
                    centres.append(C[len(C) // 2])
                    labels.append(self.display_names().get(n, n))
                    colors.append(self._camera_color(n))
            if centres:
                self.rec.log(camera_labels_path(), rr.Points3D(np.array(centres, dtype=np.float32),
                                                               labels=labels, colors=colors,
                                                               radii=rr.Radius.ui_points(4.0),
                                                               show_labels=True), static=True)

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
            if self._offset_ms_min is not None:  # the middle pose on the offset timeline (see top)
                Tm = T[n // 2]
                self.rec.reset_time()
                self.rec.set_time(TIMELINE_OFFSET_MS, sequence=self._offset_ms_min)
                self.rec.log(camera_path(name), rr.Transform3D(
                    translation=Tm[:3, 3], mat3x3=Tm[:3, :3], relation=rr.TransformRelation.ChildFromParent))
                self.rec.reset_time()

    # ---- internals: videos ----

    @staticmethod
    def _indexes(info: VideoInfo, frames: np.ndarray, offset_s: float | None) -> list:
        idx = [rr.TimeColumn(TIMELINE_FRAME, sequence=np.asarray(frames, dtype=np.int64))]
        if offset_s is not None and math.isfinite(offset_s):
            idx.append(rr.TimeColumn(TIMELINE_TIME, duration=info.timestamps_s[frames] + offset_s))
        return idx

    def _flush_videos(self, offsets: dict[str, float | None]) -> None:
        self._flushed_videos = True
        # whether any video is on the time timeline (else the viewer opens on frame: see blueprint)
        self._timed_videos = any(o is not None and math.isfinite(o) for o in offsets.values())
        total = sum(len(b.jpeg) + len(b.masks) for b in self._videos.values())
        bar = tqdm(total=total, desc="recording frames", unit="frame", leave=False,
                   disable=not self.progress or total < 50)
        max_id = max((int(m.max(initial=0)) for b in self._videos.values() for m in b.masks.values()), default=0)
        self.rec.log(VIDEOS, annotation_context(min(max(max_id, 1), 255)), static=True)
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
            self._log_still(name, buf)
            buf.jpeg.clear()
            buf.masks.clear()
        bar.close()
        self._log_moving_cameras(offsets)

    def _log_still(self, name: str, buf: _VideoBuffer) -> None:
        """One frame of the video (the one its epipolar view shows, else the middle one) with its
        mask and tracks, at the smallest candidate offset on the offset timeline (see top)."""
        if self._offset_ms_min is None:
            return
        info, W, H = buf.info, buf.info.width, buf.info.height
        frames = sorted(buf.jpeg) if buf.jpeg else (list(range(len(buf.asset_timestamps_ns)))
                                                     if buf.asset and buf.asset_timestamps_ns is not None else [])
        if not frames:
            return
        want = self._sweep_frames.get(name, frames[len(frames) // 2])
        k = min(frames, key=lambda f: abs(f - want))
        base = video_still_path(name)
        self.rec.reset_time()
        self.rec.set_time(TIMELINE_OFFSET_MS, sequence=self._offset_ms_min)
        # draw orders below the live frames (-10), in case a view shows both
        if buf.jpeg:
            w, h = buf.image_size
            self.rec.log(f"{base}/image", rr.Transform3D(scale=[W / w, H / h, 1.0]), static=True)
            self.rec.log(f"{base}/image", _decoded(buf.jpeg[k], draw_order=-30.0))
        else:
            self.rec.log(f"{base}/image", rr.VideoFrameReference(
                nanoseconds=int(buf.asset_timestamps_ns[k]), video_reference=video_asset_path(name),
                draw_order=-30.0))
        if buf.masks:
            km = min(buf.masks, key=lambda f: abs(f - k))
            m = buf.masks[km]
            self.rec.log(f"{base}/mask", rr.Transform3D(scale=[W / m.shape[1], H / m.shape[0], 1.0]), static=True)
            self.rec.log(f"{base}/mask", rr.SegmentationImage(m, opacity=0.4, draw_order=-29.0))
        tv = self._view.tracks.get(name) if self._view is not None else None
        if tv is not None and k < tv.xy.shape[1]:
            seen = np.isfinite(tv.xy[:, k]).all(-1)
            if seen.any():
                self.rec.log(f"{base}/tracks", rr.Points2D(tv.xy[seen, k].astype(np.float32),
                                                           colors=instance_colors(tv.instance[seen]),
                                                           radii=[rr.Radius.ui_points(2.5)], draw_order=-28.0))
        self.rec.log(base, rr.TextDocument(f"{name} frame {k} (τ = {info.timestamps_s[k]:.3f} s): shown on "
                                           "the offset timeline; switch to `time` to play the synchronized videos"))
        self.rec.reset_time()

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
        key = f"{land.a}__{land.b}"
        self._pairs_logged.append(key)
        ms = _offset_ms(land.offsets_s)
        self._extend_offset_range(ms)
        e = np.asarray(land.energy, dtype=np.float64)
        ok = np.isfinite(e)
        color = ACCEPTED if land.decision.accepted else REJECTED
        mark = "✓" if land.decision.accepted else "✗"
        short = self.display_names()
        # one colour per pair (its verdict is the chosen marker's colour and shape), the pair in
        # the series' name: "all landscapes" shows every pair's energy in one plot
        self.rec.log(f"{base}/energy", rr.SeriesLines(
            colors=[palette.category(len(self._pairs_logged) - 1, palette.PAIR)],
            names=[f"{mark} {short.get(land.a, land.a)}→{short.get(land.b, land.b)}"],
            widths=[1.5 if land.decision.accepted else 1.0]), static=True)
        if ok.any():
            self._pair_views.setdefault(key, set()).add("landscape")
            self.rec.send_columns(f"{base}/energy", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[ok])],
                                  rr.Scalars.columns(scalars=e[ok]))
        mi = np.asarray(land.minima_idx, dtype=np.int64)
        self.rec.log(f"{base}/minima", rr.SeriesPoints(colors=[MINIMA], names=["minima"], markers=["circle"],
                                                       marker_sizes=[4.0]), static=True)
        if len(mi):
            self.rec.send_columns(f"{base}/minima", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[mi])],
                                  rr.Scalars.columns(scalars=e[mi]))
        if math.isfinite(land.best_offset_s) and math.isfinite(land.best_energy):
            self.rec.log(f"{base}/chosen", rr.SeriesPoints(
                colors=[color], names=[f"{mark} chosen" if land.decision.accepted else f"{mark} best (rejected)"],
                markers=["diamond" if land.decision.accepted else "cross"], marker_sizes=[7.0]), static=True)
            self.rec.send_columns(f"{base}/chosen",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=[round(land.best_offset_s * 1000)])],
                                  rr.Scalars.columns(scalars=[land.best_energy]))
        if land.confirm_energy is not None:
            self._log_confirm_landscape(base, land, ms)
        if land.window_s is not None:
            self._log_window(base, land, e[ok])
        if view is not None and view.true_offset_s is not None and view.true_energy is not None:
            self.rec.log(f"{base}/truth", rr.SeriesPoints(colors=[TRUTH], names=["true Δ"],
                                                          markers=["plus"], marker_sizes=[7.0]), static=True)
            self.rec.send_columns(f"{base}/truth",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=[round(view.true_offset_s * 1000)])],
                                  rr.Scalars.columns(scalars=[view.true_energy]))

    def _log_window(self, base: str, land: PairLandscape, energy: np.ndarray) -> None:
        """The Δ_ab the --around windows allow: a bar from its lower to its upper bound, at the
        height of the landscape's highest energy (the energy is searched within it only)."""
        lo_ms, hi_ms = (round(x * 1000) for x in land.window_s)
        top = float(np.max(energy)) if len(energy) else 1.0
        self.rec.log(f"{base}/window", rr.SeriesLines(colors=[WINDOW], widths=[3.0],
                                                      names=[f"--around window {land.window_s[0]:+.3f}..."
                                                             f"{land.window_s[1]:+.3f} s"]), static=True)
        self.rec.send_columns(f"{base}/window", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=[lo_ms, hi_ms])],
                              rr.Scalars.columns(scalars=[top, top]))

    def _log_confirm_landscape(self, base: str, land: PairLandscape, ms: np.ndarray) -> None:
        """The energy of the pair's track pairs found by appearance alone (its unchecked ones left
        out), beside the full one: where its minimum lies is what confirmed or refused the pair.
        Drawn over the full landscape's range (its own robust scale differs, often tenfold), so
        the two shapes compare; result.json keeps its values."""
        e = over_range(land.confirm_energy, land.energy)
        ok = np.isfinite(e)
        self.rec.log(f"{base}/appearance_only", rr.SeriesLines(colors=[APPEARANCE_ONLY], widths=[1.0],
                                                               names=["appearance pairs alone (rescaled)"]),
                     static=True)
        if ok.any():
            self.rec.send_columns(f"{base}/appearance_only", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[ok])],
                                  rr.Scalars.columns(scalars=e[ok]))
        if math.isfinite(land.confirm_offset_s):
            at = float(np.interp(land.confirm_offset_s, land.offsets_s[ok], e[ok])) if ok.any() else float("nan")
            self.rec.log(f"{base}/appearance_only_best",
                         rr.SeriesPoints(colors=[APPEARANCE_ONLY], names=["its minimum"], markers=["diamond"],
                                         marker_sizes=[5.0]), static=True)
            self.rec.send_columns(f"{base}/appearance_only_best",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=[round(land.confirm_offset_s * 1000)])],
                                  rr.Scalars.columns(scalars=[at]))

    def _log_rate_landscape(self, land: PairLandscape, view: PairRecordView | None) -> None:
        base = pair_rate_landscape_path(land.a, land.b)
        rl = land.rate_landscape
        self.rec.log(f"{base}/energy", rr.Tensor(np.asarray(rl.energy, dtype=np.float32),
                                                 dim_names=["rate_ppm", "offset_at_pivot"]), static=True)
        if view is not None and view.rate_image is not None:
            self.rec.log(f"{base}/image", rr.Image(view.rate_image, color_model="RGB"), static=True)
        self.rec.log(f"{base}/axes", rr.TextDocument(
            f"rows: rate - 1 = {rl.rates_ppm[0]:+.0f} .. {rl.rates_ppm[-1]:+.0f} ppm (top to bottom); "
            f"columns: τ_a - τ_b at b's local time {rl.pivot_s:.3f} s = {rl.offsets_s[0]:+.4f} .. "
            f"{rl.offsets_s[-1]:+.4f} s (left to right); chosen: white ring "
            f"({land.pivot_offset_s:+.4f} s, {(land.rate - 1) * 1e6:+.1f} ppm); truth: orange cross",
            media_type="text/plain"), static=True)

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
        if land.confirm_energy is not None:  # the grey curve of the landscape
            rows.append(("appearance pairs alone", f"minimum {_fmt(land.confirm_offset_s, ' s')}"
                         if math.isfinite(land.confirm_offset_s) else "no accepted minimum"))
        short = self.display_names()
        sa, sb = short.get(land.a, land.a), short.get(land.b, land.b)
        full = f"\n\n{land.a} → {land.b}" if (sa, sb) != (land.a, land.b) else ""
        md = (f"## {sa} → {sb}: {verdict}{full}\n\n**reason:** {d.reason}\n\n| | |\n|---|---|\n"
              + "\n".join(f"| {k} | {v} |" for k, v in rows)
              + f"\n\n**minima (best first):** {minima or 'none'}\n")
        self.rec.log(pair_decision_path(land.a, land.b), rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN),
                     static=True)
        self.rec.reset_time()
        self._events += 1
        self.rec.set_time(TIMELINE_EVENT, sequence=self._events)
        # also at its chosen Δ on the offset timeline (the viewer opens there; a pair without one
        # at its first candidate), so that the decision log is not empty on it
        at = land.best_offset_s if math.isfinite(land.best_offset_s) else \
            (float(land.offsets_s[0]) if len(land.offsets_s) else None)
        if at is not None:
            self.rec.set_time(TIMELINE_OFFSET_MS, sequence=round(at * 1000))
        self.rec.log(LOG_DECISIONS, rr.TextLog(
            f"{land.a}__{land.b} {verdict.lower()} Δ={_fmt(land.best_offset_s, ' s')}: {d.reason}",
            level=rr.TextLogLevel.INFO if d.accepted else rr.TextLogLevel.WARN))
        self.rec.reset_time()

    def _log_epipolar(self, land: PairLandscape, view: PairRecordView) -> None:
        sw = view.sweep
        buf = self._videos.get(land.a)
        base = pair_epipolar_path(land.a, land.b)
        self._pair_views.setdefault(f"{land.a}__{land.b}", set()).add("epipolar")
        self._sweep_frames.setdefault(land.a, int(sw.frame_a))
        va = buf.info if buf is not None else self._bundle.video(land.a)
        W, H = va.width, va.height
        self.rec.log(base, rr.TextDocument(
            f"frame {sw.frame_a} of {land.a} (τ = {sw.time_a_s:.3f} s). Lines: epipolar lines of "
            f"{land.b}'s paired points at τ − Δ, in their instance's colour; points: {land.a}'s points, "
            "yellow when on their line, blue when far. Scrub `offset_ms`: lines pass through "
            f"the points only near the right Δ (chosen {_fmt(land.best_offset_s, ' s')})."),
            static=True)
        self.rec.log(f"{base}/border", rr.LineStrips2D([[[0, 0], [W, 0], [W, H], [0, H], [0, 0]]],
                                                       colors=[GREY]), static=True)
        if buf is not None and sw.frame_a in buf.jpeg:
            w, h = buf.image_size
            self.rec.log(f"{base}/image", rr.Transform3D(scale=[W / w, H / h, 1.0]), static=True)
            self.rec.log(f"{base}/image", _decoded(buf.jpeg[sw.frame_a]), static=True)
        elif buf is not None and buf.asset and buf.asset_timestamps_ns is not None:
            self.rec.log(f"{base}/image", rr.VideoFrameReference(
                nanoseconds=int(buf.asset_timestamps_ns[sw.frame_a]),
                video_reference=video_asset_path(land.a)), static=True)
        ms = _offset_ms(sw.offsets_s)
        cols_inst = instance_colors(sw.instance)
        ramp_px = distance_ramp_px(sw.distance_px)  # over all offsets shown
        lines_pos, lines_col, line_len, pt_col = [], [], [], []
        for d in range(len(ms)):
            seg = sw.segments[d]
            ok = np.isfinite(seg).all((1, 2))
            c = distance_colors(sw.distance_px[d], ramp_px)
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
        # in screen points: the views shrink a 1280 px frame to a few hundred px
        self.rec.log(f"{base}/points_a", rr.Points2D.from_fields(radii=[rr.Radius.ui_points(4.0)]), static=True)
        self.rec.log(f"{base}/lines", rr.LineStrips2D.from_fields(radii=[rr.Radius.ui_points(0.75)]), static=True)
        med = view.sweep_median_px
        okm = np.isfinite(med)
        if okm.any():
            self.rec.log(f"{base}/median_distance_px", rr.SeriesLines(names=["median point-line distance (px)"],
                                                                      colors=[MINIMA]), static=True)
            self.rec.send_columns(f"{base}/median_distance_px",
                                  [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[okm])],
                                  rr.Scalars.columns(scalars=med[okm]))

    # ---- internals: Stage 2 ----

    def _log_graph(self, result: SyncResult, view: RunRecordView) -> None:
        ids, labels, cols, radii, P = [], [], [], [], []
        short = self.display_names()
        for v, off in result.offsets_s.items():
            ids.append(v)
            name = short.get(v, v)
            labels.append(f"{name} {_fmt(off, ' s', 3)}" if off is not None else f"{name} unresolved")
            cols.append(self._camera_color(v) if off is not None else GREY)
            radii.append(18.0)
            P.append(view.graph_xy[v])
        edges = []
        for p in result.pairs:
            mid = f"{p.a}__{p.b}"
            acc = p.decision.accepted
            ids.append(mid)
            # short labels (long ones overlapped); the reasons are in the pairs table
            labels.append(f"✓ {_fmt(p.best_offset_s, ' s', 3)}" if acc else "✗")
            cols.append(ACCEPTED if acc else REJECTED)
            radii.append(6.0)
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
        E = len(result.solve_pairs)
        for e, (a, b) in enumerate(result.solve_pairs):
            tcol = [rr.TimeColumn(TIMELINE_ITERATION, sequence=its)]
            self.rec.send_columns(solve_residual_path(a, b), tcol, rr.Scalars.columns(scalars=R[:, e]))
            self.rec.send_columns(solve_weight_path(a, b), tcol, rr.Scalars.columns(scalars=Wt[:, e]))
            # the same numbers as bars grouped by iteration, static: shown on every timeline,
            # in the colour of the pair's landscape
            key = f"{a}__{b}"
            colour = palette.category(self._pairs_logged.index(key) if key in self._pairs_logged else e,
                                      palette.PAIR)
            x = its + (e + 0.5) / (E + 1) - 0.5
            sa, sb = (self.display_names().get(n, n) for n in (a, b))  # the legend shows the path
            for path, values in ((irls_residual_path(sa, sb), np.abs(R[:, e])), (irls_weight_path(sa, sb), Wt[:, e])):
                self.rec.log(path, rr.BarChart(np.nan_to_num(values), abscissa=x, widths=[0.9 / (E + 1)] * len(x),
                                               color=colour), static=True)

    def _log_final_offsets(self) -> None:
        """The offsets table, once, when the recording closes: the run's summary (every input
        video, Stage 0's left out too, each null in a few words and below the table in full), else
        Stage 2's result when its record view was given; nothing before Stage 2."""
        if self._summary is not None:
            s = self._summary
            self._log_offsets(s.reference, s.solver, s.offsets_s, s.uncertainty_s, s.headlines(), self._view,
                              s.unresolved)
        elif self._result is not None and self._view is not None:
            r = self._result
            self._log_offsets(r.reference, r.solver, r.offsets_s, r.uncertainty_s, r.unresolved_reason, self._view)

    def _log_offsets(self, reference: str, solver: str, offsets_s: dict, uncertainty_s: dict, notes: dict,
                     view: RunRecordView | None, in_full: dict | None = None) -> None:
        """The offsets table (notes: video -> why it is null; truth and errors from view, when
        given), and below it each null's note again (the table's cell is cut to the panel's width)
        with its whole reason (in_full), when given."""
        rows = []
        for v, off in offsets_s.items():
            u = uncertainty_s.get(v)
            t = view.true_offsets_s.get(v) if view is not None else None
            err = view.errors_ms.get(v) if view is not None else None
            note = notes.get(v, '').replace("|", "/") if off is None else ''
            rows.append(f"| {v} | {_fmt(off)} | {_fmt(u, '', 4) if u is not None else '-'} | "
                        f"{_fmt(t) if t is not None else '-'} | "
                        f"{f'{err:.1f}' if err is not None and t is not None else '-'} | {note} |")
        md = (f"## Offsets (reference {reference}, solver {solver})\n\n"
              "| video | offset_s | ± s | true_s | error_ms | note |\n|---|---|---|---|---|---|\n" + "\n".join(rows))
        nulls = [v for v, off in offsets_s.items() if off is None and v in (in_full or {})]
        if nulls:
            md += "\n\n### Why each null has no offset\n\n" + "\n\n".join(
                f"**{v}**: {notes.get(v) or in_full[v]}" + (f"\n\n> in full: {in_full[v]}" if in_full[v] != notes.get(v) else "")
                for v in nulls)
        self.rec.log(SYNC_OFFSETS, rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN), static=True)

    def _log_loops(self, view: RunRecordView) -> None:
        if not view.triangles:
            return
        rows = [f"| {t.a} → {t.b} → {t.c} | {t.residual_ms:+.1f} | {t.tolerance_ms:.1f} | "
                f"{'closes' if t.closes else '**LOOP OFF**'} | {t.accepted}/3 |" for t in view.triangles[:40]]
        more = len(view.triangles) - len(rows)
        md = ("## Loop closure per triangle of pairs\n\nOffsets are differences, so the chosen "
              "Δ_ab + Δ_bc − Δ_ac is 0 ms when all three pairs are right. A large residual names a "
              "triangle with at least one wrong pair; a pair in several large triangles is the "
              "suspect. The tolerance is `vs-inspect inspect`'s: 2 frames of the slowest video, or "
              "3σ of the pairs' uncertainties. Largest first.\n\n| triangle a → b → c | residual ms "
              "| tolerance ms | loop | pairs accepted |\n|---|---|---|---|---|\n" + "\n".join(rows)
              + (f"\n\n{more} more triangles with smaller residuals are not listed." if more > 0 else ""))
        self.rec.log(SYNC_LOOPS, rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN), static=True)

    def _log_pairs_table(self) -> None:
        """Every pair's verdict, Δ and reason in one table, in the containers' order."""
        r = self._result
        if r is None or not r.pairs:
            return
        truth = self._truth()
        short = self.display_names()
        rows = []
        for i, p in enumerate(pair_order(r.pairs)):
            true = (truth[p.b] - truth[p.a]) if truth and p.a in truth and p.b in truth else None
            rows.append(f"| {'✓' if p.decision.accepted else '✗'} | {short.get(p.a, p.a)} → {short.get(p.b, p.b)} | "
                        f"{_fmt(p.best_offset_s, '', 3)} | {_fmt(true, '', 3) if true is not None else '-'} | "
                        f"{p.decision.contrast:.2f} | {p.num_track_pairs} | {p.decision.reason} |"
                        + (" (no container)" if i >= MAX_PAIR_CONTAINERS else ""))
        n_rej = sum(not p.decision.accepted for p in r.pairs)
        md = (f"## Pairs: {len(r.pairs) - n_rej} accepted, {n_rej} rejected\n\n"
              "| | pair a → b | chosen Δ_ab s | true Δ_ab s | contrast | track pairs | reason |\n"
              "|---|---|---|---|---|---|---|\n" + "\n".join(rows))
        self.rec.log(SYNC_PAIRS, rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN), static=True)

    def _log_guide(self, names: list[str]) -> None:
        """The "how to read this recording" document."""
        r = self._result
        legend = legend_lines(self.display_names())
        names_legend = ("\n\nPanel titles, legends and the pair graph draw the videos by short names: "
                        + "; ".join(f"**{line.split(' = ', 1)[0]}** = {line.split(' = ', 1)[1]}" for line in legend)
                        + ".") if legend else ""
        n_pairs = len(r.pairs) if r is not None else len(self._pairs_logged)
        shown = min(n_pairs, MAX_PAIR_CONTAINERS)
        lo, hi = self._offset_ms_min, self._offset_ms_max
        rng = f" ({lo / 1000:+.3f} s to {hi / 1000:+.3f} s)" if lo is not None and hi is not None else ""
        capped = (f" Only the {shown} most informative of the {n_pairs} pairs have a container (rejected "
                  "pairs with the most track pairs first, then accepted pairs from the least clear "
                  "minimum up); every pair is in the **pairs** table and in **all landscapes**; to see "
                  "another pair, add a view with origin `pairs/<a>__<b>`." if n_pairs > shown else "")
        opening = ("""**No pair offset was searched in this run**, so there is no `offset_ms` timeline: the
viewer opens on **`frame`** (each video by its own frame index), and **offsets** (left) says why
each video has no offset; **decision log** and the notes at the end of this guide say what each
stage decided. The rest of this guide describes a run with pairs.""" if lo is None else
                   f"""The viewer opens on the **`offset_ms`** timeline: the candidate pair offset Δ_ab in milliseconds
over the whole search range{rng}. Δ_ab = offset_s[b] − offset_s[a]: video b started Δ_ab later
than a. `vs-inspect view FILE` puts the time cursor at the chosen Δ of the pair in front (`rerun
FILE` opens at the start of the range). Move the cursor (drag it, or type a value in the time
field) to sweep Δ.""")
        md = f"""# How to read this recording

{opening}

**Middle column: one tab per pair a→b, failed pairs first.** ✗ marks a rejected pair, ✓ an accepted
one.{capped}

- *landscape*: the energy E(Δ) of the pair, low where the epipolar constraint holds. The green
  diamond is the chosen Δ (a vermillion cross: a rejected pair's best), grey circles the
  significant minima, a white plus the true Δ when known. A rejected pair usually shows no clear single
  minimum, or its minimum sits at the edge of the search range. A pair timed by the person carrying
  a moving camera seen in the other video (its decision says "sightings of a camera's carrier")
  shows 1 − the share of heads on that camera's centre instead, 0 at the peak; it has no epipolar view. Its
  diamond is the peak fitted again with one constant shift between the heads and the camera
  (the decision gives the shift), so it may sit a little beside the curve's lowest point.
- *epipolar*: one frame of a with the epipolar lines of b's matched points at the cursor's Δ
  (lines in the colour of their moving instance). Points are a's matched points: **yellow** when
  their line passes through them, **blue** when far (scaled to the median distance of this
  pair). At the right Δ the lines go through the points; at a wrong one they miss.
- *decision*: the verdict, its reason and the numbers behind it.

**Left column**: this guide; **pairs** (verdict, chosen and true Δ and reason of every pair);
**offsets** (one per video, with the truth and the error when known); **loop closure** (Δ_ab + Δ_bc
− Δ_ac per triangle of pairs: large residuals point at wrong pairs); the **decision log** (one line
per pair at its chosen Δ). Below: **all landscapes** (every pair's E(Δ), named a→b), the **pair
graph** (videos with their offsets; a node on each evaluated pair's edge, ✓ with Δ or ✗) and the
**IRLS solve** (|residual| and weight per accepted pair, one group of bars per iteration, in the
colours of the pairs' landscapes; the same numbers are on the `iteration` timeline under `sync/solve`).

**Right column**: the videos whose frames the recording holds, and the 3D world. On `offset_ms`
each video shows one still frame with its moving-region mask and tracks. Switch the timeline to **`time`** (seconds after
synchronization) to play the videos together at the solved offsets, or **`frame`** for each
video's own frame index. In 3D: the camera frustums, each labelled with its video's name, a
moving camera's path, and the tracks of accepted pairs triangulated at the solved offsets.

**Colours** (the report's too): green means only *accepted* and vermillion only *rejected* (a
landscape's chosen Δ: green diamond, or vermillion cross for a rejected pair's best); each pair's
curve has a colour of its own; white marks the true Δ (a plus); purple the --around window and
Stage 0's joint vote; yellow a point on its epipolar line and blue one far from it. Each camera has
one colour (its frustum, label and graph node) and each moving object another (its tracks, mask
and lines), never a camera's; the static background of a mask is transparent.

**Video panels empty?** Videos embedded as H.264/AV1 files are decoded by the viewer: the native
viewer runs the `ffmpeg` executable for H.264, which must be on PATH (else the panels say "Failed
to decode: Couldn't find an installation of the FFmpeg executable"); the web viewer
(`rerun --web-viewer FILE.rrd`) decodes in the browser.

Videos in this recording: {", ".join(names) or "none"}.{names_legend}
"""
        if self._notes:
            md += "\n## Notes from the stages\n\n" + "\n".join(f"- {n}" for n in self._notes[-30:]) + "\n"
        self.rec.log(GUIDE, rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN), static=True)

    def _log_trajectories(self, view: RunRecordView) -> None:
        for tj in view.trajectories:
            X = tj.points_world  # (P,T,3)
            ok = np.isfinite(X).all(-1)
            key = trajectory_path(tj.a, tj.b)
            cols = instance_colors(tj.instance)
            strips = [X[sg.track, sg.start:sg.stop].astype(np.float32) for sg in tj.segments]
            scol = [cols[sg.track] for sg in tj.segments]
            if strips:
                self.rec.log(key, rr.LineStrips3D(strips, colors=np.array(scol), radii=rr.Radius.ui_points(2.0)),
                             static=True)
                centre = np.median(np.concatenate(strips), axis=0)
                if len(view.trajectories) <= 3:  # more labels overlap
                    self.rec.log(f"{key}/label", rr.Points3D([centre], labels=[f"tracks {tj.a}-{tj.b}"],
                                                             colors=[GREY], radii=rr.Radius.ui_points(2.0),
                                                             show_labels=True), static=True)
            frames = np.flatnonzero(ok.any(0))
            lengths = [int(ok[:, k].sum()) for k in frames]
            pos = np.concatenate([X[ok[:, k], k] for k in frames]).astype(np.float32)
            pc = np.concatenate([cols[ok[:, k]] for k in frames])
            self.rec.send_columns(f"{key}/points", [rr.TimeColumn(TIMELINE_TIME, duration=tj.time_s[frames])],
                                  rr.Points3D.columns(positions=pos, colors=pc).partition(lengths))
            self.rec.log(f"{key}/points", rr.Points3D.from_fields(radii=[rr.Radius.ui_points(4.0)]), static=True)
