"""Precision and recall of cross-view track pairs against known cameras and offsets."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.bench.pairing import bundle_pair_truth, pair_truth
from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo

K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])


def _bundle(pairs_ab: np.ndarray, shift: int = 6, n: int = 30):
    """Two static cameras seeing n points moving in 3D; b starts `shift` frames after a."""
    rng = np.random.default_rng(0)
    T, fps = 80, 20.0
    t = np.arange(T + shift)
    X = rng.uniform([-1, -1, 0.3], [1, 1, 1.7], (n, 1, 3)) \
        + 0.5 * np.sin(0.15 * t[None, :, None] + rng.uniform(0, 6, (n, 1, 3)))
    cam_a = CameraTrack(K, look_at([6.0, 0.0, 1.5], [0, 0, 1]))
    cam_b = CameraTrack(K, look_at([0.0, 6.0, 2.5], [0, 0, 1]))
    xy_a = project(K, cam_a.cam_from_world, X[:, :T]) + rng.normal(0, 0.2, (n, T, 2))
    xy_b = project(K, cam_b.cam_from_world, X[:, shift:]) + rng.normal(0, 0.2, (n, T, 2))
    ts = np.arange(T) / fps
    videos = (VideoInfo("a", 640, 480, T, ts, fps), VideoInfo("b", 640, 480, T, ts, fps))
    bundle = CueBundle(videos, {"a": cam_a, "b": cam_b}, {"a": Tracks(xy_a), "b": Tracks(xy_b)},
                       {("a", "b"): TrackPairs("a", "b", pairs_ab, np.ones(len(pairs_ab)))})
    return bundle, {"a": 0.0, "b": shift / fps}


def test_right_pairs_are_right_and_wrong_ones_wrong():
    same = np.stack([np.arange(20), np.arange(20)], 1)
    bundle, truth = _bundle(np.concatenate([same, np.stack([np.arange(20, 30), np.arange(21, 31) % 30], 1)]))
    r = pair_truth(bundle, bundle.cameras, truth, "a", "b")
    assert (r.pairs, r.judged) == (30, 30)
    assert r.right == 20
    assert r.possible == 30  # every point has its partner among the tracks
    assert r.precision == pytest.approx(20 / 30) and r.recall == pytest.approx(20 / 30)
    # at a wrong offset the same pairs are wrong, and few right pairs are possible
    wrong = pair_truth(bundle, bundle.cameras, {"a": 0.0, "b": truth["b"] + 1.0}, "a", "b")
    assert wrong.right <= 2 and wrong.possible <= 5
    # the pair taken the other way round says the same
    assert bundle_pair_truth(bundle, bundle.cameras, truth)[("a", "b")] == r
    back = pair_truth(bundle, bundle.cameras, truth, "b", "a")
    assert (back.right, back.judged) == (r.right, r.judged)
