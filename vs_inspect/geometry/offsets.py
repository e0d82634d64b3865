"""The candidate time offsets every step searches, in one place.

Δ_ab = offset_s[b] − offset_s[a] (DESIGN.md "Time and offsets"): x_a(t + Δ) and x_b(t) show the
same moment. A video a spanning local times [a0, a1] and a video b spanning [b0, b1] share at
least m seconds exactly when a0 − b1 + m <= Δ_ab <= a1 − b0 − m and both last at least m.

OffsetGrid holds what limits the search of every pair: the least common time (--min-overlap-s),
the largest |Δ| (--range-s) and per-video windows on offset_s (--around), which bound Δ_ab of a
pair by the difference of its two videos' windows (the reference's offset is 0). Every grid is
k · step for whole k, so that grids of the same step share their points. Pure numpy, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_CANDIDATE_OFFSETS = 1_000_000
"""Candidate offsets of one pair at most; each is one evaluation over every term."""

Span = tuple[float, float]  # (first, last) local time of a video or of a set of samples, s


def grid_between(lo_s: float, hi_s: float, step_s: float, max_count: int = MAX_CANDIDATE_OFFSETS,
                 what: str = "the pair") -> np.ndarray:
    """(D,) the multiples of step_s within [lo_s, hi_s] (up to 1e-9 steps of rounding), increasing;
    empty when hi_s < lo_s or step_s is not finite. ValueError beyond max_count candidates, before
    allocating them."""
    if not (math.isfinite(step_s) and step_s > 0) or not (hi_s >= lo_s):
        return np.zeros(0)
    if not (math.isfinite(lo_s) and math.isfinite(hi_s)):
        raise ValueError(f"the offsets of {what} are unbounded ({lo_s}, {hi_s})")
    k0, k1 = math.ceil(lo_s / step_s - 1e-9), math.floor(hi_s / step_s + 1e-9)
    if k1 - k0 + 1 > max_count:
        raise ValueError(f"--step-s {step_s:g} gives {k1 - k0 + 1:.3g} candidate offsets for {what} "
                         f"(at most {max_count}): use a larger --step-s or a smaller --range-s")
    return np.arange(k0, k1 + 1) * step_s


def grid_around(center_s: float, half_width_s: float, step_s: float,
                bounds_s: Span = (-math.inf, math.inf)) -> np.ndarray:
    """(D,) a line of offsets center_s + j · step_s for whole j with |j · step_s| <= half_width_s
    (the centre included), kept within bounds_s: a finer look around one candidate."""
    if not (math.isfinite(step_s) and step_s > 0 and math.isfinite(center_s)):
        return np.zeros(0)
    j = np.arange(-math.floor(half_width_s / step_s + 1e-9), math.floor(half_width_s / step_s + 1e-9) + 1)
    line = center_s + j * step_s
    return line[(line >= bounds_s[0] - 1e-9) & (line <= bounds_s[1] + 1e-9)]


def overlap_bounds(span_a: Span, span_b: Span, min_overlap_s: float = 0.0) -> Span:
    """(lo, hi) of the Δ_ab at which b's span, moved by Δ into a's time, shares at least
    min_overlap_s with a's span; (inf, -inf), no offset, when either span is shorter than that."""
    if min(span_a[1] - span_a[0], span_b[1] - span_b[0]) < min_overlap_s:
        return math.inf, -math.inf
    return span_a[0] - span_b[1] + min_overlap_s, span_a[1] - span_b[0] - min_overlap_s


@dataclass(frozen=True)
class OffsetGrid:
    """What limits the candidate Δ_ab of every pair, whichever step searches them."""

    min_overlap_s: float = 0.0  # least common time of the two videos at a candidate, s
    range_s: float | None = None  # |Δ_ab| <= range_s, s; None: no limit
    windows_s: tuple[tuple[str, float, float], ...] = ()  # (video, lo, hi): lo <= offset_s[video] <= hi, s
    reference: str | None = None  # the video whose offset_s is 0 (a window's origin)
    max_count: int = MAX_CANDIDATE_OFFSETS  # candidates of one pair at most

    def __post_init__(self) -> None:
        if not (math.isfinite(self.min_overlap_s) and self.min_overlap_s >= 0):
            raise ValueError(f"min_overlap_s must be a number >= 0, got {self.min_overlap_s}")
        if self.range_s is not None and not (self.range_s > 0):
            raise ValueError(f"range_s must be > 0, got {self.range_s}")
        for w in self.windows_s:
            if len(w) != 3 or not (math.isfinite(w[1]) and math.isfinite(w[2]) and w[1] <= w[2]):
                raise ValueError(f"a window must be (video, lo, hi) with lo <= hi, got {w!r}")
        names = [w[0] for w in self.windows_s]
        if len(set(names)) != len(names):
            raise ValueError(f"one window per video, got {names}")

    def video_window(self, name: str) -> Span:
        """(lo, hi) of offset_s[name] allowed: (0, 0) for the reference, ±inf without a window."""
        if name == self.reference:
            return 0.0, 0.0
        for n, lo, hi in self.windows_s:
            if n == name:
                return lo, hi
        return -math.inf, math.inf

    def pair_window(self, a: str, b: str) -> Span | None:
        """(lo, hi) of Δ_ab = offset_s[b] − offset_s[a] that the videos' windows allow, or None when
        they leave Δ_ab free (neither bounded)."""
        la, ha = self.video_window(a)
        lb, hb = self.video_window(b)
        lo, hi = lb - ha, hb - la
        if not (math.isfinite(lo) or math.isfinite(hi)):
            return None
        return lo, hi

    def pair_bounds(self, a: str, span_a: Span, b: str, span_b: Span,
                    min_overlap_s: float | None = None, window: bool = True) -> Span:
        """(lo, hi) of the candidate Δ_ab of a (local times span_a) and b (span_b): enough common
        time (min_overlap_s, default the grid's), within range_s and (window) the windows."""
        m = self.min_overlap_s if min_overlap_s is None else min_overlap_s
        lo, hi = overlap_bounds(span_a, span_b, m)
        if self.range_s is not None:
            lo, hi = max(lo, -self.range_s), min(hi, self.range_s)
        win = self.pair_window(a, b) if window else None
        if win is not None:
            lo, hi = max(lo, win[0]), min(hi, win[1])
        return lo, hi

    def pair_offsets(self, a: str, span_a: Span, b: str, span_b: Span, step_s: float,
                     min_overlap_s: float | None = None, window: bool = True) -> np.ndarray:
        """(D,) the candidate Δ_ab of the pair on the multiples of step_s (grid_between of
        pair_bounds). window=False: the whole range, for a search whose statistics need it (the
        energy's median, the votes' z-scores), whose choice is then held to within_window."""
        lo, hi = self.pair_bounds(a, span_a, b, span_b, min_overlap_s, window)
        return grid_between(lo, hi, step_s, self.max_count, f"{a!r} and {b!r}")

    def within_window(self, a: str, b: str, offsets_s: np.ndarray) -> np.ndarray:
        """(D,) bool: which Δ_ab of offsets_s (D,) the pair's windows allow (all without one)."""
        offsets_s = np.asarray(offsets_s, dtype=np.float64)
        win = self.pair_window(a, b)
        if win is None:
            return np.ones(offsets_s.shape, bool)
        return (offsets_s >= win[0] - 1e-9) & (offsets_s <= win[1] + 1e-9)

def span_of(times_s: np.ndarray) -> Span:
    """(first, last) of strictly increasing local times (T,) s; ValueError when empty."""
    t = np.asarray(times_s, dtype=np.float64)
    if t.ndim != 1 or not len(t):
        raise ValueError(f"times must have shape (T,) with T >= 1, got {t.shape}")
    return float(t[0]), float(t[-1])
