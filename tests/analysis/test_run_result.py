"""A RunResult rebuilt from Stage 2's result alone."""

from __future__ import annotations

from vs_inspect.analysis.run_result import run_result_from_sync
from vs_inspect.result_types import SyncResult

SYNC = SyncResult("a", {"a": 0.0, "b": 1.25, "c": None}, {"a": 0.0, "b": 0.01, "c": None},
                  {"c": "no pair"}, (), (("a", "b"),), (), solver="ls", timings_s={"total_s": 2.0})


def test_every_stage2_field_is_kept_under_its_run_result_name():
    r = run_result_from_sync(SYNC, {"a": 0.0, "b": 1.2})
    assert (r.reference, r.offsets_s, r.uncertainty_s, r.unresolved) == \
        ("a", SYNC.offsets_s, SYNC.uncertainty_s, {"c": "no pair"})
    assert (r.solver, r.solve_pairs, r.timings_s) == ("ls", (("a", "b"),), {"total_s": 2.0})
    assert r.gt_offsets_s == {"a": 0.0, "b": 1.2}
    assert r.config is None and r.cues is None


def test_an_empty_truth_is_no_truth():
    assert run_result_from_sync(SYNC, {}).gt_offsets_s is None
    assert run_result_from_sync(SYNC).gt_offsets_s is None
