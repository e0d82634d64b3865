"""Weak evidence is refused with a reason even when the landscape's shape looks clear."""

import numpy as np
import pytest

from vs_inspect.sync import decision as decision_mod
from vs_inspect.sync.config import DecisionConfig
from vs_inspect.sync.decision import (check_chosen_offset, check_track_pairs_at_best, check_uncertainty, decide,
                                      support_fraction)
from vs_inspect.result_types import PairDecision

OFFS = np.linspace(-1, 1, 201)


def bowl(center, depth=0.8, width=0.05):
    return 1.0 - depth * np.exp(-((OFFS - center) / width) ** 2)


def test_minimum_on_a_small_share_of_the_usual_overlap_is_refused():
    """A clear dip where only 12 % of the usual (track pair, frame) terms overlap."""
    support = np.full(201, 1000)
    support[125] = 120  # the dip at +0.25 s
    dec, minima = decide(bowl(0.25), support, OFFS, 100, DecisionConfig())
    assert OFFS[minima[0]] == pytest.approx(0.25)
    assert not dec.accepted
    assert dec.reason == ("minimum at +0.250 s supported by 12% of the landscape's usual overlap "
                          "(120 of a median 1000 (track pair, frame) terms; fewer than 40%): a mean "
                          "over few terms dips by chance")
    assert dec.support_fraction == pytest.approx(0.12)


def test_the_usual_overlap_is_the_median_over_offsets_with_an_energy():
    """Offsets without an energy (too few terms) do not lower the usual overlap."""
    e = bowl(0.5)
    e[:100] = np.nan
    support = np.full(201, 1000)
    support[:100] = 5
    share, usual = support_fraction(support, e, 150)
    assert usual == 1000 and share == pytest.approx(1.0)
    dec, _ = decide(e, support, OFFS, 100, DecisionConfig())
    assert dec.accepted, dec.reason


def test_minimum_with_its_usual_overlap_or_more_stays_accepted():
    support = np.round(1000 * (1.2 - np.abs(OFFS))).astype(int)  # overlap shrinks toward the edges
    dec, _ = decide(bowl(-0.6), support, OFFS, 100, DecisionConfig())
    # 600 terms at -0.6 s against a median of 700: 86 %
    assert dec.accepted and dec.reason.startswith("single clear minimum"), dec.reason
    assert dec.support_fraction == pytest.approx(600 / 700, abs=0.01)


def test_support_share_at_the_threshold_is_accepted_and_the_filter_off_accepts_all(monkeypatch):
    support = np.full(201, 1000)
    support[125] = 400
    assert decide(bowl(0.25), support, OFFS, 100, DecisionConfig())[0].accepted
    support[125] = 399
    assert not decide(bowl(0.25), support, OFFS, 100, DecisionConfig())[0].accepted
    assert decide(bowl(0.25), support, OFFS, 100, DecisionConfig(enabled=False))[0].accepted
    monkeypatch.setattr(decision_mod, "MIN_SUPPORT_FRACTION", 0.3)
    assert decide(bowl(0.25), support, OFFS, 100, DecisionConfig())[0].accepted


def test_few_track_pairs_in_all_is_refused_with_the_count():
    dec, minima = decide(bowl(0.0), np.full(201, 1000), OFFS, 6, DecisionConfig())
    assert not dec.accepted and len(minima) == 0
    assert dec.reason == "too few track pairs: only 6 (fewer than 8)"


ACCEPTED = PairDecision(True, "single clear minimum (contrast 0.80, rival/best prominence 0.00)",
                        0.8, 0.0, 1, 1, False)


def test_few_track_pairs_seen_at_the_best_offset_is_refused():
    dec = check_track_pairs_at_best(ACCEPTED, 6, 0.25, DecisionConfig())
    assert not dec.accepted and dec.track_pairs_at_best == 6
    assert dec.reason == ("only 6 track pairs seen at the best offset +0.250 s (fewer than 8): too "
                          "little evidence for an offset")


def test_enough_track_pairs_at_the_best_offset_keeps_the_decision():
    dec = check_track_pairs_at_best(ACCEPTED, 8, 0.25, DecisionConfig())
    assert dec.accepted and dec.reason == ACCEPTED.reason and dec.track_pairs_at_best == 8
    # a pair refused for another reason keeps that reason; the filter off accepts
    refused = PairDecision(False, "flat landscape", 0.1, 0.0, 1, 1, False)
    assert check_track_pairs_at_best(refused, 2, 0.0, DecisionConfig()).reason == "flat landscape"
    assert check_track_pairs_at_best(ACCEPTED, 2, 0.0, DecisionConfig(enabled=False)).accepted


def test_a_minimum_wider_than_a_frame_is_refused_with_its_width():
    """1-sigma 50 ms at 30 fps is 1.5 frames: refused, whatever the shape said; 30 ms (0.9 frame)
    stays accepted, and so does a minimum whose curvature is unknown (NaN)."""
    ok = PairDecision(True, "single clear minimum", 0.8, 0.0, 1, 1, False)
    frame = 1 / 30
    wide = check_uncertainty(ok, 0.050, -1.604, frame, DecisionConfig())
    assert not wide.accepted
    assert wide.reason == ("its minimum at -1.604 s is too wide to time the pair: 1-sigma 50 ms, 1.5 frames "
                           "of the coarser video (more than 1)")
    assert check_uncertainty(ok, 0.030, 0.0, frame, DecisionConfig()) == ok
    assert check_uncertainty(ok, float("nan"), 0.0, frame, DecisionConfig()) == ok
    # the filter off, the check off (0) or a looser bound keep it; a rejection keeps its own reason
    assert check_uncertainty(ok, 0.050, 0.0, frame, DecisionConfig(enabled=False)).accepted
    assert check_uncertainty(ok, 0.050, 0.0, frame, DecisionConfig(max_uncertainty_frames=0)).accepted
    assert check_uncertainty(ok, 0.050, 0.0, frame, DecisionConfig(max_uncertainty_frames=2)).accepted
    no = PairDecision(False, "ambiguous", 0.8, 0.9, 3, 3, False)
    assert check_uncertainty(no, 0.050, 0.0, frame, DecisionConfig()) == no


def test_a_minimum_far_from_the_delta_its_track_pairs_were_chosen_at_is_refused():
    """Track pairs kept at Δ -0.517 s (consistent with the cameras there) whose minimum is at
    -0.633 s, 3.5 frames away at 30 fps: refused; 1.5 frames away, or no such Δ, stays accepted."""
    ok = PairDecision(True, "single clear minimum", 0.8, 0.0, 1, 1, False)
    frame = 1 / 30
    far = check_chosen_offset(ok, -0.6333, -0.5167, frame, DecisionConfig())
    assert not far.accepted
    assert far.reason == ("its minimum at -0.633 s lies 3.5 frames from the Δ -0.517 s at which Stage 0 kept its "
                          "track pairs (more than 2): each was consistent with the cameras there, so the track "
                          "pairs and the cameras disagree")
    assert check_chosen_offset(ok, -0.5667, -0.5167, frame, DecisionConfig()) == ok
    assert check_chosen_offset(ok, -0.6333, None, frame, DecisionConfig()) == ok
    # the filter off, the check off (0) or a looser bound keep it; a rejection keeps its own reason
    assert check_chosen_offset(ok, -0.6333, -0.5167, frame, DecisionConfig(enabled=False)).accepted
    assert check_chosen_offset(ok, -0.6333, -0.5167, frame, DecisionConfig(chosen_agree_frames=0)).accepted
    assert check_chosen_offset(ok, -0.6333, -0.5167, frame, DecisionConfig(chosen_agree_frames=4)).accepted
    no = PairDecision(False, "ambiguous", 0.8, 0.9, 3, 3, False)
    assert check_chosen_offset(no, -0.6333, -0.5167, frame, DecisionConfig()) == no
