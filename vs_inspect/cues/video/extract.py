"""Stage 0 of one video on its own: decoding, moving regions, point tracks inside them, keyframe
features, and the frames camera estimation may need, as an engine task (pipeline/stage0.py runs one
per video and reports what it returns to the sink)."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import cv2
import numpy as np

from ...errors import InputError
from ...geometry.camera_model import scale_points
from ...types import VideoInfo
from ..config import CueConfig
from ..features import LEARNED_FEATURES
from ..pairing.descriptors import KeyframeFeatures, extract_keyframe_features, keyframe_indices
from .motion import moving_regions
from .tracking import track_points

log = logging.getLogger(__name__)

SHOWN_FRAMES = 8  # frames per video the recording shows (with their moving regions)
REGISTER_EVERY = 1  # a moving camera's frames registered on their own: every this many...
REGISTER_MAX_HZ = 10.0  # ...and at most about this many a second (at 30 fps every 3rd; slerped between)


@dataclass(frozen=True)
class VideoCues:
    """One video's own cues, found before any other video is looked at."""

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
    return scale_points(xy, *scale_xy)


def _sfm_indices(T: int, moving: bool, cfg) -> np.ndarray:
    n = cfg.camera.moving_frames if moving else cfg.camera.static_frames
    return np.unique(np.linspace(0, T - 1, max(1, min(n, T))).round().astype(int))


def _register_indices(info: VideoInfo, cfg) -> np.ndarray:
    """A moving video's frames to register against the reconstruction (cues/cameras/registration.py):
    every REGISTER_EVERY-th, at most about REGISTER_MAX_HZ per second, and the SfM
    frames too (registered from their neighbours they check the registration)."""
    step = max(REGISTER_EVERY, frame_step(info, REGISTER_MAX_HZ))
    return np.union1d(np.arange(0, info.num_frames, step), _sfm_indices(info.num_frames, True, cfg))


def frame_step(info: VideoInfo, max_hz: float) -> int:
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
    from ..cameras.sfm import aliked_tried_last
    from ..features.learned import xfeat_available

    return cfg.camera.features in LEARNED_FEATURES or (cfg.camera.features == "auto" and xfeat_available()) \
        or aliked_tried_last(cfg.camera)


def _video_cues(src, cfg: CueConfig, need_sfm: bool, timings: dict, shown: dict | None) -> VideoCues:
    """One video's cues; shown (when not None) gets {frame index: (working-resolution BGR image,
    (h,w) instance ids)} of SHOWN_FRAMES frames spread over the video, for the recording."""
    from ...io.video import downscale, iter_frames

    info = src.info
    t0 = time.perf_counter()
    grey = []
    sink_at = set(np.linspace(0, info.num_frames - 1, max(1, SHOWN_FRAMES)).round().astype(int).tolist())
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
        if k in sink_at and shown is not None:
            shown[k] = img
    frames = np.stack(grey)
    h, w = frames.shape[1:]
    scale = (info.width / w, info.height / h)
    timings["decode_s"] = timings.get("decode_s", 0.0) + time.perf_counter() - t0

    t0 = time.perf_counter()
    instances, mode, bg = moving_regions(frames, cfg.camera_motion.get(info.name), info.frame_interval_s)
    moving_fraction = float((instances > 0).mean())
    if shown is not None:
        for k in sorted(shown):
            shown[k] = (shown[k], instances[k].copy())
    timings["motion_s"] = timings.get("motion_s", 0.0) + time.perf_counter() - t0
    log.info("%s: %s camera (background motion %.2f px), moving regions cover %.1f%%",
             info.name, mode, bg, 100 * moving_fraction)

    t0 = time.perf_counter()
    xy, inst = track_points(frames, instances, cfg.max_tracks)
    timings["tracking_s"] = timings.get("tracking_s", 0.0) + time.perf_counter() - t0

    t0 = time.perf_counter()
    kf = keyframe_indices(info.num_frames, cfg.keyframes)
    feats = extract_keyframe_features(frames, instances > 0, kf, xy)
    timings["features_s"] = timings.get("features_s", 0.0) + time.perf_counter() - t0

    sfm = None
    if need_sfm:
        t0 = time.perf_counter()
        idx = _sfm_indices(info.num_frames, mode == "moving", cfg)
        imgs = [sfm_images[k] for k in idx.tolist()]
        del sfm_images
        masks = [_static_mask(instances[k] > 0, (im.shape[1], im.shape[0])) for k, im in zip(idx, imgs)]
        if mode == "static" and len(imgs) > 1:
            # one image of a static camera: the temporal median shows the background without the
            # moving objects; pixels that move in most sampled frames stay masked
            imgs = [np.median(np.stack(imgs), axis=0).astype(np.uint8)]
            masks = [np.mean([~m for m in masks], axis=0) < 0.5]
            idx = idx[:1]
        sfm = (idx, imgs, masks)
        timings["sfm_frames_s"] = timings.get("sfm_frames_s", 0.0) + time.perf_counter() - t0
    frame_feats = register_masks = None
    if need_sfm and mode == "moving":
        todo = _register_indices(info, cfg)
        if cfg.camera.features not in LEARNED_FEATURES:
            # SIFT's features to register each frame with against a SIFT reconstruction (its
            # database's kind; registration.py), found here where the frames are decoded
            from ..cameras.registration import frame_features

            t0 = time.perf_counter()
            frame_feats = frame_features(frames, instances, todo, scale,
                                         cfg.camera.max_features)
            timings["frame_features_s"] = timings.get("frame_features_s", 0.0) + time.perf_counter() - t0
        if _learned_model_possible(cfg):
            # a learned reconstruction registers them with its own features, on the frames
            # decoded again at SfM resolution only if it is built (cameras.py); their moving
            # regions are kept here, packed (a bit per pixel)
            register_masks = (todo, np.packbits(instances[todo] > 0, axis=-1), int(instances.shape[2]))
    return VideoCues(info, str(src.path), scale, to_full_px(xy, scale), inst, feats, mode, bg,
                      moving_fraction, sfm, frame_feats, register_masks)


def registration_images(src, v: VideoCues, cfg: CueConfig, chunk: int = 16):
    """(frame index, BGR image at SfM resolution, static mask or None) of v's frames to register
    (v.register_masks), decoded again from src, chunk frames at a time (a long video's frames are
    never all held at once)."""
    from ...io.video import read_frames

    todo, packed, w = v.register_masks
    for start in range(0, len(todo), chunk):
        frames = todo[start:start + chunk]
        for i, (k, img) in enumerate(zip(frames, read_frames(src, frames, cfg.camera.max_side)), start):
            moving = np.unpackbits(packed[i], axis=-1, count=w).astype(bool)
            yield int(k), img, _static_mask(moving, (img.shape[1], img.shape[0]))


@dataclass(frozen=True)
class VideoCuesOutcome:
    """What one video's Stage 0 task returns: its cues, or why it has none, and the frames the
    recording shows (the driver hands them to its sink, so tasks need no sink)."""

    cues: VideoCues | None  # None when the video could not be read
    error: str | None  # why (None when cues is set)
    shown: tuple  # ((frame index, (h,w,3) uint8 BGR working resolution, (h,w) instance ids), ...)
    timings_s: dict  # step -> seconds spent on this video


def video_cues_task(task: tuple, src) -> VideoCuesOutcome:
    """Stage 0 of one video as an engine task. task: (CueConfig, whether the frames shown are
    wanted, whether camera-estimation frames are needed); src: its VideoSource (the task opens
    the file, which must be reachable from the worker)."""
    cfg, show, need_sfm = task
    shown, timings = ({} if show else None), {}
    try:
        cues = _video_cues(src, cfg, need_sfm, timings, shown)
    except InputError as exc:
        return VideoCuesOutcome(None, str(exc), (), timings)
    return VideoCuesOutcome(cues, None, tuple((k, img, inst) for k, (img, inst) in sorted((shown or {}).items())),
                            timings)
