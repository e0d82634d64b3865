"""Cross-view track pairs: SIFT on keyframes, every keyframe of a against every keyframe of b.

The videos are not synchronized, so a descriptor match says "same physical point", not "same
moment": matches are snapped to the tracks alive at their keyframes and vote for track pairs;
instances are matched one-to-one (Hungarian method on the vote counts) and pairs across
unmatched instances are dropped (VisualSync appendix, "Correspondence Filtering").
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

from ...types import TrackPairs
from ..features.nearest_neighbours import match_descriptors

log = logging.getLogger(__name__)

MAX_FEATURES = 1500  # SIFT features per keyframe at most
RATIO = 0.8  # Lowe's ratio test
MUTUAL = True  # mutual nearest neighbours only
MASK_DILATE_PX = 9  # the moving regions are dilated by this (working px) for the descriptors
SNAP_PX = 3.0  # a match snaps to the nearest track within this distance at its keyframe (working px)
MIN_INSTANCE_SUPPORT = 5  # matched instance pairs with fewer votes are dropped (the paper: 100, dense)


@dataclass(frozen=True)
class KeyframeFeatures:
    """Descriptors of one video's keyframes, each snapped to a track."""

    frame: np.ndarray  # (M,) int, keyframe index of each feature
    xy: np.ndarray  # (M,2) float32 working px
    desc: np.ndarray  # (M,128) float32 RootSIFT, L2-normalised
    track: np.ndarray  # (M,) int, index of the track within snap distance at that frame, -1 if none
    keyframes: np.ndarray  # (K,) int, the keyframe indices
    image_size: tuple[int, int] = (0, 0)  # (width, height) working px of the keyframes


def keyframe_indices(num_frames: int, num_keyframes: int) -> np.ndarray:
    """(K,) evenly spread frame indices."""
    k = max(1, min(num_keyframes, num_frames))
    return np.unique(np.linspace(0, num_frames - 1, k).round().astype(int))


def extract_keyframe_features(frames: np.ndarray, masks: np.ndarray | None, keyframes: np.ndarray,
                              track_xy: np.ndarray) -> KeyframeFeatures:
    """RootSIFT on the keyframes, inside the dilated masks when given, snapped to tracks.

    frames (T,H,W) uint8; masks (T,H,W) bool or None; track_xy (N,T,2) working px.
    """
    detect = sift_detector()
    size = (int(frames.shape[2]), int(frames.shape[1]))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (max(1, MASK_DILATE_PX),) * 2)
    fr, xys, descs, trk = [], [], [], []
    for k in keyframes:
        m = None
        if masks is not None:
            m = cv2.dilate(masks[k].astype(np.uint8) * 255, kernel)
            if not m.any():
                continue
        xy, d = detect(frames[k], m)
        if not len(xy):
            continue
        snap = np.full(len(xy), -1, np.int64)
        alive = np.isfinite(track_xy[:, k, 0]) if len(track_xy) else np.zeros(0, bool)
        if alive.any():
            ids = np.nonzero(alive)[0]
            dist, j = cKDTree(track_xy[ids, k]).query(xy, distance_upper_bound=SNAP_PX)
            hit = np.isfinite(dist)
            snap[hit] = ids[j[hit]]
        fr.append(np.full(len(xy), k)), xys.append(xy), descs.append(d), trk.append(snap)
    if not fr:
        return KeyframeFeatures(np.zeros(0, int), np.zeros((0, 2), np.float32),
                                np.zeros((0, 128), np.float32), np.zeros(0, np.int64), keyframes, size)
    return KeyframeFeatures(np.concatenate(fr), np.concatenate(xys), np.concatenate(descs),
                            np.concatenate(trk), keyframes, size)


def sift_detector(max_features: int = MAX_FEATURES):
    """(gray image, mask or None) -> (M,2) px, (M,128) RootSIFT descriptors."""
    sift = cv2.SIFT_create(nfeatures=max_features)

    def detect(gray: np.ndarray, mask: np.ndarray | None):
        kps, d = sift.detectAndCompute(gray, mask)
        if d is None or not len(kps):
            return np.zeros((0, 2), np.float32), np.zeros((0, 128), np.float32)
        d = d.astype(np.float32)
        d /= np.maximum(d.sum(1, keepdims=True), 1e-9)  # RootSIFT
        return np.array([kp.pt for kp in kps], np.float32), np.sqrt(d)

    return detect


@dataclass(frozen=True)
class PairStats:
    matches: int  # descriptor matches over all keyframe pairs
    snapped: int  # matches whose both ends snapped to a track
    instance_pairs: int  # matched instance pairs kept
    track_pairs: int  # track pairs output
    keyframe_matches: np.ndarray | None = None  # (Ka,Kb) int matches per keyframe pair (rows fa.keyframes, cols fb.keyframes)


def match_tracks(a: str, b: str, fa: KeyframeFeatures, fb: KeyframeFeatures, inst_a: np.ndarray,
                 inst_b: np.ndarray) -> tuple[TrackPairs, PairStats]:
    """Track pairs between videos a and b from keyframe descriptor matches (every keyframe pair)."""
    votes_a, votes_b = [], []
    total = 0
    per_pair = np.zeros((len(fa.keyframes), len(fb.keyframes)), np.int64)
    for i, ka in enumerate(fa.keyframes):
        sa = np.nonzero(fa.frame == ka)[0]
        if not len(sa):
            continue
        for j, kb in enumerate(fb.keyframes):
            sb = np.nonzero(fb.frame == kb)[0]
            if len(sb) < 2:
                continue
            m = match_descriptors(fa.desc[sa], fb.desc[sb], RATIO, MUTUAL)
            total += len(m)
            per_pair[i, j] = len(m)
            ta, tb = fa.track[sa[m[:, 0]]], fb.track[sb[m[:, 1]]]
            ok = (ta >= 0) & (tb >= 0)
            votes_a.append(ta[ok]), votes_b.append(tb[ok])
    empty = TrackPairs(a, b, np.zeros((0, 2), np.int64), np.zeros(0))
    if not votes_a or not sum(len(v) for v in votes_a):
        return empty, PairStats(total, 0, 0, 0, per_pair)
    va, vb = np.concatenate(votes_a), np.concatenate(votes_b)
    snapped = len(va)
    nb = int(vb.max()) + 1
    key, count = np.unique(va * nb + vb, return_counts=True)
    ta, tb, w = key // nb, key % nb, count.astype(float)

    # one-to-one instance matching (Hungarian method on vote counts)
    ia, ib = inst_a[ta], inst_b[tb]
    ua, ra = np.unique(ia, return_inverse=True)
    ub, rb = np.unique(ib, return_inverse=True)
    C = np.zeros((len(ua), len(ub)))
    np.add.at(C, (ra, rb), w)
    C[ua == 0, :] = 0  # tracks never inside a moving region do not form instances
    C[:, ub == 0] = 0
    rows, cols = linear_sum_assignment(-C)
    good = C[rows, cols] >= MIN_INSTANCE_SUPPORT
    allowed = set(zip(ua[rows[good]].tolist(), ub[cols[good]].tolist()))
    kept_inst = len(allowed)
    keep = np.array([(x, y) in allowed for x, y in zip(ia.tolist(), ib.tolist())], bool)
    ta, tb, w = ta[keep], tb[keep], w[keep]
    if len(ta):  # each track the other's most voted partner
        order = np.lexsort((-w, ta))
        best_b = {}
        for i in order:
            best_b.setdefault(int(ta[i]), i)
        order = np.lexsort((-w, tb))
        best_a = {}
        for i in order:
            best_a.setdefault(int(tb[i]), i)
        keep = np.array([best_b[int(ta[i])] == i and best_a[int(tb[i])] == i for i in range(len(ta))], bool)
        ta, tb, w = ta[keep], tb[keep], w[keep]
    tp = TrackPairs(a, b, np.stack([ta, tb], axis=1).astype(np.int64), w)
    return tp, PairStats(total, snapped, kept_inst, len(ta), per_pair)
