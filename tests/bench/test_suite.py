"""The benchmark's shortcuts equal the real pipeline, and the caliscope bundle is built right."""


import numpy as np
import pytest

from vs_inspect.bench.datasets import caliscope_cut, caliscope_cuts, load_caliscope
from vs_inspect.bench.suite import stage1_pairwise, without_filter
from vs_inspect.bench.datasets import BenchData
from vs_inspect.sync.config import DecisionConfig, PairSelection, SolveConfig, SyncConfig
from vs_inspect.sync.pairs import select_pairs
from vs_inspect.pipeline.stage12 import solve_stage2, sync_bundle
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

SMALL = CueSceneConfig(cameras=4, moving=1, variable_rate=1, seconds=4.0, pairs_per_view_pair=120,
                       max_offset_s=1.0, seed=2)


@pytest.fixture(scope="module")
def small():
    sc = make_cue_scene(SMALL)
    return sc, sync_bundle(sc.bundle, SyncConfig(), progress=False)


def test_ablation_shortcuts_equal_full_runs(small):
    """The bench reuses the default run's landscapes for its Stage 2 ablations: the filter off
    (without_filter) and fewer pairs give what a full run with those settings gives."""
    sc, base = small
    b = sc.bundle
    lands = list(base.pairs)
    off = sync_bundle(b, SyncConfig(decision=DecisionConfig(enabled=False)), progress=False)
    assert solve_stage2(b, without_filter(lands), SolveConfig()).offsets_s == off.offsets_s
    assert all(p.decision.accepted or p.num_track_pairs < 8 for p in without_filter(lands))
    sel = PairSelection.parse("rst", 1)
    rst = sync_bundle(b, SyncConfig(pairs=sel), progress=False)
    has = {k for k, v in b.pairs.items() if len(v.index)}
    by = {(p.a, p.b): p for p in lands}
    chosen = select_pairs(b.names, has, sel)
    assert len(chosen) == len(b.names) - 1
    assert solve_stage2(b, [by[p] for p in chosen], SolveConfig()).offsets_s == rst.offsets_s


def test_stage1_pairwise_counts_missing_pairs_as_wrong(small):
    sc, base = small
    data = BenchData("x", "x", sc.bundle)
    a100, a500 = stage1_pairwise(data, list(base.pairs))
    gt = sc.bundle.gt_offsets_s
    err = [abs(p.best_offset_s - (gt[p.b] - gt[p.a])) if np.isfinite(p.best_offset_s) else np.inf
           for p in base.pairs]
    best = int(np.argmin(err))  # dropping the most accurate pair must cost A@100
    a100_less, _ = stage1_pairwise(data, [p for i, p in enumerate(base.pairs) if i != best])
    assert 0 < a100 <= 100 and a100 <= a500
    assert a100_less < a100


def test_caliscope_bundle_from_real_corners(shared_data):
    s = load_caliscope(shared_data / "caliscope_post_optimization")
    assert s.names == ["cam_0", "cam_1", "cam_2", "cam_3"]
    none = caliscope_cut(s, {}, "nocut")
    assert all(abs(v) < 0.03 for v in none.bundle.gt_offsets_s.values())  # synchronized within ~20 ms
    cuts = {"cam_0": 2, "cam_1": 0, "cam_2": 5, "cam_3": 1}
    d = caliscope_cut(s, cuts, "c")
    b = d.bundle
    for v in b.names:
        assert b.video(v).num_frames == len(s.frame_time_s[v]) - cuts[v]
        assert b.video(v).fps is None and b.video(v).timestamps_s[0] == 0.0  # variable rate
        want = s.frame_time_s[v][cuts[v]] - s.frame_time_s["cam_0"][cuts["cam_0"]]
        assert b.gt_offsets_s[v] == pytest.approx(want)
    assert b.gt_offsets_s["cam_2"] == pytest.approx(0.5, abs=0.05)  # 3 frames at ~6 fps later than cam_0
    tp = b.pair("cam_0", "cam_1")
    assert len(tp.index) >= 8 and np.all(tp.index[:, 0] == tp.index[:, 1])  # same corner id
    # undistortion moved the points (cam_0 has strong radial distortion)
    raw_any = np.isfinite(s.xy_px["cam_0"][..., 0]).sum()
    assert raw_any > 100
    # random cuts are reproducible and independent of how many are asked for
    assert caliscope_cuts(s, 2)[1].notes == caliscope_cuts(s, 4)[1].notes
    # the synced result is near the truth (the epipolar cue on real corners)
    res = sync_bundle(b, SyncConfig(), progress=False)
    err = [abs(res.offsets_s[v] - b.gt_offsets_s[v]) for v in b.names if res.offsets_s[v] is not None]
    assert np.median(err) < 1 / 6  # under one frame


def test_stage0_failure_is_a_failure_row_but_the_motion_peer_still_runs():
    from vs_inspect.bench.suite import stage0_failed
    from vs_inspect.types import VideoInfo

    truth = {"a": 0.0, "b": 0.7}
    infos = [VideoInfo.constant_rate(n, 320, 240, 80, 10.0) for n in truth]
    rng = np.random.default_rng(0)
    g = np.arange(-2, 12, 0.1)
    f = rng.uniform(0, 1, len(g))
    signals = {v.name: (v.timestamps_s, np.interp(v.timestamps_s + truth[v.name], g, f)) for v in infos}
    data = BenchData("clips/x", "clips", None, None, 0.1,
                     {"truth": truth, "videos_info": infos, "motion_signals": signals})
    rows = stage0_failed(data, "NoUsableVideos: no video could be used", 12.0)
    assert [r.method for r in rows] == ["vs_inspect", "motion-xcorr", "ransac-inlier"]
    assert rows[0].error.startswith("NoUsableVideos") and rows[0].unresolved == 2 and rows[0].a100 == 0.0
    assert rows[2].error and not rows[1].error
    assert rows[1].delta_med_ms < 1e-6 and rows[1].unresolved == 0  # exact shift of 7 frames
