"""Guided SIFT matching along a verified two-view geometry (COLMAP's rule, without its cost).

After geometric verification, COLMAP can match a pair's SIFT descriptors again with the search
restricted to the other image's keypoints within `max_error` px of the epipolar line (squared
Sampson distance to F) or of the homography's transfer (H for planar / panoramic pairs), with the
same ratio test, distance bound and cross check as the first matching. Its CPU version (COLMAP's
source) fills the full integer distance matrix of every pair first, which dominates matching on
720p videos. Here the geometric test comes first and a descriptor distance is computed only for
the few keypoints that pass it. Same rule as pycolmap 4.2's: squared L2 distances of the uint8
descriptors, a keypoint off the model counted at distance 512, the test in float32. b's Sampson
terms are computed once per keypoint, the test runs over all of b's keypoints in one vectorised
pass and only the fits are visited. The matches are COLMAP's guided matches (measured: see
BENCHMARKS.md, "Measurements behind defaults").

Distances are exact integers, so the result does not depend on compilation or thread count.
"""

from __future__ import annotations

import numba as nb
import numpy as np

_SQ_NORM = 512 * 512  # COLMAP's uint8 SIFT descriptors are unit vectors times 512


@nb.njit(inline="always")
def _int_dot(a, b):
    s = 0
    for k in range(a.shape[0]):
        s += np.int64(a[k]) * np.int64(b[k])
    return s


@nb.njit(inline="always")
def _keep_two(top, best, fit, k, other, d):
    """Keypoint k's two smallest distances so far, and which keypoint of the other image is nearest."""
    fit[k] += 1
    if d < top[k, 0]:
        top[k, 1] = top[k, 0]
        top[k, 0] = d
        best[k] = other
    elif d < top[k, 1]:
        top[k, 1] = d


# numpy's error model: a division by zero gives inf or NaN, which fits nothing (numba's default
# raises ZeroDivisionError where F x_a has a third coordinate of exactly 0)
@nb.njit(nogil=True, cache=True, error_model="numpy")
def _best_two(desc_a, desc_b, xy_a, xy_b, model, homography, max_sq_px):
    """For every keypoint of a (rows) and of b (columns): the nearest and second-nearest
    descriptor (squared L2, integers) among the other image's keypoints that fit the model within
    max_sq_px, and how many fit. COLMAP gives a pair that does not fit the distance 512² (and so
    it can be a second-nearest); that is left to the caller, which knows the counts."""
    n, m = desc_a.shape[0], desc_b.shape[0]
    sq_a = np.empty(n, np.int64)
    sq_b = np.empty(m, np.int64)
    for i in range(n):
        sq_a[i] = _int_dot(desc_a[i], desc_a[i])
    for j in range(m):
        sq_b[j] = _int_dot(desc_b[j], desc_b[j])
    big = np.iinfo(np.int64).max
    best_a = np.full(n, -1, np.int64)
    top_a = np.full((n, 2), big, np.int64)
    fit_a = np.zeros(n, np.int64)
    best_b = np.full(m, -1, np.int64)
    top_b = np.full((m, 2), big, np.int64)
    fit_b = np.zeros(m, np.int64)
    M = model
    px, py = xy_b[:, 0].copy(), xy_b[:, 1].copy()  # contiguous, for the vectorised passes
    # Fᵀ x_b, the Sampson denominator's b terms: once per keypoint, not per candidate
    r0 = M[0, 0] * px + M[1, 0] * py + M[2, 0]
    r1 = M[0, 1] * px + M[1, 1] * py + M[2, 1]
    # which of b's keypoints fit a's keypoint i: one vectorised pass over b, then only the fits
    # are visited, eight flags to a word (2.3x faster where 1 in 70 fits, on random keypoints)
    words = (m + 7) // 8
    fits = np.zeros(8 * words, np.uint8)
    fit_words = fits.view(np.uint64)
    for i in range(n):
        u, v = xy_a[i, 0], xy_a[i, 1]
        # F x_a (epipolar line in b) or H x_a (transferred point)
        l0 = M[0, 0] * u + M[0, 1] * v + M[0, 2]
        l1 = M[1, 0] * u + M[1, 1] * v + M[1, 2]
        l2 = M[2, 0] * u + M[2, 1] * v + M[2, 2]
        if homography:
            tx, ty = l0 / l2, l1 / l2  # the transferred point
            for j in range(m):
                du = tx - px[j]
                dv = ty - py[j]
                fits[j] = du * du + dv * dv <= max_sq_px  # NaN (point at infinity) fails too
        else:
            ll = l0 * l0 + l1 * l1
            for j in range(m):
                e = px[j] * l0 + py[j] * l1 + l2  # x_bᵀ F x_a: the squared Sampson distance's numerator
                fits[j] = e * e <= max_sq_px * (ll + r0[j] * r0[j] + r1[j] * r1[j])
        for w in range(words):
            if fit_words[w] == 0:
                continue
            for j in range(8 * w, min(8 * w + 8, m)):
                if fits[j]:
                    d = sq_a[i] + sq_b[j] - 2 * _int_dot(desc_a[i], desc_b[j])
                    _keep_two(top_a, best_a, fit_a, i, j, d)
                    _keep_two(top_b, best_b, fit_b, j, i, d)
    return best_a, top_a, fit_a, best_b, top_b, fit_b


def _passes(best: np.ndarray, top: np.ndarray, fit: np.ndarray, others: int, max_ratio: float,
            max_distance: float) -> np.ndarray:
    """COLMAP's one-way test on descriptor distances (L2 of the uint8 vectors): the nearest within
    max_distance × 512 and below max_ratio times the second nearest, where a keypoint that does
    not fit the model counts at distance 512 (as in COLMAP's guided distance matrix)."""
    second = top[:, 1].astype(np.float64)
    second = np.where(fit < others, np.minimum(second, _SQ_NORM), second)
    nearest = top[:, 0].astype(np.float64)
    return ((best >= 0) & (nearest <= _SQ_NORM * max_distance ** 2)
            & (np.sqrt(nearest) < max_ratio * np.sqrt(second)))


def guided_matches(xy_a: np.ndarray, desc_a: np.ndarray, xy_b: np.ndarray, desc_b: np.ndarray,
                   model: np.ndarray, homography: bool, max_error_px: float = 4.0,
                   max_ratio: float = 0.8, max_distance: float = 0.7) -> np.ndarray:
    """Mutual best SIFT matches between images a and b among keypoint pairs that fit the model.

    xy_a (N,2), xy_b (M,2): keypoints in px (the same convention the model was estimated in);
    desc_a (N,128), desc_b (M,128): uint8 SIFT descriptors; model (3,3): F with x_bᵀ F x_a = 0, or
    H with x_b ~ H x_a when homography; max_error_px: Sampson distance (F) or transfer error (H);
    max_ratio, max_distance: COLMAP's SiftMatchingOptions (pycolmap 4.2 reads max_distance as a
    descriptor distance in units of the descriptors' norm, 512).
    Returns (K,2) int indices (a, b), sorted by a."""
    desc_a = np.ascontiguousarray(desc_a, np.uint8)
    desc_b = np.ascontiguousarray(desc_b, np.uint8)
    if desc_a.ndim != 2 or desc_b.ndim != 2 or desc_a.shape[1] != desc_b.shape[1]:
        raise ValueError(f"descriptors must be (N,D) and (M,D), got {desc_a.shape} and {desc_b.shape}")
    if len(xy_a) != len(desc_a) or len(xy_b) != len(desc_b):
        raise ValueError("one keypoint per descriptor is needed")
    if np.shape(model) != (3, 3):
        raise ValueError(f"model must be (3,3), got {np.shape(model)}")
    if not len(desc_a) or not len(desc_b):
        return np.zeros((0, 2), np.int64)
    best_a, top_a, fit_a, best_b, top_b, fit_b = _best_two(
        desc_a, desc_b, np.ascontiguousarray(xy_a[:, :2], np.float32),
        np.ascontiguousarray(xy_b[:, :2], np.float32), np.ascontiguousarray(model, np.float32),
        bool(homography), np.float32(max_error_px) ** 2)
    ok_a = _passes(best_a, top_a, fit_a, len(desc_b), max_ratio, max_distance)
    ok_b = _passes(best_b, top_b, fit_b, len(desc_a), max_ratio, max_distance)
    i = np.flatnonzero(ok_a)
    j = best_a[i]
    mutual = ok_b[j] & (best_b[j] == i)
    return np.stack([i[mutual], j[mutual]], axis=1)
