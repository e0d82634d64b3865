"""The recording's default layout in the rerun viewer (a rerun blueprint).

The viewer opens on the `offset_ms` timeline (the candidate offsets Δ of the pairs), paused, with
the time panel expanded over the whole search range. Three columns:

- left: "how to read this recording", the pairs table, offsets, loop closure and the decision log
  (tabs); below them all landscapes (one series per pair), the pair graph and the IRLS solve;
- middle: one container per pair (landscape, epipolar lines over the tracklets, decision text),
  failed pairs first, at most MAX_PAIR_CONTAINERS of them;
- right: the videos that have frames and the 3D world (cameras, trajectories).

Videos are named by their short display names (analysis.display_names) in titles and legends.
The viewer has no setting for where its time cursor starts: it opens at the smallest offset of the
range; `vs-inspect view` (record/viewer.py) opens a recording with the cursor at the front pair's Δ.
"""

from __future__ import annotations

import math

from ..io.recording_paths import (
    GUIDE, LOG, SYNC_GRAPH, SYNC_IRLS, SYNC_LOOPS, SYNC_OFFSETS, SYNC_PAIRS, TIMELINE_OFFSET_MS, WORLD,
    pair_decision_path, pair_epipolar_path, pair_landscape_path, pair_votes_path, video_path,
)
from ..result_types import PairLandscape, SyncResult
from .people import PEOPLE_CUE, pair_people_path

MAX_PAIR_CONTAINERS = 12  # pair containers in the middle column; the rest are in the pairs table
MAX_VIDEO_VIEWS = 8  # video views in the grid


def pair_order(pairs) -> list[PairLandscape]:
    """Most informative first: rejected pairs (those with more track pairs first: something was
    there to be found), then accepted ones from the least clear (lowest contrast) up."""
    def key(p: PairLandscape):
        c = p.decision.contrast
        return (p.decision.accepted, -p.num_track_pairs if not p.decision.accepted else 0,
                c if math.isfinite(c) else -math.inf, p.a, p.b)
    return sorted(pairs, key=key)


def _bounds(size: tuple[int, int] | None):
    """The whole image of a video (full-resolution px), whatever else the view holds."""
    import rerun.blueprint as rrb
    if size is None:
        return None
    return rrb.VisualBounds2D(x_range=[0, size[0]], y_range=[0, size[1]])


def pair_title(a: str, b: str, labels: dict[str, str] | None = None) -> str:
    """"a→b" in the videos' display names: the end of a pair container's title."""
    labels = labels or {}
    return f"{labels.get(a, a)}→{labels.get(b, b)}"


def _pair_container(a: str, b: str, accepted: bool | None, views: set[str],
                    range_ms: tuple[int, int] | None, size_a: tuple[int, int] | None = None,
                    labels: dict[str, str] | None = None):
    import rerun.blueprint as rrb
    arrow = pair_title(a, b, labels)
    mark = "" if accepted is None else ("✓ " if accepted else "✗ ")
    lower = []
    if "epipolar" in views:
        lower.append(rrb.Spatial2DView(origin=pair_epipolar_path(a, b), name=f"epipolar {arrow}",
                                       visual_bounds=_bounds(size_a)))
    lower.append(rrb.TextDocumentView(origin=pair_decision_path(a, b), name=f"decision {arrow}"))
    bottom = rrb.Horizontal(*lower, column_shares=[3, 2][: len(lower)]) if len(lower) > 1 else lower[0]
    if "landscape" not in views:  # no finite energy: nothing to plot
        return rrb.Vertical(bottom, name=f"{mark}{arrow}")
    land = rrb.TimeSeriesView(origin=pair_landscape_path(a, b), name=f"landscape {arrow}",
                              time_ranges=_full_range(), axis_x=_axis(range_ms),
                              plot_legend=rrb.PlotLegend(visible=True))
    return rrb.Vertical(land, bottom, row_shares=[2, 3], name=f"{mark}{arrow}")


def _full_range():
    """All the data of the offset timeline, wherever the cursor is."""
    import rerun.blueprint as rrb
    inf = rrb.TimeRangeBoundary.infinite()
    return [rrb.VisibleTimeRange(TIMELINE_OFFSET_MS, start=inf, end=inf)]


def _axis(range_ms: tuple[int, int] | None):
    """An x axis over the whole search range (by default a plot follows the cursor with a window
    narrower than the range)."""
    import rerun as rr
    import rerun.blueprint as rrb
    if range_ms is None:
        return None
    lo, hi = range_ms
    return rrb.TimeAxis(view_range=rr.TimeRange(start=rrb.TimeRangeBoundary.absolute(seq=lo),
                                                end=rrb.TimeRangeBoundary.absolute(seq=hi)))


def _redundant(pairs) -> bool:
    """The accepted pairs hold a loop (more pairs than a spanning forest of their videos): only
    then do residuals and weights of the robust solve say anything (else they are 0 and 1)."""
    parent: dict[str, str] = {}

    def root(v: str) -> str:
        while parent.setdefault(v, v) != v:
            v = parent[v]
        return v

    for a, b in pairs:
        ra, rb = root(a), root(b)
        if ra == rb:
            return True
        parent[ra] = rb
    return False


def shown_pairs(pairs_logged: list[str], result: SyncResult | None) -> list[tuple[str, str, bool | None]]:
    """(a, b, accepted) of the pairs that get a container, in order (None: verdict unknown)."""
    if result is not None and result.pairs:
        return [(p.a, p.b, p.decision.accepted) for p in pair_order(result.pairs)][:MAX_PAIR_CONTAINERS]
    return [(*k.split("__", 1), None) for k in pairs_logged][:MAX_PAIR_CONTAINERS]


def blueprint(video_names: list[str], pairs_logged: list[str], result: SyncResult | None,
              pair_views: dict[str, set[str]] | None = None, timeline: str = TIMELINE_OFFSET_MS,
              has_loops: bool = False, range_ms: tuple[int, int] | None = None,
              sizes: dict[str, tuple[int, int]] | None = None, eye: tuple | None = None,
              transfer_origin: str | None = None, three_view_origin: str | None = None,
              votes_logged: list[str] | None = None, people_logged: list[str] | None = None,
              show_world: bool = True, offsets_logged: bool = False,
              labels: dict[str, str] | None = None, with_frames: set[str] | None = None):
    """The default blueprint.

    pairs_logged: "a__b" of every pair in the order they were logged (their order when the result
    is unknown). pair_views: "a__b" -> the views that have data ("landscape", "epipolar"; a pair
    missing here is assumed to have both). timeline: the one the viewer opens on. has_loops:
    triangles of pairs were logged (SYNC_LOOPS). range_ms: the search range on offset_ms, the
    landscape plots' x axis (None: rerun's default). sizes: video -> (width, height) px, the
    bounds of its 2D views. eye: (position, look target, up) of the 3D view (None: rerun's).
    transfer_origin: where Stage 0's point-transfer checks were logged (None: none were).
    three_view_origin: where Stage 0's three-view checks of sure cameras were logged (None: none were).
    votes_logged: "a__b" of the pairs whose geometric pairing votes were logged (Stage 0).
    people_logged: "a__b" of the pairs whose people shift evidence was logged (Stage 0's people cue;
    None: the cue did not run).
    show_world: whether the 3D view is shown (False: no camera was logged, e.g. Stage 0 refused
    every one, and the view would open empty). offsets_logged: the run's offsets table was logged
    (also without a SyncResult: Stage 0 could use no video); with no pair logged it opens in front.
    labels: video -> the short name its titles use (default: its name). with_frames: the videos
    with images (frames or an embedded video); only these get a video view (None: all of them).
    """
    import rerun.blueprint as rrb
    pair_views, sizes, labels = pair_views or {}, sizes or {}, labels or {}
    shown = shown_pairs(pairs_logged, result)
    containers = [_pair_container(a, b, acc, pair_views.get(f"{a}__{b}", {"landscape", "epipolar"}),
                                  range_ms, sizes.get(a), labels) for a, b, acc in shown]
    info, active = _info_tabs(pairs_logged, result, has_loops, offsets_logged, people_logged is not None)
    overview = _overview_tabs(pairs_logged, result, pair_views, range_ms, transfer_origin, three_view_origin,
                              votes_logged, people_logged)
    left = rrb.Vertical(rrb.Tabs(*info, active_tab=active), *( [rrb.Tabs(*overview, active_tab=0)] if overview else []),
                        row_shares=[1, 1][: 1 + bool(overview)])
    right = _scene_views(video_names, sizes, eye, show_world, labels, with_frames)
    columns = [left]
    if containers:
        columns.append(rrb.Tabs(*containers, active_tab=0, name="pair containers"))
    if right:
        columns.append(rrb.Vertical(*right, row_shares=[1] * len(right)) if len(right) > 1 else right[0])
    shares = ([2, 3] if containers else [2]) + ([3] if right else [])
    return rrb.Blueprint(rrb.Horizontal(*columns, column_shares=shares),
                         rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"),
                         rrb.TimePanel(state="expanded", timeline=timeline, play_state="paused"),
                         auto_views=False)


def _info_tabs(pairs_logged: list[str], result: SyncResult | None, has_loops: bool, offsets_logged: bool,
               people: bool = False):
    """(the text views of the left column's upper tabs: guide, pairs, offsets, loops, the people
    cue's summary (people: it ran), log; the index of the one in front)."""
    import rerun.blueprint as rrb
    info = [rrb.TextDocumentView(origin=GUIDE, name="how to read this recording")]
    if result is not None:
        info.append(rrb.TextDocumentView(origin=SYNC_PAIRS, name="pairs (failed first)"))
    active = 0
    if result is not None or offsets_logged:
        if offsets_logged and not pairs_logged:  # no pair to look at: why each video has no offset comes first
            active = len(info)
        info.append(rrb.TextDocumentView(origin=SYNC_OFFSETS, name="offsets"))
    if has_loops:
        info.append(rrb.TextDocumentView(origin=SYNC_LOOPS, name="loop closure"))
    if people:
        info.append(rrb.TextDocumentView(origin=PEOPLE_CUE, name="people (Stage 0)"))
    info.append(rrb.TextLogView(origin=LOG, name="decision log"))
    return info, active


def _overview_tabs(pairs_logged: list[str], result: SyncResult | None, pair_views: dict[str, set[str]],
                   range_ms: tuple[int, int] | None, transfer_origin: str | None, three_view_origin: str | None,
                   votes_logged: list[str] | None, people_logged: list[str] | None = None) -> list:
    """The views of the left column's lower tabs: all landscapes, pair graph, IRLS solve, Stage 0's
    pairing votes, people shifts and checks (only those with data)."""
    import rerun.blueprint as rrb
    # every pair's energy in its colour, with its chosen Δ marked by verdict (diamond / cross)
    energies = [f"+ /{pair_landscape_path(*k.split('__', 1))}/{part}" for k in pairs_logged
                if "landscape" in pair_views.get(k, {"landscape"}) for part in ("energy", "chosen")]
    overview = []
    if energies:
        overview.append(rrb.TimeSeriesView(origin="/", contents=energies, name="all landscapes",
                                           time_ranges=_full_range(), axis_x=_axis(range_ms),
                                           plot_legend=rrb.PlotLegend(visible=True)))
    if result is not None:
        overview.append(rrb.GraphView(origin=SYNC_GRAPH, name="pair graph"))
        if result.iterations and _redundant(result.solve_pairs):  # bars (static: on every timeline)
            overview.append(rrb.Vertical(
                rrb.BarChartView(origin=f"{SYNC_IRLS}/residual_ms", name="IRLS: |residual| per pair, ms (bars: iterations)",
                                 plot_legend=rrb.PlotLegend(visible=True)),
                rrb.BarChartView(origin=f"{SYNC_IRLS}/weight", name="IRLS: weight per pair (bars: iterations)",
                                 plot_legend=rrb.PlotLegend(visible=True)),
                name="IRLS solve"))
    if votes_logged:
        overview.append(_pairs_series("pairing votes (Stage 0, z per Δ)", votes_logged, pair_votes_path,
                                      ("z", "chosen"), range_ms))
    if people_logged:
        overview.append(_pairs_series("people shifts (Stage 0, evidence per Δ)", people_logged,
                                      lambda a, b: f"{pair_people_path(a, b)}/evidence", ("evidence", "chosen"),
                                      range_ms))
    if transfer_origin is not None:
        overview.append(rrb.TimeSeriesView(origin=transfer_origin, name="point transfer (Stage 0: a camera's offset)",
                                           time_ranges=_full_range(), plot_legend=rrb.PlotLegend(visible=True)))
    if three_view_origin is not None:
        overview.append(rrb.TimeSeriesView(origin=three_view_origin, name="three-view check (Stage 0: sure cameras)",
                                           time_ranges=_full_range(), plot_legend=rrb.PlotLegend(visible=True)))
    return overview


def _pairs_series(name: str, keys: list[str], path_of, parts: tuple[str, ...], range_ms: tuple[int, int] | None):
    """One plot of the series `parts` below path_of(a, b) of every pair "a__b" in keys, over the
    offsets searched."""
    import rerun.blueprint as rrb
    return rrb.TimeSeriesView(origin="/", contents=[f"+ /{path_of(*k.split('__', 1))}/{part}" for k in keys
                                                    for part in parts],
                              name=name, time_ranges=_full_range(), axis_x=_axis(range_ms),
                              plot_legend=rrb.PlotLegend(visible=True))


def _scene_views(video_names: list[str], sizes: dict[str, tuple[int, int]], eye: tuple | None, show_world: bool,
                 labels: dict[str, str], with_frames: set[str] | None) -> list:
    """The right column: a grid of the videos with frames and the 3D view (none of either: no
    column)."""
    import rerun.blueprint as rrb
    framed = [v for v in video_names if with_frames is None or v in with_frames]
    video_views = [rrb.Spatial2DView(origin=video_path(v), name=labels.get(v, v), visual_bounds=_bounds(sizes.get(v)))
                   for v in framed[:MAX_VIDEO_VIEWS]]
    world = [rrb.Spatial3DView(origin=WORLD, name="3D",
                               eye_controls=rrb.EyeControls3D(position=eye[0], look_target=eye[1], eye_up=eye[2])
                               if eye else None)] if show_world else []
    # no panel for what the recording does not hold: no video view without frames, no column
    # without videos and 3D (a run that wrote no frame and no camera)
    right = [rrb.Grid(*video_views, name="videos")] if video_views else []
    right += world
    return right
