"""The default layout: opens on offset_ms, paused, landscapes over the whole search range; one
container per pair with failed pairs first and at most MAX_PAIR_CONTAINERS of them; only views
that have data."""

from __future__ import annotations

import math

import numpy as np

from vs_inspect.record.blueprint import MAX_PAIR_CONTAINERS, blueprint, pair_order, shown_pairs
from vs_inspect.result_types import PairDecision, PairLandscape, SyncResult


def _pair(a, b, accepted, contrast, tracks):
    return PairLandscape(a, b, np.zeros(3), np.ones(3), np.ones(3, int), np.array([0]), 0.1, 1.0,
                         0.01, tracks, PairDecision(accepted, "why", contrast, 0.1, 1, 1, False))


def _views(container) -> list:
    import rerun.blueprint as rrb
    out = []
    for c in container.contents:
        out += _views(c) if isinstance(c, rrb.Container) else [c]
    return out


def test_pair_order_failed_first_then_least_clear():
    pairs = [_pair("a", "b", True, 0.9, 50), _pair("a", "c", False, 0.5, 10),
             _pair("b", "c", True, 0.3, 50), _pair("a", "d", False, math.nan, 80)]
    got = [(p.a, p.b) for p in pair_order(pairs)]
    assert got == [("a", "d"), ("a", "c"), ("b", "c"), ("a", "b")]


def test_blueprint_opens_on_offsets_with_capped_containers():
    names = [f"v{i}" for i in range(7)]
    pairs = tuple(_pair(a, b, (i % 3) != 0, 0.1 * (i % 7), 20 + i)
                  for i, (a, b) in enumerate((a, b) for k, a in enumerate(names) for b in names[k + 1:]))
    assert len(pairs) == 21 > MAX_PAIR_CONTAINERS
    result = SyncResult("v0", dict.fromkeys(names, 0.0), {}, {}, pairs, (), ())
    views = {f"{p.a}__{p.b}": {"landscape", "epipolar"} for p in pairs}
    views["v0__v1"] = set()  # no finite energy and no epipolar view: the decision text alone
    bp = blueprint(names, list(views), result, views, has_loops=True, range_ms=(-1500, 1500),
                   sizes={n: (640, 480) for n in names})
    assert bp.time_panel.timeline == "offset_ms" and str(bp.time_panel.play_state).lower().endswith("paused")
    left, middle, right = bp.root_container.contents
    shown = shown_pairs(list(views), result)
    assert len(middle.contents) == MAX_PAIR_CONTAINERS == len(shown)
    assert [c.name for c in middle.contents] == [f"{'✓' if acc else '✗'} {a}→{b}" for a, b, acc in shown]
    n_failed = sum(not p.decision.accepted for p in pairs)
    assert all(not acc for _, _, acc in shown[:n_failed])  # failed pairs first
    for c, (a, b, _) in zip(middle.contents, shown):
        kinds = [type(v).__name__ for v in _views(c)]
        if f"{a}__{b}" == "v0__v1":
            assert kinds == ["TextDocumentView"]
        else:
            assert kinds == ["TimeSeriesView", "Spatial2DView", "TextDocumentView"]
    left_names = [v.name for v in _views(left)]
    assert left_names[0] == "how to read this recording" and "loop closure" in left_names
    assert "all landscapes" in left_names and "pair graph" in left_names
    assert [v.name for v in _views(right)] == names[:8][: len(names)] + ["3D"]


def test_point_transfer_view_only_when_a_check_was_logged():
    result = SyncResult("a", {"a": 0.0, "b": 0.0}, {}, {}, (), (), ())
    for origin in (None, "cues/transfer"):
        left = blueprint(["a", "b"], [], result, {}, transfer_origin=origin).root_container.contents[0]
        got = [v for v in _views(left) if v.name.startswith("point transfer")]
        assert len(got) == (origin is not None)
        if origin:
            assert str(got[0].origin).strip("/") == "cues/transfer"


def test_people_views_only_when_the_people_cue_ran():
    result = SyncResult("a", {"a": 0.0, "b": 0.0}, {}, {}, (), (), ())
    for logged in (None, [], ["a__b"]):
        left = blueprint(["a", "b"], [], result, {}, people_logged=logged).root_container.contents[0]
        names = [v.name for v in _views(left)]
        assert ("people (Stage 0)" in names) == (logged is not None)
        shifts = [v for v in _views(left) if v.name.startswith("people shifts")]
        assert len(shifts) == bool(logged)
        if logged:
            assert "pairs/a__b/people/evidence/evidence" in str(shifts[0].contents)


def test_a_run_that_searched_no_pair_opens_on_frames_and_its_offsets_table():
    """Stage 0 could use no video: no SyncResult and no pair, so no offset_ms
    timeline; the layout still shows the run's offsets table (why each video is null), in front,
    and opens on the frame timeline, on which the videos were logged."""
    import rerun.blueprint as rrb

    bp = blueprint(["a", "b"], [], None, {}, timeline="frame", offsets_logged=True, show_world=False)
    assert bp.time_panel.timeline == "frame"
    left = bp.root_container.contents[0]
    tabs = left.contents[0]
    assert isinstance(tabs, rrb.Tabs)
    names = [v.name for v in tabs.contents]
    assert names == ["how to read this recording", "offsets", "decision log"]
    assert tabs.active_tab == names.index("offsets")
    # a run with pairs keeps the guide in front, and no offsets table is shown without one logged
    result = SyncResult("a", {"a": 0.0, "b": 0.1}, {}, {}, (), (), ())
    tabs = blueprint(["a", "b"], ["a__b"], result, {}, offsets_logged=True).root_container.contents[0].contents[0]
    assert tabs.active_tab == 0 and "offsets" in [v.name for v in tabs.contents]
    tabs = blueprint(["a", "b"], [], None, {}).root_container.contents[0].contents[0]
    assert "offsets" not in [v.name for v in tabs.contents]


def test_the_robust_solve_gets_a_tab_only_when_its_pairs_hold_a_loop():
    """Residuals and weights say something only when the accepted pairs hold a loop (a tree of
    pairs is solved exactly: 0 and 1 everywhere, an empty-looking tab)."""
    from vs_inspect.record.blueprint import _redundant
    assert not _redundant([("a", "b")]) and not _redundant([("a", "b"), ("b", "c"), ("d", "e")])
    assert _redundant([("a", "b"), ("b", "c"), ("a", "c")])
    assert _redundant([("a", "b"), ("c", "d"), ("d", "e"), ("c", "e")])
