"""The recording's default layout in the rerun viewer (a rerun blueprint)."""

from __future__ import annotations

from ..io.recording import (LOG, PAIRS, SYNC_GRAPH, SYNC_OFFSETS, SYNC_SOLVE, VIDEOS, WORLD,
                            pair_landscape_path, pair_epipolar_path, video_path)
from ..types import SyncResult


def blueprint(video_names: list[str], pairs_logged: list[str], result: SyncResult | None):
    """Videos and the 3D world on the left; the best pair's landscape and epipolar view, then the
    decision log, offsets, pair graph, solve and all landscapes on the right.

    pairs_logged: "a__b" of every pair in the order they were logged (the first is shown when the
    result is unknown).
    """
    import rerun.blueprint as rrb
    video_views = [rrb.Spatial2DView(origin=video_path(v), name=v) for v in video_names[:8]]
    first = pairs_logged[0] if pairs_logged else None
    if result is not None and result.pairs:
        best = sorted(result.pairs, key=lambda p: (not p.decision.accepted, -p.decision.contrast))[0]
        first = f"{best.a}__{best.b}"
    left = rrb.Vertical(
        rrb.Grid(*video_views, name="videos") if video_views else rrb.TextDocumentView(origin=VIDEOS),
        rrb.Spatial3DView(origin=WORLD, name="3D"),
        row_shares=[1, 1])
    pair_views = []
    if first:
        a, b = first.split("__", 1)
        pair_views = [rrb.TimeSeriesView(origin=pair_landscape_path(a, b), name=f"landscape {first}"),
                      rrb.Spatial2DView(origin=pair_epipolar_path(a, b),
                                        name=f"epipolar {first} (scrub offset_ms)")]
    right = rrb.Vertical(
        *pair_views,
        rrb.Tabs(rrb.TextLogView(origin=LOG, name="decision log"),
                 rrb.TextDocumentView(origin=SYNC_OFFSETS, name="offsets"),
                 rrb.GraphView(origin=SYNC_GRAPH, name="pair graph"),
                 rrb.TimeSeriesView(origin=SYNC_SOLVE, name="IRLS solve"),
                 rrb.TimeSeriesView(origin=PAIRS, name="all landscapes")),
    )
    return rrb.Blueprint(rrb.Horizontal(left, right, column_shares=[3, 2]), collapse_panels=False)
