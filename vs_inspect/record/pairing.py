"""Stage 0's pairing evidence (cues/pairing/) in the recording: descriptor matches per keyframe
pair, the geometric votes of each pair over Δ_ab, and the point-transfer and three-view checks of
each camera over its candidate offsets. All but the matches are series on offset_ms, the
landscapes' axis, so that a run that stops before Stage 1 still opens there.

Entities: pairs/<a>__<b>/keyframe_matches, pairs/<a>__<b>/votes/*, cues/transfer/<v>/*,
cues/three_view/<v>/* (io/recording_paths.py).
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from .. import palette
from ..io.recording_paths import (
    TIMELINE_KEYFRAME_PAIR, TIMELINE_OFFSET_MS, pair_matches_path, pair_votes_path, three_view_path, transfer_path,
)
from .context import RecordingContext
from .style import ACCEPTED, REJECTED, offset_ms


def _verdict(ok: bool) -> tuple[tuple[int, int, int], str]:
    """The colour and mark of a check's verdict."""
    return (ACCEPTED, "✓") if ok else (REJECTED, "✗")


class PairingLog:
    """Stage 0's pairing part of the recording."""

    def __init__(self, ctx: RecordingContext):
        self.ctx = ctx
        self.votes_logged: list[str] = []  # "a__b" of the pairs whose geometric votes were logged
        self.transfer_logged: list[str] = []  # cameras whose point-transfer check was logged
        self.three_view_logged: list[str] = []  # cameras whose three-view check was logged

    def matches(self, a: str, b: str, frames_a: np.ndarray, frames_b: np.ndarray, counts: np.ndarray) -> None:
        rec = self.ctx.rec
        counts = np.asarray(counts, dtype=np.int64).reshape(len(frames_a), len(frames_b))
        base = pair_matches_path(a, b)
        rec.log(base, rr.SeriesLines(names=["descriptor matches per keyframe pair"]), static=True)
        if counts.size:
            rec.send_columns(base, [rr.TimeColumn(TIMELINE_KEYFRAME_PAIR, sequence=np.arange(counts.size))],
                             rr.Scalars.columns(scalars=counts.ravel().astype(np.float64)))
            rec.log(f"{base}/grid", rr.Tensor(counts, dim_names=(f"keyframe of {a}", f"keyframe of {b}")),
                    static=True)
        # which frames the keyframe_pair index k stands for: a's frames_a[k // Kb], b's frames_b[k % Kb]
        rec.log(f"{base}/keyframes", rr.AnyValues(frames_a=np.asarray(frames_a, np.int64),
                                                  frames_b=np.asarray(frames_b, np.int64)), static=True)

    def _on_offsets(self, path: str, style, ms: np.ndarray, values: np.ndarray) -> None:
        """A static series style and its values (D,) at ms (D,) on the offset_ms timeline."""
        self.ctx.rec.log(path, style, static=True)
        self.ctx.extend_offset_range(ms)
        if len(ms):
            self.ctx.rec.send_columns(path, [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms)],
                                      rr.Scalars.columns(scalars=np.asarray(values, np.float64)))

    def _point_at(self, path: str, offsets_s: np.ndarray, values: np.ndarray, at_s: float,
                  colour, marker: str, name: str) -> None:
        """One marker on a series: its value at the candidate offset nearest at_s, drawn at at_s."""
        i = int(np.argmin(np.abs(offsets_s - at_s)))
        self._on_offsets(path, rr.SeriesPoints(colors=[colour], markers=[marker], marker_sizes=[6.0], names=[name]),
                         offset_ms([at_s]), values[i:i + 1])

    def votes(self, a: str, b: str, offsets_s: np.ndarray, votes: np.ndarray, z: np.ndarray,
              chosen_s: float | None) -> None:
        base = pair_votes_path(a, b)
        self.votes_logged.append(f"{a}__{b}")
        offsets_s, z = np.asarray(offsets_s, np.float64), np.asarray(z, np.float64)
        ms = offset_ms(offsets_s)
        self._on_offsets(f"{base}/z", rr.SeriesLines(names=[f"{a}→{b}"], widths=[1.2]), ms, z)
        self._on_offsets(f"{base}/count", rr.SeriesLines(names=[f"{a}→{b} votes"], widths=[1.0]), ms, votes)
        if chosen_s is not None and len(ms):
            self._point_at(f"{base}/chosen", offsets_s, z, chosen_s, ACCEPTED, "diamond", f"{a}→{b} kept")

    def transfer(self, camera: str, offsets_s: np.ndarray, share: np.ndarray, joint_offset_s: float,
                 transfer_offset_s: float | None, confirmed: bool) -> None:
        base = transfer_path(camera)
        self.transfer_logged.append(camera)
        offsets_s, share = np.asarray(offsets_s, np.float64), np.asarray(share, np.float64)
        ms = offset_ms(offsets_s)
        color, mark = _verdict(confirmed)
        self._on_offsets(f"{base}/share", rr.SeriesLines(colors=[color], widths=[1.5],
                                                         names=[f"{mark} {camera}: samples on their track"]), ms, share)
        for what, at, colour, marker in (("joint", joint_offset_s, palette.SOLVED, "circle"),
                                         ("peak", transfer_offset_s, color, "diamond")):
            if at is not None and len(ms):
                self._point_at(f"{base}/{what}", offsets_s, share, at, colour, marker, f"{camera}: {what} offset")

    def three_view(self, camera: str, offsets_s: np.ndarray, supporters: np.ndarray,
                   joint_offset_s: float, passed: bool) -> None:
        base = three_view_path(camera)
        offsets_s, supporters = np.asarray(offsets_s, np.float64), np.asarray(supporters, np.float64)
        if not len(offsets_s):
            return
        self.three_view_logged.append(camera)
        color, mark = _verdict(passed)
        self._on_offsets(f"{base}/supporters", rr.SeriesLines(
            colors=[color], widths=[1.5], names=[f"{mark} {camera}: trajectories followed"]),
            offset_ms(offsets_s), supporters)
        self._point_at(f"{base}/joint", offsets_s, supporters, joint_offset_s, palette.SOLVED, "circle",
                       f"{camera}: joint offset")
