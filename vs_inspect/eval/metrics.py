"""Accuracy of estimated offsets against true ones.

A@T: area under the accuracy-vs-threshold curve for thresholds 0..T ms over all pairs of videos,
in % (100 = every pair exact). For one pair with error e the area is max(0, 1 - e/T), so A@T is
the mean of that over pairs. A pair involving an unresolved video counts as wrong (area 0).
δ: per-video error in ms after fixing the reference's offset to its true value.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SyncMetrics:
    a100: float  # %, pairwise AUC up to 100 ms
    a500: float  # %, pairwise AUC up to 500 ms
    delta_mean_ms: float  # mean per-video error over resolved non-reference videos (NaN if none)
    delta_med_ms: float  # median of the same
    delta_max_ms: float  # worst resolved video
    num_unresolved: int  # videos with no estimate (their pairs count as wrong above)
    per_video_ms: dict[str, float | None]  # error of each video, None if unresolved
    reference: str


def pair_auc(errors_ms: np.ndarray, threshold_ms: float) -> float:
    """Mean over pairs of the area under accuracy(τ) for τ in [0, T], normalized to %."""
    e = np.asarray(errors_ms, dtype=np.float64)
    if e.size == 0:
        return float("nan")
    area = np.where(np.isfinite(e), np.clip(1.0 - e / threshold_ms, 0.0, 1.0), 0.0)
    return float(100.0 * area.mean())


def offset_errors_ms(estimated_s: dict[str, float | None], true_s: dict[str, float],
                     reference: str) -> dict[str, float | None]:
    """|error| in ms of every video in both dicts, after aligning the reference with the truth.

    The one definition of "error against the truth" (tables, report, recording, benchmarks):
    (offset_v - offset_ref) - (true_v - true_ref). None where a video or the reference is
    unresolved; the reference itself gets 0.0 when resolved.
    """
    ref_est, ref_true = estimated_s.get(reference), true_s.get(reference)
    out: dict[str, float | None] = {}
    for v, est in estimated_s.items():
        if v not in true_s:
            continue
        if est is None or ref_est is None or ref_true is None:
            out[v] = None
        else:
            out[v] = 1000.0 * abs((est - ref_est) - (true_s[v] - ref_true))
    return out


def evaluate_offsets(estimated_s: dict[str, float | None], true_s: dict[str, float],
                     reference: str) -> SyncMetrics:
    missing = sorted(set(true_s) - set(estimated_s))
    if missing:
        raise ValueError(f"result has no entry for videos {missing}")
    names = sorted(true_s)
    pair_err = []
    for a, b in itertools.combinations(names, 2):
        ea, eb = estimated_s[a], estimated_s[b]
        if ea is None or eb is None:
            pair_err.append(math.inf)
        else:
            pair_err.append(1000.0 * abs((eb - ea) - (true_s[b] - true_s[a])))
    ref_est = estimated_s.get(reference)
    errors = offset_errors_ms({v: estimated_s[v] for v in names}, true_s, reference)
    per_video = {v: errors[v] for v in names if v != reference}
    errs = np.array([e for e in per_video.values() if e is not None])
    return SyncMetrics(
        pair_auc(np.array(pair_err), 100.0), pair_auc(np.array(pair_err), 500.0),
        float(errs.mean()) if errs.size else float("nan"),
        float(np.median(errs)) if errs.size else float("nan"),
        float(errs.max()) if errs.size else float("nan"),
        sum(1 for e in per_video.values() if e is None) + (1 if ref_est is None else 0),
        per_video, reference)


@dataclass(frozen=True)
class VideoTimeError:
    """One video's error against the truth, relative to the reference (time model with drift).

    The error at the video's local time t is that of the moment it maps t to, in the
    reference's terms: ((offset_v - offset_ref) + rate_v t) - ((true_v - true_ref) + true_rate_v t),
    rates relative to the reference's; linear in t, so largest at an end of the video."""

    offset_err_s: float  # the error at local time 0: (offset_v - offset_ref) - (true_v - true_ref), signed
    offset_err_frames: float | None  # the same in this video's frames (None without its fps)
    drift_err_ppm: float | None  # rate relative to the reference, estimated - true (None: no drift given)
    end_err_s: float | None = None  # the error at the video's last local time, signed (None without its span)
    worst_err_s: float | None = None  # max |error| at the span's first and last local times (None without it)
    worst_err_frames: float | None = None  # the same in this video's frames (None without its fps or span)


def time_errors(estimated_s: dict[str, float | None], true_s: dict[str, float], reference: str,
                fps: dict[str, float] | None = None, est_drift_ppm: dict[str, float | None] | None = None,
                true_drift_ppm: dict[str, float] | None = None,
                span_s: dict[str, tuple[float, float]] | None = None) -> dict[str, VideoTimeError | None]:
    """Signed per-video errors of offset (s and frames), drift (ppm) and, given a video's span
    (its first and last local times, s), at its end and at its worst, relative to the reference.
    The one definition of these errors (eval, bench drone, bench drift). A result without
    drift counts as drift 0 (the constant-offset model); a truth without drift (or without this
    video's) as drift 0 in the time map, and then no drift error is given. None where the video
    or the reference is unresolved."""
    ref_est, ref_true = estimated_s.get(reference), true_s.get(reference)
    est_d, true_d = est_drift_ppm or {}, true_drift_ppm or {}
    out: dict[str, VideoTimeError | None] = {}
    for v, est in estimated_s.items():
        if v not in true_s:
            continue
        if est is None or ref_est is None or ref_true is None:
            out[v] = None
            continue
        rel_est = (1 + (est_d.get(v) or 0.0) * 1e-6) / (1 + (est_d.get(reference) or 0.0) * 1e-6)
        rel_true = (1 + true_d.get(v, 0.0) * 1e-6) / (1 + true_d.get(reference, 0.0) * 1e-6)
        err = (est - ref_est) - (true_s[v] - ref_true)
        v_fps = fps.get(v) if fps else None
        d_err = (rel_est - rel_true) * 1e6 if v in true_d and reference in true_d else None
        end = worst = worst_frames = None
        if span_s is not None and v in span_s:
            first, last = (((est - ref_est) + rel_est * t) - ((true_s[v] - ref_true) + rel_true * t)
                           for t in span_s[v])
            end, worst = float(last), float(max(abs(first), abs(last)))
            worst_frames = None if v_fps is None else worst * v_fps
        out[v] = VideoTimeError(float(err), None if v_fps is None else float(err * v_fps), d_err, end, worst,
                                worst_frames)
    return out
