"""People followed over time in one video: the poses found frame by frame (cues/people_detect.py)
linked into one track per person.

Each frame, every live track is continued by at most one pose and each pose continues at most
one track (Hungarian assignment) when their landmarks lie close: within max_step_share of the
person's size (median over the landmarks both see, under either labelling:
geometry/skeleton.pose_distance) per frame since the track was last seen, or their landmark boxes
overlapping by min_box_iou. A track not continued for max_gap_s ends; a pose that continues none
starts a track. BlazePose may swap a person's left and right from one frame to the next (seen from
behind): a track's labelling is kept consistent over time by taking, each frame, the labelling
nearer to the track's last pose. Pure numpy/scipy, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..geometry.skeleton import MIRROR, NUM_LANDMARKS, box_overlap, landmark_box, person_scale_px, pose_distance
from ..people_types import VideoPeople


@dataclass(frozen=True)
class TrackingConfig:
    """How poses found frame by frame become one track per person."""

    min_visibility: float = 0.5
    """A landmark counts as seen when BlazePose's visibility is at least this."""
    max_step_share: float = 0.35
    """A pose continues a track when their landmarks lie within this share of the person's size
    of each other (median), per frame since the track was last seen..."""
    min_box_iou: float = 0.5
    """...or when their landmark boxes overlap this much (intersection over union)."""
    max_gap_s: float = 0.5
    """A track not continued for this long ends."""
    min_track_s: float = 1.0
    """Tracks shorter than this (from first to last frame) are dropped."""
    min_landmarks: int = 6
    """A pose with fewer seen landmarks is ignored."""

    def __post_init__(self) -> None:
        if not (0 <= self.min_visibility <= 1) or self.max_step_share <= 0 or self.max_gap_s < 0 \
                or self.min_track_s < 0 or self.min_landmarks < 2 or not (0 < self.min_box_iou <= 1):
            raise ValueError(f"TrackingConfig out of range: {self}")


def seen_xy(landmarks: np.ndarray, min_visibility: float) -> np.ndarray:
    """(...,33,2) x, y of (...,33,3) landmarks, NaN where visibility < min_visibility."""
    vis = np.nan_to_num(landmarks[..., 2], nan=0.0)
    return np.where((vis >= min_visibility)[..., None], landmarks[..., :2], np.nan)


class PeopleTracker:
    """Links the poses of successive frames into tracks (update once per frame, in order)."""

    def __init__(self, name: str, times_s: np.ndarray, cfg: TrackingConfig = TrackingConfig()):
        self.name, self.cfg = name, cfg
        self.times_s = np.asarray(times_s, dtype=np.float64)
        self._tracks: list[dict] = []  # {"rows": {frame: (33,3)}, "last": frame}
        self._live: list[int] = []

    def live(self, k: int) -> list[tuple[int, np.ndarray]]:
        """(track id, its last pose (33,3)) of the tracks still live at frame k: seen within
        max_gap_s, and (a track seen once) in the frame before."""
        t = self.times_s[k]
        self._live = [i for i in self._live
                      if t - self.times_s[self._tracks[i]["last"]] <= self.cfg.max_gap_s + 1e-9
                      and (len(self._tracks[i]["rows"]) > 1 or self._tracks[i]["last"] >= k - 1)]
        return [(i, self._tracks[i]["rows"][self._tracks[i]["last"]]) for i in self._live]

    def update(self, k: int, poses: np.ndarray) -> None:
        """Frame k's poses (K,33,3) (x px, y px, visibility)."""
        cfg = self.cfg
        poses = np.asarray(poses, dtype=np.float64).reshape(-1, NUM_LANDMARKS, 3)
        xy = seen_xy(poses, cfg.min_visibility)
        keep = np.isfinite(xy).all(-1).sum(-1) >= cfg.min_landmarks
        poses, xy = poses[keep], xy[keep]
        live = self.live(k)
        cost = np.full((len(live), len(poses)), np.inf)
        boxes = landmark_box(xy)
        for r, (i, last) in enumerate(live):
            last_xy = seen_xy(last, cfg.min_visibility)
            gap = max(k - self._tracks[i]["last"], 1)
            d = pose_distance(last_xy[None], xy) / max(float(person_scale_px(last_xy)), 1.0)
            iou, _ = box_overlap(landmark_box(last_xy)[None], boxes)
            ok = (d <= cfg.max_step_share * gap) | (iou >= cfg.min_box_iou)
            cost[r] = np.where(ok, np.minimum(d, 1.0 - iou), np.inf)
        taken = set()
        if cost.size and np.isfinite(cost).any():
            rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e9))
            for r, c in zip(rows, cols):
                if np.isfinite(cost[r, c]):
                    i = live[r][0]
                    tr = self._tracks[i]
                    tr["rows"][k] = _consistent_labelling(tr["rows"][tr["last"]], poses[c], cfg.min_visibility)
                    tr["last"] = k
                    taken.add(int(c))
        for c in range(len(poses)):
            if c not in taken:
                self._tracks.append({"rows": {k: poses[c]}, "last": k})
                self._live.append(len(self._tracks) - 1)

    def result(self) -> VideoPeople:
        """The tracks long enough (min_track_s), as (P,T,33,3) landmarks."""
        t = self.times_s
        kept = [tr for tr in self._tracks
                if t[max(tr["rows"])] - t[min(tr["rows"])] >= self.cfg.min_track_s - 1e-9]
        out = np.full((len(kept), len(t), NUM_LANDMARKS, 3), np.nan)
        for p, tr in enumerate(kept):
            for k, pose in tr["rows"].items():
                out[p, k] = pose
        return VideoPeople(self.name, out, t, self.cfg.min_visibility)


def link_people(name: str, times_s: np.ndarray, frames: list[np.ndarray],
                cfg: TrackingConfig = TrackingConfig()) -> VideoPeople:
    """One track per person of a video whose frame k (local time times_s[k]) shows the poses
    frames[k] (K_k,33,3) (x px, y px, visibility)."""
    if len(frames) != len(times_s):
        raise ValueError(f"{name}: {len(frames)} frames of poses for {len(times_s)} frame times")
    tracker = PeopleTracker(name, times_s, cfg)
    for k, poses in enumerate(frames):
        tracker.update(k, poses)
    return tracker.result()


def _consistent_labelling(previous: np.ndarray, pose: np.ndarray, min_visibility: float) -> np.ndarray:
    """pose (33,3) as given or mirrored, whichever lies nearer to the track's previous pose."""
    prev_xy = seen_xy(previous, min_visibility)
    xy = seen_xy(pose, min_visibility)

    def dist(other: np.ndarray) -> float:
        d = np.linalg.norm(prev_xy - other, axis=-1)
        d = d[np.isfinite(d)]
        return float(np.median(d)) if len(d) else np.inf

    return pose[MIRROR] if dist(xy[MIRROR]) < dist(xy) else pose
