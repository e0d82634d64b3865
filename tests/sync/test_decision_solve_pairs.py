import numpy as np
import pytest

from vs_inspect.sync.config import DecisionConfig, PairSelection
from vs_inspect.sync.decision import decide, local_minima
from vs_inspect.sync.pairs import select_pairs
from vs_inspect.sync.solve import PairMeasurement, huber_weights, linked_reference, solve_offsets

OFFS = np.linspace(-1, 1, 201)


def bowl(center, depth=1.0, width=0.05):
    return depth * np.exp(-((OFFS - center) / width) ** 2)


def test_single_clear_minimum_is_accepted():
    e = 1.0 - bowl(0.3, 0.8)
    dec, minima = decide(e, np.full(201, 1000), OFFS, 100, DecisionConfig())
    assert dec.accepted and OFFS[minima[0]] == pytest.approx(0.3)
    assert dec.contrast == pytest.approx(0.8, abs=0.01)


def test_two_equal_minima_are_ambiguous():
    e = 1.0 - bowl(-0.5, 0.8) - bowl(0.5, 0.78)
    dec, _ = decide(e, np.full(201, 1000), OFFS, 100, DecisionConfig())
    assert not dec.accepted and dec.reason.startswith("ambiguous")
    assert dec.second_depth_ratio == pytest.approx(0.78 / 0.8, abs=0.02)


def test_lowest_minimum_on_little_overlap_yields_to_a_better_supported_one():
    """A periodic motion matched again near the end of the range: the lowest dip rests on less
    than half the overlap of an almost equally deep one, which becomes the best."""
    e = 1.0 - bowl(-0.8, 0.8) - bowl(0.1, 0.78)
    support = np.round(2000 * (1 - np.abs(OFFS))).astype(int)  # overlap shrinks toward the edges
    dec, minima = decide(e, support, OFFS, 100, DecisionConfig())
    assert dec.accepted and OFFS[minima[0]] == pytest.approx(0.1)
    assert "-0.800 s" in dec.reason and "overlap" in dec.reason
    # the filter-off ablation keeps the lowest energy
    _, minima_off = decide(e, support, OFFS, 100, DecisionConfig(enabled=False))
    assert OFFS[minima_off[0]] == pytest.approx(-0.8)
    # with equal overlap the same landscape stays ambiguous
    dec_flat, _ = decide(e, np.full(201, 1000), OFFS, 100, DecisionConfig())
    assert not dec_flat.accepted and dec_flat.reason.startswith("ambiguous")


def test_flat_landscape_is_rejected():
    rng = np.random.default_rng(0)
    e = 1.0 + 0.02 * rng.normal(size=201)
    dec, _ = decide(e, np.full(201, 1000), OFFS, 100, DecisionConfig())
    assert not dec.accepted and dec.reason.startswith("flat")


def test_minimum_at_the_range_edge_is_rejected_and_filter_off_accepts():
    e = 1.0 - 0.8 * np.clip(-OFFS, 0, None)  # decreasing to the left border
    dec, _ = decide(e, np.full(201, 1000), OFFS, 100, DecisionConfig())
    assert not dec.accepted and "edge" in dec.reason and dec.at_range_edge
    dec_off, _ = decide(e, np.full(201, 1000), OFFS, 100, DecisionConfig(enabled=False))
    assert dec_off.accepted


def test_too_few_track_pairs():
    dec, _ = decide(1.0 - bowl(0.0), np.full(201, 10), OFFS, 3, DecisionConfig())
    assert not dec.accepted and "too few track pairs" in dec.reason


def test_local_minima_include_edges_and_sort_by_energy():
    e = np.array([0.1, 0.5, 0.9, 0.3, 0.9, 0.2])
    idx, prom = local_minima(e, 0.05)
    assert idx.tolist() == [0, 5, 3]
    assert np.allclose(prom, [0.8, 0.7, 0.6])


def test_huber_weights():
    assert np.allclose(huber_weights(np.array([0.0, 0.05, -0.2]), 0.1), [1.0, 1.0, 0.5])


def m(a, b, x, s=0.01):
    return PairMeasurement(a, b, x, s)


def test_irls_downweights_an_outlier_that_ls_follows():
    truth = {"v0": 0.0, "v1": 1.0, "v2": -0.5, "v3": 2.0}
    meas = [m(a, b, truth[b] - truth[a]) for a, b in
            [("v0", "v1"), ("v0", "v2"), ("v0", "v3"), ("v1", "v2"), ("v1", "v3"), ("v2", "v3")]]
    meas[5] = m("v2", "v3", truth["v3"] - truth["v2"] + 1.5)  # a wrong pair
    names = list(truth)
    irls = solve_offsets(names, "v0", meas, "irls", 0.02)
    ls = solve_offsets(names, "v0", meas, "ls")
    err_irls = max(abs(irls.offsets_s[v] - truth[v]) for v in names)
    err_ls = max(abs(ls.offsets_s[v] - truth[v]) for v in names)
    assert err_irls < 0.02 and err_ls > 0.1  # Huber keeps a small pull of size ~delta
    assert irls.iterations[-1].weight[5] < 0.05
    assert all(u is not None and u >= 0 for u in irls.uncertainty_s.values())


def test_video_between_contradicting_pairs_gets_null_not_a_compromise():
    # the caliscope case: a, b, e agree; c is tied to them only by two pairs 3 s apart and came
    # out between them (2 s off the truth); d hangs on c alone
    names = ["a", "b", "c", "d", "e"]
    meas = [m("a", "b", 0.5), m("a", "e", 1.0), m("b", "e", 0.5),
            m("a", "c", -5.0), m("b", "c", -2.5), m("c", "d", 0.2)]
    out = solve_offsets(names, "a", meas, "irls", 0.05)
    assert out.offsets_s["a"] == 0.0
    assert out.offsets_s["b"] == pytest.approx(0.5) and out.offsets_s["e"] == pytest.approx(1.0)
    assert out.offsets_s["c"] is None and out.offsets_s["d"] is None
    assert "contradict each other" in out.unresolved_reason["c"]
    assert "a__c" in out.unresolved_reason["c"] and "b__c" in out.unresolved_reason["c"]
    assert "only through c" in out.unresolved_reason["d"]
    assert out.pairs == (("a", "b"), ("a", "e"), ("b", "e"))  # the kept solve: agreeing pairs only
    # plain least squares (the ablation) keeps its compromise
    ls = solve_offsets(names, "a", meas, "ls")
    assert ls.offsets_s["c"] is not None and not ls.unresolved_reason


def test_agreeing_pairs_with_noise_are_not_a_contradiction():
    truth = {"a": 0.0, "b": 0.3, "c": -1.0}
    meas = [m("a", "b", 0.3 + 0.04), m("a", "c", -1.0 - 0.05), m("b", "c", -1.3 + 0.06)]
    out = solve_offsets(list(truth), "a", meas, "irls", 0.05)
    assert not out.unresolved_reason
    assert all(abs(out.offsets_s[v] - truth[v]) < 0.1 for v in truth)


def test_unconnected_video_gets_null_and_a_reason():
    out = solve_offsets(["a", "b", "c"], "a", [m("a", "b", 0.4)])
    assert out.offsets_s == {"a": 0.0, "b": pytest.approx(0.4), "c": None}
    assert "not connected" in out.unresolved_reason["c"]


def test_a_reference_no_accepted_pair_reaches_gives_way_to_the_largest_linked_group():
    names = ["a", "b", "c", "d", "e"]
    assert linked_reference(names, "a", [("a", "b"), ("c", "d")]) == "a"  # linked: kept
    assert linked_reference(names, "a", [("b", "c"), ("d", "e"), ("c", "e")]) == "b"
    assert linked_reference(names, "a", [("d", "e"), ("b", "c"), ("b", "d")]) == "b"
    assert linked_reference(names, "a", [("c", "d"), ("b", "e"), ("d", "e")]) == "b"  # first by name order
    assert linked_reference(names, "a", [("d", "e"), ("b", "c")]) == "b"  # a tie: the first video
    assert linked_reference(names, "c", [("d", "e"), ("a", "b"), ("a", "e")]) == "a"
    assert linked_reference(names, "a", []) == "a"  # nothing linked: nothing to move to


def test_reference_must_be_a_video():
    with pytest.raises(ValueError, match="reference"):
        solve_offsets(["a", "b"], "zz", [])


def test_pair_selection_modes():
    names = [f"v{i}" for i in range(8)]
    allp = select_pairs(names, set(), PairSelection("all"))
    assert len(allp) == 28
    matched = set(allp)
    rst = select_pairs(names, matched, PairSelection("rst", seed=1))
    assert len(rst) == 7  # a spanning tree
    from scipy.sparse.csgraph import connected_components
    from scipy.sparse import coo_matrix
    idx = {n: i for i, n in enumerate(names)}
    g = coo_matrix((np.ones(7), ([idx[a] for a, _ in rst], [idx[b] for _, b in rst])), shape=(8, 8))
    assert connected_components(g, directed=False)[0] == 1
    half = select_pairs(names, matched, PairSelection("fraction", 0.5, seed=1))
    assert len(half) == 14 and set(rst) <= set(half) | set(rst)
    assert select_pairs(names, matched, PairSelection("rst", seed=1)) == rst  # deterministic
    assert PairSelection.parse("0.8").fraction == 0.8
    with pytest.raises(ValueError):
        PairSelection.parse("2")


def _ring(n: int) -> dict:
    """n static cameras on a circle, each looking at the centre (viewing directions 360/n apart)."""
    from vs_inspect.geometry.epipolar import look_at
    from vs_inspect.types import CameraTrack
    K = np.array([[800.0, 0, 640], [0, 800, 360], [0, 0, 1]])
    return {f"v{i}": CameraTrack(K, look_at([9 * np.cos(2 * np.pi * i / n), 9 * np.sin(2 * np.pi * i / n), 2],
                                            [0, 0, 1])) for i in range(n)}


def test_knn_pairs_are_the_nearest_viewing_directions_and_stay_connected():
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    n = 16
    cams = _ring(n)
    names = list(cams)
    every = select_pairs(names, set(), PairSelection("all"))
    sel = PairSelection.parse("knn:2")
    assert (sel.mode, sel.k) == ("knn", 2)
    knn = select_pairs(names, set(every), sel, cams)
    # on a ring the two nearest viewing directions are the two neighbours: the ring's n edges
    ring = {tuple(sorted((f"v{i}", f"v{(i + 1) % n}"), key=names.index)) for i in range(n)}
    assert set(knn) == ring
    assert len(knn) <= n * sel.k + n - 1
    # with k=1 the nearest-neighbour graph falls apart; the spanning tree joins it again
    idx = {v: i for i, v in enumerate(names)}
    one = select_pairs(names, set(every), PairSelection.parse("knn:1"), cams)
    g = coo_matrix((np.ones(len(one)), ([idx[a] for a, _ in one], [idx[b] for _, b in one])), shape=(n, n))
    assert connected_components(g, directed=False)[0] == 1
    # pairs without track pairs are never spent on
    some = set(every) - {("v0", "v1")}
    assert ("v0", "v1") not in select_pairs(names, some, sel, cams)
    with pytest.raises(ValueError, match="needs the cameras"):
        select_pairs(names, set(every), sel)
    for bad in ("knn:0", "knn:x", "knn:"):
        with pytest.raises(ValueError, match="knn:K"):
            PairSelection.parse(bad)


def test_knn_on_a_large_rig_costs_n_times_k():
    from vs_inspect.bench.scale import rig_config
    from vs_inspect.synth.cues import make_cue_scene
    bundle = make_cue_scene(rig_config(64)).bundle
    has = {k for k, v in bundle.pairs.items() if len(v.index)}
    knn = select_pairs(bundle.names, has, PairSelection.parse("knn:4"), bundle.cameras)
    assert 64 * 2 <= len(knn) <= 64 * 4 + 63  # not 2016
