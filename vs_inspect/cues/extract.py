"""Stage 0: videos in, a cue bundle out (cameras, tracks inside moving regions, cross-view pairs).

Each step is a pure function in its own module (motion, tracking, matching, cameras); this
module decodes the videos, calls them in order, reports to the sink and keeps per-stage timings.
A video that cannot be used (unreadable, no camera) is left out of the bundle with its reason
in CueStats.dropped, so that the caller can report it as not synchronized; when no video can be
used, NoUsableVideos carries those reasons instead of a bundle.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import itertools
import logging
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np
from tqdm import tqdm

from ..analysis.record_views import record_frame, record_mask
from ..engine import Engine, LocalEngine, TaskFailed
from ..errors import InputError, NoUsableVideos
from ..record.sink import DeferredSink, NullSink, Sink
from ..types import CameraTrack, CueBundle, CueStats, TrackPairs, Tracks, VideoCueStats, VideoInfo
from .config import CueConfig
from .learned import LEARNED_FEATURES
from .matching import (KeyframeFeatures, extract_keyframe_features, keyframe_indices,
                       match_tracks)
from .motion import moving_regions
from .tracking import track_points

log = logging.getLogger(__name__)

MOVING_POINTS = "moving points"  # the kind of the camera set _estimate builds from the moving points alone


def _owner(kind: str) -> str:
    """Whose cameras a set of `kind` are, for messages: "SIFT's", "the moving points'"."""
    return "the moving points'" if kind == MOVING_POINTS else f"{kind.upper()}'s"


@dataclass
class _VideoCues:
    info: VideoInfo
    path: str
    scale_xy: tuple[float, float]  # full px per working px (x, y)
    xy_full: np.ndarray  # (N,T,2) full-resolution px, distorted
    instance: np.ndarray  # (N,)
    features: KeyframeFeatures
    camera_motion: str
    background_motion_px: float
    moving_fraction: float
    sfm_frames: tuple | None = None  # (indices, BGR images, static masks) for camera estimation
    frame_features: object | None = None  # registration.FrameFeatures of a moving camera's frames
    # a moving camera's frames to register, for a learned reconstruction: (frames (F,) int, their
    # moving regions (F,h,ceil(w/8)) uint8 np.packbits of (h,w) bool at working px, w)
    register_masks: tuple | None = None


def to_full_px(xy: np.ndarray, scale_xy: tuple[float, float]) -> np.ndarray:
    """Working-resolution px -> full-resolution px (pixel centres at integers on both)."""
    s = np.asarray(scale_xy, dtype=np.float64)
    return (xy.astype(np.float64) + 0.5) * s - 0.5


def _sfm_indices(T: int, moving: bool, cfg) -> np.ndarray:
    n = cfg.camera.moving_frames if moving else cfg.camera.static_frames
    return np.unique(np.linspace(0, T - 1, max(1, min(n, T))).round().astype(int))


def _register_indices(info: VideoInfo, cfg) -> np.ndarray:
    """A moving video's frames to register against the reconstruction (cues/registration.py):
    every cfg.camera.register_every-th, at most about register_max_hz per second, and the SfM
    frames too (registered from their neighbours they check the registration)."""
    step = max(cfg.camera.register_every, _frame_step(info, cfg.camera.register_max_hz))
    return np.union1d(np.arange(0, info.num_frames, step), _sfm_indices(info.num_frames, True, cfg))


def _frame_step(info: VideoInfo, max_hz: float) -> int:
    """Every how many frames a video is sampled at most about max_hz times a second (0: every frame)."""
    if max_hz > 0 and info.frame_interval_s > 0:
        return max(1, int(np.ceil(1.0 / (info.frame_interval_s * max_hz) - 1e-6)))
    return 1


def _static_mask(moving: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(H,W) bool, True where camera estimation may take features: moving (h,w) bool at working
    px resized to size (W,H) and dilated, as COLMAP's masks of the SfM images."""
    m = cv2.resize(moving.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST)
    return cv2.dilate(m, np.ones((15, 15), np.uint8)) == 0


def _learned_model_possible(cfg) -> bool:
    """Whether camera estimation may build a learned reconstruction: learned features asked for,
    or auto with XFeat installed (its second try) or ALIKED's tried last."""
    from .cameras import aliked_tried_last
    from .learned import xfeat_available

    return cfg.camera.features in LEARNED_FEATURES or (cfg.camera.features == "auto" and xfeat_available()) \
        or aliked_tried_last(cfg.camera)


def _video_cues(src, cfg: CueConfig, sink: Sink, need_sfm: bool, timings: dict) -> _VideoCues:
    from ..io.video import downscale, iter_frames

    info = src.info
    t0 = time.perf_counter()
    grey = []
    sink_at = set(np.linspace(0, info.num_frames - 1, max(1, cfg.sink_frames)).round().astype(int).tolist())
    # the frames camera estimation may need (static or moving: decided after decoding) are kept
    # from this one pass instead of decoding the video a second time
    sfm_keep = (set(_sfm_indices(info.num_frames, False, cfg).tolist())
                | set(_sfm_indices(info.num_frames, True, cfg).tolist())) if need_sfm else set()
    sfm_images: dict[int, np.ndarray] = {}
    for k, full in iter_frames(src, max_side=None):
        if k in sfm_keep:
            sfm_images[k] = downscale(full, cfg.camera.max_side)
        img = downscale(full, cfg.max_side)
        grey.append(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
        if k in sink_at and sink.options is not None:
            sink.video_frame(info.name, k, record_frame(img, sink.options))
    frames = np.stack(grey)
    h, w = frames.shape[1:]
    scale = (info.width / w, info.height / h)
    timings["decode_s"] = timings.get("decode_s", 0.0) + time.perf_counter() - t0

    t0 = time.perf_counter()
    instances, mode, bg = moving_regions(frames, cfg.motion, cfg.camera_motion.get(info.name),
                                             info.frame_interval_s)
    moving_fraction = float((instances > 0).mean())
    if sink.options is not None:
        for k in sorted(sink_at):
            sink.dynamic_mask(info.name, k, record_mask(instances[k], sink.options))
    timings["motion_s"] = timings.get("motion_s", 0.0) + time.perf_counter() - t0
    log.info("%s: %s camera (background motion %.2f px), moving regions cover %.1f%%",
             info.name, mode, bg, 100 * moving_fraction)

    t0 = time.perf_counter()
    xy, inst = track_points(frames, instances, cfg.track)
    timings["tracking_s"] = timings.get("tracking_s", 0.0) + time.perf_counter() - t0

    t0 = time.perf_counter()
    kf = keyframe_indices(info.num_frames, cfg.match.num_keyframes)
    feats = extract_keyframe_features(frames, (instances > 0) if cfg.match.dynamic_only else None,
                                      kf, xy, cfg.match)
    timings["features_s"] = timings.get("features_s", 0.0) + time.perf_counter() - t0

    sfm = None
    if need_sfm:
        t0 = time.perf_counter()
        idx = _sfm_indices(info.num_frames, mode == "moving", cfg)
        imgs = [sfm_images[k] for k in idx.tolist()]
        del sfm_images
        masks = []
        for k, im in zip(idx, imgs):
            masks.append(_static_mask(instances[k] > 0, (im.shape[1], im.shape[0]))
                         if cfg.camera.mask_moving else None)
        if mode == "static" and len(imgs) > 1:
            # one image of a static camera: the temporal median shows the background without the
            # moving objects; pixels that move in most sampled frames stay masked
            imgs = [np.median(np.stack(imgs), axis=0).astype(np.uint8)]
            if cfg.camera.mask_moving:
                masks = [np.mean([~m for m in masks], axis=0) < 0.5]
            idx = idx[:1]
        sfm = (idx, imgs, masks)
        timings["sfm_frames_s"] = timings.get("sfm_frames_s", 0.0) + time.perf_counter() - t0
    frame_feats = register_masks = None
    if need_sfm and mode == "moving" and cfg.camera.register_every > 0:
        todo = _register_indices(info, cfg)
        if cfg.camera.features not in LEARNED_FEATURES:
            # SIFT's features to register each frame with against a SIFT reconstruction (its
            # database's kind; registration.py), found here where the frames are decoded
            from .registration import frame_features

            t0 = time.perf_counter()
            frame_feats = frame_features(frames, instances if cfg.camera.mask_moving else None, todo, scale,
                                         cfg.camera.max_features)
            timings["frame_features_s"] = timings.get("frame_features_s", 0.0) + time.perf_counter() - t0
        if _learned_model_possible(cfg):
            # a learned reconstruction registers them with its own features, on the frames
            # decoded again at SfM resolution only if it is built (cameras.py); their moving
            # regions are kept here, packed (a bit per pixel)
            register_masks = (todo, np.packbits(instances[todo] > 0, axis=-1), int(instances.shape[2]))
    return _VideoCues(info, str(src.path), scale, to_full_px(xy, scale), inst, feats, mode, bg,
                      moving_fraction, sfm, frame_feats, register_masks)


def _registration_images(src, v: _VideoCues, cfg: CueConfig, chunk: int = 16):
    """(frame index, BGR image at SfM resolution, static mask or None) of v's frames to register
    (v.register_masks), decoded again from src, chunk frames at a time (a long video's frames are
    never all held at once)."""
    from ..io.video import read_frames

    todo, packed, w = v.register_masks
    for start in range(0, len(todo), chunk):
        frames = todo[start:start + chunk]
        for i, (k, img) in enumerate(zip(frames, read_frames(src, frames, cfg.camera.max_side)), start):
            moving = np.unpackbits(packed[i], axis=-1, count=w).astype(bool)
            yield int(k), img, _static_mask(moving, (img.shape[1], img.shape[0])) if cfg.camera.mask_moving else None


@dataclass(frozen=True)
class VideoCuesOutcome:
    """What one video's Stage 0 task returns: its cues, or why it has none, with the views the
    recording keeps (the driver hands them to its sink, so tasks need no sink)."""

    cues: _VideoCues | None  # None when the video could not be read
    error: str | None  # why (None when cues is set)
    frames: tuple  # ((frame index, (h,w,3) uint8 BGR), ...) as the recording keeps them
    masks: tuple  # ((frame index, (h,w) instance ids), ...)
    timings_s: dict  # step -> seconds spent on this video


class _Collect(NullSink):
    """Keeps what _video_cues would show a recording sink, to hand over from a task."""

    def __init__(self, options):
        self.options = options
        self.frames: list = []
        self.masks: list = []

    def video_frame(self, name, frame_index, image_bgr):
        self.frames.append((frame_index, image_bgr))

    def dynamic_mask(self, name, frame_index, instances):
        self.masks.append((frame_index, instances))


def video_cues_task(task: tuple, src) -> VideoCuesOutcome:
    """Stage 0 of one video as an engine task. task: (CueConfig, the sink's RecordOptions or None,
    whether camera-estimation frames are needed); src: its VideoSource (the task opens the file,
    which must be reachable from the worker)."""
    cfg, options, need_sfm = task
    collect, timings = _Collect(options), {}
    try:
        cues = _video_cues(src, cfg, collect, need_sfm, timings)
    except InputError as exc:
        return VideoCuesOutcome(None, str(exc), tuple(collect.frames), tuple(collect.masks), timings)
    return VideoCuesOutcome(cues, None, tuple(collect.frames), tuple(collect.masks), timings)


def _import_cameras(calibration: dict, vids: dict[str, _VideoCues]) -> tuple[dict, dict, dict, dict]:
    """(cameras, undistorted tracks, dropped, {video: undistort (...,2) full px like its tracks})
    from an imported calibration."""
    from ..io.calibration import fit_to_video, to_camera_track, undistort_points

    cams, tracks, dropped, undistort = {}, {}, {}, {}
    for name, v in vids.items():
        cal = calibration.get(name)
        if cal is None:
            dropped[name] = "the calibration has no camera for this video"
            continue
        try:
            cal = fit_to_video(cal, v.info.width, v.info.height, name=name)
        except InputError as exc:
            dropped[name] = str(exc)
            continue
        if cal.cam_from_world.ndim == 3 and len(cal.cam_from_world) != v.info.num_frames:
            dropped[name] = (f"the calibration has {len(cal.cam_from_world)} per-frame poses but the "
                             f"video has {v.info.num_frames} frames")
            continue
        cams[name] = to_camera_track(cal)
        undistort[name] = functools.partial(undistort_points, cal)  # (...,2), NaN kept
        tracks[name] = Tracks(undistort[name](v.xy_full), v.instance)
    return cams, tracks, dropped, undistort


def extract_cues(sources, calibration: dict | None = None, cfg: CueConfig = CueConfig(),
                 sink: Sink | None = None, progress: bool = True,
                 engine: Engine | None = None) -> tuple[CueBundle, CueStats]:
    """Cues of every video: (CueBundle of the usable videos, CueStats).

    engine: where each video's own cues (decoding, moving regions, tracks, features) are
    computed, one task per video (default: in this process); matching across videos, the
    cameras and everything reported to the sink stay here, in video order.

    sources: VideoSource list (vs_inspect.io.video.open_video). calibration: name ->
    CameraCalibration (vs_inspect.io.calibration.load_calibration) or None to estimate the
    cameras with pycolmap. CueStats: timings per step, per-video and per-pair counts, the videos
    left out of the bundle with their reason, the cameras' source.
    """
    sink = sink or NullSink()
    if len(sources) < 2:
        raise InputError(f"need at least 2 videos to synchronize, got {len(sources)}")
    names = [s.info.name for s in sources]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"video names must be unique, got {dup} more than once "
                         "(rename the files or put them in differently named folders)")
    timings: dict[str, float] = {}
    stats: dict = {"videos": {}, "pairs": {}, "dropped": {}, "timings_s": timings,
                   "camera_source": "calibration" if calibration is not None else "estimated"}
    t_all = time.perf_counter()
    vids: dict[str, _VideoCues] = {}
    engine = engine or LocalEngine()
    task = (cfg, sink.options, calibration is None)
    t_videos = time.perf_counter()
    # two videos at a time on threads locally: one video alone kept 2 cores 1.6x busy on average
    # (the 720p scene's four: 23.5 -> 19.4 s, the same tracks). Not with learned keyframe
    # descriptors: they set torch's process-wide thread count around each call
    for src, out in zip(sources, engine.map(video_cues_task, sources, shared=task, desc="cues per video",
                                            unit="video", progress=progress,
                                            threads=cfg.match.descriptor == "sift")):
        sink.video(src.info, str(src.path))
        if isinstance(out, TaskFailed):  # its worker or node died
            out = VideoCuesOutcome(None, out.reason, (), (), {})
        for k, img in out.frames:
            sink.video_frame(src.info.name, k, img)
        for k, mask in out.masks:
            sink.dynamic_mask(src.info.name, k, mask)
        for step, sec in out.timings_s.items():
            timings[step] = timings.get(step, 0.0) + sec
        if out.cues is None:
            stats["dropped"][src.info.name] = f"could not be read: {out.error}"
            sink.stage_event("cues", f"{src.info.name}: could not be read: {out.error}")
            log.warning("%s: could not be read: %s", src.info.name, out.error)
            continue
        v = out.cues
        vids[src.info.name] = v
        n_tracks = v.xy_full.shape[0]
        stats["videos"][src.info.name] = {
            "path": v.path, "camera_motion": v.camera_motion,
            "background_motion_px": round(v.background_motion_px, 3),
            "moving_fraction": round(v.moving_fraction, 4), "tracks": int(n_tracks),
            "instances": int(len(np.unique(v.instance[v.instance > 0]))),
            "keyframe_features": int(len(v.features.frame)),
            "snapped_features": int((v.features.track >= 0).sum()),
        }
        if v.moving_fraction == 0 or n_tracks == 0:
            msg = "no moving regions found (nothing moves in this video)" if v.moving_fraction == 0 \
                else "no point tracks inside the moving regions"
            stats["videos"][src.info.name]["note"] = msg
            sink.stage_event("cues", f"{src.info.name}: {msg}")
            log.warning("%s: %s", src.info.name, msg)

    # the per-video steps' times are sums over videos, which may run two at a time: this is the wall time
    timings["videos_s"] = time.perf_counter() - t_videos
    # a camera seen moving: the heads are found on a thread of their own while the cameras are
    # estimated (COLMAP's mapping keeps one core) and the geometric pairs voted; they are only
    # used when a camera moves in the end
    ahead = _HeadsAhead.start(sources, vids, cfg) \
        if cfg.heads and any(v.camera_motion == "moving" for v in vids.values()) else None
    with ahead or contextlib.nullcontext():
        t0 = time.perf_counter()
        all_pairs: dict[tuple[str, str], TrackPairs] = {}
        for a, b in tqdm(list(itertools.combinations([n for n in names if n in vids], 2)), desc="cross-view pairs",
                         unit="pair", disable=not progress, leave=False):
            tp, ps = match_tracks(a, b, vids[a].features, vids[b].features, vids[a].instance,
                                  vids[b].instance, cfg.match)
            all_pairs[(a, b)] = tp
            sink.pair_matches(a, b, vids[a].features.keyframes, vids[b].features.keyframes, ps.keyframe_matches)
            stats["pairs"][f"{a}__{b}"] = {"matches": ps.matches, "snapped": ps.snapped,
                                           "instance_pairs": ps.instance_pairs, "track_pairs": ps.track_pairs}
            log.info("%s__%s: %d matches, %d snapped, %d instance pairs, %d track pairs",
                     a, b, ps.matches, ps.snapped, ps.instance_pairs, ps.track_pairs)
        timings["matching_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        if calibration is not None:
            cameras, tracks, dropped, undistort = _import_cameras(calibration, vids)
            stats["dropped"].update(dropped)
            kept = _vote_on_cameras(_CameraSet(cameras, tracks, None, None, undistort), vids, all_pairs, cfg,
                                    stats, sink, progress, estimated=False)
        else:
            kept = _estimated_cameras(vids, cfg, stats, all_pairs, {s.info.name: s for s in sources}, sink,
                                      progress)
        cameras, tracks, undistort, pairs = kept.cameras, kept.tracks, kept.undistort, kept.pairs
        points, colors = kept.points, kept.colors
        timings["cameras_s"] = time.perf_counter() - t0 - kept.voting_s
        if cfg.geometric.enabled:
            timings["geometric_pairs_s"] = kept.voting_s
        heads = {}
        if cfg.heads and any(c.is_moving for c in cameras.values()):
            t0 = time.perf_counter()
            heads = _heads(sources, vids, cameras, undistort, cfg, stats, sink, progress, ahead)
            timings["heads_s"] = time.perf_counter() - t0
    stats["registered_cameras"] = len(cameras)
    if cameras:  # after the moving points' cameras were checked: a refused one is not drawn
        sink.cameras(cameras, points, colors)
    usable = [n for n in names if n in cameras]
    timings["total_s"] = time.perf_counter() - t_all
    stats["track_pairs"] = int(sum(len(p.index) for p in pairs.values()))
    stats["tracks"] = int(sum(t.num_tracks for t in tracks.values()))
    for n in names:  # every video left out says why, whatever step lost it
        if n not in cameras and n not in stats["dropped"]:
            stats["dropped"][n] = "no camera for this video"
    if not usable:
        reasons = "; ".join(f"{n}: {r}" for n, r in stats["dropped"].items())
        raise NoUsableVideos(f"no video could be used: {reasons}", _cue_stats(stats),
                             {s.info.name: str(s.path) for s in sources})
    bundle = CueBundle(tuple(vids[n].info for n in usable), {n: cameras[n] for n in usable},
                       {n: tracks[n] for n in usable}, pairs, heads={n: h for n, h in heads.items() if n in usable})
    sink.stage_event("cues", "cue extraction finished", tracks=stats["tracks"],
                     track_pairs=stats["track_pairs"], cameras=len(cameras))
    return bundle, _cue_stats(stats)


def _video_landmarks(src, info: VideoInfo, cfg: CueConfig, pose=None, stop: threading.Event | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(frames looked at (K,), their (K,33,3) BlazePose landmarks) of one video decoded again at
    working resolution, at most about cfg.heads_max_hz frames a second. pose: a started tracker
    (people.start_pose) or None; stop: set to end early (InterruptedError)."""
    from ..io.video import iter_frames
    from .people import detect_landmarks

    step = _frame_step(info, cfg.heads_max_hz)

    def frames():
        for _, img in iter_frames(src, step=step, max_side=cfg.max_side):
            if stop is not None and stop.is_set():
                raise InterruptedError("heads no longer needed")
            yield img
    return np.arange(0, info.num_frames, step), detect_landmarks(frames(), pose)


class _HeadsAhead:
    """The landmarks (_video_landmarks) of the first max_videos readable videos, found one video
    after another on a thread of their own while the cameras are estimated and the geometric
    pairs voted. The trackers are started here, on the calling thread (their start-up silences
    stderr), each holding some 80 MB until its video is done: hence the cap; _heads finds the
    other videos' heads itself. Leaving the with block stops the thread at its next frame and
    waits for it."""

    max_videos = 4

    def __init__(self, sources, vids: dict[str, _VideoCues], cfg: CueConfig):
        from .people import start_pose

        self._stop = threading.Event()
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="heads")
        self._poses, self._jobs, self._seconds = {}, {}, {}
        try:
            for src in sources:
                n = src.info.name
                if n in vids and len(self._jobs) < self.max_videos:
                    self._poses[n] = start_pose()
                    self._jobs[n] = self._pool.submit(self._timed, n, src, vids[n].info, cfg)
        except BaseException:
            self.__exit__()
            raise

    def _timed(self, name: str, src, info: VideoInfo, cfg: CueConfig) -> tuple[np.ndarray, np.ndarray]:
        t0 = time.perf_counter()
        try:
            return _video_landmarks(src, info, cfg, self._poses[name], self._stop)
        finally:
            self._seconds[name] = time.perf_counter() - t0

    def seconds(self) -> dict[str, float]:
        """{video: seconds its heads took on the heads thread} of the videos done (or stopped) so
        far: that time overlaps the cameras and geometric pairs, so no stage's time shows it."""
        return dict(self._seconds)

    @classmethod
    def start(cls, sources, vids: dict[str, _VideoCues], cfg: CueConfig) -> _HeadsAhead | None:
        """None where it would not help or cannot run: one core, or no detector installed."""
        from .people import heads_unavailable

        if (os.cpu_count() or 1) < 2 or heads_unavailable():
            return None
        try:
            return cls(sources, vids, cfg)
        except (RuntimeError, OSError, ValueError) as exc:  # _heads then says, per video, what fails
            log.warning("heads not found ahead: a tracker did not start (%s: %s)", type(exc).__name__, exc)
            return None

    def landmarks(self, name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """_video_landmarks of that video (waits for them; raises what they raised), None when it
        was not among the videos looked at here."""
        return self._jobs[name].result() if name in self._jobs else None

    def __enter__(self) -> _HeadsAhead:
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        for n, job in self._jobs.items():
            if job.cancel():  # never started: its tracker is closed here
                self._poses[n].close()
        self._pool.shutdown(wait=True)


def _heads(sources, vids: dict[str, _VideoCues], cameras: dict, undistort: dict, cfg: CueConfig, stats: dict,
           sink: Sink, progress: bool, ahead: _HeadsAhead | None = None) -> dict[str, np.ndarray]:
    """{video: (T,2) undistorted full-resolution px of the head the person detector found in a
    frame (NaN: none, or a frame beyond cfg.heads_max_hz not looked at)}, for every video with a
    camera, decoded again at working resolution (or taken from ahead); {} with the reason in
    stats["heads"] when the detector is not installed."""
    from .people import head_points, heads_unavailable

    why = heads_unavailable()
    if why:
        stats["heads"] = {"skipped": why}
        log.info("worn-camera sightings skipped: %s", why)
        sink.stage_event("cues", f"worn-camera sightings skipped: {why}")
        return {}
    out, found, failed = {}, {}, {}
    for src in tqdm([s for s in sources if s.info.name in cameras], desc="heads", unit="video",
                    disable=not progress, leave=False):
        n = src.info.name
        info = vids[n].info
        try:
            done = ahead.landmarks(n) if ahead is not None else None
            todo, landmarks = done if done is not None else _video_landmarks(src, info, cfg)
        except (InputError, OSError, ValueError, RuntimeError) as exc:  # this decoding pass failed
            failed[n] = f"{type(exc).__name__}: {exc}"
            continue
        if len(landmarks) != len(todo):
            failed[n] = f"decoded {len(landmarks)} frames again, not {len(todo)}"
            continue
        heads = np.full((info.num_frames, 2), np.nan)
        heads[todo] = head_points(landmarks)
        raw = to_full_px(heads, vids[n].scale_xy)
        out[n] = undistort[n](raw) if n in undistort else raw
        found[n] = int(np.isfinite(out[n][:, 0]).sum())
        sink.stage_event("cues", f"{n}: a person's head in {found[n]} of {len(raw)} frames", heads=found[n])
    for n, why in failed.items():
        log.warning("%s: no heads: %s", n, why)
        sink.stage_event("cues", f"{n}: no heads: {why}")
    stats["heads"] = {"detector": "mediapipe BlazePose (pose_landmark_full)", "frames_with_a_head": found}
    if ahead is not None and (spent := ahead.seconds()):
        stats["heads"]["found_ahead_s"] = {n: round(t, 3) for n, t in spent.items()}
    if failed:
        stats["heads"]["failed"] = failed
    log.info("heads found: %s", ", ".join(f"{n} {k}" for n, k in found.items()))
    return out


def _cue_stats(stats: dict) -> CueStats:
    """The typed record of the counts gathered while extracting (a private dict until here)."""
    return CueStats(stats["camera_source"], stats["registered_cameras"], stats["tracks"],
                    stats["track_pairs"], {n: VideoCueStats(**v) for n, v in stats["videos"].items()},
                    stats["pairs"], stats["dropped"], stats["timings_s"], stats.get("geometric_peaks"),
                    stats.get("sfm"), stats.get("geometric_joint"), stats.get("heads"))


@dataclass(frozen=True)
class _GeometricPairing:
    """What _add_geometric_pairs made of one set of cameras."""

    pairs: dict  # (a, b) -> TrackPairs: the descriptor pairs kept plus the geometric ones
    voted: dict  # (a, b) -> the Δ_ab (s) whose supporters were added
    peaks_s: dict  # (a, b) -> tuple of the pair's vote peaks Δ_ab (s), as the vote found them


def _add_geometric_pairs(pairs: dict, cameras: dict, tracks: dict, vids: dict, cfg: CueConfig,
                         stats: dict, sink: Sink, progress: bool, estimated: bool,
                         other_peaks: dict | None = None, other: str = "") -> _GeometricPairing:
    """Descriptor pairs plus epipolar-consistency pairs for every pair of known cameras (a moving
    one with its per-frame poses), the Δ_ab whose supporters were added and every pair's vote peaks.
    estimated: Stage 0 estimated the cameras (no calibration given); only then are sure cameras
    checked in three views. other_peaks: (a, b) -> the vote peaks of another camera model (named
    other), which a sure camera's joint offset must meet in one of its pairs
    (geometric_pairs.disputed_by_other_model).

    With three or more such cameras, the vote peaks whose offsets close every triangle
    (Δ_ab + Δ_bc ≈ Δ_ac) are chosen and only their supporters kept. When no choice closes the
    triangles, the peaks of at least one pair are all wrong and Stage 1 could not tell (the
    pairs were picked to agree with them), so no geometric pair is added; nor with three cameras,
    whose one triangle's closure is too weak a check (consistent_peaks: "one triangle"). With two static
    cameras (no triangle) every kept peak's supporters are added, marked TrackPairs.unchecked (Stage 1
    accepts the pair only if its descriptor pairs alone give the same minimum); with a moving
    camera, none (GeometricPairConfig.unchecked_moving).
    """
    from .geometric_pairs import consistent_peaks, geometric_pairs, joint_offsets

    # every pair of cameras: a moving one with its per-frame poses (two moving ones: the
    # geometry per frame of b and per offset)
    todo = list(pairs)
    found = {}
    for a, b in tqdm(todo, desc="geometric pairs", unit="pair", disable=not progress, leave=False):
        found[(a, b)] = geometric_pairs(a, b, vids[a].info, vids[b].info, cameras[a], cameras[b],
                                        tracks[a].xy, tracks[b].xy, cfg.geometric)
    peaks_s = {k: tuple(gs.peaks_s) for k, (_, gs) in found.items()}
    coarsest = max((vids[n].info.frame_interval_s for k in found for n in k), default=0.0)
    # each of a triangle's three peaks is located to about ±1 frame (its support window), so
    # right peaks close within about 3 frames, while wrong ones miss by far more
    joint = joint_offsets({k: gs for k, (_, gs) in found.items()}, 3.0 * coarsest) \
        if cfg.geometric.joint else None
    sure = {} if joint is None else {n: m >= cfg.geometric.joint_min_margin for n, m in joint.margin.items()}
    three_view = {}
    # the check is of cameras Stage 0 estimated: a calibration's are given (with one, the tiny
    # bench-timing scene's right hand-held camera had 3 trajectories followed, wrong ones 0-2)
    if cfg.geometric.three_view_min_supporters > 0 and estimated and sum(sure.values()) >= 3:
        three_view = _check_in_three_views(found, joint, sure, cameras, tracks, vids, cfg, sink)
        sure = {n: ok and (n not in three_view or three_view[n].passed) for n, ok in sure.items()}
    dissent = {}
    # after the three-view check, which triangulates the pairs of the cameras sure then (without
    # the hand-held camera this refuses, stop 43's sweep seed 1 left its static cam2 too few
    # trajectories); estimated cameras only: with a calibration a right pair had 0.35
    if cfg.geometric.joint_min_pair_share > 0 and estimated and joint is not None:
        from .geometric_pairs import dissenting_cameras

        dissent = dissenting_cameras({k: gs for k, (_, gs) in found.items()}, joint, sure,
                                     cfg.geometric.joint_min_pair_share)
        for n, why in dissent.items():
            sure[n] = False
            msg = f"joint vote not sure of {n}: {why}"
            sink.stage_event("cues", msg)
            log.warning(msg)
    overruled = {}  # camera -> why the other model's dispute of it was overruled
    if other_peaks is not None and estimated and joint is not None:
        from .geometric_pairs import disputed_by_other_model

        shares = {n: chk.supporters / chk.best_supporters for n, chk in three_view.items() if chk.best_supporters}
        disputed, overruled = disputed_by_other_model(joint, sure, other_peaks,
                                                      cfg.geometric.other_model_agree_frames * coarsest, other,
                                                      shares, cfg.geometric.other_model_overrule_share)
        for n, why in overruled.items():
            msg = f"joint vote still sure of {n}: {why}"
            sink.stage_event("cues", msg)
            log.info(msg)
        for n, why in disputed.items():
            sure[n] = False
            dissent[n] = why
            msg = f"joint vote not sure of {n}: {why}"
            sink.stage_event("cues", msg)
            log.warning(msg)
    refused = bool(dissent) or any(not chk.passed for chk in three_view.values())
    # a camera refused (by its pairs or in three views) keeps the joint path (no geometric pair
    # for it), instead of the triangle fallback below choosing among the same cameras' vote peaks
    if sum(sure.values()) >= 2 or refused:
        checks, traj = {}, None
        if cfg.geometric.transfer and not all(sure.values()) and sum(sure.values()) >= 2:
            # not of a camera its own pairs contradict: point transfer projects into the same
            # camera, and confirmed stop 43's hand-held one 4.4 frames off (its lens is biased)
            checks, traj = _confirm_by_transfer(found, joint, sure, cameras, tracks, vids, cfg, sink,
                                                frozenset(dissent))
        sure = {n: ok or (n in checks and checks[n].confirmed) for n, ok in sure.items()}
        said = _JointChecks({c: chk.summary(traj.num_trajectories) for c, chk in checks.items()},
                            {c: chk.summary() for c, chk in three_view.items()}, dissent, overruled)
        out, used = _add_joint_pairs(pairs, found, joint, sure, cameras, tracks, vids, cfg, stats, sink, said)
        return _GeometricPairing(_add_transfer_pairs(out, checks, traj, list(vids), stats, sink), used, peaks_s)
    if joint is not None:
        # sure of fewer than two cameras, the joint vote has chosen nothing: the triangle rule
        # decides (and refuses when the triangles do not close), as before the joint choice
        sink.stage_event("cues", "joint vote sure of fewer than two cameras (margins "
                         + ", ".join(f"{n} {m:.1f}" for n, m in joint.margin.items())
                         + "): geometric peaks chosen by triangle closure")
    chosen, status = consistent_peaks({k: (gs.peaks_s, gs.peak_votes) for k, (_, gs) in found.items()},
                                      3.0 * coarsest)
    stats["geometric_peaks"] = status
    # the descriptor pairs are unchecked too then: alone they put rendered and demo cameras
    # 88-1456 ms off and were accepted (README, point transfer); kept only where consistent at the
    # joint vote's offsets, unsure as they are, so that a wrong offset leaves too few of them
    unchecked = status in ("inconsistent", "one triangle")
    filter_desc = unchecked and joint is not None and cfg.geometric.joint_filter_descriptor
    unchecked_why = None
    if unchecked:
        unchecked_why = ("the vote peaks of the camera pairs do not close the triangles (Δ_ab + Δ_bc ≠ Δ_ac), "
                         "so some peaks are wrong" if status == "inconsistent" else
                         "three cameras give one triangle, and its closure (Δ_ab + Δ_bc ≈ Δ_ac) is a single "
                         "check on 27 choices of vote peaks, some of which close by chance")
        msg = (f"geometric track pairs not used: {unchecked_why}"
               + ("; descriptor pairs kept only where consistent at the joint vote's offsets" if filter_desc else ""))
        sink.stage_event("cues", msg)
        log.warning(msg)
    out = dict(pairs)
    for (a, b), (gp, gs) in found.items():
        pick = chosen.get((a, b)) if chosen is not None else None  # index of the chosen peak
        index, withheld = gp.index, None
        if pick is not None:
            index = index[gs.pair_peak == pick]
        elif unchecked:
            index, withheld = index[:0], unchecked_why
        elif len(index) and (cameras[a].is_moving or cameras[b].is_moving) and not cfg.geometric.unchecked_moving:
            withheld = (f"no triangle checks its vote peaks ({', '.join(f'{p:+.3f}' for p in gs.peaks_s)} s), "
                        f"and a moving camera's per-frame geometry lets wrong tracks fit a wrong offset")
            msg = f"geometric track pairs not used for {a}__{b}: {withheld}"
            sink.stage_event("cues", msg, pair=f"{a}__{b}")
            log.warning(msg)
            index = index[:0]
        _log_votes(sink, a, b, gs, gs.peaks_s[pick] if pick is not None else None)
        desc = pairs[(a, b)]
        n_desc = len(desc.index)
        if filter_desc:
            desc = _consistent_descriptor_pairs(desc, joint.offsets_s[b] - joint.offsets_s[a], cameras,
                                                tracks, vids, cfg)
        # supporters of a peak no triangle chose: Stage 1 must find the pair's minimum without them too
        # with no geometric pair, every row was kept at the joint vote's Δ
        kept_at = joint.offsets_s[b] - joint.offsets_s[a] if filter_desc and not len(index) else None
        out[(a, b)], n_new = _merge_pairs(desc, index, unchecked=pick is None, chosen_at_offset_s=kept_at)
        info = {"geometric_candidates": gs.candidates, "geometric_informative": gs.informative,
                "geometric_pairs": int(len(index)), "geometric_new": n_new,
                "geometric_peaks_s": [round(p, 4) for p in gs.peaks_s],
                "geometric_peak_votes": list(gs.peak_votes),
                "geometric_chosen_peak_s": round(gs.peaks_s[pick], 4) if pick is not None else None}
        if withheld:
            info["geometric_withheld"] = withheld
        if pick is None and n_new:
            info["geometric_unchecked"] = int(n_new)
        if filter_desc:
            info.update({"descriptor_pairs_kept": int(len(desc.index)), "descriptor_pairs_before": int(n_desc)})
        stats["pairs"].setdefault(f"{a}__{b}", {}).update(info)
        which = (f"peak {gs.peaks_s[pick]:+.3f} s chosen: the peaks of all static pairs close every triangle"
                 if pick is not None else
                 f"vote peaks at {', '.join(f'{p:+.3f}' for p in gs.peaks_s)} s")
        sink.stage_event("cues", f"{a}__{b}: {len(index)} track pairs from epipolar consistency ({which})")
        log.info("%s__%s: %d geometric track pairs (%d new), %s", a, b, len(index), n_new, which)
    used = {k: found[k][1].peaks_s[i] for k, i in (chosen or {}).items() if i is not None}
    return _GeometricPairing(out, used, peaks_s)


def _check_fitted_offsets(fallback: dict, voted: dict, vids: dict) -> dict[str, str]:
    """Cameras from the moving points that their own epipolar votes contradict or leave
    unconfirmed: {camera: reason}; fallback["check"] records every pair's comparison.

    Those cameras were fitted to track pairs aligned at coarse offsets (fitted_offsets_s). Right
    cameras at right offsets make the votes over all track pairs peak at the same Δ (caliscope:
    within a frame); cameras fitted to wrong pairs at wrong offsets put the peaks elsewhere
    (rendered seed 0 with SIFT: seconds away), and Stage 1 then accepts minima at offsets the
    cameras were never fitted for. Any contradiction refuses every such camera (they were fitted
    jointly); a camera in no agreeing pair is refused as unconfirmed. Two cameras give no check
    (their votes peak where their own F was fitted): they pass, marked unchecked (they are used
    only with camera.fallback_unchecked_pair; by default _estimate refuses them)."""
    fitted = fallback["fitted_offsets_s"]
    if len(fitted) < 3:
        fallback["check"] = {"verdict": "unchecked (two cameras: no third to confirm their offset)"}
        return {}
    tol_s = 3.0 * max(vids[n].info.frame_interval_s for n in fitted)
    rows, agreeing, contradicted = {}, set(), []
    for (a, b), delta in sorted(voted.items()):
        if a not in fitted or b not in fitted:
            continue
        expect = fitted[b] - fitted[a]
        ok = abs(delta - expect) <= tol_s
        rows[f"{a}__{b}"] = {"fitted_s": round(expect, 4), "voted_s": round(delta, 4), "agrees": ok}
        if ok:
            agreeing |= {a, b}
        else:
            contradicted.append(f"{a}__{b} fitted at Δ {expect:+.3f} s, voted {delta:+.3f} s")
    if contradicted:
        why = ("camera from the moving points refused: its own epipolar votes contradict the offsets "
               f"it was fitted at ({'; '.join(contradicted)}; tolerance {tol_s:.3f} s), so the track "
               "pairs it was fitted to were wrong")
        refused = {n: why for n in fitted}
    else:
        refused = {n: ("camera from the moving points refused: no pair of it with a sure epipolar vote "
                       "confirmed the offset it was fitted at") for n in fitted if n not in agreeing}
    fallback["check"] = {"tolerance_s": round(tol_s, 4), "pairs": rows,
                         "verdict": "contradicted" if contradicted else
                         "confirmed" if not refused else "partly unconfirmed",
                         "refused": sorted(refused)}
    return refused


def _log_votes(sink: Sink, a: str, b: str, gs, chosen_s: float | None) -> None:
    """The pair's geometric votes over Δ_ab and the Δ whose supporters were kept, to the sink."""
    from .geometric_pairs import vote_z

    if gs.votes is not None and len(gs.votes):
        sink.pair_votes(a, b, gs.vote_offsets_s, gs.votes, vote_z(gs)[1], chosen_s)


def _transfer_source(a: str, b: str, sure: dict[str, bool], cameras: dict) -> bool:
    """Whether pair (a, b)'s joint Δ may be triangulated for point transfer: both cameras sure,
    and when both move, a third camera sure too (their per-frame geometry lets wrong tracks fit
    one wrong offset)."""
    if not (sure.get(a) and sure.get(b)):
        return False
    return not (cameras[a].is_moving and cameras[b].is_moving) or sum(sure.values()) >= 3


def _joint_pair_used(a: str, b: str, sure: dict[str, bool], cameras: dict, min_sure: int) -> bool:
    """Whether the joint vote's Δ of pair (a, b) is trusted: a transfer source, and at least
    min_sure cameras sure in all (GeometricPairConfig.joint_min_sure: 3 = a closed triangle of
    sure cameras confirms it; see _add_joint_pairs)."""
    return _transfer_source(a, b, sure, cameras) and sum(sure.values()) >= min_sure


def _sure_pairs(found: dict, joint, sure: dict[str, bool], cameras: dict) -> dict:
    """The supporters of the joint Δ of every pair that point transfer may triangulate
    (_transfer_source)."""
    from .geometric_pairs import supporters

    out = {}
    for (a, b), (_, gs) in found.items():
        if not _transfer_source(a, b, sure, cameras):
            continue
        index = supporters(gs, joint.offsets_s[b] - joint.offsets_s[a])
        out[(a, b)] = TrackPairs(a, b, index, np.ones(len(index)))
    return out


def _transfer_radius_px(info: VideoInfo, g) -> float:
    """How near a projected point a track of the camera must be (GeometricPairConfig.transfer_radius_diag)."""
    return max(3.0, g.transfer_radius_diag * float(np.hypot(info.width, info.height)))


def _check_in_three_views(found: dict, joint, sure: dict[str, bool], cameras: dict, tracks: dict,
                          vids: dict, cfg: CueConfig, sink: Sink) -> dict:
    """{camera: transfer.ThreeViewCheck} for every sure camera: the other sure cameras' track
    pairs triangulated at their joint offsets and projected into it at its own. Wrong cameras can
    make the joint vote sure of wrong offsets, consistent in every triangle (rendered seed 2 with
    XFeat's cameras: three cameras 0.5-2.8 s off, margins 8.5-23.6), since a line through a
    wrong epipole still meets some track; a point in a third view rarely does."""
    from .transfer import check_in_three_views, triangulate_pairs

    g = cfg.geometric
    infos = {n: v.info for n, v in vids.items()}
    xy = {n: t.xy for n, t in tracks.items()}
    checks = {}
    for c in sorted(n for n, ok in sure.items() if ok):
        others = {n: ok and n != c for n, ok in sure.items()}
        traj = triangulate_pairs(infos, cameras, xy, _sure_pairs(found, joint, others, cameras),
                                 {n: joint.offsets_s[n] for n, ok in others.items() if ok})
        chk = check_in_three_views(c, joint.offsets_s[c], traj, infos[c], cameras[c], xy[c],
                                   _transfer_radius_px(infos[c], g), g.transfer_min_hits,
                                   g.three_view_min_supporters, g.three_view_min_share_of_best)
        checks[c] = chk
        sink.three_view_landscape(c, chk.landscape.offsets_s, chk.landscape.supporters, chk.joint_offset_s,
                                  chk.passed)
        msg = f"{c}: {chk.reason}"
        sink.stage_event("cues", msg, camera=c, passed=int(chk.passed), supporters=chk.supporters,
                         best_supporters=chk.best_supporters, trajectories=chk.trajectories)
        (log.info if chk.passed else log.warning)(msg)
    return checks


def _confirm_by_transfer(found: dict, joint, sure: dict[str, bool], cameras: dict, tracks: dict,
                         vids: dict, cfg: CueConfig, sink: Sink, skip: frozenset[str] = frozenset()):
    """({camera: transfer.TransferCheck}, the transfer.Trajectories projected): a check of every
    camera the joint vote is unsure of (but those of skip), the sure cameras' track pairs
    triangulated at their joint offsets and projected into it over its candidate offsets
    (cues/transfer.py)."""
    from .transfer import confirm_offset, offset_grid, transfer_landscape, triangulate_pairs

    g = cfg.geometric
    sure_offsets = {n: joint.offsets_s[n] for n, ok in sure.items() if ok}
    traj = triangulate_pairs({n: v.info for n, v in vids.items()}, cameras,
                             {n: t.xy for n, t in tracks.items()},
                             _sure_pairs(found, joint, sure, cameras), sure_offsets)
    checks = {}
    for c in sorted(n for n, ok in sure.items() if not ok and n not in skip):
        info = vids[c].info
        land = transfer_landscape(traj, info, cameras[c], tracks[c].xy,
                                  offset_grid(traj, info, 0.5 * info.frame_interval_s),
                                  _transfer_radius_px(info, g), g.transfer_min_hits)
        chk = confirm_offset(c, joint.offsets_s[c], land, info.frame_interval_s,
                             g.transfer_agree_frames, g.transfer_min_z, g.transfer_min_supporters)
        checks[c] = chk
        sink.transfer_landscape(c, land.offsets_s, land.share, chk.joint_offset_s, land.offset_s,
                                chk.confirmed)
        msg = f"{c}: {chk.reason}"
        sink.stage_event("cues", msg, camera=c, confirmed=int(chk.confirmed), z=round(land.z, 2),
                         trajectories=traj.num_trajectories)
        (log.info if chk.confirmed else log.warning)(msg)
    return checks, traj


def _add_transfer_pairs(pairs: dict, checks: dict, traj, order: list[str], stats: dict,
                        sink: Sink) -> dict:
    """pairs plus, for every camera that point transfer confirmed, its tracks that follow a
    trajectory (of traj, transfer.Trajectories) paired with both tracks the trajectory was
    triangulated from; order: the videos' order (a pair's key names the earlier one first)."""
    out = dict(pairs)
    for c, chk in checks.items():
        if not chk.confirmed:
            continue
        new: dict[tuple[str, str], list] = {}
        for t, j in chk.landscape.matches.tolist():
            pair_no, ta, tb, _ = traj.source[t].tolist()
            a, b = traj.pairs[pair_no]
            for other, track in ((a, ta), (b, tb)):
                key = (other, c) if order.index(other) < order.index(c) else (c, other)
                new.setdefault(key, []).append((track, j) if key[0] == other else (j, track))
        for key, rows in new.items():
            if key not in out:
                continue
            # no chosen_at_offset_s: the new rows follow trajectories at the transfer's offset
            out[key], n_new = _merge_pairs(out[key], np.unique(np.array(rows, np.int64), axis=0))
            stats["pairs"].setdefault(f"{key[0]}__{key[1]}", {})["transfer_new"] = int(n_new)
            sink.stage_event("cues", f"{key[0]}__{key[1]}: {n_new} track pairs from point transfer",
                             pair=f"{key[0]}__{key[1]}", transfer_new=int(n_new))
    return out


def _consistent_descriptor_pairs(desc: TrackPairs, delta_s: float, cameras: dict, tracks: dict,
                                 vids: dict, cfg: CueConfig) -> TrackPairs:
    """The descriptor pairs of (desc.a, desc.b) that are epipolar-consistent at Δ = delta_s
    (geometric_pairs.consistent_at with the geometric pairs' tolerances)."""
    from .geometric_pairs import consistent_at

    if not len(desc.index):
        return desc
    a, b, g = desc.a, desc.b, cfg.geometric
    tau = max(2.0, g.tau_diag * float(np.hypot(vids[b].info.width, vids[b].info.height)))
    ok = consistent_at(vids[a].info, vids[b].info, cameras[a], cameras[b], tracks[a].xy,
                       tracks[b].xy, desc.index, delta_s, tau, g.min_inlier_share, g.min_frames)
    return TrackPairs(a, b, desc.index[ok], None if desc.weight is None else desc.weight[ok])


def _merge_pairs(tp: TrackPairs, index: np.ndarray, unchecked: bool = False,
                 chosen_at_offset_s: float | None = None) -> tuple[TrackPairs, int]:
    """Descriptor pairs tp plus the geometric pairs index (P,2) not already in it: (pairs, new).
    unchecked: the new rows are marked TrackPairs.unchecked (no triangle checked their vote peak);
    chosen_at_offset_s: the Δ_ab at which every row of both was kept (TrackPairs), if one was."""
    w_desc = tp.weight if tp.weight is not None else np.ones(len(tp.index))
    have = {tuple(x) for x in tp.index.tolist()}
    new = np.array([x for x in index.tolist() if tuple(x) not in have], np.int64).reshape(-1, 2)
    mark = None
    if unchecked and len(new):
        mark = np.concatenate([np.zeros(len(tp.index), bool), np.ones(len(new), bool)])
    return TrackPairs(tp.a, tp.b, np.concatenate([tp.index, new]),
                      np.concatenate([w_desc, np.ones(len(new))]), mark, chosen_at_offset_s), len(new)


@dataclass(frozen=True)
class _JointChecks:
    """What the checks after the joint vote said of its cameras, kept in result.json."""

    transfer: dict = dataclasses.field(default_factory=dict)  # camera -> point transfer's summary
    three_view: dict = dataclasses.field(default_factory=dict)  # camera -> the three-view check's summary
    dissent: dict = dataclasses.field(default_factory=dict)  # camera -> why its pairs (or the other model) contradict it
    overruled: dict = dataclasses.field(default_factory=dict)  # camera -> why the other model's dispute was overruled


def _add_joint_pairs(pairs: dict, found: dict, joint, sure: dict[str, bool], cameras: dict,
                     tracks: dict, vids: dict, cfg: CueConfig, stats: dict, sink: Sink,
                     said: _JointChecks = _JointChecks()) -> tuple[dict, dict]:
    """(pairs, {(a, b): the joint Δ_ab whose supporters were added}): the supporters of the
    jointly chosen offsets (geometric_pairs.joint_offsets) for every pair whose Δ is trusted
    (_joint_pair_used: both cameras' offsets won by at least joint_min_margin, or point transfer
    confirmed them, and joint_min_sure cameras are sure; sure: camera -> whether it is, said:
    what the checks after the vote said, for result.json); nothing for the others. A
    descriptor pair is kept only if it is epipolar-consistent at the joint Δ (with
    joint_filter_descriptor): the descriptor pairs are mostly wrong on small moving objects
    (BENCHMARKS.md), and the joint Δ is the best evidence there is of the moment they share."""
    from .geometric_pairs import supporters, votes_at

    # the pairs whose joint Δ is trusted, and that Δ: the one decision everything below reads
    used = {(a, b): joint.offsets_s[b] - joint.offsets_s[a] for a, b in found
            if _joint_pair_used(a, b, sure, cameras, cfg.geometric.joint_min_sure)}
    stats["geometric_peaks"] = "joint"
    stats["geometric_joint"] = {"origin": joint.origin,
                                "offsets_s": {n: round(o, 4) for n, o in joint.offsets_s.items()},
                                "score": round(joint.score, 2),
                                "margin": {n: round(m, 2) for n, m in joint.margin.items()},
                                "sure": sorted(n for n, ok in sure.items() if ok),
                                "used": sorted({n for k in used for n in k})}
    # copies (asdict), in field order; an empty check is left out
    stats["geometric_joint"].update({key: value for key, value in dataclasses.asdict(said).items() if value})
    three_view, dissent, transfer = said.three_view, said.dissent, said.transfer
    failed = sorted(n for n, chk in three_view.items() if not chk["passed"] and not sure[n])
    if failed:
        seen = ", ".join(f"{n} {three_view[n]['supporters']}" for n in failed)
        msg = (f"geometric track pairs not used for {', '.join(failed)}: the joint vote was sure of "
               f"their offsets, but the points the other sure cameras triangulate are not seen there "
               f"(supporters {seen}; a camera needs {cfg.geometric.three_view_min_supporters}, and "
               f"{cfg.geometric.three_view_min_share_of_best:.2g} of those at its best offset)")
        sink.stage_event("cues", msg)
        log.warning(msg)
    weak = sorted(n for n, ok in sure.items() if not ok and n not in failed and n not in dissent)
    if weak:
        msg = (f"geometric track pairs not used for {', '.join(weak)}: the joint vote prefers their "
               f"offsets by less than {cfg.geometric.joint_min_margin:g} (margins "
               f"{', '.join(f'{n} {joint.margin[n]:.1f}' for n in weak)})"
               + ("; point transfer did not confirm them" if transfer else ""))
        sink.stage_event("cues", msg)
        log.warning(msg)
    # a Δ only when a third camera is sure too (a closed triangle confirms it): with a single
    # sure pair nothing checks it, and Stage 1 accepts the minimum its own supporters make
    # (fencing1 with looser moving regions: aria01-aria03 at +2.4 s, truth +1.5 s; rendered
    # seed 1 with estimated cameras: cam3 3.7 s off; the all-around scene: cam1 141 ms off)
    unconfirmed = {(a, b) for (a, b) in found if sure.get(a) and sure.get(b) and (a, b) not in used}
    if unconfirmed:
        names = ", ".join(sorted(f"{a}__{b}" for a, b in unconfirmed))
        msg = (f"geometric track pairs not used for {names}: the joint vote is sure of "
               f"{sum(sure.values())} camera(s) only, so no triangle of sure cameras confirms their Δ")
        sink.stage_event("cues", msg)
        log.warning(msg)
    out = dict(pairs)
    for (a, b), (_, gs) in found.items():
        delta = joint.offsets_s[b] - joint.offsets_s[a]
        both = (a, b) in used
        index = supporters(gs, delta) if both else np.zeros((0, 2), np.int64)
        _log_votes(sink, a, b, gs, delta if both else None)
        desc = pairs[(a, b)]
        n_desc = len(desc.index)
        # an unsure camera's descriptor pairs are filtered too: at a wrong joint Δ few survive
        # (the pair is then refused for too few pairs) instead of a wrong minimum being accepted
        if cfg.geometric.joint_filter_descriptor:
            desc = _consistent_descriptor_pairs(desc, delta, cameras, tracks, vids, cfg)
        every = cfg.geometric.joint_filter_descriptor or not n_desc  # every row kept at delta
        out[(a, b)], n_new = _merge_pairs(desc, index, chosen_at_offset_s=delta if every else None)
        stats["pairs"].setdefault(f"{a}__{b}", {}).update({
            "geometric_candidates": gs.candidates, "geometric_informative": gs.informative,
            "geometric_pairs": int(len(index)), "geometric_new": int(n_new),
            "geometric_peaks_s": [round(p, 4) for p in gs.peaks_s],
            "geometric_peak_votes": list(gs.peak_votes), "geometric_joint_delta_s": round(delta, 4),
            "descriptor_pairs_kept": int(len(desc.index)), "descriptor_pairs_before": int(n_desc)})
        votes = votes_at(gs, delta)
        stats["pairs"][f"{a}__{b}"].update({"geometric_joint_votes": votes,
                                            "geometric_joint_margin": [round(joint.margin[a], 2),
                                                                       round(joint.margin[b], 2)]})
        sink.stage_event("cues", f"{a}__{b}: {len(index)} track pairs from epipolar consistency "
                                 f"(joint vote over all camera pairs: Δ {delta:+.3f} s)",
                         pair=f"{a}__{b}", votes=votes, informative=gs.informative,
                         geometric_pairs=int(len(index)), descriptor_pairs_kept=int(len(desc.index)),
                         descriptor_pairs_before=int(n_desc), margin_a=round(joint.margin[a], 2),
                         margin_b=round(joint.margin[b], 2))
        log.info("%s__%s: %d geometric track pairs (%d new) at the joint Δ %+.3f s", a, b,
                 len(index), n_new, delta)
    return out, used


@dataclass
class _CameraSet:
    """One set of cameras for the videos and what the pairing made of them."""

    cameras: dict[str, CameraTrack]
    tracks: dict[str, Tracks]  # undistorted with the cameras' lenses
    points: np.ndarray | None  # (P,3) static points of the reconstruction, None without one
    colors: np.ndarray | None  # (P,3) uint8
    undistort: dict  # name -> function undistorting (...,2) full-resolution px
    pairs: dict | None = None  # (a, b) -> TrackPairs after the pairing
    used: frozenset = frozenset()  # cameras with a pair whose geometric Δ the pairing trusted
    peaks: dict | None = None  # (a, b) -> the pair's vote peaks Δ_ab (s)
    voting_s: float = 0.0  # seconds spent voting
    stats: dict | None = None  # CueStats' dict as this set left it (estimated cameras)
    events: DeferredSink | None = None  # its reports, held until the set is kept


def _copy_stats(stats: dict) -> dict:
    """A copy of stats to try a set of cameras on; the timings stay shared."""
    return {k: (v if k == "timings_s" else copy.deepcopy(v)) for k, v in stats.items()}


def _vote_on_cameras(cams: _CameraSet, vids: dict, all_pairs: dict, cfg: CueConfig, stats: dict, sink: Sink,
                     progress: bool, estimated: bool, other_peaks: dict | None = None,
                     other: str = "") -> _CameraSet:
    """cams with its pairs: the descriptor pairs of its cameras plus the geometric ones
    (_add_geometric_pairs; other_peaks, other: another camera model's vote peaks and its name),
    a camera fitted to the moving points at an offset its votes refuse taken out."""
    cameras = dict(cams.cameras)
    for name, why in stats["dropped"].items():
        if name in vids:
            sink.stage_event("cameras", f"{name}: {why}")
    for name, r in (stats.get("sfm") or {}).get("frame_registration", {}).items():
        if name in cameras:  # the moving camera's own poses, each frame registered on its own
            sink.stage_event("cameras", f"{name}: {r['registered']} of {r['tried']} frames outside the "
                                        f"reconstruction registered against it (median {r['median_inliers']:.0f} "
                                        f"inliers, {r['refused']} refused); the rest slerped",
                             registered=r["registered"], tried=r["tried"], refused=r["refused"])
    pairs = {k: v for k, v in all_pairs.items() if k[0] in cameras and k[1] in cameras}
    used, peaks, voting_s = frozenset(), {}, 0.0
    if cfg.geometric.enabled:
        t0 = time.perf_counter()
        pairing = _add_geometric_pairs(pairs, cameras, cams.tracks, vids, cfg, stats, sink, progress,
                                       estimated=estimated, other_peaks=other_peaks, other=other)
        pairs, voted = pairing.pairs, pairing.voted
        fallback = (stats.get("sfm") or {}).get("fallback") or {}
        if fallback.get("used"):
            refused = _check_fitted_offsets(fallback, voted, vids)
            for n, why in refused.items():
                cameras.pop(n, None)
                stats["dropped"][n] = why
                sink.stage_event("cameras", f"{n}: {why}")
                log.warning("%s: %s", n, why)
            pairs = {k: v for k, v in pairs.items() if k[0] in cameras and k[1] in cameras}
        used = frozenset(n for k in voted for n in k if n in cameras)
        peaks = {k: pairing.peaks_s.get(k, ()) for k in pairs}
        voting_s = time.perf_counter() - t0
    return dataclasses.replace(cams, cameras=cameras, pairs=pairs, used=used, peaks=peaks, voting_s=voting_s)


def _estimated_cameras(vids: dict[str, _VideoCues], cfg: CueConfig, stats: dict, all_pairs: dict,
                       sources: dict, sink: Sink, progress: bool) -> _CameraSet:
    """The cameras pycolmap estimates and their pairs. With camera features "auto", when the
    joint vote on SIFT's cameras leaves a video without a trusted geometric Δ, XFeat's model is
    tried too (cameras.CameraModels.second), its sure cameras held to SIFT's vote peaks
    (geometric_pairs.disputed_by_other_model); the set with more such videos is kept, SIFT's on
    a tie. When the kept set still leaves one untrusted, ALIKED's model is tried last
    (CameraModels.third), held to the first set's peaks too, and kept only when it trusts more videos.
    stats ends as the kept set left it, with every tried set's counts in stats["sfm"]["models"]."""
    from .cameras import CameraModels

    frames = {n: v.sfm_frames for n, v in vids.items() if v.sfm_frames is not None}
    sizes = {n: (v.info.width, v.info.height) for n, v in vids.items()}
    with CameraModels(frames, sizes, {n: v.info.num_frames for n, v in vids.items()},
                      {n: v.camera_motion == "moving" for n, v in vids.items()}, cfg.camera,
                      frame_features={n: v.frame_features for n, v in vids.items() if v.frame_features is not None},
                      frame_images={n: (functools.partial(_registration_images, sources[n], v, cfg),
                                        len(v.register_masks[0]))
                                    for n, v in vids.items() if v.register_masks is not None},
                      progress=progress) as models:

        memo: dict = {}

        def attempt(est, other_peaks=None, other="", from_tracks=False) -> tuple[str, _CameraSet] | None:
            own = _copy_stats(stats)
            events = DeferredSink(sink.options)
            cams = _estimate(vids, cfg, own, all_pairs, est, from_tracks, memo)
            if from_tracks and not (own["sfm"].get("fallback") or {}).get("used"):
                return None  # est's own cameras again, already voted on
            out = _vote_on_cameras(cams, vids, all_pairs, cfg, own, events, progress, estimated=True,
                                   other_peaks=other_peaks, other=other)
            kind = MOVING_POINTS if from_tracks else est.features
            return kind, dataclasses.replace(out, stats=own, events=events)

        kept_est = models.first()
        kind, kept = attempt(kept_est)
        first_kind, first_peaks = kind, kept.peaks
        tried, failed = [(kind, kept)], []
        for which, build in (("second", models.second), ("third", models.third)):
            if not cfg.geometric.enabled or kept.used >= set(vids):
                break
            try:
                est = build()
                if est is None:
                    continue
                log.info("the joint vote trusted %d of %d videos on %s's cameras: trying %s's model",
                         len(kept.used), len(vids), kind.upper(), est.features.upper())
                # each later model is held to the first one's vote peaks
                tried.append(attempt(est, first_peaks, f"{first_kind.upper()}'s model"))
            except Exception as exc:  # another opinion that fails leaves the earlier ones standing
                failed.append(f"the {which} camera model failed ({type(exc).__name__}: {exc}); "
                              f"{kind.upper()}'s kept")
                log.warning("%s", failed[-1])
                continue
            if len(tried[-1][1].used) > len(kept.used):
                (kind, kept), kept_est = tried[-1], est
        if (cfg.geometric.enabled and cfg.camera.fallback_when_untrusted and cfg.camera.fallback_from_tracks
                and not kept.used
                and not any(c.stats["sfm"].get("fallback") for _, c in tried)):
            # every model placed the static cameras, and none was trusted: the moving points' own cameras
            log.info("the joint vote trusted no video on any camera model: trying the moving points' cameras")
            points = attempt(kept_est, from_tracks=True)
            if points is not None:
                tried.append(points)
                if points[1].used:
                    kind, kept = points
        skipped = models.third_skipped
    kept.events.replay(sink)
    stats.clear()
    stats.update(kept.stats)
    _note_other_models(stats["dropped"], kept, [(k, c) for k, c in tried if c is not kept], vids)
    if len(tried) > 1:
        stats["sfm"]["models"] = [{"features": k, "cameras": len(c.cameras), "trusted": sorted(c.used),
                                   "kept": c is kept} for k, c in tried]
        msg = (f"camera models: {_owner(kind)} kept; the joint vote trusted "
               + ", ".join(f"{len(c.used)} video(s) on {_owner(k)}" for k, c in tried))
        sink.stage_event("cameras", msg)
        log.info(msg)
    if failed:
        stats["sfm"]["models_failed"] = "; ".join(failed)
        sink.stage_event("cameras", stats["sfm"]["models_failed"])
    if skipped:
        stats["sfm"]["models_skipped"] = skipped
        sink.stage_event("cameras", skipped)
    return kept


def _note_other_models(dropped: dict[str, str], kept: _CameraSet, others: list[tuple[str, _CameraSet]],
                       vids: dict) -> None:
    """Adds to the reason of each video the kept set has no camera for what the other models tried
    made of it, so a null says whether any model could place its camera."""
    for n in [n for n in dropped if n in vids and n not in kept.cameras]:
        notes = []
        for kind, c in others:
            whose = f"{_owner(kind)} {'cameras' if kind == MOVING_POINTS else 'model'}"
            if n in c.cameras:
                notes.append(f"{whose} registered it, but its set was not kept "
                             f"(its joint vote trusted {len(c.used)} video(s))")
            else:  # the reason's first clause: the rest repeats for every model (the moving points' cameras)
                why = c.stats["dropped"].get(n, "no camera").split("; ")[0]
                notes.append(f"{whose}: {why}")
        if notes:
            dropped[n] += f" (also tried: {'; '.join(notes)})"


def _estimate(vids: dict[str, _VideoCues], cfg: CueConfig, stats: dict, pairs: dict, est,
              from_tracks: bool = False, memo: dict | None = None) -> _CameraSet:
    """The cameras of est (cameras.CameraEstimate) and the tracks undistorted with them, or the
    cameras the moving points give when their cameras explain the points better and est is weak,
    or from_tracks (the joint vote trusted no video on est's cameras; the moving points' cameras
    may then be fewer). memo: kept between calls on the same videos and pairs, so that the moving
    points' cameras, which do not depend on est, are fitted once."""
    from .cameras import lens_record, undistort_with_colmap
    from .pairwise import cameras_from_tracks, epipolar_fit_px

    stats["sfm"] = {"features": est.features, "images": est.num_images, "registered_images": est.num_registered,
                    "registered_frames": {n: c.registered_frames.tolist() for n, c in est.cameras.items()},
                    "image_pairs": list(est.image_pairs),
                    # the tracks are undistorted with it; other image points (e.g. an evidence
                    # script's detections) need it too
                    "lens": {n: lens_record(c) for n, c in est.cameras.items()}}
    regs = {n: c.frame_registration for n, c in est.cameras.items() if c.frame_registration is not None}
    if regs:
        stats["sfm"]["frame_registration"] = regs
    if est.features == "xfeat":
        stats["sfm"]["xfeat_matcher"] = cfg.camera.xfeat_matcher
    static = [n for n, v in vids.items() if v.camera_motion != "moving"]
    # a model resting on few points per image, or missing a static camera, is checked against the
    # moving points: such models can pass the point threshold with wrong focals and rotations
    fewest = min((c.points_seen for c in est.cameras.values()), default=0)
    weak = len(est.cameras) < 2 or any(n not in est.cameras for n in static) or \
        fewest < 2 * cfg.camera.min_inliers
    if (weak or from_tracks) and cfg.camera.fallback_from_tracks and len(static) >= 2:
        ref = max(vids, key=lambda n: sum(len(p.index) for k, p in pairs.items() if n in k))
        infos = {n: v.info for n, v in vids.items()}
        xy = {n: v.xy_full for n, v in vids.items()}
        if memo is not None and "from_tracks" in memo:  # the same track pairs for every model
            cams, reasons, details = copy.deepcopy(memo["from_tracks"])
        else:
            cams, reasons, details = cameras_from_tracks(
                ref, infos, xy, pairs, {n: v.camera_motion == "moving" for n, v in vids.items()},
                joint=cfg.camera.fallback_joint_offsets)
            if memo is not None:
                memo["from_tracks"] = copy.deepcopy((cams, reasons, details))
        if from_tracks:  # the background did reconstruct; these cameras are the static ones only
            reasons = {n: ("camera could not be registered: a moving camera, and the moving points give "
                           "static cameras only" if vids[n].camera_motion == "moving" else reason)
                       for n, reason in reasons.items()}
        if len(est.cameras) < 2:
            why = f"the background reconstruction registered {len(est.cameras)} camera(s)"
        elif weak:
            why = (f"the background reconstruction rests on few points (fewest {fewest} per image) or left a "
                   f"static camera out")
        else:
            why = "the joint vote trusted no video on any camera model's cameras"
        if len(cams) == 2 and not cfg.camera.fallback_unchecked_pair:
            # the coarse offset and F were chosen by the same track pairs; Stage 1 then finds the
            # minimum they were fitted for, right or wrong, and no third camera can refuse it
            lone = ("only two cameras came out, whose geometry and offset would both come from the same "
                    "track pairs with no third camera to check them")
            reasons = reasons | dict.fromkeys(cams, f"camera could not be registered: {lone}")
            why += f"; {lone}"
            cams = {}
        use = len(cams) >= 2
        if use and len(est.cameras) >= 2:
            # both: keep the one whose cameras explain the moving points better, on the pairs of
            # the background model's static cameras (tracks undistorted with its lens)
            coarse = {n: d["coarse_offset_s"] for n, d in details.items() if "coarse_offset_s" in d} | {ref: 0.0}
            sfm_static = {n: c.track for n, c in est.cameras.items() if n in static}
            sfm_px, n_sfm = epipolar_fit_px(sfm_static, infos, {n: undistort_with_colmap(est.cameras[n], xy[n])
                                                                  for n in sfm_static}, pairs, coarse)
            fb_px, n_fb = epipolar_fit_px({n: c for n, c in cams.items() if n in sfm_static}, infos, xy, pairs, coarse)
            use = (len(cams) >= len(est.cameras) or from_tracks) and n_fb >= n_sfm and fb_px < sfm_px
            if n_sfm == 0:  # e.g. one static camera and a moving one: nothing to compare on
                why += (f"; no pair of its {len(sfm_static)} static camera(s) has enough aligned track pairs "
                        f"to compare it with the moving points' cameras on, so it is kept")
            else:
                why += (f"; on the moving points its cameras leave a median epipolar distance of {sfm_px:.1f} px, "
                        f"the moving points' own cameras {fb_px:.1f} px")
        stats["sfm"]["fallback"] = {"reference": ref, "pairs": details, "why": why, "used": bool(use)}
        log.warning("%s; cameras from the moving points: %d (%s)", why, len(cams), "used" if use else "not used")
        if use:
            # the offsets the cameras were fitted at, relative to the reference (_check_fitted_offsets)
            stats["sfm"]["fallback"]["fitted_offsets_s"] = {ref: 0.0} | {
                n: details[n]["coarse_offset_s"] for n in cams if n != ref}
            stats["camera_source"] = "estimated from moving points (two-view geometry)"
            stats["sfm"]["lens"] = {}  # these cameras are pinhole: the tracks stay as they were
            stats["dropped"].update(reasons)
            for n, reason in reasons.items():
                log.warning("%s: %s", n, reason)
            # pinhole cameras: their points are not undistorted
            return _CameraSet(cams, {n: Tracks(vids[n].xy_full, vids[n].instance) for n in cams}, None, None, {})
        if len(est.cameras) < 2:  # neither worked: say why for both
            est = dataclasses.replace(est, unregistered={
                n: (f"{sfm_why}; from the moving points: {reasons[n].removeprefix('camera could not be registered: ')}"
                    if n in reasons else sfm_why) for n, sfm_why in est.unregistered.items()})
    stats["dropped"].update(est.unregistered)
    for n, why in est.unregistered.items():
        log.warning("%s: %s", n, why)
    cameras, tracks, undistort = {}, {}, {}
    for n, c in est.cameras.items():
        cameras[n] = c.track
        undistort[n] = functools.partial(undistort_with_colmap, c)
        tracks[n] = Tracks(undistort[n](vids[n].xy_full), vids[n].instance)
    return _CameraSet(cameras, tracks, est.points_world, est.colors, undistort)
