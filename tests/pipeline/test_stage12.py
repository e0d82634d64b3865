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


def test_stage1_refuses_a_pair_whose_minimum_is_wider_than_the_bound(small):
    """The width check runs on every epipolar pair at its refined minimum: with a bound under the
    narrowest accepted minimum every such pair is refused, each with its own width; by default
    (a frame) the right pairs of this scene stay accepted."""
    import dataclasses

    from vs_inspect.sync.config import DecisionConfig

    bundle, base = small
    info = {v.name: v for v in bundle.videos}
    accepted = [land for land in base.pairs if land.decision.accepted]
    assert accepted
    frames = [land.uncertainty_s / max(info[land.a].frame_interval_s, info[land.b].frame_interval_s)
              for land in accepted]
    assert max(frames) <= 1.0
    tight = dataclasses.replace(SyncConfig(), decision=DecisionConfig(max_uncertainty_frames=0.5 * min(frames)))
    res = sync_bundle(bundle, tight, progress=False)
    by = {(land.a, land.b): land for land in res.pairs}
    for land in accepted:
        d = by[(land.a, land.b)].decision
        assert not d.accepted and "is too wide to time the pair" in d.reason, d.reason


def test_a_reference_without_an_accepted_pair_is_null_with_a_reason(small):
    import dataclasses
    bundle, base = small
    ref = bundle.names[0]
    lands = [p if ref not in (p.a, p.b) else dataclasses.replace(
        p, decision=dataclasses.replace(p.decision, accepted=False, reason="planted rejection"))
        for p in base.pairs]
    out = solve_stage2(bundle, lands)
    assert out.offsets_s[ref] is None and out.uncertainty_s[ref] is None
    assert out.unresolved_reason[ref].startswith("the reference, but no accepted pair links it")
    assert "planted rejection" in out.unresolved_reason[ref]
    # the videos that accepted pairs still link are timed against the first of them instead
    new = bundle.names[1]
    assert out.reference == new and f"{new}, of the largest group" in out.unresolved_reason[ref]
    assert out.offsets_s[new] == 0.0
    assert None not in base.offsets_s.values()
    for v in bundle.names[2:]:
        assert out.offsets_s[v] == pytest.approx(base.offsets_s[v] - base.offsets_s[new], abs=0.01)
    # with its pairs accepted it keeps its 0.0 and no reason
    assert base.offsets_s[ref] == 0.0 and ref not in base.unresolved_reason


@pytest.fixture(scope="module")
def shifted_pair():
    """Two static 30 fps cameras, and b's tracks once more shifted 30 frames in time: pairing a's
    tracks with those copies fits Δ_ab + 1 s exactly as the right pairs fit Δ_ab (what a wrong
    epipolar vote peak of two cameras gives: consistent tracks at a wrong offset)."""
    import dataclasses

    import numpy as np

    from vs_inspect.types import Tracks
    sc = make_cue_scene(CueSceneConfig(cameras=2, moving=0, variable_rate=0, seconds=6.0, pairs_per_view_pair=200,
                                       max_offset_s=0.5, no_match_pairs=0, all_wrong_pair=False,
                                       wrong_fraction=0.0, fps_choices=(30.0,), seed=3))
    (a, b), tp = next(iter(sc.bundle.pairs.items()))
    xy = sc.bundle.tracks[b].xy
    late = np.full_like(xy, np.nan)
    late[:, :-30] = xy[:, 30:]
    tracks = {**sc.bundle.tracks, b: Tracks(np.concatenate([xy, late]))}
    bundle = dataclasses.replace(sc.bundle, tracks=tracks)
    truth = sc.bundle.gt_offsets_s[b] - sc.bundle.gt_offsets_s[a]
    return bundle, a, b, tp.index, len(xy), truth


def _with_pairs(bundle, a, b, checked, unchecked):
    import dataclasses

    import numpy as np

    from vs_inspect.types import TrackPairs
    index = np.concatenate([checked, unchecked])
    mark = np.r_[np.zeros(len(checked), bool), np.ones(len(unchecked), bool)]
    return dataclasses.replace(bundle, pairs={(a, b): TrackPairs(a, b, index, None, mark)})


def test_unchecked_track_pairs_need_the_others_to_agree(shifted_pair):
    """Track pairs marked unchecked (two cameras' epipolar vote, no triangle) decide the pair only
    when the pair's other track pairs alone find the same minimum (within 2 frames)."""
    import dataclasses

    import numpy as np

    from vs_inspect.pipeline.stage12 import pair_landscape
    from vs_inspect.sync.config import DecisionConfig
    bundle, a, b, right, n_b, truth = shifted_pair
    assert len(right) >= 160
    wrong = right[40:160] + np.array([0, n_b])  # the same tracks of a with b's late copies
    # 120 wrong unchecked pairs outweigh 40 right ones: without the check, the wrong minimum wins
    lone = _with_pairs(bundle, a, b, right[:40], wrong)
    off = SyncConfig(decision=DecisionConfig(unchecked_agree_frames=0))
    land, _ = pair_landscape(lone, a, b, off)
    assert land.decision.accepted and abs(land.best_offset_s - (truth + 1.0)) < 0.02, land.decision.reason
    land, _ = pair_landscape(lone, a, b, SyncConfig())
    assert not land.decision.accepted and abs(land.best_offset_s - (truth + 1.0)) < 0.02
    assert "found by appearance alone put it at" in land.decision.reason, land.decision.reason
    others = float(land.decision.reason.split("put it at ")[1].split(" s")[0])  # where the others put it
    assert abs(others - truth) < 1 / 30, (others, truth)
    # their landscape is kept beside the full one, on the same offsets (the recording's grey curve)
    assert land.confirm_energy.shape == land.offsets_s.shape and abs(land.confirm_offset_s - others) < 1e-3
    assert abs(land.offsets_s[np.nanargmin(land.confirm_energy)] - truth) < 1 / 30
    # right unchecked pairs: the other 40 confirm them
    land, _ = pair_landscape(_with_pairs(bundle, a, b, right[:40], right[40:160]), a, b, SyncConfig())
    assert land.decision.accepted and abs(land.best_offset_s - truth) < 1 / 30  # a frame (0.5° pose error)
    assert "confirmed by the 40 track pairs" in land.decision.reason
    # too few others to have a minimum: refused, with their own reason
    land, _ = pair_landscape(_with_pairs(bundle, a, b, right[:5], right[40:160]), a, b, SyncConfig())
    assert not land.decision.accepted and "give no minimum of their own" in land.decision.reason
    assert "too few track pairs: only 5" in land.decision.reason
    # no unchecked mark: nothing to confirm
    plain = dataclasses.replace(lone, pairs={(a, b): dataclasses.replace(lone.pairs[(a, b)], unchecked=None)})
    land, _ = pair_landscape(plain, a, b, SyncConfig())
    assert land.decision.accepted and land.confirm_energy is None


def test_the_drift_solve_also_times_the_videos_against_a_linked_reference(small):
    import dataclasses

    from vs_inspect.pipeline.stage12 import solve_stage2_drift
    from vs_inspect.sync.config import DriftConfig
    bundle, _ = small
    cfg = dataclasses.replace(SyncConfig(), drift=DriftConfig(enabled=True))
    base = sync_bundle(bundle, cfg, progress=False)
    ref, new = bundle.names[0], bundle.names[1]
    lands = [p if ref not in (p.a, p.b) else dataclasses.replace(
        p, decision=dataclasses.replace(p.decision, accepted=False, reason="planted rejection"))
        for p in base.pairs]
    out = solve_stage2_drift(bundle, lands, cfg.solve, cfg.drift)
    assert out.reference == new and out.offsets_s[ref] is None and out.drift_ppm[ref] is None
    assert out.unresolved_reason[ref].startswith("the reference, but no accepted pair links it")
    assert f"{new}, of the largest group" in out.unresolved_reason[ref]
    assert None not in base.offsets_s.values() and out.offsets_s[new] == 0.0
    for v in bundle.names[2:]:
        assert out.offsets_s[v] == pytest.approx(base.offsets_s[v] - base.offsets_s[new], abs=0.01)


def test_a_pair_whose_minimum_is_far_from_where_stage0_chose_its_track_pairs_is_refused(small):
    import dataclasses

    bundle, base = small
    land = next(p for p in base.pairs if p.decision.accepted)
    tp = bundle.pairs[(land.a, land.b)]
    for shift_s, accepted in ((0.01, True), (0.5, False)):
        moved = dataclasses.replace(tp, chosen_at_offset_s=land.best_offset_s + shift_s)
        out = sync_bundle(dataclasses.replace(bundle, pairs={**bundle.pairs, (land.a, land.b): moved}),
                          SyncConfig(), progress=False)
        got = next(p for p in out.pairs if (p.a, p.b) == (land.a, land.b))
        assert got.decision.accepted == accepted, got.decision.reason
        assert got.best_offset_s == pytest.approx(land.best_offset_s)
        assert ("at which Stage 0 kept its track pairs" in got.decision.reason) != accepted
