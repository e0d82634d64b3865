"""Stage 2 alone (solve_stage2) on Stage 1's landscapes gives what the whole Stage 1 + 2 gives."""

from __future__ import annotations

import pytest

from vs_inspect.pipeline.stage12 import solve_stage2, sync_bundle
from vs_inspect.sync.config import SolveConfig, SyncConfig
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

SMALL = CueSceneConfig(cameras=4, moving=1, variable_rate=1, seconds=4.0, pairs_per_view_pair=120,
                       max_offset_s=1.0, seed=2)


@pytest.fixture(scope="module")
def small():
    sc = make_cue_scene(SMALL)
    return sc.bundle, sync_bundle(sc.bundle, SyncConfig(), progress=False)


@pytest.mark.parametrize("solver", ["irls", "ls"])
def test_solve_stage2_equals_sync_bundle(small, solver):
    bundle, base = small
    full = sync_bundle(bundle, SyncConfig(solve=SolveConfig(solver=solver)), progress=False)
    alone = solve_stage2(bundle, base.pairs, SolveConfig(solver=solver))
    assert alone.offsets_s == full.offsets_s
    assert alone.uncertainty_s == full.uncertainty_s
    assert alone.unresolved_reason == full.unresolved_reason
    assert alone.solve_pairs == full.solve_pairs and alone.solver == solver
    assert set(full.timings_s) == {"stage1_s", "stage2_s"} and alone.timings_s == {}


def test_unknown_reference_is_an_input_error(small):
    from vs_inspect.errors import InputError
    bundle, base = small
    with pytest.raises(InputError, match="'nope' is not a video of the bundle"):
        solve_stage2(bundle, base.pairs, SolveConfig(reference="nope"))


def test_decisions_carry_the_evidence_behind_the_best_minimum(small):
    """Every pair with a minimum says on how much it rests: the share of the usual overlap at its
    best minimum and the track pairs seen there (at most all of them); right pairs have plenty."""
    bundle, base = small
    truth = bundle.gt_offsets_s
    with_minimum = [land for land in base.pairs if len(land.minima_idx)]
    assert len(with_minimum) >= 5
    for land in base.pairs:
        d = land.decision
        if not len(land.minima_idx):
            assert not d.accepted and d.track_pairs_at_best == -1  # not counted
            continue
        assert 0 < d.track_pairs_at_best <= land.num_track_pairs
        assert d.support_fraction > 0
        if abs(land.best_offset_s - (truth[land.b] - truth[land.a])) < 0.05:
            assert d.accepted, d.reason
            assert d.support_fraction >= 0.4 and d.track_pairs_at_best >= 8


def test_a_reference_without_an_accepted_pair_is_null_with_a_reason(small):
    import dataclasses
    bundle, base = small
    ref = bundle.names[0]
    lands = [p if ref not in (p.a, p.b) else dataclasses.replace(
        p, decision=dataclasses.replace(p.decision, accepted=False, reason="planted rejection"))
        for p in base.pairs]
    out = solve_stage2(bundle, lands)
    assert out.reference == ref and out.offsets_s[ref] is None and out.uncertainty_s[ref] is None
    assert out.unresolved_reason[ref].startswith("the reference, but no accepted pair links it")
    assert "planted rejection" in out.unresolved_reason[ref]
    # with its pairs accepted it keeps its 0.0 and no reason
    assert base.offsets_s[ref] == 0.0 and ref not in base.unresolved_reason
