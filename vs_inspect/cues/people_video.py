"""Every person of one video found and followed: detect, then follow.

Every discover_s (and on the first frame) the detector looks over the whole frame and its
windows (cues/people_detect.frame_windows) for people; on every frame each person followed is
looked for again in a square crop around where they last were, where the detector's 224 px
input sees them large. The poses of a frame are merged (one per person) and linked to the tracks
(cues/people_tracking.PeopleTracker). A few pairs of successive frames also measure how much the
background moves (cues/video/motion.py), which tells a static camera from a moving one.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from ..geometry.skeleton import person_scale_px, pose_distance
from ..io.video import downscale
from ..people_types import VideoPeople
from .video.motion import background_motion
from .people_detect import DetectorConfig, DetectorPool, frame_windows, merge_duplicates
from .people_tracking import PeopleTracker, TrackingConfig, seen_xy


@dataclass(frozen=True)
class PeopleVideoConfig:
    """How the people of one video are found and followed."""

    detector: DetectorConfig = field(default_factory=DetectorConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    discover_s: float = 0.5
    """The whole frame and its windows are searched for new people this often (s)."""
    crop_scale: float = 1.6
    """A person followed is looked for in a square this many times the larger side of the box
    around their last landmarks..."""
    min_crop_px: int = 128
    """...and at least this many px wide."""
    motion_pairs: int = 8
    """Pairs of successive frames (spread over the video) whose background motion tells a static
    camera from a moving one."""
    motion_side: int = 640
    """...measured with the frames' longer side at most this many px (Stage 0's working size)."""

    def __post_init__(self) -> None:
        if self.discover_s < 0 or self.crop_scale < 1 or self.min_crop_px < 32:
            raise ValueError(f"PeopleVideoConfig out of range: {self}")


def crop_around(pose: np.ndarray, width: int, height: int, scale: float, min_side: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) px: a square around a pose (33,3)'s landmarks (any visibility), scale times
    their box's larger side (at least min_side, at most the frame's shorter side), kept inside
    the frame."""
    xy = pose[:, :2][np.isfinite(pose[:, :2]).all(1)]
    x0, y0 = xy.min(0)
    x1, y1 = xy.max(0)
    side = int(round(min(max(scale * max(x1 - x0, y1 - y0), min_side), min(width, height))))
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    left = int(round(min(max(cx - side / 2, 0), width - side)))
    top = int(round(min(max(cy - side / 2, 0), height - side)))
    return left, top, left + side, top + side


def _matching(pose: np.ndarray, found: list[np.ndarray], cfg: TrackingConfig) -> np.ndarray | None:
    """The pose of found nearest to a followed person's last pose, when near enough."""
    if not found:
        return None
    last = seen_xy(pose, cfg.min_visibility)
    size = max(float(person_scale_px(last)), 1.0)
    d = [pose_distance(last, seen_xy(f, cfg.min_visibility)) / size for f in found]
    k = int(np.argmin(d))
    return found[k] if d[k] <= 2 * cfg.max_step_share else None


@dataclass(frozen=True)
class PeopleVideoStats:
    """What finding the people of one video took."""

    frames: int
    discovery_frames: int  # frames searched whole for new people
    crops: int  # crops around people followed
    seconds: float
    background_motion_px: float  # typical motion of the background between frames (cues/video/motion.py), px at
    # motion_side


def find_people(name: str, frames: Iterable[tuple[int, np.ndarray]], times_s: np.ndarray,
                cfg: PeopleVideoConfig = PeopleVideoConfig(), workers: int | None = None
                ) -> tuple[VideoPeople, PeopleVideoStats]:
    """The people of one video: frames yields (frame index, (H,W,3) uint8 BGR) in order (every
    frame, at the resolution the landmarks are wanted in), times_s (T,) are the video's local
    frame times. workers: detectors looking at a frame's crops and windows at once (default: two,
    or one on a one-core machine); the result does not depend on it."""
    import cv2

    t0 = time.perf_counter()
    times_s = np.asarray(times_s, dtype=np.float64)
    tracker = PeopleTracker(name, times_s, cfg.tracking)
    last_discovery, n_frames, n_disc, n_crops = -np.inf, 0, 0, 0
    T = len(times_s)
    firsts = set(np.unique(np.linspace(0, max(T - 2, 0), min(cfg.motion_pairs, max(T - 1, 0))).astype(int)).tolist())
    grey: dict[int, np.ndarray] = {}
    with DetectorPool(cfg.detector, workers or min(2, os.cpu_count() or 1)) as detectors:
        for k, bgr in frames:
            h, w = bgr.shape[:2]
            if k in firsts or k - 1 in firsts:
                grey[k] = cv2.cvtColor(downscale(bgr, cfg.motion_side), cv2.COLOR_BGR2GRAY)
            followed = [pose for _, pose in tracker.live(k)]
            crops = [crop_around(pose, w, h, cfg.crop_scale, cfg.min_crop_px) for pose in followed]
            discover = times_s[k] - last_discovery >= cfg.discover_s - 1e-9
            whole = frame_windows(w, h, cfg.detector) if discover else []
            found = detectors.poses_in(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), crops + whole,
                                       [True] * len(crops) + [False] * len(whole))
            n_crops += len(crops)
            poses, windows, window_of = [], [], []
            for pose, box, in_crop in zip(followed, crops, found):
                match = _matching(pose, in_crop, cfg.tracking)
                if match is not None:
                    windows.append(box)
                    window_of.append(len(windows) - 1)
                    poses.append(match)
            if discover:
                for i, in_window in enumerate(found[len(crops):]):
                    poses += in_window
                    window_of += [len(windows) + i] * len(in_window)
                windows += whole
                last_discovery = times_s[k]
                n_disc += 1
            merged = merge_duplicates(poses, windows, window_of, cfg.detector)
            tracker.update(k, merged.landmarks)
            n_frames += 1
    moves = [background_motion(np.stack([grey[t], grey[t + 1]]), samples=1) for t in sorted(firsts)
             if t in grey and t + 1 in grey]
    motion = float(np.median(moves)) if moves else 0.0
    return tracker.result(), PeopleVideoStats(n_frames, n_disc, n_crops, time.perf_counter() - t0, motion)
