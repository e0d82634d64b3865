"""decide(allowed): an --around window holds the choice of the minimum; the landscape's median and
range stay the whole landscape's, and minima outside the window are no rivals."""

from __future__ import annotations

import numpy as np

from vs_inspect.sync.config import DecisionConfig
from vs_inspect.sync.decision import decide

OFFSETS = np.linspace(-3.0, 3.0, 121)  # 0.05 s apart


def two_minima(deep_at: float = 1.5, shallow_at: float = -1.0) -> np.ndarray:
    """Energy 1 with a dip to 0.1 at deep_at and to 0.4 at shallow_at (Gaussian, 0.1 s wide)."""
    return (1.0 - 0.9 * np.exp(-((OFFSETS - deep_at) / 0.1) ** 2)
            - 0.6 * np.exp(-((OFFSETS - shallow_at) / 0.1) ** 2))


def test_without_a_window_the_deepest_minimum_wins_over_its_rival():
    e = two_minima()
    d, minima = decide(e, np.full(len(e), 1000), OFFSETS, 50, DecisionConfig())
    assert OFFSETS[minima[0]] == np.float64(OFFSETS[np.argmin(e)])
    assert abs(OFFSETS[minima[0]] - 1.5) < 1e-9 and d.second_depth_ratio > 0.5


def test_a_window_takes_its_own_minimum_and_the_other_is_no_rival():
    e = two_minima()
    allowed = (OFFSETS >= -1.5) & (OFFSETS <= -0.5)
    d, minima = decide(e, np.full(len(e), 1000), OFFSETS, 50, DecisionConfig(), allowed)
    assert abs(OFFSETS[minima[0]] - (-1.0)) < 1e-9
    assert d.accepted, d.reason
    assert d.second_depth_ratio == 0.0  # the deeper minimum outside the window does not compete
    # the contrast is read against the whole landscape's median (1.0), not the window's
    assert abs(d.contrast - 0.6) < 0.01


def test_a_window_without_a_minimum_is_refused():
    e = two_minima()
    allowed = (OFFSETS >= 0.2) & (OFFSETS <= 0.8)  # the energy is flat there: no local minimum
    d, minima = decide(e, np.full(len(e), 1000), OFFSETS, 50, DecisionConfig(), allowed)
    assert not d.accepted and "within the --around window" in d.reason and len(minima) == 0
