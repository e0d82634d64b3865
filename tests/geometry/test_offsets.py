"""The one candidate-offset grid (geometry/offsets.py): exact values of its bounds and grids."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vs_inspect.geometry.offsets import (MAX_CANDIDATE_OFFSETS, OffsetGrid, grid_around, grid_between,
                                         overlap_bounds, span_of)


def test_grid_between_is_the_multiples_of_the_step_inside_the_bounds():
    got = grid_between(-0.25, 0.31, 0.1)
    assert np.allclose(got, [-0.2, -0.1, 0.0, 0.1, 0.2, 0.3])
    assert got[2] == 0.0  # through 0 exactly: grids of one step share their points
    assert np.allclose(grid_between(0.2, 0.4, 0.1), [0.2, 0.3, 0.4])  # bounds on the grid are kept
    assert len(grid_between(1.0, 0.5, 0.1)) == 0
    assert len(grid_between(0.0, 1.0, math.inf)) == 0


def test_grid_between_refuses_too_many_candidates_before_allocating():
    with pytest.raises(ValueError, match="candidate offsets"):
        grid_between(-10.0, 10.0, 1e-12)
    assert len(grid_between(0.0, 1.0, 1.0 / (MAX_CANDIDATE_OFFSETS - 1))) == MAX_CANDIDATE_OFFSETS


def test_overlap_bounds_leave_the_least_common_time():
    # a spans 0..10 s, b 0..5 s: b moved by Δ into a's time spans Δ..Δ+5
    assert overlap_bounds((0.0, 10.0), (0.0, 5.0)) == (-5.0, 10.0)
    assert overlap_bounds((0.0, 10.0), (0.0, 5.0), 1.0) == (-4.0, 9.0)
    assert overlap_bounds((0.0, 5.0), (0.0, 10.0), 1.0) == (-9.0, 4.0)  # the pair the other way round
    lo, hi = overlap_bounds((0.0, 10.0), (0.0, 0.5), 1.0)  # b lasts less than the overlap asked for
    assert lo > hi and len(grid_between(lo, hi, 0.1)) == 0


def test_pair_bounds_honour_overlap_range_and_windows():
    span = (0.0, 10.0)
    free = OffsetGrid(min_overlap_s=1.0)
    assert free.pair_bounds("r", span, "v", span) == (-9.0, 9.0)
    assert OffsetGrid(1.0, range_s=3.0).pair_bounds("r", span, "v", span) == (-3.0, 3.0)
    # v's offset within 1..2 s of the reference r: Δ_rv = offset_v within 1..2, Δ_vr = -offset_v
    g = OffsetGrid(1.0, windows_s=(("v", 1.0, 2.0), ("u", -1.0, 0.0)), reference="r")
    assert g.pair_bounds("r", span, "v", span) == (1.0, 2.0)
    assert g.pair_bounds("v", span, "r", span) == (-2.0, -1.0)
    # two windowed videos: Δ_uv = offset_v - offset_u within 1 - 0 .. 2 - (-1)
    assert g.pair_window("u", "v") == (1.0, 3.0)
    assert g.pair_window("v", "u") == (-3.0, -1.0)
    # a video without a window leaves its pairs with other non-reference videos free
    assert g.pair_window("w", "v") is None
    assert g.pair_bounds("w", span, "v", span) == (-9.0, 9.0)
    assert g.pair_window("r", "w") is None
    # the range and the overlap still hold inside a window
    g2 = OffsetGrid(1.0, range_s=1.5, windows_s=(("v", 1.0, 20.0),), reference="r")
    assert g2.pair_bounds("r", span, "v", span) == (1.0, 1.5)
    g3 = OffsetGrid(1.0, windows_s=(("v", 5.0, 20.0),), reference="r")
    assert g3.pair_bounds("r", span, "v", span) == (5.0, 9.0)


def test_pair_offsets_is_the_grid_of_the_bounds():
    g = OffsetGrid(0.5, windows_s=(("v", 0.98, 1.31),), reference="r")
    got = g.pair_offsets("r", (0.0, 4.0), "v", (0.0, 3.0), 0.1)
    assert np.allclose(got, [1.0, 1.1, 1.2, 1.3])
    assert len(g.pair_offsets("r", (0.0, 4.0), "v", (0.0, 0.2), 0.1)) == 0  # no overlap inside the window


def test_grid_around_stays_within_its_bounds():
    assert np.allclose(grid_around(1.0, 0.2, 0.1), [0.8, 0.9, 1.0, 1.1, 1.2])
    assert np.allclose(grid_around(1.0, 0.2, 0.1, (0.95, 1.5)), [1.0, 1.1, 1.2])
    assert len(grid_around(math.nan, 0.2, 0.1)) == 0


def test_bad_grids_are_refused():
    with pytest.raises(ValueError, match="min_overlap_s"):
        OffsetGrid(min_overlap_s=-1.0)
    with pytest.raises(ValueError, match="range_s"):
        OffsetGrid(range_s=0.0)
    with pytest.raises(ValueError, match="lo <= hi"):
        OffsetGrid(windows_s=(("v", 2.0, 1.0),))
    with pytest.raises(ValueError, match="one window per video"):
        OffsetGrid(windows_s=(("v", 0.0, 1.0), ("v", 1.0, 2.0)))
    with pytest.raises(ValueError, match=r"\(T,\)"):
        span_of(np.zeros((2, 2)))
