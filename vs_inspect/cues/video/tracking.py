"""Point tracks inside moving regions: pyramidal KLT with a forward-backward check, re-seeded
with goodFeaturesToTrack inside the mask as points are lost. Pure function of arrays.

Frame-to-frame KLT drifts: a track loses part of its motion each frame, slides backwards over
its object and looks late by a growing fraction of its age, which biases the offset. Each new
position is therefore refined against the point's appearance in an anchor frame (where it was
seeded, renewed when the refinement fails), which keeps the error from adding up frame after
frame (measured in BENCHMARKS.md, "Measurements behind defaults")."""

from __future__ import annotations

import cv2
import numpy as np

MAX_POINTS = 1500  # most tracks alive at once in a video (CueConfig.max_tracks)
MIN_DISTANCE_PX = 6.0  # least distance between seeded points (working px)
QUALITY_LEVEL = 0.005  # goodFeaturesToTrack's quality level
WIN_SIZE = 9  # KLT window (working px); a larger one mixes more background into a point near an outline
PYRAMID_LEVELS = 4  # KLT pyramid levels (large motion at low frame rates needs more)
FB_MAX_PX = 1.0  # forward-backward check: a point whose round trip misses by more is lost
MIN_LENGTH = 3  # tracks seen in fewer frames are dropped
SEED_ERODE_PX = 5  # seeds at least about half this far inside a moving region (erosion, working px)
RESEED_EVERY = 1  # new points seeded inside moving regions every this many frames
ANCHOR_MAX_PX = 2.0  # an anchor refinement moving the point by more is refused and the point re-anchored


def track_points(frames: np.ndarray, instances: np.ndarray, max_points: int = MAX_POINTS,
                 seed_mask: np.ndarray | None = None):
    """KLT tracks of one video at working resolution.

    frames: (T,H,W) uint8 grey; instances: (T,H,W) int instance ids (0 = background), seeds are
    placed where the id is > 0 (or where seed_mask (T,H,W) bool is true when given).
    Returns xy (N,T,2) float32 working px with NaN where unseen, and instance (N,) int32 (the id
    under the track most often; 0 if never inside a region).
    """
    if frames.ndim != 3 or instances.shape != frames.shape:
        raise ValueError(f"frames (T,H,W) and instances must match, got {frames.shape} and {instances.shape}")
    T, H, W = frames.shape
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)
    lk = dict(winSize=(WIN_SIZE, WIN_SIZE), maxLevel=PYRAMID_LEVELS, criteria=criteria)
    # refinement from the frame-to-frame estimate: one pyramid level is enough
    lk_anchor = dict(winSize=(WIN_SIZE, WIN_SIZE), maxLevel=1, criteria=criteria,
                     flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
    store = np.full((max(64, 2 * max_points), T, 2), np.nan, np.float32)  # grows as needed
    n_rows = 0
    active_xy = np.zeros((0, 2), np.float32)
    active_id = np.zeros(0, np.int64)
    anchor_t = np.zeros(0, np.int64)  # frame of each active point's anchor
    anchor_xy = np.zeros((0, 2), np.float32)  # its position there
    r = max(1, int(round(MIN_DISTANCE_PX)))
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    for t in range(T):
        if t > 0 and len(active_xy):
            p0 = active_xy.reshape(-1, 1, 2)
            p1, st, _ = cv2.calcOpticalFlowPyrLK(frames[t - 1], frames[t], p0, None, **lk)
            pb, st2, _ = cv2.calcOpticalFlowPyrLK(frames[t], frames[t - 1], p1, None, **lk)
            fb = np.linalg.norm((pb - p0).reshape(-1, 2), axis=1)
            q = p1.reshape(-1, 2)
            ok = (st[:, 0] == 1) & (st2[:, 0] == 1) & (fb < FB_MAX_PX)
            _refine_on_anchors(frames, t, q, ok, anchor_t, anchor_xy, lk_anchor)
            ok &= (q[:, 0] >= 0) & (q[:, 0] <= W - 1) & (q[:, 1] >= 0) & (q[:, 1] <= H - 1)
            active_xy, active_id = q[ok].astype(np.float32), active_id[ok]
            anchor_t, anchor_xy = anchor_t[ok], anchor_xy[ok]
            store[active_id, t] = active_xy
        want = max_points - len(active_xy)
        if want > 0 and (t % max(1, RESEED_EVERY) == 0):
            region = (seed_mask[t] if seed_mask is not None else instances[t] > 0).astype(np.uint8) * 255
            if SEED_ERODE_PX > 1:  # corners on an object's outline straddle the background
                region = cv2.erode(region, np.ones((SEED_ERODE_PX, SEED_ERODE_PX), np.uint8))
            if region.any():
                if len(active_xy):
                    taken = np.zeros_like(region)
                    ij = np.clip(np.round(active_xy).astype(int), 0, [W - 1, H - 1])
                    taken[ij[:, 1], ij[:, 0]] = 255
                    region[cv2.dilate(taken, disk) > 0] = 0
                pts = cv2.goodFeaturesToTrack(frames[t], maxCorners=want, qualityLevel=QUALITY_LEVEL,
                                              minDistance=MIN_DISTANCE_PX, mask=region, blockSize=5)
                if pts is not None and len(pts):
                    pts = cv2.cornerSubPix(frames[t], pts.astype(np.float32), (3, 3), (-1, -1),
                                           (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03))
                    pts = pts.reshape(-1, 2).astype(np.float32)
                    if n_rows + len(pts) > len(store):
                        grow = np.full((max(len(store), len(pts)), T, 2), np.nan, np.float32)
                        store = np.concatenate([store, grow])
                    ids = np.arange(n_rows, n_rows + len(pts))
                    n_rows += len(pts)
                    store[ids, t] = pts
                    active_xy = np.concatenate([active_xy, pts])
                    active_id = np.concatenate([active_id, ids])
                    anchor_t = np.concatenate([anchor_t, np.full(len(pts), t)])
                    anchor_xy = np.concatenate([anchor_xy, pts])
    if n_rows == 0:
        return np.zeros((0, T, 2), np.float32), np.zeros(0, np.int32)
    xy = store[:n_rows]
    seen = np.isfinite(xy[:, :, 0])
    xy = xy[seen.sum(1) >= MIN_LENGTH]
    return xy, track_instances(xy, instances)


def _refine_on_anchors(frames: np.ndarray, t: int, q: np.ndarray, ok: np.ndarray, anchor_t: np.ndarray,
                       anchor_xy: np.ndarray, lk_anchor: dict) -> None:
    """In place: q[ok] (frame-to-frame positions at t) refined by KLT from each point's anchor;
    points whose refinement fails (lost, or moved further than ANCHOR_MAX_PX: the appearance
    changed) are re-anchored at t on their frame-to-frame position."""
    for s in np.unique(anchor_t[ok]):
        g = np.nonzero(ok & (anchor_t == s))[0]
        p, st, _ = cv2.calcOpticalFlowPyrLK(frames[s], frames[t], anchor_xy[g].reshape(-1, 1, 2),
                                            q[g].reshape(-1, 1, 2), **lk_anchor)
        p = p.reshape(-1, 2)
        good = (st[:, 0] == 1) & (np.linalg.norm(p - q[g], axis=1) < ANCHOR_MAX_PX)
        q[g[good]] = p[good]
        renew = g[~good]
        anchor_t[renew] = t
        anchor_xy[renew] = q[renew]


def track_instances(xy: np.ndarray, instances: np.ndarray) -> np.ndarray:
    """(N,) int32: the instance id under each track in most of its frames (ignoring background)."""
    N, T, _ = xy.shape
    out = np.zeros(N, np.int32)
    if N == 0:
        return out
    H, W = instances.shape[1:]
    n_idx, t_idx = np.nonzero(np.isfinite(xy[:, :, 0]))
    px = np.clip(np.round(xy[n_idx, t_idx, 0]).astype(int), 0, W - 1)
    py = np.clip(np.round(xy[n_idx, t_idx, 1]).astype(int), 0, H - 1)
    ids = instances[t_idx, py, px].astype(np.int64)
    fg = ids > 0
    if not fg.any():
        return out
    key = n_idx[fg].astype(np.int64) * (int(ids.max()) + 1) + ids[fg]
    uk, counts = np.unique(key, return_counts=True)
    tr, inst = uk // (int(ids.max()) + 1), uk % (int(ids.max()) + 1)
    order = np.lexsort((-counts, tr))
    first = np.r_[True, tr[order][1:] != tr[order][:-1]]
    out[tr[order][first]] = inst[order][first]
    return out
