"""Stage 2 with drift: per-video offset and drift from pair time maps."""

from __future__ import annotations

import math

import pytest

from vs_inspect.sync.drift import PairTiming, solve_offsets_drift

OFFSETS = {"r": 0.0, "p": 2.5, "q": -7.25, "s": 11.0}
DRIFTS = {"r": 0.0, "p": 150e-6, "q": -300e-6, "s": 80e-6}


def _pair(a, b, bad=0.0):
    off = (OFFSETS[b] - OFFSETS[a]) / (1 + DRIFTS[a]) + bad
    return PairTiming(a, b, off, math.log((1 + DRIFTS[b]) / (1 + DRIFTS[a])), 1e-3, 1e-5)


def test_exact_pairs_give_the_time_models_back():
    names = list(OFFSETS)
    pairs = [_pair(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
    sol = solve_offsets_drift("r", pairs)
    for n in names:
        assert sol.offsets_s[n] == pytest.approx(OFFSETS[n], abs=1e-9)
        assert sol.drift_ppm[n] == pytest.approx(DRIFTS[n] * 1e6, abs=1e-6)


def test_one_wrong_pair_is_outvoted_and_constant_model_has_no_drift():
    names = list(OFFSETS)
    pairs = [_pair(a, b, bad=5.0 if (a, b) == ("p", "q") else 0.0)
             for i, a in enumerate(names) for b in names[i + 1:]]
    sol = solve_offsets_drift("r", pairs)
    for n in names:
        assert sol.offsets_s[n] == pytest.approx(OFFSETS[n], abs=0.01)
    assert abs(sol.pair_residuals[("p", "q")][0]) > 4.0
    # the solve's own Huber weights: the wrong pair (~5 s off, std 1 ms) down to 3 / 5000,
    # the others whole
    assert sol.pair_weights[("p", "q")] == pytest.approx(3.0 / (abs(sol.pair_residuals[("p", "q")][0]) / 1e-3))
    assert sol.pair_weights[("p", "q")] < 1e-3
    assert all(w == 1.0 for k, w in sol.pair_weights.items() if k != ("p", "q"))
    const = solve_offsets_drift("r", [_pair(a, b) for i, a in enumerate(names) for b in names[i + 1:]],
                                with_drift=False)
    assert set(const.drift_ppm.values()) == {0.0}
    assert const.offsets_s["q"] == pytest.approx(OFFSETS["q"], abs=0.01)


def test_unconnected_video_is_left_out():
    sol = solve_offsets_drift("r", [_pair("r", "p")])
    assert set(sol.offsets_s) == {"r", "p"}


def test_walk_from_the_reference_visits_neighbours_in_the_pairs_order():
    """The initial guess seeds videos in this order (a robust solve can depend on it): each
    video's neighbours in the order of the pairs, whatever the pair's direction or the names."""
    from vs_inspect.sync.drift import _connected
    pairs = [_pair(a, b) for a, b in (("r", "p"), ("s", "q"), ("r", "q"), ("s", "r"))]
    assert _connected("r", pairs) == ["r", "p", "q", "s"]
    assert _connected("q", pairs) == ["q", "s", "r", "p"]
    assert _connected("r", []) == ["r"]
    assert _connected("r", [_pair("p", "q")]) == ["r"]
