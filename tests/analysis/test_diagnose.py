"""The diagnosis of a run from its RunResult alone: pair disagreements with their tolerance, and
the suspects it names (a wrong pair between videos that agree elsewhere, an unresolved video)."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.analysis.diagnose import DEFAULT_FRAME_MS, check_pairs, find_suspects
from vs_inspect.io.recording import RecordedVideo
from vs_inspect.types import PairDecision, PairLandscape, RunResult, VideoInfo

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
