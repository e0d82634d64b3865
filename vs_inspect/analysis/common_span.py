"""The time span every synchronized video covers, as a frame range of each video.

Global time g = local time + offset_s (DESIGN.md). The span starts at the first frame of the
slowest video (largest frame interval) at or after the latest start, and ends at its last frame
at or before the earliest end; every other video takes its frame nearest to those two moments.
So each trimmed video begins within half of its own frame interval of the slowest video's first
frame, which none of them can beat at their own rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..types import VideoInfo


@dataclass(frozen=True)
class VideoSpan:
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
    reference: str
    start_s: float  # global time of the slowest video's first frame in the span, s
    end_s: float  # global time of its last frame in the span, s
    anchor: str  # the slowest video, whose frames set start_s and end_s
    videos: dict[str, VideoSpan]  # the synchronized videos (offset known), input order
    skipped: dict[str, str]  # video -> why it has no span


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
