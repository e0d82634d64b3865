"""A run's RunResult when only its Stage 2 result is known (a recording closed without the run's
summary): the summary is rebuilt from SyncResult, without inputs, config or cue statistics."""

from __future__ import annotations

from ..result_types import RunResult, SyncResult


def run_result_from_sync(result: SyncResult, gt_offsets_s: dict[str, float] | None = None) -> RunResult:
    """result as a RunResult, with the true offsets when known (an empty dict counts as unknown)."""
    r = result
    return RunResult(r.reference, r.offsets_s, r.uncertainty_s, r.unresolved_reason, r.pairs, r.solver,
                     r.solve_pairs, r.iterations, r.timings_s, gt_offsets_s=gt_offsets_s or None)
