"""`sync` on a pose-free bundle (cameras with K only): Stage 1 estimates each pair's F, shift and
rate from its tracks (sync.posefree), runs the energy with that F, and (--drift) Stage 2 solves
offset and drift per video. Synthetic: one moving point (a drone) seen by three cameras."""

from __future__ import annotations

import dataclasses
import importlib.util

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.io.bundle import read_bundle, write_bundle
from vs_inspect.pipeline.stage12 import estimate_pose_free_pairs, is_pose_free_pair, sync_bundle
from vs_inspect.engine import EngineConfig, open_engine
from vs_inspect.sync.config import DriftConfig, LandscapeConfig, SyncConfig
from vs_inspect.types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo

OFFSETS = {"c0": 0.0, "c1": 3.217, "c2": -4.61}
DRIFT_PPM = {"c0": 0.0, "c1": 200.0, "c2": -150.0}
FPS = {"c0": 30.0, "c1": 25.0, "c2": 30.0}
SECONDS = {"c0": 90.0, "c1": 80.0, "c2": 85.0}


def _world(g: np.ndarray) -> np.ndarray:
    return np.c_[20 * np.sin(0.11 * g) + 5 * np.sin(0.37 * g),
                 8 * np.cos(0.13 * g) + 3 * np.sin(0.5 * g) - 4,
                 45 + 6 * np.sin(0.07 * g) + 2 * np.cos(0.29 * g)]


def _camera(k: int):
    K = np.array([[900.0 + 300 * k, 0, 640 + 150 * k], [0, 880 + 300 * k, 360 + 90 * k], [0, 0, 1]])
    axis = np.array([0.3, -0.9, 0.2 * k - 0.1])
    R = Rotation.from_rotvec(np.deg2rad(12 * k) * axis / np.linalg.norm(axis)).as_matrix()
    C = np.array([[0.0, 0, 0], [12.0, 1.5, -2.0], [-9.0, 3.0, 1.0]])[k]
    return K, R, C


def drone_bundle(seed: int = 0) -> CueBundle:
    rng = np.random.default_rng(seed)
    videos, cams, tracks = [], {}, {}
    for k, n in enumerate(OFFSETS):
        v = VideoInfo.constant_rate(n, 1280 + 640 * (k == 1), 720 + 360 * (k == 1),
                                    int(SECONDS[n] * FPS[n]), FPS[n])
        K, R, C = _camera(k)
        X = _world(OFFSETS[n] + (1 + DRIFT_PPM[n] * 1e-6) * v.timestamps_s)
        x = (X - C) @ R.T @ K.T
        xy = x[:, :2] / x[:, 2:] + rng.normal(0, 0.3, (v.num_frames, 2))
        for start in rng.integers(0, len(xy) - 40, 12):  # missed detections, in runs
            xy[start:start + rng.integers(5, 40)] = np.nan
        videos.append(v)
        cams[n] = CameraTrack(K, np.eye(4))  # K only: the pose is a placeholder
        tracks[n] = Tracks(xy[None])
    one = np.zeros((1, 2), dtype=np.int64)
    names = list(OFFSETS)
    pairs = {(a, b): TrackPairs(a, b, one) for i, a in enumerate(names) for b in names[i + 1:]}
    return CueBundle(tuple(videos), cams, tracks, pairs, dict(OFFSETS), frozenset(names), dict(DRIFT_PPM))


CFG = SyncConfig(landscape=LandscapeConfig(range_s=15.0))


def test_pose_free_marker_round_trips(tmp_path):
    b = drone_bundle()
    back = read_bundle(write_bundle(b, tmp_path / "b"))
    assert back.pose_free == frozenset(OFFSETS)
    assert back.gt_drift_ppm == DRIFT_PPM
    assert is_pose_free_pair(back, "c0", "c1")
    # without the marker, identical placeholder poses (no baseline) still make a pose-free pair
    assert is_pose_free_pair(dataclasses.replace(back, pose_free=frozenset()), "c0", "c2")


def test_pose_free_bundle_with_drift_recovers_offsets_and_drift():
    res = sync_bundle(drone_bundle(), dataclasses.replace(CFG, drift=DriftConfig(enabled=True)), progress=False)
    assert all(p.pose_free and p.decision.accepted for p in res.pairs), [p.decision.reason for p in res.pairs]
    assert res.drift_ppm is not None
    for n in OFFSETS:
        fps = FPS[n]
        assert abs(res.offsets_s[n] - OFFSETS[n]) * fps < 0.1, (n, res.offsets_s[n])
        assert abs(res.drift_ppm[n] - DRIFT_PPM[n]) < 30.0, (n, res.drift_ppm[n])
        assert res.drift_std_ppm[n] is not None and res.uncertainty_s[n] is not None
    for p in res.pairs:  # the (Δ, rate) image of every pair
        assert p.rate_landscape is not None and np.isfinite(p.rate_landscape.energy).all()


def test_pose_free_bundle_constant_model_is_the_ablation():
    """Without --drift the same pairs run the 1-D energy at rate 1: a constant offset per video,
    no drift in the result; over 80 s a 200 ppm clock leaves it off by several ms at the ends."""
    res = sync_bundle(drone_bundle(), CFG, progress=False)
    assert res.drift_ppm is None
    assert all(p.pose_free for p in res.pairs)
    for n in OFFSETS:
        assert res.offsets_s[n] is not None
        assert abs(res.offsets_s[n] - OFFSETS[n]) < 0.1


def test_pose_free_pairs_on_ray_match_in_process():
    """The pose-free pairs run on the run's engine (no pool of their own): as Ray tasks they give
    the in-process estimates bit for bit, in the order of the pairs."""
    if importlib.util.find_spec("ray") is None:  # not imported here: the engine sets its env first
        pytest.skip("ray is not installed (pip install 'vs_inspect[distributed]')")
    b = drone_bundle()
    pairs = [("c0", "c2"), ("c0", "c1")]
    one = estimate_pose_free_pairs(b, pairs, CFG)
    with open_engine(EngineConfig("ray", ray_cpus=2)) as eng:
        two = estimate_pose_free_pairs(b, pairs, CFG, engine=eng)
    assert list(one) == list(two) == pairs
    for k in pairs:
        assert one[k].offset_s == two[k].offset_s and one[k].rate == two[k].rate
        np.testing.assert_array_equal(one[k].F_ab, two[k].F_ab)
