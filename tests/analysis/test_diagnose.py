"""The diagnosis of a run from its RunResult alone: pair disagreements with their tolerance, and
the suspects it names (a wrong pair between videos that agree elsewhere, an unresolved video)."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.analysis.diagnose import DEFAULT_FRAME_MS, check_pairs, find_suspects
from vs_inspect.io.recording import RecordedVideo
from vs_inspect.result_types import PairDecision, PairLandscape, RunResult
from vs_inspect.types import VideoInfo

TRUE_S = {"A": 0.0, "B": 1.0, "C": 2.0, "D": 3.0}
WRONG_DELTA_S = 1.5  # C__D's own Δ, 0.5 s from the solution's 1.0 s


def _pair(a: str, b: str, delta_s: float, accepted: bool = True, uncertainty_s: float = float("nan"),
          reason: str = "single clear minimum") -> PairLandscape:
    offsets = np.linspace(-4.0, 4.0, 81)
    energy = np.abs(offsets - delta_s) + 1.0
    i = int(np.argmin(energy))
    return PairLandscape(a, b, offsets, energy, np.full(81, 10), np.array([i]), delta_s, 1.0,
                         uncertainty_s, 50, PairDecision(accepted, reason, 0.5, 0.1, 1, 1, False))


def _result(cd_uncertainty_s: float = float("nan")) -> RunResult:
    pairs = tuple(_pair(a, b, TRUE_S[b] - TRUE_S[a]) for a, b in
                  (("A", "B"), ("B", "C"), ("A", "C"), ("A", "D"), ("B", "D")))
    pairs += (_pair("C", "D", WRONG_DELTA_S, uncertainty_s=cd_uncertainty_s),)
    offsets = {**TRUE_S, "E": None}
    return RunResult("A", offsets, {v: None for v in offsets}, {"E": "no accepted pair connects it"},
                     pairs, "irls", tuple((p.a, p.b) for p in pairs), (), {})


def test_check_pairs_orders_by_disagreement_with_frame_tolerance():
    videos = [RecordedVideo(n, n, 640, 480, 100, 25.0, 3.96) for n in TRUE_S]
    checks = check_pairs(_result(), videos)
    first = checks[0]
    assert (first.a, first.b) == ("C", "D")
    assert first.offset_s == WRONG_DELTA_S and first.solution_s == 1.0
    assert first.disagreement_ms == pytest.approx(500.0, abs=1e-9)
    assert first.tolerance_ms == pytest.approx(80.0)  # two frames at 25 fps
    assert first.bad and first.accepted
    assert all(not c.bad and c.disagreement_ms == pytest.approx(0.0, abs=1e-9) for c in checks[1:])


def test_tolerance_from_uncertainty_and_default_clock():
    # without clocks: the default frame interval; a 0.2 s uncertainty widens C__D's tolerance to 600 ms
    cd = check_pairs(_result(cd_uncertainty_s=0.2))[0]
    assert cd.tolerance_ms == pytest.approx(600.0)
    assert not cd.bad
    plain = check_pairs(_result())[0]
    assert plain.tolerance_ms == pytest.approx(2 * DEFAULT_FRAME_MS)


def test_video_info_and_recorded_video_give_the_same_tolerance():
    infos = [VideoInfo.constant_rate(n, 640, 480, 100, 50.0) for n in TRUE_S]
    recorded = [RecordedVideo(n, n, 640, 480, 100, None, 99 / 50.0) for n in TRUE_S]  # variable rate
    a, b = check_pairs(_result(), infos)[0], check_pairs(_result(), recorded)[0]
    assert a.tolerance_ms == pytest.approx(40.0) and b.tolerance_ms == pytest.approx(40.0)


def test_suspects_name_the_wrong_pair_and_the_unresolved_video():
    suspects = find_suspects(_result())
    kinds = {(s.kind, s.name) for s in suspects}
    assert kinds == {("pair", "C__D"), ("video", "E")}
    cd = next(s for s in suspects if s.name == "C__D")
    assert "accepted at Δ=+1.5000 s but the solution says +1.0000 s (500 ms apart" in cd.message
    e = next(s for s in suspects if s.name == "E")
    assert e.message == "E: not synchronized (no accepted pair connects it)"


def test_a_video_whose_pairs_mostly_fail_is_named():
    r = _result()
    # every pair with D is rejected: D is the suspect, not its pairs
    pairs = tuple(_pair(p.a, p.b, p.best_offset_s, accepted="D" not in (p.a, p.b),
                        reason="flat landscape") for p in r.pairs)
    r = RunResult(r.reference, r.offsets_s, r.uncertainty_s, r.unresolved, pairs, r.solver,
                  r.solve_pairs, r.iterations, r.timings_s)
    suspects = find_suspects(r)
    names = {(s.kind, s.name) for s in suspects}
    assert ("video", "D") in names
    assert not any(s.kind == "pair" and "D" in s.name for s in suspects)
    d = next(s for s in suspects if s.name == "D")
    assert "3 of 3 pairs fail (3 rejected, 0 inconsistent" in d.message


# ---- planted failures: every one named with its cause, no innocent video accused -------------

FIVE_S = {"A": 0.0, "B": 0.4, "C": -0.7, "D": 1.1, "E": 0.2}
INLIERS = "few epipolar inliers at the best offset: 20% of observations within 20.0 px (< 45%)"


def _pl(a: str, b: str, delta_s: float, accepted: bool, reason: str, track_pairs: int = 150,
        uncertainty_s: float = float("nan")) -> PairLandscape:
    offsets = np.linspace(-4.0, 4.0, 81)
    energy = np.abs(offsets - delta_s) + 1.0 if np.isfinite(delta_s) else np.full(81, np.nan)
    idx = np.array([int(np.argmin(energy))]) if np.isfinite(delta_s) else np.zeros(0, int)
    return PairLandscape(a, b, offsets, energy, np.full(81, 10), idx, delta_s, 1.0, uncertainty_s,
                         track_pairs, PairDecision(accepted, reason, 0.5, 0.1, 1, 1, False))


def _planted() -> RunResult:
    """A (the reference) is innocent; B has a wrong pose (its pairs miss the epipolar lines but
    their minima are right), E is blind (no cross-view track pairs), A__C has all-wrong matches
    (a minimum 2.5 s off); C__D is rejected only cautiously (its minimum is right)."""
    pairs = []
    names = sorted(FIVE_S)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            true = FIVE_S[b] - FIVE_S[a]
            if "E" in (a, b):
                pairs.append(_pl(a, b, float("nan"), False, "no cross-view track pairs (the views "
                                 "share no matched motion)", track_pairs=0))
            elif "B" in (a, b):
                pairs.append(_pl(a, b, true + 0.01, False, INLIERS))
            elif (a, b) == ("A", "C"):
                pairs.append(_pl(a, b, true + 2.5, False, "flat landscape: best energy only 12% below "
                                 "the median (< 30%)"))
            elif (a, b) == ("C", "D"):
                pairs.append(_pl(a, b, true + 0.005, False, INLIERS))
            else:
                pairs.append(_pl(a, b, true, True, "single clear minimum"))
    offsets = {"A": 0.0, "B": None, "C": -0.7, "D": 1.1, "E": None}
    return RunResult("A", offsets, {v: None for v in offsets}, {"B": "x", "E": "y"}, tuple(pairs),
                     "irls", (), (), {})


def test_planted_failures_are_named_with_their_cause_and_no_innocent_video():
    from vs_inspect.analysis.diagnose import (
        CAUSE_GEOMETRY,
        CAUSE_LOOPS,
        CAUSE_NO_PAIRS,
        diagnose,
    )
    videos = [VideoInfo.constant_rate(n, 640, 480, 100, 25.0) for n in FIVE_S]
    d = diagnose(_planted(), videos)
    named = {(s.kind, s.name): s for s in d.suspects}
    assert set(named) == {("video", "E"), ("video", "B"), ("pair", "A__C")}
    assert named["video", "E"].cause == CAUSE_NO_PAIRS
    assert named["video", "B"].cause == CAUSE_GEOMETRY
    assert "pose or calibration" in named["video", "B"].message
    assert named["pair", "A__C"].cause == CAUSE_LOOPS
    assert d.global_cause is None
    assert [c.key for c in d.cautious] == ["C__D"]  # rejected, but its minimum closes its loops
    assert "B" not in d.consequences and "E" not in d.consequences  # accused, not consequences
    # every failing pair has a cause category
    assert all(c.cause for c in d.checks if c.bad)
    # the innocent reference A is never named, though 3 of its 4 pairs fail
    assert not any(s.name == "A" for s in d.suspects)


def _no_pairs_result() -> tuple[RunResult, list[str]]:
    """Four videos whose six pairs all have too few track pairs (3-7), none resolved."""
    names = ["cam0", "cam1", "cam2", "cam3"]
    pairs = tuple(_pl(a, b, float("nan"), False, f"too few track pairs: only {k} (fewer than 8)",
                      track_pairs=k)
                  for k, (a, b) in zip((3, 4, 5, 6, 7, 3),
                                       [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]))
    offs = dict.fromkeys(names)
    return RunResult("cam0", offs, dict(offs), {n: "no accepted pair" for n in names}, pairs, "irls",
                     (), (), {}), names


def test_most_pairs_failing_for_one_reason_is_a_global_cause():
    from vs_inspect.analysis.diagnose import CAUSE_NO_PAIRS, diagnose
    r, names = _no_pairs_result()
    d = diagnose(r)
    assert d.global_cause == CAUSE_NO_PAIRS
    assert [s.kind for s in d.suspects] == ["global"]
    msg = d.suspects[0].message
    assert msg.startswith("most pairs fail (6 of 6") and "the cause is global: no cross-view pairs" in msg
    assert "(3-7 track pairs per pair)" in msg
    assert set(d.consequences) == set(names)  # unresolved, but nobody is blamed
    assert "three views" not in msg
    # the same run where Stage 0's three-view check refused three estimated cameras: it says so
    import dataclasses

    from ..cue_records import cue_stats, joint
    three_view = {n: {"passed": n == "cam0", "supporters": 0 if n != "cam0" else 9} for n in names}
    cues = cue_stats(joint_vote=joint(dict.fromkeys(names, 10.0), sure=("cam0",), three_view=three_view),
                     registered=4, tracks=100, track_pairs=0)
    msg = diagnose(dataclasses.replace(r, cues=cues)).suspects[0].message
    assert "Stage 0 refused cam1, cam2, cam3 in three views" in msg and "--calib" in msg
    assert "moved" not in msg  # no video statistics, no claim about them


def test_no_cross_view_pairs_shows_what_stage0_had_to_pair():
    """The global "no cross-view pairs" cause gives each video's tracks and moving share, and
    names the cameras that moved (e.g. three head-worn cameras with few tracks each)."""
    import dataclasses

    from vs_inspect.analysis.diagnose import diagnose
    from vs_inspect.cue_stats import CueStats, VideoCueStats

    r, names = _no_pairs_result()
    videos = {n: VideoCueStats(f"{n}.mp4", "moving" if n == "cam3" else "static", 0.0,
                               0.009 if n == "cam3" else 0.04, 38 if n == "cam3" else 500, 2, 0, 0)
              for n in names}
    cues = CueStats("calibration", 4, 1538, 0, videos, {}, {}, {})
    msg = diagnose(dataclasses.replace(r, cues=cues)).suspects[0].message
    assert "tracks per video (share of the frames in moving regions): cam0 500 (4.0 %)" in msg
    assert "cam3 38 (0.9 %)" in msg
    assert "; cam3 moved: " in msg and "cam0 moved" not in msg and "three views" not in msg


def test_a_loop_missing_by_more_than_its_tolerance_is_not_ok():
    from vs_inspect.analysis.diagnose import diagnose
    # three accepted pairs each 21.7 ms from the solution (tolerance 40 ms at 50 fps), but their
    # loop misses by 65 ms (> two frames, 40 ms): none of them is "ok"
    truth = {"a": 0.0, "b": 0.3, "c": -0.5}
    e = 0.0217
    pairs = (_pl("a", "b", 0.3 + e, True, "single clear minimum"),
             _pl("b", "c", -0.8 + e, True, "single clear minimum"),
             _pl("a", "c", -0.5 - e, True, "single clear minimum"))
    r = RunResult("a", dict(truth), {v: 0.001 for v in truth}, {}, pairs, "irls", (), (), {})
    videos = [VideoInfo.constant_rate(n, 640, 480, 100, 50.0) for n in truth]
    d = diagnose(r, videos)
    (loop,) = d.loops
    assert loop.residual_ms == pytest.approx(65.1, abs=0.1) and loop.tolerance_ms == pytest.approx(40.0)
    assert loop.bad
    assert all(not c.bad and c.loops_bad == 1 and not c.ok for c in d.checks)
    # the same pairs with a closing loop are ok
    good = tuple(_pl(p.a, p.b, truth[p.b] - truth[p.a], True, "single clear minimum") for p in pairs)
    d2 = diagnose(RunResult("a", dict(truth), {v: 0.001 for v in truth}, {}, good, "irls", (), (), {}),
                  videos)
    assert all(c.ok for c in d2.checks) and not d2.loops[0].bad


def test_errors_against_the_truth_per_pair():
    checks = check_pairs(_result(), gt=TRUE_S)
    cd = next(c for c in checks if c.key == "C__D")
    assert cd.error_ms == pytest.approx(500.0)
    assert all(c.error_ms == pytest.approx(0.0, abs=1e-9) for c in checks if c.key != "C__D")


def test_a_blind_video_that_stage0_refused_is_named_with_stage0s_reason():
    """E's pairs have no track pairs because Stage 0's joint vote was unsure of it and point
    transfer disagreed (result.json cues.geometric_joint): the suspect says so, not 'does not see
    the shared motion'."""
    import dataclasses

    from vs_inspect.analysis.diagnose import CAUSE_NO_PAIRS, diagnose
    from ..cue_records import cue_stats, joint

    videos = [VideoInfo.constant_rate(n, 640, 480, 100, 25.0) for n in FIVE_S]
    plain = next(s for s in diagnose(_planted(), videos).suspects if s.name == "E")
    assert "does not see the shared motion" in plain.message
    vote = joint({"A": 9.0, "B": 8.0, "C": 7.5, "D": 6.0, "E": 3.3}, used=("A", "B", "C", "D"), origin="A",
                 transfer={"E": {"reason": "point transfer puts it at +0.150 s, the joint vote at "
                                           "+0.200 s (2.7 frames apart): they disagree", "confirmed": False}})
    cues = cue_stats("calibration", joint_vote=vote, registered=5, tracks=100)
    e = next(s for s in diagnose(dataclasses.replace(_planted(), cues=cues), videos).suspects if s.name == "E")
    assert e.cause == CAUSE_NO_PAIRS
    assert "joint vote was not sure of its offset (margin 3.3)" in e.message
    assert "they disagree" in e.message and "does not see" not in e.message


def test_a_pair_refused_as_too_wide_is_given_that_cause():
    """The width check's own reason (built by sync.decision) is read as its cause, not left
    without one."""
    from vs_inspect.analysis.diagnose import CAUSE_MEANING, CAUSE_WIDE, _cause_of_reason
    from vs_inspect.sync.config import DecisionConfig
    from vs_inspect.sync.decision import check_uncertainty
    from vs_inspect.result_types import PairDecision

    ok = PairDecision(True, "single clear minimum", 0.8, 0.0, 1, 1, False)
    refused = check_uncertainty(ok, 0.077, -1.604, 1 / 30, DecisionConfig())
    assert not refused.accepted
    assert _cause_of_reason(refused.reason) == CAUSE_WIDE and CAUSE_WIDE in CAUSE_MEANING
