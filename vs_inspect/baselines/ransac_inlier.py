"""Peer 2: the RANSAC-inlier criterion (the paper's ablation baseline, after Albl et al. 2017).

For each candidate offset Δ_ab, the track pairs of a and b are shifted by Δ, every frame where
both points are seen gives one correspondence, a fundamental matrix is fitted to them with
RANSAC (cv2.findFundamentalMat, FM_RANSAC, fixed seed) and the score is the number of
correspondences within the inlier threshold. The best offset of each pair goes to vs_inspect's
Stage 2 solver. No camera poses are used: one F per pair is assumed for all frames, which holds
for static cameras only (a moving camera breaks the criterion; that is part of what is measured).

The candidate grid has the coarser video's frame interval as step (the frame-level search of the
criterion); there is no sub-frame refinement.
"""

from __future__ import annotations

import math
import time

import cv2
import numpy as np

from ..geometry.epipolar import epipolar_lines
from ..geometry.sampling import sample_video
from ..geometry.two_view import fundamental_ransac
from ..sync.config import LandscapeConfig
from ..sync.pairs import select_pairs
from ..sync.config import PairSelection
from ..sync.landscape import search_offsets
from ..types import CueBundle, TrackPairs
from .common import PeerPair, PeerResult, best_of, solve_peer


def shifted_correspondences(bundle: CueBundle, a: str, b: str, tp: TrackPairs,
                            offset_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(x_a (M,2), x_b (M,2)) px: point pairs seen at the same moment if Δ_ab = offset_s.

    The coarser video is read at its frames and the other is interpolated linearly.
    """
    va, vb = bundle.video(a), bundle.video(b)
    sample_is_a = va.frame_interval_s > vb.frame_interval_s
    vs, vi = (va, vb) if sample_is_a else (vb, va)
    ps, pi = (tp.index[:, 0], tp.index[:, 1]) if sample_is_a else (tp.index[:, 1], tp.index[:, 0])
    sign = -1.0 if sample_is_a else 1.0
    # no cameras: this criterion fits its own F, so only the points are read
    at_i = sample_video(vi.timestamps_s, None, bundle.tracks[vi.name].xy,
                        vs.timestamps_s + sign * offset_s, rows=pi)
    ok = at_i.valid
    if not ok.any() or len(ps) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    xs = np.asarray(bundle.tracks[vs.name].xy[ps][:, ok], dtype=np.float64)  # (P,T',2)
    xi = at_i.xy[:, ok]
    good = np.isfinite(xs).all(-1) & np.isfinite(xi).all(-1)
    xs, xi = xs[good], xi[good]
    return (xs, xi) if sample_is_a else (xi, xs)


def epipolar_distance_sq(F: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """OpenCV's RANSAC error for x2ᵀ F x1 = 0: max of the squared point-to-line distances (px²)."""
    l2 = epipolar_lines(F, x1)  # lines in image 2 (F maps 1 to 2 here)
    l1 = epipolar_lines(F.T, x2)  # lines in image 1
    num = (l2[:, 0] * x2[:, 0] + l2[:, 1] * x2[:, 1] + l2[:, 2]) ** 2
    d2 = num / np.maximum(l2[:, 0] ** 2 + l2[:, 1] ** 2, 1e-300)
    d1 = num / np.maximum(l1[:, 0] ** 2 + l1[:, 1] ** 2, 1e-300)
    return np.maximum(d1, d2)


def ransac_inlier_count(x_a: np.ndarray, x_b: np.ndarray, threshold_px: float, max_fit: int,
                        max_iters: int, seed: int) -> int:
    """Inliers of the RANSAC F among all correspondences (the fit uses at most max_fit of them)."""
    n = len(x_a)
    sel = np.arange(n)
    if n > max_fit:
        sel = np.sort(np.random.default_rng(seed).choice(n, max_fit, replace=False))
    cv2.setRNGSeed(seed)
    F_ab, _ = fundamental_ransac(x_a[sel], x_b[sel], threshold_px, 0.999, max_iters, method="ransac")
    if F_ab is None:
        return 0
    return int(np.sum(epipolar_distance_sq(F_ab.T, x_a, x_b) <= threshold_px ** 2))


def ransac_inlier_landscape(bundle: CueBundle, a: str, b: str, cfg: LandscapeConfig = LandscapeConfig(),
                            threshold_px: float = 2.0, max_fit: int = 300, max_iters: int = 300,
                            min_correspondences: int = 30, seed: int = 0) -> PeerPair:
    """Inlier count per candidate Δ_ab on a grid with the coarser frame interval as step."""
    va, vb = bundle.video(a), bundle.video(b)
    tp = bundle.pair(a, b)
    step = max(va.frame_interval_s, vb.frame_interval_s)
    grid_cfg = LandscapeConfig(min_overlap_s=cfg.min_overlap_s, range_s=cfg.range_s,
                               step_s=cfg.step_s or step)
    offsets = search_offsets(va, vb, grid_cfg)
    score = np.full(len(offsets), np.nan)
    if tp is None or len(tp.index) < 8:
        return PeerPair(a, b, offsets, score, float("nan"),
                        f"too few track pairs ({0 if tp is None else len(tp.index)} < 8)")
    for i, d in enumerate(offsets):
        xa, xb = shifted_correspondences(bundle, a, b, tp, float(d))
        if len(xa) >= max(min_correspondences, 8):
            score[i] = ransac_inlier_count(xa, xb, threshold_px, max_fit, max_iters, seed)
    best = best_of(offsets, score)
    return PeerPair(a, b, offsets, score, best,
                    "" if math.isfinite(best) else "no offset with enough correspondences")


def sync_ransac_inlier(bundle: CueBundle, cfg: LandscapeConfig = LandscapeConfig(),
                       reference: str | None = None, threshold_px: float = 2.0,
                       seed: int = 0) -> PeerResult:
    """Every pair of videos with track pairs, best inlier count per pair, then Stage 2."""
    t0 = time.perf_counter()
    names = bundle.names
    has = {k for k, v in bundle.pairs.items() if len(v.index)}
    pairs = [ransac_inlier_landscape(bundle, a, b, cfg, threshold_px, seed=seed)
             for a, b in select_pairs(names, has, PairSelection())]
    t1 = time.perf_counter()
    ref = reference or names[0]
    offsets, reasons = solve_peer(bundle.videos, pairs, ref)
    t2 = time.perf_counter()
    return PeerResult("ransac-inlier", ref, offsets, tuple(pairs), reasons,
                      {"stage1_s": t1 - t0, "stage2_s": t2 - t1})
