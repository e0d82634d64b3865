"""Typed, frozen records of a run's results: each pair's energy landscape and decision (Stage 1),
the offset of every video (Stage 2), a whole run as result.json keeps it, and the time span the
synchronized videos share.

Every array field states its shape and unit (DESIGN.md's conventions for offsets and time).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .cue_stats import CueStats


# ---- Stage 1 and Stage 2 results -------------------------------------------------------------


@dataclass(frozen=True)
class PairDecision:
    """Whether a pair's landscape is trusted, with the numbers behind it."""

    accepted: bool
    reason: str  # readable, e.g. "single clear minimum" or "ambiguous: 3 minima of similar depth"
    contrast: float  # 1 - E_best / E_baseline (0 = flat landscape, 1 = perfectly sharp)
    second_depth_ratio: float  # prominence of the strongest rival minimum / the best's (0 = none, 1 = tie)
    num_minima: int  # significant local minima (by prominence)
    num_pareto_minima: int  # minima Pareto-optimal in (energy, overlap)
    at_range_edge: bool  # best minimum lies on the border of the search range
    inlier_fraction: float = float("nan")  # share of terms at the best offset within inlier_tau_px
    inlier_tau_px: float = float("nan")  # Sampson distance counted as an inlier, px
    support_fraction: float = float("nan")  # terms at the best minimum / median terms over the landscape
    track_pairs_at_best: int = -1  # track pairs with at least one term at the best offset (-1: not counted)


@dataclass(frozen=True)
class PairLandscape:
    """Stage 1 result for one ordered pair (a, b)."""

    a: str
    b: str
    offsets_s: np.ndarray  # (D,) candidate Δ_ab = offset_s[b] - offset_s[a], seconds
    energy: np.ndarray  # (D,) normalized robust energy, NaN where overlap is too small
    support: np.ndarray  # (D,) int, number of (track pair, frame) terms behind each energy
    minima_idx: np.ndarray  # (M,) int, indices of significant local minima, best first
    best_offset_s: float  # sub-frame refined Δ_ab, seconds (NaN if none)
    best_energy: float  # energy at best_offset_s
    uncertainty_s: float  # 1-sigma of best_offset_s from the landscape curvature
    num_track_pairs: int
    decision: PairDecision
    residual: str = "sampson"
    robust_scale: float = float("nan")  # scale of the robust loss, in the residual's units
    rate: float = 1.0  # (1 + drift_b) / (1 + drift_a): τ_a = Δ + rate · τ_b (1 without the drift model)
    log_rate_std: float = float("nan")  # 1-sigma of log(rate); NaN without the drift model
    pivot_s: float = 0.0  # b's local time where pivot_offset_s is measured (middle of the overlap)
    pivot_offset_s: float = float("nan")  # τ_a - τ_b at τ_b = pivot_s (nearly uncorrelated with the rate)
    pivot_offset_std_s: float = float("nan")  # its 1-sigma
    rate_landscape: RateLandscape | None = None  # the energy over (Δ, rate), with the drift model
    pose_free: bool = False  # the pair's F came from its tracks (sync.posefree), not from cameras
    # (D,) energy of the pair's track pairs not marked unchecked, alone, on offsets_s (the check
    # of TrackPairs.unchecked); None: the check did not run
    confirm_energy: np.ndarray | None = None
    confirm_offset_s: float = float("nan")  # that landscape's refined best minimum, s (NaN: none accepted)
    window_s: tuple[float, float] | None = None  # (lo, hi) of Δ_ab the --around windows allow, s; None: no window


@dataclass(frozen=True)
class RateLandscape:
    """A pair's energy over (offset at the pivot, rate) around its minimum (the drift model)."""

    pivot_s: float  # b's local time about which the rows turn
    offsets_s: np.ndarray  # (U,) τ_a - τ_b at τ_b = pivot_s, seconds
    rates_ppm: np.ndarray  # (V,) (rate - 1) * 1e6
    energy: np.ndarray  # (V,U) normalized energy, NaN where the overlap is too small


@dataclass(frozen=True)
class SolveIteration:
    """One IRLS iteration of Stage 2."""

    residual_s: np.ndarray  # (E,) s_b - s_a - Δ_ab per accepted pair, seconds
    weight: np.ndarray  # (E,) Huber weight per accepted pair


@dataclass(frozen=True)
class SyncResult:
    """Stage 2 result: one offset per video (None when it cannot be synchronized)."""

    reference: str
    offsets_s: dict[str, float | None]
    uncertainty_s: dict[str, float | None]
    unresolved_reason: dict[str, str]  # video -> why it has no offset
    pairs: tuple[PairLandscape, ...]
    solve_pairs: tuple[tuple[str, str], ...]  # the accepted pairs, in the order of residuals
    iterations: tuple[SolveIteration, ...]
    solver: str = "irls"
    timings_s: dict[str, float] = field(default_factory=dict)
    drift_ppm: dict[str, float | None] | None = None  # with the drift model: (1 + drift) - 1 per video, ppm
    drift_std_ppm: dict[str, float | None] | None = None  # its 1-sigma, ppm


# ---- a whole run (Stage 0 + 1 + 2), as written to result.json --------------------------------


@dataclass(frozen=True)
class RunInputs:
    """What a run was given, as result.json's "input" records it (paths as the user gave them)."""

    bundle: str | None = None  # cue bundle folder read or written by the run
    videos: dict[str, str] = field(default_factory=dict)  # video name -> file or image folder
    scene: str | None = None  # rendered scene folder (demo)
    cues: str | None = None  # where the cues came from when not Stage 0 (e.g. "true cue bundle")
    fps: float | None = None  # --fps given for image folders, frames per second


@dataclass(frozen=True)
class RunResult:
    """A whole run: one offset per input video (None with a reason), and how it was reached.

    offsets_s covers every input video, including those Stage 0 left out (None, reason in
    unresolved). pairs, solve_pairs and iterations are Stage 1 and Stage 2's (SyncResult).
    """

    reference: str
    offsets_s: dict[str, float | None]  # video -> offset_s (DESIGN.md convention), seconds
    uncertainty_s: dict[str, float | None]  # video -> 1-sigma of offset_s, seconds
    unresolved: dict[str, str]  # video -> why it has no offset (the plain sentence, then the technical account)
    pairs: tuple[PairLandscape, ...]
    solver: str  # "irls" | "ls"
    solve_pairs: tuple[tuple[str, str], ...]  # the accepted pairs, in the order of residuals
    iterations: tuple[SolveIteration, ...]
    timings_s: dict[str, float]  # per stage, seconds ("total_s" for the whole run)
    inputs: RunInputs = field(default_factory=RunInputs)
    config: dict[str, Any] | None = None  # the run's config as saved (pipeline.RunConfig.to_dict)
    cues: CueStats | None = None  # None when the run started from a cue bundle
    gt_offsets_s: dict[str, float] | None = None  # true offsets when known (bundle gt.json, --gt)
    drift_ppm: dict[str, float | None] | None = None  # with the drift model (--drift), per video, ppm
    drift_std_ppm: dict[str, float | None] | None = None  # its 1-sigma, ppm
    gt_drift_ppm: dict[str, float] | None = None  # true drift when known (gt.json drift_ppm)
    unresolved_headline: dict[str, str] | None = None  # video -> why it has no offset and what to try,
    # one plain sentence (pipeline/reasons.py; unresolved holds it and then the whole technical
    # account); None in a result read from a file without it

    @property
    def resolved(self) -> list[str]:
        return [v for v, off in self.offsets_s.items() if off is not None]

    def headlines(self) -> dict[str, str]:
        """Each unresolved video's reason in one plain sentence (unresolved_headline), else in full."""
        return {v: (self.unresolved_headline or {}).get(v) or why for v, why in self.unresolved.items()}

    def pair(self, a: str, b: str) -> PairLandscape | None:
        for p in self.pairs:
            if (p.a, p.b) == (a, b):
                return p
        return None


@dataclass(frozen=True)
class VideoSpan:
    """One synchronized video's part of the common time span (analysis/common_span.py)."""

    name: str
    offset_s: float  # DESIGN.md convention: global time of the video's local time 0
    frame_interval_s: float  # median spacing of the video's frames, s
    first_frame: int  # first frame index inside the common span
    last_frame: int  # last frame index inside it (inclusive)
    first_time_s: float  # global time of first_frame, s
    last_time_s: float  # global time of last_frame, s

    @property
    def num_frames(self) -> int:
        return self.last_frame - self.first_frame + 1

    @property
    def offset_frames(self) -> float:
        """offset_s in frames of this video."""
        return self.offset_s / self.frame_interval_s


@dataclass(frozen=True)
class CommonSpan:
    """The time span every synchronized video covers, as a frame range of each."""

    reference: str
    start_s: float  # global time of the slowest video's first frame in the span, s
    end_s: float  # global time of its last frame in the span, s
    anchor: str  # the slowest video, whose frames set start_s and end_s
    videos: dict[str, VideoSpan]  # the synchronized videos (offset known), input order
    skipped: dict[str, str]  # video -> why it has no span
