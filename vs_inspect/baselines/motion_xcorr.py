"""Peer 1: motion-signal cross-correlation.

Each video becomes one scalar per frame, the amount of image motion: the mean absolute difference
of consecutive frames for decoded video, or the mean speed of the tracked points for cue-level
data. Two signals are resampled to a common rate and the normalized cross-correlation (Pearson's
r over the overlapping part) is evaluated at every candidate offset of the same search grid that
vs_inspect uses; the best lag of each pair goes to the same Stage 2 solver. This is what
video-mode sync tools do when there is no audio track. It needs no cameras and no cross-view
matches, so it can be run on every pair.
"""

from __future__ import annotations

import itertools
import time

import numpy as np

from ..sync.config import LandscapeConfig
from ..sync.landscape import search_offsets
from ..types import CueBundle, Tracks, VideoInfo
from .common import PeerPair, PeerResult, best_of, solve_peer


def motion_signal_from_tracks(video: VideoInfo, tracks: Tracks) -> tuple[np.ndarray, np.ndarray]:
    """(times_s (T-1,), speed_px_per_s (T-1,)): mean speed of the points seen in both frames k and
    k+1, at the midpoint time of the two frames (NaN where no point is seen twice)."""
    ts = video.timestamps_s
    xy = np.asarray(tracks.xy, dtype=np.float64)
    if video.num_frames < 2:
        return np.zeros(0), np.zeros(0)
    step = np.linalg.norm(xy[:, 1:] - xy[:, :-1], axis=-1)  # (N,T-1) px, NaN if unseen
    dt = np.diff(ts)
    seen = np.isfinite(step)
    count = seen.sum(axis=0)
    total = np.where(seen, step, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    return 0.5 * (ts[1:] + ts[:-1]), speed / dt


def motion_signal_from_frames(frames, timestamps_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(times_s (T-1,), mean |I_{k+1} - I_k| per second (T-1,)) from an iterable of grey or colour
    frames (H,W[,C]) uint8, one per timestamp."""
    ts = np.asarray(timestamps_s, dtype=np.float64)
    prev, out = None, []
    for f in frames:
        g = np.asarray(f, dtype=np.float32)
        if g.ndim == 3:
            g = g.mean(axis=2)
        if prev is not None:
            out.append(float(np.mean(np.abs(g - prev))))
        prev = g
    if len(out) != len(ts) - 1:
        raise ValueError(f"got {len(out) + 1} frames for {len(ts)} timestamps")
    return 0.5 * (ts[1:] + ts[:-1]), np.asarray(out) / np.diff(ts)


def _resample(t: np.ndarray, s: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(s)
    if ok.sum() < 2:
        return np.zeros(0), np.zeros(0)
    grid = np.arange(t[ok][0], t[ok][-1] + 1e-12, 1.0 / rate_hz)
    return grid, np.interp(grid, t[ok], s[ok])


def xcorr_offset(t_a: np.ndarray, s_a: np.ndarray, t_b: np.ndarray, s_b: np.ndarray,
                 offsets_s: np.ndarray, rate_hz: float, min_overlap_s: float = 1.0) -> np.ndarray:
    """(D,) Pearson correlation of s_a(τ + Δ) with s_b(τ) over the common time, per candidate Δ_ab.

    Both signals are first resampled to rate_hz on their own time axes; NaN where the overlap is
    shorter than min_overlap_s or a signal is constant there.
    """
    ga, ya = _resample(np.asarray(t_a, float), np.asarray(s_a, float), rate_hz)
    gb, yb = _resample(np.asarray(t_b, float), np.asarray(s_b, float), rate_hz)
    out = np.full(len(offsets_s), np.nan)
    if len(ga) < 2 or len(gb) < 2:
        return out
    need = max(3, int(np.ceil(min_overlap_s * rate_hz)))
    for i, d in enumerate(np.asarray(offsets_s, float)):
        q = gb + d  # a's local time of each of b's samples
        inside = (q >= ga[0]) & (q <= ga[-1])
        if inside.sum() < need:
            continue
        x = np.interp(q[inside], ga, ya)
        y = yb[inside]
        x = x - x.mean()
        y = y - y.mean()
        den = np.sqrt(np.dot(x, x) * np.dot(y, y))
        if den > 0:
            out[i] = float(np.dot(x, y) / den)
    return out


def sync_motion_xcorr(bundle: CueBundle, cfg: LandscapeConfig = LandscapeConfig(),
                      reference: str | None = None, signals: dict | None = None) -> PeerResult:
    """Cross-correlate every pair of videos of a cue bundle, then Stage 2.

    signals: optional {name: (times_s, signal)} (e.g. from decoded frames); default = the mean
    track speed of each video's tracks.
    """
    t0 = time.perf_counter()
    if signals is None:
        signals = {n: motion_signal_from_tracks(bundle.video(n), bundle.tracks[n]) for n in bundle.names}
    t_signals = time.perf_counter() - t0
    res = sync_motion_xcorr_videos(list(bundle.videos), signals, cfg, reference)
    res.timings_s["stage1_s"] += t_signals  # the signals are part of this peer's Stage 1
    return res


def sync_motion_xcorr_videos(videos: list[VideoInfo], signals: dict, cfg: LandscapeConfig = LandscapeConfig(),
                             reference: str | None = None) -> PeerResult:
    """The peer on videos alone (no cameras, no tracks): {name: (times_s, signal)} per video."""
    t0 = time.perf_counter()
    names = [v.name for v in videos]
    by = {v.name: v for v in videos}
    pairs = []
    for a, b in itertools.combinations(names, 2):
        va, vb = by[a], by[b]
        offsets = search_offsets(va, vb, cfg)
        rate = 1.0 / min(va.frame_interval_s, vb.frame_interval_s)
        score = xcorr_offset(*signals[a], *signals[b], offsets, rate, cfg.min_overlap_s)
        best = best_of(offsets, score)
        pairs.append(PeerPair(a, b, offsets, score, best,
                              "" if np.isfinite(best) else "no lag with enough overlap and motion"))
    t1 = time.perf_counter()
    ref = reference or names[0]
    offsets, reasons = solve_peer(videos, pairs, ref)
    t2 = time.perf_counter()
    return PeerResult("motion-xcorr", ref, offsets, tuple(pairs), reasons,
                      {"stage1_s": t1 - t0, "stage2_s": t2 - t1})
