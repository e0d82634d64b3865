"""Moving regions of one video: static vs moving camera, per-frame masks, instances over time.

Pure functions of grey frames (T,H,W) uint8 at working resolution; no I/O, no sink.
"""

from __future__ import annotations

import logging

import cv2
import numpy as np

log = logging.getLogger(__name__)

STATIC_MAX_MOTION_PX = 0.5  # a camera whose slower features (30th percentile) move less is static
DIFF_THRESHOLD = 22.0  # grey-level difference (0-255) from the background or the neighbour that moves
BACKGROUND_FRAMES = 60  # static camera: frames (evenly spread) of the temporal-median background
NEIGHBOUR_FRAMES = 2  # moving camera: frame t against t-d and t+d, d at least this many frames...
NEIGHBOUR_S = 0.08  # ...and the whole number of frames nearest this when the rate is known
OPEN_PX = 3  # morphological opening (working px): speckle removed
CLOSE_PX = 15  # morphological closing (working px): holes filled
MIN_REGION_FRACTION = 0.002  # connected regions smaller than this share of the image are dropped
LINK_IOU = 0.05  # a region continues an instance of the previous frame from this overlap (IoU)


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


def decide_camera_motion(frames: np.ndarray) -> tuple[str, float]:
    """('static' | 'moving', measured background motion in px)."""
    motion = background_motion(frames)
    return ("static" if motion < STATIC_MAX_MOTION_PX else "moving"), motion


def _clean(mask: np.ndarray) -> np.ndarray:
    """Opening, closing, and removal of small regions: (H,W) bool -> (H,W) bool."""
    m = mask.astype(np.uint8)
    if OPEN_PX > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_OPEN, cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (OPEN_PX, OPEN_PX)))
    if CLOSE_PX > 1:
        m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (CLOSE_PX, CLOSE_PX)))
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    min_area = MIN_REGION_FRACTION * mask.size
    keep = np.zeros(n, bool)
    keep[1:] = stats[1:, cv2.CC_STAT_AREA] >= min_area
    return keep[lab]


def static_camera_masks(frames: np.ndarray) -> np.ndarray:
    """(T,H,W) bool moving regions of a static camera: difference from a temporal-median background."""
    _check_frames(frames)
    T = frames.shape[0]
    idx = np.unique(np.linspace(0, T - 1, min(BACKGROUND_FRAMES, T)).round().astype(int))
    blur = np.stack([cv2.GaussianBlur(f, (5, 5), 0) for f in frames])
    background = np.median(blur[idx], axis=0).astype(np.int16)
    masks = np.empty(frames.shape, bool)
    for t in range(T):
        diff = np.abs(blur[t].astype(np.int16) - background)
        masks[t] = _clean(diff > DIFF_THRESHOLD)
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


def neighbour_gap(frame_interval_s: float | None = None) -> int:
    """d, in frames, between a moving camera's frame and the neighbours it is compared with: at
    least NEIGHBOUR_FRAMES and, when the frame spacing is known, the whole number of frames
    nearest NEIGHBOUR_S."""
    d = max(1, NEIGHBOUR_FRAMES)
    if frame_interval_s is not None and frame_interval_s > 0:
        d = max(d, int(round(NEIGHBOUR_S / frame_interval_s)))
    return d


def moving_camera_masks(frames: np.ndarray, frame_interval_s: float | None = None) -> np.ndarray:
    """(T,H,W) bool moving regions of a moving camera: residual difference after compensating the
    camera's own motion (a homography to the neighbours t-d and t+d, min of the two differences;
    d from neighbour_gap)."""
    _check_frames(frames)
    T = frames.shape[0]
    d = neighbour_gap(frame_interval_s)
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
        masks[t] = _clean(diff > DIFF_THRESHOLD)
    return masks


def link_instances(masks: np.ndarray) -> np.ndarray:
    """(T,H,W) int16 (int32 if many) instance ids (0 = background) from per-frame masks.

    Connected regions of consecutive frames that overlap (IoU >= LINK_IOU) belong to one
    instance; a region that overlaps several earlier instances merges them (union-find), so
    an object that splits and re-joins keeps one id. Overlaps are counted per region pair, not
    per pixel id, so any number of instances keeps distinct ids.
    """
    parent: list[int] = [0]

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def components(t: int) -> tuple[int, np.ndarray]:
        return cv2.connectedComponents(masks[t].astype(np.uint8), connectivity=8, ltype=cv2.CV_32S)

    # first pass: each frame's regions get a union-find node (the ids stay per region, so the
    # whole video is never held as labels); the second pass writes the final ids
    node_of_region: list[np.ndarray] = []
    prev_lab = prev_node = None
    for t in range(masks.shape[0]):
        n, lab = components(t)
        node = np.zeros(n, np.int64)
        iou_ok = None
        if prev_lab is not None and n > 1 and len(prev_node) > 1:
            both = (lab > 0) & (prev_lab > 0)
            if both.any():
                m = len(prev_node)
                # overlap of each region with each earlier instance (its regions pooled, as the
                # earlier frame's pixels carry their instance's node)
                pair = np.bincount(lab[both].astype(np.int64) * m + prev_lab[both], minlength=n * m).reshape(n, m)
                instances, of_region = np.unique(prev_node, return_inverse=True)
                overlap = np.zeros((n, len(instances)), np.int64)
                np.add.at(overlap.T, of_region, pair.T)
                area = np.bincount(lab.ravel(), minlength=n)
                prev_area = np.zeros(len(instances), np.int64)
                np.add.at(prev_area, of_region, np.bincount(prev_lab.ravel(), minlength=m))
                with np.errstate(invalid="ignore", divide="ignore"):
                    iou = overlap / (area[:, None] + prev_area[None, :] - overlap)
                iou_ok = (overlap > 0) & (iou >= LINK_IOU) & (instances > 0)[None, :]
        for c in range(1, n):
            ids = instances[iou_ok[c]].tolist() if iou_ok is not None else []
            if ids:
                root = find(ids[0])
                for other in ids[1:]:
                    r = find(other)
                    if r != root:
                        parent[max(r, root)] = min(r, root)
                        root = min(r, root)
                node[c] = root
            else:
                parent.append(len(parent))
                node[c] = len(parent) - 1
        node_of_region.append(node)
        prev_lab, prev_node = lab, node
    roots = np.array([find(i) for i in range(len(parent))], np.int64)
    used = np.unique(roots[1:])
    final = np.zeros(len(parent), np.int64)
    final[1:] = np.searchsorted(used, roots[1:]) + 1
    out = np.zeros(masks.shape, np.int16 if len(used) + 1 < 32000 else np.int32)
    for t, node in enumerate(node_of_region):
        n, lab = components(t)
        out[t] = final[node].astype(out.dtype)[lab]
    return out


def moving_regions(frames: np.ndarray, camera_motion: str | None = None,
                   frame_interval_s: float | None = None):
    """(instances (T,H,W) int16, int32 if many (link_instances), camera_motion, background_motion_px)
    for one video.
    frame_interval_s: its typical frame spacing (s), when known (a moving camera's neighbours)."""
    mode, bg = decide_camera_motion(frames)
    if camera_motion in ("static", "moving"):  # the user's word for this video
        mode = camera_motion
    masks = static_camera_masks(frames) if mode == "static" else moving_camera_masks(frames, frame_interval_s)
    return link_instances(masks), mode, bg
