import numpy as np
import pytest

from vs_inspect.geometry.epipolar import fundamental_from_cameras
from vs_inspect.geometry.sampling import sample_video, tracks_between_frames
from vs_inspect.sync.config import LandscapeConfig, SyncConfig
from vs_inspect.sync.landscape import PairEnergy, PairInput, search_offsets
from vs_inspect.sync.reference import reference_energy
from vs_inspect.sync.pair import pair_landscape
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.types import VideoInfo


@pytest.fixture(scope="module")
def scene():
    cfg = CueSceneConfig(cameras=3, moving=1, variable_rate=1, seconds=5.0, noise_px=0.5,
                         wrong_fraction=0.25, pose_error_deg=0.2, no_match_pairs=0,
                         all_wrong_pair=False, pairs_per_view_pair=200, seed=11)
    return make_cue_scene(cfg)


def truth(scene, a, b):
    gt = scene.bundle.gt_offsets_s
    return gt[b] - gt[a]


def test_search_range_leaves_the_overlap():
    va = VideoInfo.constant_rate("a", 10, 10, 31, 10.0)  # 3.0 s long
    vb = VideoInfo.constant_rate("b", 10, 10, 21, 20.0)  # 1.0 s long
    off = search_offsets(va, vb, LandscapeConfig(min_overlap_s=0.5))
    assert off[1] - off[0] == pytest.approx(0.05)  # the finer frame interval
    # b's [Δ, Δ+1] must overlap a's [0, 3] by 0.5 s: Δ in [-0.5, 2.5]
    assert off[0] == pytest.approx(-0.5) and off[-1] == pytest.approx(2.5)
    assert len(search_offsets(va, vb, LandscapeConfig(min_overlap_s=0.5, range_s=0.2))) == 9


@pytest.mark.parametrize("a,b", [("cam0", "cam1"), ("cam0", "cam2"), ("cam1", "cam2")])
def test_pair_offset_recovered_sub_frame(scene, a, b):
    land, _ = pair_landscape(scene.bundle, a, b, SyncConfig())
    assert land.decision.accepted, land.decision.reason
    assert abs(land.best_offset_s - truth(scene, a, b)) < 0.006


def test_swapping_the_pair_negates_the_offset_and_the_wrong_sign_is_not_a_minimum(scene):
    a, b = max([("cam0", "cam1"), ("cam0", "cam2"), ("cam1", "cam2")],
               key=lambda p: abs(truth(scene, *p)))
    ab, _ = pair_landscape(scene.bundle, a, b, SyncConfig())
    ba, _ = pair_landscape(scene.bundle, b, a, SyncConfig())
    assert ba.best_offset_s == pytest.approx(-ab.best_offset_s, abs=0.004)
    d = truth(scene, a, b)
    assert abs(d) > 0.2
    i_true = np.nanargmin(np.abs(ab.offsets_s - d))
    i_flip = np.nanargmin(np.abs(ab.offsets_s + d))
    assert ab.energy[i_flip] > 2 * ab.energy[i_true]


def test_kernel_matches_reference_for_every_residual_static_and_moving(scene):
    b = scene.bundle
    for a_name, b_name in (("cam0", "cam1"), ("cam0", "cam2")):  # cam2 is the moving camera
        for residual in ("sampson", "symmetric", "cosine", "algebraic"):
            cfg = LandscapeConfig(residual=residual)
            side = [PairInput(b.video(n), b.cameras[n], b.tracks[n]) for n in (a_name, b_name)]
            pe = PairEnergy(*side, b.pair(a_name, b_name), cfg)
            offs = np.linspace(-1.0, 1.0, 7) + truth(scene, a_name, b_name)
            scale = float(np.nanmedian(pe.residuals(float(offs[3])))) * 9
            fast, n_fast = pe.energy(offs, scale)
            ref, n_ref = reference_energy(pe, offs, scale)
            assert np.array_equal(n_fast, n_ref)
            assert np.allclose(fast, ref, rtol=2e-4, equal_nan=True), residual


def test_no_track_pairs_is_rejected_with_a_reason(scene):
    from vs_inspect.types import CueBundle
    bd = scene.bundle
    empty = CueBundle(bd.videos, bd.cameras, bd.tracks, {}, bd.gt_offsets_s)
    land, _ = pair_landscape(empty, "cam0", "cam1", SyncConfig())
    assert not land.decision.accepted
    assert "track pairs" in land.decision.reason


@pytest.mark.parametrize("a,b", [("cam0", "cam1"), ("cam0", "cam2"), ("cam2", "cam0")])
def test_the_energy_reads_videos_as_geometry_sampling_does(scene, a, b):
    """The interpolated video's points and camera in the energy are those of sample_video."""
    bundle = scene.bundle
    side = {n: PairInput(bundle.video(n), bundle.cameras[n], bundle.tracks[n]) for n in (a, b)}
    pe = PairEnergy(side[a], side[b], bundle.pair(a, b), LandscapeConfig())
    off = truth(scene, a, b) + 0.013
    q = pe.s.video.timestamps_s + pe.sign * off  # the interpolated video's local times
    got = sample_video(pe.i.video.timestamps_s, pe.i.camera, pe.xi, q, rows=pe.pair_i)
    k, w = pe._brackets(np.array([off]))
    inner = tracks_between_frames(pe.xi, k[0], w[0], pe.pair_i)
    fin = np.isfinite(got.xy)
    assert fin.any()
    np.testing.assert_array_equal(got.xy[fin], inner[fin])
    np.testing.assert_array_equal(np.isfinite(inner[:, got.valid]), fin[:, got.valid])
    if pe.moving:  # G of the energy is F between s at its frames and i as sampled
        G = pe._G_moving(k, w)[0]
        s_cam = pe.s.camera
        F = fundamental_from_cameras(s_cam.K_at(np.arange(len(q))), s_cam.pose_at(np.arange(len(q))),
                                     got.K, got.cam_from_world)
        ok = np.isfinite(G[:, 0, 0])
        assert ok.any()
        np.testing.assert_array_equal(ok, got.valid & (s_cam.valid if s_cam.valid is not None else True))
        np.testing.assert_array_equal(G[ok], F[ok])


def test_search_offsets_refuses_too_many_candidates_before_allocating():
    from vs_inspect.geometry.offsets import MAX_CANDIDATE_OFFSETS
    a = VideoInfo.constant_rate("a", 64, 48, 300, 30.0)
    b = VideoInfo.constant_rate("b", 64, 48, 300, 30.0)
    with pytest.raises(ValueError, match="--step-s 1e-12 gives .* candidate offsets"):
        search_offsets(a, b, LandscapeConfig(step_s=1e-12))
    step = 18.0 / MAX_CANDIDATE_OFFSETS * 1.01  # just under the bound: allowed
    assert 0 < len(search_offsets(a, b, LandscapeConfig(step_s=step))) <= MAX_CANDIDATE_OFFSETS
