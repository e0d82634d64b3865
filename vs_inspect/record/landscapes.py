"""Stage 1 in the recording, one pair at a time: its energy landscape over Δ_ab on offset_ms (with
its minima, the chosen Δ, the truth, the --around window and the appearance pairs' own landscape),
its (Δ, rate) landscape under the drift model, its decision, and its epipolar view.

Entities: pairs/<a>__<b>/{landscape,rate_landscape,decision,epipolar}/* and log/decisions
(io/recording_paths.py).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr

from .. import palette
from ..analysis.colours import distance_colors, distance_ramp_px, instance_colors
from ..analysis.record_views import over_range
from ..io.recording_paths import (
    LOG_DECISIONS, TIMELINE_EVENT, TIMELINE_OFFSET_MS, pair_decision_path, pair_epipolar_path,
    pair_landscape_path, pair_rate_landscape_path, video_asset_path,
)
from ..result_types import PairLandscape
from .context import RecordingContext
from .style import (ACCEPTED, APPEARANCE_ONLY, MINIMA, REJECTED, TRUTH, WINDOW, fmt, image_border, offset_ms,
                    scaled_to)
from .videos import decoded

if TYPE_CHECKING:
    from ..analysis.record_views import PairRecordView


def _series(rec: rr.RecordingStream, path: str, style, ms, values) -> None:
    """A static series style and its values at ms on offset_ms."""
    rec.log(path, style, static=True)
    rec.send_columns(path, [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms)], rr.Scalars.columns(scalars=values))


class PairLog:
    """Stage 1's part of the recording."""

    def __init__(self, ctx: RecordingContext, still_frames: dict[str, int]):
        self.ctx = ctx
        self.still_frames = still_frames  # video -> frame its still shows: the one its epipolar view shows
        self.logged: list[str] = []  # "a__b" of every pair logged, in order
        self.views: dict[str, set[str]] = {}  # "a__b" -> views with data ("landscape", "epipolar")

    def log(self, land: PairLandscape, view: PairRecordView | None) -> None:
        self._log_landscape(land, view)
        if land.rate_landscape is not None:
            self._log_rate_landscape(land, view)
        self._log_decision(land, view)
        if view is not None and view.sweep is not None:
            self._log_epipolar(land, view)

    def _log_landscape(self, land: PairLandscape, view: PairRecordView | None) -> None:
        rec, base, key = self.ctx.rec, pair_landscape_path(land.a, land.b), f"{land.a}__{land.b}"
        self.logged.append(key)
        ms = offset_ms(land.offsets_s)
        self.ctx.extend_offset_range(ms)
        e = np.asarray(land.energy, dtype=np.float64)
        ok = np.isfinite(e)
        accepted = land.decision.accepted
        mark = "✓" if accepted else "✗"
        # one colour per pair (its verdict is the chosen marker's colour and shape), the pair in
        # the series' name: "all landscapes" shows every pair's energy in one plot
        rec.log(f"{base}/energy", rr.SeriesLines(
            colors=[palette.category(len(self.logged) - 1, palette.PAIR)],
            names=[f"{mark} {self.ctx.short(land.a)}→{self.ctx.short(land.b)}"],
            widths=[1.5 if accepted else 1.0]), static=True)
        if ok.any():
            self.views.setdefault(key, set()).add("landscape")
            rec.send_columns(f"{base}/energy", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[ok])],
                             rr.Scalars.columns(scalars=e[ok]))
        mi = np.asarray(land.minima_idx, dtype=np.int64)
        rec.log(f"{base}/minima", rr.SeriesPoints(colors=[MINIMA], names=["minima"], markers=["circle"],
                                                  marker_sizes=[4.0]), static=True)
        if len(mi):
            rec.send_columns(f"{base}/minima", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[mi])],
                             rr.Scalars.columns(scalars=e[mi]))
        if math.isfinite(land.best_offset_s) and math.isfinite(land.best_energy):
            _series(rec, f"{base}/chosen", rr.SeriesPoints(
                colors=[ACCEPTED if accepted else REJECTED], names=[f"{mark} chosen" if accepted else
                                                                    f"{mark} best (rejected)"],
                markers=["diamond" if accepted else "cross"], marker_sizes=[7.0]),
                [round(land.best_offset_s * 1000)], [land.best_energy])
        if land.confirm_energy is not None:
            self._log_confirm_landscape(base, land, ms)
        if land.window_s is not None:
            self._log_window(base, land, e[ok])
        if view is not None and view.true_offset_s is not None and view.true_energy is not None:
            _series(rec, f"{base}/truth", rr.SeriesPoints(colors=[TRUTH], names=["true Δ"], markers=["plus"],
                                                          marker_sizes=[7.0]),
                    [round(view.true_offset_s * 1000)], [view.true_energy])

    def _log_window(self, base: str, land: PairLandscape, energy: np.ndarray) -> None:
        """The Δ_ab the --around windows allow: a bar from its lower to its upper bound, at the
        height of the landscape's highest energy (the energy is searched within it only)."""
        lo_ms, hi_ms = (round(x * 1000) for x in land.window_s)
        top = float(np.max(energy)) if len(energy) else 1.0
        _series(self.ctx.rec, f"{base}/window", rr.SeriesLines(
            colors=[WINDOW], widths=[3.0], names=[f"--around window {land.window_s[0]:+.3f}..."
                                                  f"{land.window_s[1]:+.3f} s"]), [lo_ms, hi_ms], [top, top])

    def _log_confirm_landscape(self, base: str, land: PairLandscape, ms: np.ndarray) -> None:
        """The energy of the pair's track pairs found by appearance alone (its unchecked ones left
        out), beside the full one: where its minimum lies is what confirmed or refused the pair.
        Drawn over the full landscape's range (its own robust scale differs, often tenfold), so
        the two shapes compare; result.json keeps its values."""
        rec = self.ctx.rec
        e = over_range(land.confirm_energy, land.energy)
        ok = np.isfinite(e)
        rec.log(f"{base}/appearance_only", rr.SeriesLines(colors=[APPEARANCE_ONLY], widths=[1.0],
                                                          names=["appearance pairs alone (rescaled)"]), static=True)
        if ok.any():
            rec.send_columns(f"{base}/appearance_only", [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms[ok])],
                             rr.Scalars.columns(scalars=e[ok]))
        if math.isfinite(land.confirm_offset_s):
            at = float(np.interp(land.confirm_offset_s, land.offsets_s[ok], e[ok])) if ok.any() else float("nan")
            _series(rec, f"{base}/appearance_only_best", rr.SeriesPoints(
                colors=[APPEARANCE_ONLY], names=["its minimum"], markers=["diamond"], marker_sizes=[5.0]),
                [round(land.confirm_offset_s * 1000)], [at])

    def _log_rate_landscape(self, land: PairLandscape, view: PairRecordView | None) -> None:
        rec, base, rl = self.ctx.rec, pair_rate_landscape_path(land.a, land.b), land.rate_landscape
        rec.log(f"{base}/energy", rr.Tensor(np.asarray(rl.energy, dtype=np.float32),
                                            dim_names=["rate_ppm", "offset_at_pivot"]), static=True)
        if view is not None and view.rate_image is not None:
            rec.log(f"{base}/image", rr.Image(view.rate_image, color_model="RGB"), static=True)
        rec.log(f"{base}/axes", rr.TextDocument(
            f"rows: rate - 1 = {rl.rates_ppm[0]:+.0f} .. {rl.rates_ppm[-1]:+.0f} ppm (top to bottom); "
            f"columns: τ_a - τ_b at b's local time {rl.pivot_s:.3f} s = {rl.offsets_s[0]:+.4f} .. "
            f"{rl.offsets_s[-1]:+.4f} s (left to right); chosen: white ring "
            f"({land.pivot_offset_s:+.4f} s, {(land.rate - 1) * 1e6:+.1f} ppm); truth: orange cross",
            media_type="text/plain"), static=True)

    def _decision_markdown(self, land: PairLandscape, view: PairRecordView | None) -> str:
        d = land.decision
        true = view.true_offset_s if view is not None else None
        minima = ", ".join(f"{land.offsets_s[i]:+.4f} s (E={land.energy[i]:.4g})" for i in land.minima_idx[:6])
        rows = [("chosen Δ_ab", f"{fmt(land.best_offset_s, ' s')} ± {fmt(land.uncertainty_s, ' s')}"),
                ("true Δ_ab", fmt(true, " s") if true is not None else "unknown"),
                ("best energy", f"{land.best_energy:.6g}"),
                ("contrast", f"{d.contrast:.3f}"),
                ("2nd minimum depth ratio", f"{d.second_depth_ratio:.3f}"),
                ("significant minima", str(d.num_minima)),
                ("Pareto minima", str(d.num_pareto_minima)),
                ("at search range edge", str(d.at_range_edge)),
                ("track pairs", str(land.num_track_pairs)),
                ("residual", land.residual),
                ("robust scale", f"{land.robust_scale:.4g}")]
        if land.confirm_energy is not None:  # the grey curve of the landscape
            rows.append(("appearance pairs alone", f"minimum {fmt(land.confirm_offset_s, ' s')}"
                         if math.isfinite(land.confirm_offset_s) else "no accepted minimum"))
        sa, sb = self.ctx.short(land.a), self.ctx.short(land.b)
        full = f"\n\n{land.a} → {land.b}" if (sa, sb) != (land.a, land.b) else ""
        verdict = "ACCEPTED" if d.accepted else "REJECTED"
        return (f"## {sa} → {sb}: {verdict}{full}\n\n**reason:** {d.reason}\n\n| | |\n|---|---|\n"
                + "\n".join(f"| {k} | {v} |" for k, v in rows)
                + f"\n\n**minima (best first):** {minima or 'none'}\n")

    def _log_decision(self, land: PairLandscape, view: PairRecordView | None) -> None:
        rec, d = self.ctx.rec, land.decision
        rec.log(pair_decision_path(land.a, land.b), rr.TextDocument(
            self._decision_markdown(land, view), media_type=rr.MediaType.MARKDOWN), static=True)
        rec.reset_time()
        rec.set_time(TIMELINE_EVENT, sequence=self.ctx.next_event())
        # also at its chosen Δ on the offset timeline (the viewer opens there; a pair without one
        # at its first candidate), so that the decision log is not empty on it
        at = land.best_offset_s if math.isfinite(land.best_offset_s) else \
            (float(land.offsets_s[0]) if len(land.offsets_s) else None)
        if at is not None:
            rec.set_time(TIMELINE_OFFSET_MS, sequence=round(at * 1000))
        verdict = "accepted" if d.accepted else "rejected"
        rec.log(LOG_DECISIONS, rr.TextLog(
            f"{land.a}__{land.b} {verdict} Δ={fmt(land.best_offset_s, ' s')}: {d.reason}",
            level=rr.TextLogLevel.INFO if d.accepted else rr.TextLogLevel.WARN))
        rec.reset_time()

    def _log_epipolar(self, land: PairLandscape, view: PairRecordView) -> None:
        """One frame of a with the epipolar lines of b's paired points at each shown Δ on
        offset_ms, a's points coloured by their distance to their line, and that distance's median."""
        rec, sw, base = self.ctx.rec, view.sweep, pair_epipolar_path(land.a, land.b)
        buf = self.ctx.videos.get(land.a)
        self.views.setdefault(f"{land.a}__{land.b}", set()).add("epipolar")
        self.still_frames.setdefault(land.a, int(sw.frame_a))
        va = buf.info if buf is not None else self.ctx.bundle.video(land.a)
        W, H = va.width, va.height
        rec.log(base, rr.TextDocument(
            f"frame {sw.frame_a} of {land.a} (τ = {sw.time_a_s:.3f} s). Lines: epipolar lines of "
            f"{land.b}'s paired points at τ − Δ, in their instance's colour; points: {land.a}'s points, "
            "yellow when on their line, blue when far. Scrub `offset_ms`: lines pass through "
            f"the points only near the right Δ (chosen {fmt(land.best_offset_s, ' s')})."), static=True)
        rec.log(f"{base}/border", image_border(W, H), static=True)
        if buf is not None and sw.frame_a in buf.jpeg:
            rec.log(f"{base}/image", scaled_to(W, H, buf.image_size), static=True)
            rec.log(f"{base}/image", decoded(buf.jpeg[sw.frame_a]), static=True)
        elif buf is not None and buf.asset and buf.asset_timestamps_ns is not None:
            rec.log(f"{base}/image", rr.VideoFrameReference(
                nanoseconds=int(buf.asset_timestamps_ns[sw.frame_a]),
                video_reference=video_asset_path(land.a)), static=True)
        self._log_sweep(base, view)

    def _log_sweep(self, base: str, view: PairRecordView) -> None:
        rec, sw = self.ctx.rec, view.sweep
        ms = offset_ms(sw.offsets_s)
        cols_inst = instance_colors(sw.instance)
        ramp_px = distance_ramp_px(sw.distance_px)  # over all offsets shown
        lines_pos, lines_col, line_len, pt_col = [], [], [], []
        for d in range(len(ms)):
            seg = sw.segments[d]
            ok = np.isfinite(seg).all((1, 2))
            lines_pos.append(seg[ok].reshape(-1, 2))
            lines_col.append(cols_inst[ok])
            line_len.append(int(ok.sum()))
            pt_col.append(distance_colors(sw.distance_px[d], ramp_px))
        # Each row: a list of 2-point strips -> partition LineStrips2D by strip count per offset.
        strips = np.concatenate(lines_pos).reshape(-1, 2, 2).astype(np.float32)  # (S,2,2): 2-point strips
        tcol = [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms)]
        if len(strips):
            rec.send_columns(f"{base}/lines", tcol, rr.LineStrips2D.columns(
                strips=strips, colors=np.concatenate(lines_col)).partition(line_len))
        rec.send_columns(f"{base}/points_a", tcol, rr.Points2D.columns(
            positions=np.tile(sw.points_a.astype(np.float32), (len(ms), 1)),
            colors=np.concatenate(pt_col)).partition([len(sw.points_a)] * len(ms)))
        # in screen points: the views shrink a 1280 px frame to a few hundred px
        rec.log(f"{base}/points_a", rr.Points2D.from_fields(radii=[rr.Radius.ui_points(4.0)]), static=True)
        rec.log(f"{base}/lines", rr.LineStrips2D.from_fields(radii=[rr.Radius.ui_points(0.75)]), static=True)
        med = view.sweep_median_px
        okm = np.isfinite(med)
        if okm.any():
            _series(rec, f"{base}/median_distance_px", rr.SeriesLines(
                names=["median point-line distance (px)"], colors=[MINIMA]), ms[okm], med[okm])
