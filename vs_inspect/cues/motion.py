"""Moving regions of one video: static vs moving camera, per-frame masks, instances over time.

Pure functions of grey frames (T,H,W) uint8 at working resolution; no I/O, no sink.
"""

from __future__ import annotations

import logging

import cv2
import numpy as np

from .config import MotionConfig

log = logging.getLogger(__name__)


def _check_frames(frames: np.ndarray) -> None:
    if frames.ndim != 3 or frames.dtype != np.uint8:
        raise ValueError(f"frames must be (T,H,W) uint8 grey images, got {frames.shape} {frames.dtype}")


def _sparse_flow(a: np.ndarray, b: np.ndarray, max_corners: int = 400):
    """Corners of a and where they went in b (forward-backward checked): (P,2), (P,2)."""
    pts = cv2.goodFeaturesToTrack(a, maxCorners=max_corners, qualityLevel=0.01, minDistance=8,
                                  blockSize=7)
    if pts is None or len(pts) < 8:
        return np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32)
    nxt, st, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, None, winSize=(21, 21), maxLevel=4)
    back, st2, _ = cv2.calcOpticalFlowPyrLK(b, a, nxt, None, winSize=(21, 21), maxLevel=4)
    ok = (st[:, 0] == 1) & (st2[:, 0] == 1) & (np.linalg.norm(back - pts, axis=2)[:, 0] < 1.0)
    return pts[ok, 0], nxt[ok, 0]


def background_motion(frames: np.ndarray, samples: int = 8, gap: int = 1) -> float:
    """Typical displacement (px) of background features between frames t and t+gap.

    The per-pair statistic is the 30th percentile over all tracked corners, which a moving
    object covering less than 70% of the corners cannot move; the result is the median over pairs.
    """
    _check_frames(frames)
    T = frames.shape[0]
    if T < 2:
        return 0.0
    starts = np.unique(np.linspace(0, T - 1 - gap, min(samples, T - gap)).round().astype(int))
    meds = []
    for t in starts:
        p, q = _sparse_flow(frames[t], frames[t + gap])
        if len(p) >= 8:
            meds.append(float(np.percentile(np.linalg.norm(q - p, axis=1), 30)))
    return float(np.median(meds)) if meds else 0.0


def decide_camera_motion(frames: np.ndarray, cfg: MotionConfig) -> tuple[str, float]:
    """('static' | 'moving', measured background motion in px)."""
    motion = background_motion(frames)
    if cfg.camera_motion in ("static", "moving"):
        return cfg.camera_motion, motion
    return ("static" if motion < cfg.static_max_motion_px else "moving"), motion


def _clean(mask: np.ndarray, cfg: MotionConfig) -> np.ndarray:
    """Opening, closing, and removal of small regions: (H,W) bool -> (H,W) bool."""
    m = mask.astype(np.uint8)
    if cfg.open_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (cfg.open_px, cfg.open_px)))
    if cfg.close_px > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (cfg.close_px, cfg.close_px)))
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    min_area = cfg.min_region_fraction * mask.size
    keep = np.zeros(n, bool)
    keep[1:] = stats[1:, cv2.CC_STAT_AREA] >= min_area
    return keep[lab]


def static_camera_masks(frames: np.ndarray, cfg: MotionConfig) -> np.ndarray:
    """(T,H,W) bool moving regions of a static camera: difference from a temporal-median background."""
    _check_frames(frames)
    T = frames.shape[0]
    idx = np.unique(np.linspace(0, T - 1, min(cfg.background_frames, T)).round().astype(int))
    blur = np.stack([cv2.GaussianBlur(f, (5, 5), 0) for f in frames])
    background = np.median(blur[idx], axis=0).astype(np.int16)
    masks = np.empty(frames.shape, bool)
    for t in range(T):
        diff = np.abs(blur[t].astype(np.int16) - background)
        masks[t] = _clean(diff > cfg.diff_threshold, cfg)
    return masks


def _warp_to(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """src warped onto dst by the homography of their background motion, and the valid area."""
    p, q = _sparse_flow(src, dst)
    if len(p) < 12:
        return None
    H, inl = cv2.findHomography(p, q, cv2.RANSAC, 2.0)
    if H is None:
        return None
    h, w = dst.shape
    warped = cv2.warpPerspective(src, H, (w, h), flags=cv2.INTER_LINEAR)
    valid = cv2.warpPerspective(np.ones_like(src), H, (w, h), flags=cv2.INTER_NEAREST) > 0
    return warped, valid


def neighbour_gap(cfg: MotionConfig, frame_interval_s: float | None = None) -> int:
    """d, in frames, between a moving camera's frame and the neighbours it is compared with: at
    least cfg.neighbour_frames and, when the frame spacing is known, the whole number of frames
    nearest cfg.neighbour_s."""
    d = max(1, cfg.neighbour_frames)
    if frame_interval_s is not None and frame_interval_s > 0:
        d = max(d, int(round(cfg.neighbour_s / frame_interval_s)))
    return d


def moving_camera_masks(frames: np.ndarray, cfg: MotionConfig,
                        frame_interval_s: float | None = None) -> np.ndarray:
    """(T,H,W) bool moving regions of a moving camera: residual difference after compensating the
    camera's own motion (a homography to the neighbours t-d and t+d, min of the two differences;
    d from neighbour_gap)."""
    _check_frames(frames)
    T = frames.shape[0]
    d = neighbour_gap(cfg, frame_interval_s)
    blur = np.stack([cv2.GaussianBlur(f, (5, 5), 0) for f in frames])
    masks = np.zeros(frames.shape, bool)
    for t in range(T):
        diffs = []
        for s in (t - d, t + d):
            if 0 <= s < T:
                out = _warp_to(blur[s], blur[t])
                if out is None:
                    continue
                warped, valid = out
                diff = np.abs(blur[t].astype(np.int16) - warped.astype(np.int16))
                diff[~valid] = 0
                diffs.append(diff)
        if not diffs:
            continue
        diff = np.minimum.reduce(diffs) if len(diffs) > 1 else diffs[0]
        masks[t] = _clean(diff > cfg.diff_threshold, cfg)
    return masks


def link_instances(masks: np.ndarray, cfg: MotionConfig) -> np.ndarray:
    """(T,H,W) int16 (int32 if many) instance ids (0 = background) from per-frame masks.

    Connected regions of consecutive frames that overlap (IoU >= link_iou) belong to one
    instance; a region that overlaps several earlier instances merges them (union-find), so
    an object that splits and re-joins keeps one id.
    """
    T = masks.shape[0]
    labels = np.zeros(masks.shape, np.int32 if masks.shape[0] * masks[0].size < 2**26 else np.int16)
    parent: list[int] = [0]

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    prev = None
    for t in range(T):
        n, lab = cv2.connectedComponents(masks[t].astype(np.uint8), connectivity=8)
        lab = lab.astype(np.int64)
        cur_ids = np.zeros(n, np.int64)
        area = np.bincount(lab.ravel(), minlength=n)
        links: dict[int, list[int]] = {}
        if prev is not None and n > 1:
            both = (lab > 0) & (prev > 0)
            if both.any():
                m = int(prev.max()) + 1
                key, cnt = np.unique(lab[both] * m + prev[both], return_counts=True)
                prev_area = np.bincount(prev.ravel(), minlength=m)
                for k, c in zip(key.tolist(), cnt.tolist()):
                    ci, pi = divmod(k, m)
                    if c / (area[ci] + prev_area[pi] - c) >= cfg.link_iou:
                        links.setdefault(ci, []).append(pi)
        for c in range(1, n):
            ids = links.get(c, [])
            if ids:
                root = find(ids[0])
                for other in ids[1:]:
                    r = find(other)
                    if r != root:
                        parent[max(r, root)] = min(r, root)
                        root = min(r, root)
                cur_ids[c] = root
            else:
                parent.append(len(parent))
                cur_ids[c] = len(parent) - 1
        cur = cur_ids[lab]
        labels[t] = cur
        prev = cur
    roots = np.array([find(i) for i in range(len(parent))], np.int32)
    labels = roots[labels]
    uniq = np.unique(labels)
    remap = np.zeros(int(uniq.max()) + 1, np.int32)
    remap[uniq[uniq > 0]] = np.arange(1, int((uniq > 0).sum()) + 1)
    return remap[labels].astype(np.int16) if len(uniq) < 32000 else remap[labels]


def moving_regions(frames: np.ndarray, cfg: MotionConfig, camera_motion: str | None = None,
                   frame_interval_s: float | None = None):
    """(instances (T,H,W) int32, camera_motion, background_motion_px) for one video.
    frame_interval_s: its typical frame spacing (s), when known (a moving camera's neighbours)."""
    mode, bg = decide_camera_motion(frames, cfg)
    if camera_motion in ("static", "moving"):
        mode = camera_motion
    masks = static_camera_masks(frames, cfg) if mode == "static" else \
        moving_camera_masks(frames, cfg, frame_interval_s)
    return link_instances(masks, cfg), mode, bg
