"""Colours from instance ids and point-to-line distances."""

from __future__ import annotations

import numpy as np

from vs_inspect import palette
from vs_inspect.analysis.colours import GREY, MIN_RAMP_PX, PALETTE, distance_colors, distance_ramp_px, instance_colors


def test_instance_colours_wrap_the_palette_and_grey_out_unknown_ids():
    got = instance_colors([0, 1, -1, len(PALETTE) + 1])
    assert got.dtype == np.uint8 and got.shape == (4, 3)
    assert [tuple(c) for c in got] == [palette.instance_colour(0), palette.instance_colour(1), GREY,
                                       palette.instance_colour(1)]


def test_distance_colours_run_from_on_line_to_far_and_grey_for_nan():
    got = distance_colors(np.array([[0.0, 20.0], [10.0, np.nan]]), 10.0)
    assert got.shape == (2, 2, 3)
    assert tuple(got[0, 0]) == palette.ON_LINE
    assert tuple(got[0, 1]) == tuple(got[1, 0]) == palette.FAR  # at the scale and beyond
    assert tuple(got[1, 1]) == GREY


def test_the_ramp_spans_the_median_finite_distance_and_at_least_a_pixel():
    assert distance_ramp_px(np.array([[np.nan, 2.0], [4.0, 10.0]])) == 4.0
    assert distance_ramp_px(np.array([0.1, 0.2, 0.3])) == MIN_RAMP_PX
    assert distance_ramp_px(np.full((2, 3), np.nan)) == MIN_RAMP_PX
