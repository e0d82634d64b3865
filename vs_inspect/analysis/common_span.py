"""The time span every synchronized video covers, as a frame range of each video.

Global time g = local time + offset_s (DESIGN.md). The span starts at the first frame of the
slowest video (largest frame interval) at or after the latest start, and ends at its last frame
at or before the earliest end; every other video takes its frame nearest to those two moments.
So each trimmed video begins within half of its own frame interval of the slowest video's first
frame, which none of them can beat at their own rate.
"""

from __future__ import annotations

import numpy as np

from ..result_types import CommonSpan, VideoSpan
from ..types import VideoInfo


def common_span(infos: list[VideoInfo], offsets_s: dict[str, float | None], reference: str
                ) -> CommonSpan:
    """The common span of the videos with an offset; ValueError when there is none (fewer than
    one video with an offset, or videos that never overlap in time)."""
    skipped = {v.name: "no offset (not synchronized)" for v in infos if offsets_s.get(v.name) is None}
    used = [v for v in infos if offsets_s.get(v.name) is not None]
    if not used:
        raise ValueError("no video has an offset")
    g = {v.name: np.asarray(v.timestamps_s, dtype=np.float64) + float(offsets_s[v.name]) for v in used}
    lo = max(t[0] for t in g.values())
    hi = min(t[-1] for t in g.values())
    if hi < lo:
        raise ValueError(f"the videos do not overlap in time: the latest starts at {lo:+.3f} s, "
                         f"the earliest ends at {hi:+.3f} s (global time)")
    eps = 1e-9
    anchor = max(used, key=lambda v: (v.frame_interval_s, v.name))
    ta = g[anchor.name]
    inside = np.flatnonzero((ta >= lo - eps) & (ta <= hi + eps))
    if len(inside) == 0:  # the span is shorter than one frame of the slowest video
        k = int(np.argmin(np.abs(ta - (lo + hi) / 2)))
        start_s = end_s = float(ta[k])
    else:
        start_s, end_s = float(ta[inside[0]]), float(ta[inside[-1]])
    spans = {}
    for v in used:
        t = g[v.name]
        k0 = int(np.argmin(np.abs(t - start_s)))
        k1 = int(np.argmin(np.abs(t - end_s)))
        spans[v.name] = VideoSpan(v.name, float(offsets_s[v.name]), float(v.frame_interval_s),
                                  k0, max(k0, k1), float(t[k0]), float(t[max(k0, k1)]))
    return CommonSpan(reference, start_s, end_s, anchor.name, spans, skipped)
