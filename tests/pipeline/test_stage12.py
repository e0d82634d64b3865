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
