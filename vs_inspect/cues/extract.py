"""Stage 0: videos in, a cue bundle out (cameras, tracks inside moving regions, cross-view pairs).

Each step is a function in its own module (motion, tracking, matching, cameras; which cameras
in camera_choice, the joint vote on them in joint_vote); this module decodes the videos, calls
them in order, reports to the sink and keeps per-stage timings.
A video that cannot be used (unreadable, no camera) is left out of the bundle with its reason
in CueStats.dropped, so that the caller can report it as not synchronized; when no video can be
used, NoUsableVideos carries those reasons instead of a bundle.
"""

from __future__ import annotations

import contextlib
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
from ..record.sink import NullSink, Sink
from ..types import CueBundle, CueStats, TrackPairs, Tracks, VideoCueStats, VideoInfo
from .camera_choice import CameraSet, estimated_cameras, vote_on_cameras
from .config import CueConfig
from .learned import LEARNED_FEATURES
from .matching import (KeyframeFeatures, extract_keyframe_features, keyframe_indices,
                       match_tracks)
from .motion import moving_regions
from .tracking import track_points

log = logging.getLogger(__name__)

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
            kept = vote_on_cameras(CameraSet(cameras, tracks, None, None, undistort), vids, all_pairs, cfg,
                                   stats, sink, progress, estimated=False)
        else:
            by_name = {s.info.name: s for s in sources}
            frame_images = {n: (functools.partial(_registration_images, by_name[n], v, cfg), len(v.register_masks[0]))
                            for n, v in vids.items() if v.register_masks is not None}
            kept = estimated_cameras(vids, cfg, stats, all_pairs, frame_images, sink, progress)
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
