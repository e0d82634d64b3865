"""The views a recording shows beyond the stages' results: which candidate offsets get an
epipolar view, which tracks are logged, where the pair graph's nodes sit, the truth and errors,
and the trajectories; computed only from the bundle, the result and RecordOptions."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vs_inspect.analysis.record_views import (GRAPH_PAIR_AT, GRAPH_RADIUS_PX, graph_layout,
                                              pair_record_view, run_record_view, sweep_offsets,
                                              track_rows, triangle_residuals)
from vs_inspect.eval.metrics import offset_errors_ms
from vs_inspect.analysis.record_options import RecordOptions
from vs_inspect.sync.config import SyncConfig
from vs_inspect.pipeline.stage12 import sync_bundle
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.result_types import PairDecision, PairLandscape, SyncResult


def _land(offsets_s: np.ndarray, minima_idx: list[int], best_offset_s: float) -> PairLandscape:
    D = len(offsets_s)
    return PairLandscape("a", "b", offsets_s, np.ones(D), np.ones(D, int), np.array(minima_idx),
                         best_offset_s, 1.0, 0.01, 10, PairDecision(True, "ok", 0.5, 0.1, 1, 1, False))


def test_sweep_offsets_spread_minima_and_a_run_around_the_chosen_offset():
    off = np.round(np.arange(-10, 11) * 0.1, 10)  # 21 candidates
    land = _land(off, [12, 3], 0.23)
    # spread {0, 20}, minima {12, 3}, the 3 candidates around 0.2 s, then the chosen Δ itself
    np.testing.assert_allclose(sweep_offsets(land, 5), [-1.0, -0.7, 0.1, 0.2, 0.23, 0.3, 1.0])
    np.testing.assert_array_equal(sweep_offsets(land, -1), off)  # all
    np.testing.assert_array_equal(sweep_offsets(land, 21), off)  # no more than there are
    no_best = _land(off, [], float("nan"))
    np.testing.assert_allclose(sweep_offsets(no_best, 6), [-1.0, 0.0, 1.0])  # the spread alone (6 // 2)


@pytest.fixture(scope="module")
def synced():
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=4.0,
                                          points_per_object=10, pairs_per_view_pair=80,
                                          no_match_pairs=0, all_wrong_pair=False, seed=2))
    return scene.bundle, sync_bundle(scene.bundle, SyncConfig(), progress=False)


def test_graph_layout_circle_and_pair_nodes_on_their_chords(synced):
    _, result = synced
    xy = graph_layout(result)
    names = list(result.offsets_s)
    assert xy[names[0]] == pytest.approx((GRAPH_RADIUS_PX, 0.0))
    for v in names:
        assert np.hypot(*xy[v]) == pytest.approx(GRAPH_RADIUS_PX)
    t = GRAPH_PAIR_AT
    for p in result.pairs:
        node = xy[f"{p.a}__{p.b}"]
        assert node == pytest.approx((xy[p.a][0] + t * (xy[p.b][0] - xy[p.a][0]),
                                      xy[p.a][1] + t * (xy[p.b][1] - xy[p.a][1])))


def test_graph_layout_pair_nodes_do_not_meet_at_the_centre():
    """Four videos: the two diagonals cross at the centre, where halfway nodes (and their labels)
    would lie on top of each other."""
    names = ["v0", "v1", "v2", "v3"]
    pairs = tuple(_land(np.zeros(3), [], 0.0) for _ in range(2))
    pairs = (replace(pairs[0], a="v0", b="v2"), replace(pairs[1], a="v1", b="v3"))
    result = SyncResult("v0", {n: 0.0 for n in names}, {}, {}, pairs, (), ())
    xy = graph_layout(result)
    d = np.subtract(xy["v0__v2"], xy["v1__v3"])
    assert np.hypot(*d) > 0.25 * GRAPH_RADIUS_PX


def test_triangle_residuals_close_loops_and_name_the_wrong_pair():
    """Δ_ab + Δ_bc − Δ_ac per triangle, either direction of a pair (Δ_ba = −Δ_ab); a wrong pair
    shows in every triangle it is part of, largest first."""
    true = {"a": 0.0, "b": 1.0, "c": 2.5, "d": -0.5}
    wrong = ("b", "d")

    def pair(x, y, off):
        return replace(_land(np.zeros(3), [], off), a=x, b=y)
    pairs = [pair("a", "b", 1.0), pair("c", "b", -1.5), pair("a", "c", 2.5), pair("a", "d", -0.5),
             pair("b", "d", -1.5 + 0.2), pair("c", "d", -3.0)]
    pairs.append(replace(pair("b", "c", float("nan")), decision=PairDecision(False, "x", 0, 0, 0, 0, False)))
    result = SyncResult("a", dict.fromkeys(true, 0.0), {}, {}, tuple(pairs), (), ())
    tri = triangle_residuals(result)
    assert {(t.a, t.b, t.c) for t in tri} == {("a", "b", "c"), ("a", "b", "d"), ("a", "c", "d"), ("b", "c", "d")}
    by = {(t.a, t.b, t.c): t.residual_ms for t in tri}
    assert by[("a", "b", "c")] == pytest.approx(0.0, abs=1e-9)  # (c,b) used reversed; (b,c) has no Δ
    assert by[("a", "c", "d")] == pytest.approx(0.0, abs=1e-9)
    assert by[("a", "b", "d")] == pytest.approx(200.0)  # Δ_ab + Δ_bd − Δ_ad = 1 − 1.3 + 0.5 (s)
    assert by[("b", "c", "d")] == pytest.approx(-200.0)  # Δ_bc + Δ_cd − Δ_bd = 1.5 − 3 + 1.3
    assert {(t.a, t.b, t.c) for t in tri[:2]} == {("a", "b", "d"), ("b", "c", "d")}  # both hold b-d
    assert all(wrong[0] in (t.a, t.b, t.c) and wrong[1] in (t.a, t.b, t.c) for t in tri[:2])
    # inspect's verdict: the two triangles through the wrong pair miss, the others close
    assert [t.closes for t in tri] == [False, False, True, True]
    assert all(0 < t.tolerance_ms < 200.0 for t in tri)


def test_track_rows_prefer_paired_tracks(synced):
    bundle, _ = synced
    name = bundle.names[0]
    n = bundle.tracks[name].num_tracks
    np.testing.assert_array_equal(track_rows(bundle, name, -1), np.arange(n))
    np.testing.assert_array_equal(track_rows(bundle, name, n), np.arange(n))
    used = set()
    for (a, b), tp in bundle.pairs.items():
        used |= set(tp.index[:, 0]) if a == name else set(tp.index[:, 1]) if b == name else set()
    k = min(5, len(used))
    rows = track_rows(bundle, name, k)
    assert len(rows) == k and np.all(np.diff(rows) > 0)
    assert set(rows.tolist()) <= used  # paired tracks first
    np.testing.assert_array_equal(rows, track_rows(bundle, name, k))  # seeded: the same each time


def test_pair_view_truth_and_sweep(synced):
    bundle, result = synced
    land = next(p for p in result.pairs if np.isfinite(p.best_offset_s))
    gt = bundle.gt_offsets_s
    view = pair_record_view(bundle, land, RecordOptions())
    assert view.true_offset_s == gt[land.b] - gt[land.a]
    ok = np.isfinite(land.energy)
    assert view.true_energy == float(np.interp(view.true_offset_s, land.offsets_s[ok], land.energy[ok]))
    np.testing.assert_array_equal(view.sweep.offsets_s, sweep_offsets(land, RecordOptions().epipolar_offsets))
    assert view.sweep.points_a.shape[0] <= RecordOptions().epipolar_lines
    for d, row in enumerate(view.sweep.distance_px):
        want = np.nanmedian(row) if np.isfinite(row).any() else np.nan
        np.testing.assert_equal(view.sweep_median_px[d], want)
    off = pair_record_view(bundle, land, RecordOptions.minimal())
    assert off.sweep is None and off.sweep_median_px.size == 0
    assert off.true_offset_s == view.true_offset_s
    assert pair_record_view(replace(bundle, gt_offsets_s=None), land, RecordOptions()).true_energy is None


def test_run_view_errors_tracks_and_trajectories(synced):
    bundle, result = synced
    view = run_record_view(bundle, result, RecordOptions(max_tracks_per_video=7))
    assert view.errors_ms == offset_errors_ms(result.offsets_s, bundle.gt_offsets_s, result.reference)
    ref_true = bundle.gt_offsets_s[result.reference]
    assert view.true_offsets_s == {v: bundle.gt_offsets_s[v] - ref_true for v in result.offsets_s}
    assert set(view.tracks) == set(bundle.names)
    for name, tv in view.tracks.items():
        rows = track_rows(bundle, name, 7)
        np.testing.assert_array_equal(tv.xy, bundle.tracks[name].xy[rows])
        assert tv.instance.shape == (len(rows),)
    accepted = [p for p in result.pairs if p.decision.accepted]
    assert len(view.trajectories) == len(accepted) > 0
    assert [(t.a, t.b) for t in view.trajectories] == \
        [(p.a, p.b) for p in sorted(accepted, key=lambda p: -p.decision.contrast)]
    minimal = run_record_view(bundle, result, RecordOptions.minimal())
    assert minimal.tracks == {} and minimal.trajectories == ()
