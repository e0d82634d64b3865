"""Cameras from pairwise fundamental matrices and shared points: three asymmetric views of a
scene, their exact F's and noisy sightings; the focal lengths, the chained poses and the bundle
adjustment against the truth."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.epipolar import fundamental_from_cameras, look_at, project, relative_pose
from vs_inspect.geometry.people_rig import (Observations, PairF, PairPose, bundle_adjust, chain_poses,
                                            essential_cost, focals_from_pairs, intrinsics, pair_pose,
                                            register_views)
from vs_inspect.geometry.two_view import sampson_px

SIZE = np.array([960.0, 960.0, 1280.0])
PP = np.array([[480.0, 270], [480, 270], [640, 360]])
FOCAL = np.array([820.0, 1150.0, 1000.0])


def _rig():
    """Three cameras whose optical axes pass each other at a distance (axes that meet leave the
    focal lengths undetermined by the F's alone)."""
    centres = [(6.0, 0.5, 2.8), (-1.5, 6.5, 2.2), (-5.0, -3.5, 3.1)]
    targets = [(0.2, -0.1, 1.0), (0.9, 0.3, 0.2), (-0.4, 0.8, 1.5)]
    T = []
    for i, c in enumerate(centres):
        M = look_at(np.array(c), np.array(targets[i]))
        r = np.deg2rad([3.0, -5.0, 2.0][i])
        roll = np.array([[np.cos(r), -np.sin(r), 0], [np.sin(r), np.cos(r), 0], [0, 0, 1.0]])
        M[:3] = roll @ M[:3]
        T.append(M)
    K = [intrinsics(FOCAL[i], PP[i]) for i in range(3)]
    return K, T


def _points(n=400, seed=0):
    return np.random.default_rng(seed).uniform([-1.5, -1.5, 0.0], [1.5, 1.5, 1.9], (n, 3))


def test_essential_cost_is_zero_for_true_intrinsics_only():
    K, T = _rig()
    F = fundamental_from_cameras(K[0], T[0], K[1], T[1])
    assert essential_cost(F, K[0], K[1]) < 1e-9
    assert essential_cost(F, intrinsics(1.5 * FOCAL[0], PP[0]), K[1]) > 1e-3


def test_focals_from_three_pairs():
    K, T = _rig()
    pairs = [PairF(a, b, fundamental_from_cameras(K[a], T[a], K[b], T[b]), 1.0) for a, b in ((0, 1), (0, 2), (1, 2))]
    f = focals_from_pairs(pairs, PP, SIZE, num=200)
    np.testing.assert_allclose(f, FOCAL, rtol=0.03)


def test_chain_then_adjust_recovers_the_rig_up_to_similarity():
    K, T = _rig()
    X = _points()
    rng = np.random.default_rng(1)
    xs = [project(K[v], T[v], X) + rng.normal(0, 0.5, (len(X), 2)) for v in range(3)]
    poses = [PairPose(a, b, pair_pose(fundamental_from_cameras(K[a], T[a], K[b], T[b]), K[a], K[b], xs[a], xs[b]),
                      w) for (a, b), w in (((0, 1), 3.0), ((0, 2), 2.0), ((1, 2), 1.0))]
    chained = chain_poses(3, 0, poses)
    assert set(chained) == {0, 1, 2}
    np.testing.assert_allclose(chained[0], np.eye(4))
    # the tree's edges 0-1 and 0-2 carry the true rotations
    for v in (1, 2):
        true = relative_pose(T[v], T[0])[:3, :3]
        assert np.allclose(chained[v][:3, :3], true, atol=1e-3)
    # start the adjustment from wrong focal lengths (+15 %) and the unit baselines
    obs = Observations(np.tile(np.arange(len(X)), 3), np.repeat(np.arange(3), len(X)), np.concatenate(xs),
                       np.full(3 * len(X), 0.5))
    start_f = {v: 1.15 * FOCAL[v] for v in range(3)}
    placed = register_views(chained, start_f, PP, obs, 0, [1, 2])
    rig = bundle_adjust(placed, start_f, PP, obs, reference=0,
                        focal_bounds_px={v: (0.3 * SIZE[v], 5 * SIZE[v]) for v in range(3)})
    assert np.nanmedian(rig.residual_px) < 1.0
    assert rig.cost_end < rig.cost_start
    for v in range(3):
        assert rig.focal_px[v] == pytest.approx(FOCAL[v], rel=0.02)
    # every pair's F from the adjusted rig is the true one (up to scale): exact points fit it
    Xt = _points(100, seed=5)
    for a, b in ((0, 1), (0, 2), (1, 2)):
        F = fundamental_from_cameras(intrinsics(rig.focal_px[a], PP[a]), rig.cam_from_world[a],
                                     intrinsics(rig.focal_px[b], PP[b]), rig.cam_from_world[b])
        assert np.median(sampson_px(F, project(K[a], T[a], Xt), project(K[b], T[b], Xt))) < 0.5


def test_chain_leaves_out_views_without_pairs():
    out = chain_poses(3, 0, [PairPose(0, 1, np.eye(4), 1.0)])
    assert set(out) == {0, 1}
