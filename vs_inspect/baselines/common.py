"""What both peers share: one best offset per pair, then vs_inspect's own Stage 2 solver."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..sync.solve import PairMeasurement, solve_offsets
from collections.abc import Sequence

from ..types import VideoInfo


@dataclass(frozen=True)
class PeerPair:
    """A peer's Stage 1 result for one ordered pair (a, b)."""

    a: str
    b: str
    offsets_s: np.ndarray  # (D,) candidate Δ_ab = offset_s[b] - offset_s[a], seconds
    score: np.ndarray  # (D,) higher is better (correlation or inlier count), NaN where undefined
    best_offset_s: float  # argmax of score, seconds (NaN when no candidate has a score)
    reason: str = ""  # why the pair has no offset, when it has none


@dataclass(frozen=True)
class PeerResult:
    """Per-video offsets of a peer (None = not synchronized), its pairs and timings."""

    method: str
    reference: str
    offsets_s: dict[str, float | None]
    pairs: tuple[PeerPair, ...]
    unresolved_reason: dict[str, str]
    timings_s: dict[str, float] = field(default_factory=dict)  # stage1_s, stage2_s


def best_of(offsets_s: np.ndarray, score: np.ndarray) -> float:
    """Offset of the highest finite score (first one on ties), NaN when none."""
    if len(score) == 0 or not np.isfinite(score).any():
        return float("nan")
    return float(offsets_s[int(np.nanargmax(score))])


def solve_peer(videos: Sequence[VideoInfo], pairs: list[PeerPair], reference: str | None = None,
               solver: str = "irls") -> tuple[dict, dict]:
    """Stage 2 exactly as vs_inspect runs it: every pair with an offset is a measurement with the
    grid's own resolution as sigma; Huber threshold = half the coarsest frame interval."""
    names = [v.name for v in videos]
    reference = reference or names[0]
    intervals = [v.frame_interval_s for v in videos if math.isfinite(v.frame_interval_s)]
    slowest = max(intervals) if intervals else 0.1
    meas = []
    for p in pairs:
        if math.isfinite(p.best_offset_s):
            step = p.offsets_s[1] - p.offsets_s[0] if len(p.offsets_s) > 1 else slowest
            meas.append(PairMeasurement(p.a, p.b, p.best_offset_s, max(step / math.sqrt(12.0), 1e-6)))
    out = solve_offsets(names, reference, meas, solver, 0.5 * slowest)
    return out.offsets_s, dict(out.unresolved_reason)
