"""Stage 1 with clock drift: (Δ, rate) of a pair on the energy (sync.rate)."""

import numpy as np

from vs_inspect.bench.datasets import cue_scene
from vs_inspect.sync.pair import pair_landscape
from vs_inspect.sync.config import DriftConfig, SyncConfig
from vs_inspect.sync.rate import overlap_pivot_s, scaled_video
from vs_inspect.types import VideoInfo


def test_scaled_video_scales_times_and_rate():
    v = VideoInfo.constant_rate("v", 64, 48, 5, 25.0)
    s = scaled_video(v, 1.001)
    assert np.allclose(s.timestamps_s, v.timestamps_s * 1.001)
    assert abs(s.fps - 25.0 / 1.001) < 1e-12


def test_overlap_pivot_is_middle_of_common_span():
    a = VideoInfo.constant_rate("a", 64, 48, 101, 10.0)  # 0..10 s
    b = VideoInfo.constant_rate("b", 64, 48, 101, 10.0)
    # τ_a = 4 + τ_b: b's times 0..6 fall into a's span
    assert abs(overlap_pivot_s(a, b, 4.0, 1.0) - 3.0) < 1e-9


def test_pair_rate_recovered_on_a_drifting_synthetic_pair():
    data = cue_scene("easy", 0, drift_ppm=200.0)
    b = data.bundle
    wrong = data.notes["all_wrong_pair"]
    a_name, b_name = max((k for k in b.pairs if k != wrong), key=lambda k: len(b.pairs[k].index))
    truth_rate = (1 + b.gt_drift_ppm[b_name] * 1e-6) / (1 + b.gt_drift_ppm[a_name] * 1e-6)
    truth_off = (b.gt_offsets_s[b_name] - b.gt_offsets_s[a_name]) / (1 + b.gt_drift_ppm[a_name] * 1e-6)
    cfg = SyncConfig(drift=DriftConfig(enabled=True))
    land, _ = pair_landscape(b, a_name, b_name, cfg)
    assert land.decision.accepted, land.decision.reason
    assert land.rate_landscape is not None and land.rate_landscape.energy.shape == (21, 17)
    # 8 s of video hardly tell the rate (200 ppm moves the ends by 0.8 ms): the pair must say so
    # through its uncertainty, and the offset stays within the 5 ms target
    assert abs(land.best_offset_s - truth_off) < 0.005, (land.best_offset_s, truth_off)
    assert np.isfinite(land.log_rate_std) and land.log_rate_std > 0
    assert abs(np.log(land.rate / truth_rate)) < 3 * land.log_rate_std, (land.rate, land.log_rate_std)
