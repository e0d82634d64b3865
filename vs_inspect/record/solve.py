"""Stage 2 in the recording: the pair graph with each video's offset, the IRLS iterations (series
on `iteration` and bars shown on every timeline), the offsets, pairs and loop-closure tables, and
the accepted pairs' tracks triangulated at the solved offsets.

Entities: sync/{graph,solve,offsets,pairs,loops} and world/trajectories/* (io/recording_paths.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import rerun as rr

from .. import palette
from ..analysis.colours import GREY, instance_colors
from ..io.recording_paths import (
    SYNC_GRAPH, SYNC_LOOPS, SYNC_OFFSETS, SYNC_PAIRS, TIMELINE_ITERATION, TIMELINE_TIME, irls_residual_path,
    irls_weight_path, solve_residual_path, solve_weight_path, trajectory_path,
)
from ..result_types import SyncResult
from .blueprint import MAX_PAIR_CONTAINERS, pair_order
from .context import RecordingContext
from .style import ACCEPTED, REJECTED, fmt

if TYPE_CHECKING:
    from ..analysis.record_views import RunRecordView

MAX_LOOPS_LISTED = 40  # triangles in the loop-closure table, largest residual first
MAX_LABELLED_TRAJECTORIES = 3  # more labels in the 3D view overlap


def _markdown(rec: rr.RecordingStream, path: str, md: str) -> None:
    rec.log(path, rr.TextDocument(md, media_type=rr.MediaType.MARKDOWN), static=True)


def log_graph(ctx: RecordingContext, result: SyncResult, view: RunRecordView) -> None:
    """Videos as nodes with their offsets, and a node on each evaluated pair's edge (✓ Δ or ✗)."""
    ids, labels, cols, radii, P = [], [], [], [], []
    for v, off in result.offsets_s.items():
        ids.append(v)
        labels.append(f"{ctx.short(v)} {fmt(off, ' s', 3)}" if off is not None else f"{ctx.short(v)} unresolved")
        cols.append(ctx.camera_color(v) if off is not None else GREY)
        radii.append(18.0)
        P.append(view.graph_xy[v])
    edges = []
    for p in result.pairs:
        mid = f"{p.a}__{p.b}"
        acc = p.decision.accepted
        ids.append(mid)
        # short labels (long ones overlapped); the reasons are in the pairs table
        labels.append(f"✓ {fmt(p.best_offset_s, ' s', 3)}" if acc else "✗")
        cols.append(ACCEPTED if acc else REJECTED)
        radii.append(6.0)
        P.append(view.graph_xy[mid])
        edges += [(p.a, mid), (mid, p.b)]
    ctx.rec.log(SYNC_GRAPH, rr.GraphNodes(ids, labels=labels, colors=cols, radii=radii, positions=P,
                                          show_labels=True), static=True)
    ctx.rec.log(SYNC_GRAPH, rr.GraphEdges(edges, graph_type=rr.GraphType.Undirected), static=True)


def log_solve(ctx: RecordingContext, result: SyncResult, pairs_logged: list[str]) -> None:
    """Each accepted pair's residual (ms) and weight per IRLS iteration."""
    if not result.iterations:
        return
    rec = ctx.rec
    its = np.arange(len(result.iterations), dtype=np.int64)
    R = np.array([it.residual_s for it in result.iterations], dtype=float) * 1000.0  # (I,E)
    Wt = np.array([it.weight for it in result.iterations], dtype=float)
    E = len(result.solve_pairs)
    for e, (a, b) in enumerate(result.solve_pairs):
        tcol = [rr.TimeColumn(TIMELINE_ITERATION, sequence=its)]
        rec.send_columns(solve_residual_path(a, b), tcol, rr.Scalars.columns(scalars=R[:, e]))
        rec.send_columns(solve_weight_path(a, b), tcol, rr.Scalars.columns(scalars=Wt[:, e]))
        # the same numbers as bars grouped by iteration, static: shown on every timeline,
        # in the colour of the pair's landscape
        key = f"{a}__{b}"
        colour = palette.category(pairs_logged.index(key) if key in pairs_logged else e, palette.PAIR)
        x = its + (e + 0.5) / (E + 1) - 0.5
        sa, sb = ctx.short(a), ctx.short(b)  # the legend shows the path
        for path, values in ((irls_residual_path(sa, sb), np.abs(R[:, e])), (irls_weight_path(sa, sb), Wt[:, e])):
            rec.log(path, rr.BarChart(np.nan_to_num(values), abscissa=x, widths=[0.9 / (E + 1)] * len(x),
                                      color=colour), static=True)


def log_final_offsets(ctx: RecordingContext) -> None:
    """The offsets table, once, when the recording closes: the run's summary (every input video,
    Stage 0's left out too, each null in a few words and below the table in full), else Stage 2's
    result when its record view was given; nothing before Stage 2."""
    if ctx.summary is not None:
        s = ctx.summary
        log_offsets(ctx, s.reference, s.solver, s.offsets_s, s.uncertainty_s, s.headlines(), ctx.view, s.unresolved)
    elif ctx.result is not None and ctx.view is not None:
        r = ctx.result
        log_offsets(ctx, r.reference, r.solver, r.offsets_s, r.uncertainty_s, r.unresolved_reason, ctx.view)


def log_offsets(ctx: RecordingContext, reference: str, solver: str, offsets_s: dict, uncertainty_s: dict,
                notes: dict, view: RunRecordView | None, in_full: dict | None = None) -> None:
    """The offsets table (notes: video -> why it is null; truth and errors from view, when
    given), and below it each null's note again (the table's cell is cut to the panel's width)
    with its whole reason (in_full), when given."""
    rows = []
    for v, off in offsets_s.items():
        u = uncertainty_s.get(v)
        t = view.true_offsets_s.get(v) if view is not None else None
        err = view.errors_ms.get(v) if view is not None else None
        note = notes.get(v, '').replace("|", "/") if off is None else ''
        rows.append(f"| {v} | {fmt(off)} | {fmt(u, '', 4) if u is not None else '-'} | "
                    f"{fmt(t) if t is not None else '-'} | "
                    f"{f'{err:.1f}' if err is not None and t is not None else '-'} | {note} |")
    md = (f"## Offsets (reference {reference}, solver {solver})\n\n"
          "| video | offset_s | ± s | true_s | error_ms | note |\n|---|---|---|---|---|---|\n" + "\n".join(rows))
    nulls = [v for v, off in offsets_s.items() if off is None and v in (in_full or {})]
    if nulls:
        md += "\n\n### Why each null has no offset\n\n" + "\n\n".join(
            f"**{v}**: {notes.get(v) or in_full[v]}" + (f"\n\n> in full: {in_full[v]}" if in_full[v] != notes.get(v) else "")
            for v in nulls)
    _markdown(ctx.rec, SYNC_OFFSETS, md)


def log_loops(ctx: RecordingContext, view: RunRecordView) -> None:
    """Δ_ab + Δ_bc − Δ_ac per triangle of pairs, largest residual first."""
    if not view.triangles:
        return
    rows = [f"| {t.a} → {t.b} → {t.c} | {t.residual_ms:+.1f} | {t.tolerance_ms:.1f} | "
            f"{'closes' if t.closes else '**LOOP OFF**'} | {t.accepted}/3 |"
            for t in view.triangles[:MAX_LOOPS_LISTED]]
    more = len(view.triangles) - len(rows)
    md = ("## Loop closure per triangle of pairs\n\nOffsets are differences, so the chosen "
          "Δ_ab + Δ_bc − Δ_ac is 0 ms when all three pairs are right. A large residual names a "
          "triangle with at least one wrong pair; a pair in several large triangles is the "
          "suspect. The tolerance is `vs-inspect inspect`'s: 2 frames of the slowest video, or "
          "3σ of the pairs' uncertainties. Largest first.\n\n| triangle a → b → c | residual ms "
          "| tolerance ms | loop | pairs accepted |\n|---|---|---|---|---|\n" + "\n".join(rows)
          + (f"\n\n{more} more triangles with smaller residuals are not listed." if more > 0 else ""))
    _markdown(ctx.rec, SYNC_LOOPS, md)


def log_pairs_table(ctx: RecordingContext) -> None:
    """Every pair's verdict, Δ and reason in one table, in the containers' order."""
    r = ctx.result
    if r is None or not r.pairs:
        return
    truth = ctx.truth()
    rows = []
    for i, p in enumerate(pair_order(r.pairs)):
        true = (truth[p.b] - truth[p.a]) if truth and p.a in truth and p.b in truth else None
        rows.append(f"| {'✓' if p.decision.accepted else '✗'} | {ctx.short(p.a)} → {ctx.short(p.b)} | "
                    f"{fmt(p.best_offset_s, '', 3)} | {fmt(true, '', 3) if true is not None else '-'} | "
                    f"{p.decision.contrast:.2f} | {p.num_track_pairs} | {p.decision.reason} |"
                    + (" (no container)" if i >= MAX_PAIR_CONTAINERS else ""))
    n_rej = sum(not p.decision.accepted for p in r.pairs)
    md = (f"## Pairs: {len(r.pairs) - n_rej} accepted, {n_rej} rejected\n\n"
          "| | pair a → b | chosen Δ_ab s | true Δ_ab s | contrast | track pairs | reason |\n"
          "|---|---|---|---|---|---|---|\n" + "\n".join(rows))
    _markdown(ctx.rec, SYNC_PAIRS, md)


def log_trajectories(ctx: RecordingContext, view: RunRecordView) -> None:
    """Each accepted pair's tracks triangulated at the solved offsets: static strips, and the
    points per moment on `time`."""
    rec = ctx.rec
    for tj in view.trajectories:
        X = tj.points_world  # (P,T,3)
        ok = np.isfinite(X).all(-1)
        key = trajectory_path(tj.a, tj.b)
        cols = instance_colors(tj.instance)
        strips = [X[sg.track, sg.start:sg.stop].astype(np.float32) for sg in tj.segments]
        scol = [cols[sg.track] for sg in tj.segments]
        if strips:
            rec.log(key, rr.LineStrips3D(strips, colors=np.array(scol), radii=rr.Radius.ui_points(2.0)), static=True)
            centre = np.median(np.concatenate(strips), axis=0)
            if len(view.trajectories) <= MAX_LABELLED_TRAJECTORIES:
                rec.log(f"{key}/label", rr.Points3D([centre], labels=[f"tracks {tj.a}-{tj.b}"], colors=[GREY],
                                                    radii=rr.Radius.ui_points(2.0), show_labels=True), static=True)
        frames = np.flatnonzero(ok.any(0))
        lengths = [int(ok[:, k].sum()) for k in frames]
        pos = np.concatenate([X[ok[:, k], k] for k in frames]).astype(np.float32)
        pc = np.concatenate([cols[ok[:, k]] for k in frames])
        rec.send_columns(f"{key}/points", [rr.TimeColumn(TIMELINE_TIME, duration=tj.time_s[frames])],
                         rr.Points3D.columns(positions=pos, colors=pc).partition(lengths))
        rec.log(f"{key}/points", rr.Points3D.from_fields(radii=[rr.Radius.ui_points(4.0)]), static=True)
