"""People as correspondences: association, F and shift of two asymmetric cameras from synthetic
BlazePose landmarks of three walkers (one labelled mirrored in b) and a false person per view."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.epipolar import fundamental_from_cameras
from vs_inspect.geometry.offsets import OffsetGrid
from vs_inspect.geometry.two_view import sampson_px
from vs_inspect.synth.people import ViewOptions, Walker, default_walkers, people_scene, ring_camera
from vs_inspect.sync.people_config import PeoplePairConfig
from vs_inspect.sync.people_pairs import estimate_people_pair

OFFSET_S = 1.23  # b started this long after a: 2.3 frames and a third
FPS = 10.0
OFFSET_TOL_S = 0.1 / FPS  # a tenth of a frame
K_A = np.array([[820.0, 0, 470], [0, 800, 275], [0, 0, 1]])
K_B = np.array([[1100.0, 0, 490], [0, 1130, 262], [0, 0, 1]])
CFG = PeoplePairConfig(search_frames=16, max_hypotheses=6, candidates=2)
GRID = OffsetGrid(min_overlap_s=3.0, range_s=2.5)


def _cameras(num_a=80, num_b=70):
    a = ring_camera("a", 0, K_A, roll_deg=4, fps=FPS, num_frames=num_a)
    b = ring_camera("b", 105, K_B, distance=7, height=2.4, roll_deg=-6, fps=FPS, num_frames=num_b,
                    offset_s=OFFSET_S)
    return a, b


def _estimate(scene, first="a", second="b", cfg=CFG):
    A, B = scene.views[first], scene.views[second]
    offs = GRID.pair_offsets(first, (0.0, A.times_s[-1]), second, (0.0, B.times_s[-1]), 1 / FPS)
    return estimate_people_pair(first, A.times_s, A.seen_xy(cfg.landmarks), second, B.times_s,
                                B.seen_xy(cfg.landmarks), offs, cfg)


@pytest.fixture(scope="module")
def scene():
    return people_scene(_cameras(), default_walkers(),
                        {"a": ViewOptions(seed=1), "b": ViewOptions(seed=2, mirrored=(1,))})


@pytest.fixture(scope="module")
def pair(scene):
    return _estimate(scene)


def test_shift_association_and_mirror(scene, pair):
    assert pair.accepted, pair.reason
    assert abs(pair.offset_s - OFFSET_S) < OFFSET_TOL_S
    truth_a, truth_b = scene.person_of_track["a"], scene.person_of_track["b"]
    got = {(int(truth_a[x.person_a]), int(truth_b[x.person_b]), x.mirrored) for x in pair.associations}
    assert got == {(0, 0, False), (1, 1, True), (2, 2, False)}  # the false people left out
    assert pair.margin is None or pair.margin >= CFG.min_margin
    # the candidate grid's best is the frame step nearest the truth
    assert pair.best_grid_offset_s == pytest.approx(1.2)


def test_F_is_the_cameras_epipolar_geometry(scene, pair):
    """Points of the scene projected by the true cameras satisfy the estimated F_ab."""
    ca, cb = scene.cameras
    rng = np.random.default_rng(3)
    X = rng.uniform([-1.5, -1.5, 0.0], [1.5, 1.5, 1.8], (200, 3))
    from vs_inspect.geometry.epipolar import project
    xa, xb = project(ca.K, ca.cam_from_world, X), project(cb.K, cb.cam_from_world, X)
    F_true = fundamental_from_cameras(ca.K, ca.cam_from_world, cb.K, cb.cam_from_world)
    assert np.median(sampson_px(F_true, xa, xb)) < 1e-6
    assert np.median(sampson_px(pair.F_ab, xa, xb)) < 2.0  # px; the landmarks' noise is 1 px
    # a and b swapped would give F_abᵀ: the estimate is not symmetric by accident
    assert np.median(sampson_px(pair.F_ab.T, xa, xb)) > 20.0


def test_swapping_the_videos_flips_the_shift(scene):
    r = _estimate(scene, "b", "a")
    assert r.accepted, r.reason
    assert abs(r.offset_s + OFFSET_S) < OFFSET_TOL_S


def test_people_standing_still_give_no_shift():
    """Without motion every shift fits: an ambiguous shift, refused."""
    still = tuple(Walker(w.centre, (1e-3, 1e-3), 1e6, w.phase, 0.0, 0.0, w.height) for w in default_walkers())
    sc = people_scene(_cameras(), still, {"a": ViewOptions(seed=1), "b": ViewOptions(seed=2)})
    r = _estimate(sc)
    assert not r.accepted
    assert r.reason.startswith(("flat landscape", "ambiguous shift")), r.reason


def test_no_people_is_refused_with_its_reason(scene):
    A = scene.views["a"]
    none = np.zeros((0, len(A.times_s), len(CFG.landmarks), 2))
    r = estimate_people_pair("a", A.times_s, A.seen_xy(CFG.landmarks), "b", A.times_s, none, np.arange(-2, 2, 0.1), CFG)
    assert not r.accepted and r.reason == "no person followed in b"


def test_shapes_are_checked():
    with pytest.raises(ValueError, match=r"a: people must be \(P,3,21,2\), got \(2, 3, 5, 2\)"):
        estimate_people_pair("a", np.arange(3.0), np.zeros((2, 3, 5, 2)), "b", np.arange(3.0),
                             np.zeros((1, 3, 21, 2)), np.zeros(1), CFG)
