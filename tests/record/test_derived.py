"""The numbers behind the recording's derived views: DLT triangulation, the epipolar offset sweep
(lines pass through the points only at the true offset) and trajectories at the solved offsets."""

from __future__ import annotations

import dataclasses

import numpy as np

from vs_inspect.geometry.epipolar import look_at, project
from vs_inspect.geometry.triangulate import projection_matrix, reprojection_error, triangulate_dlt
from vs_inspect.record.derived import clip_lines, epipolar_sweep, triangulate_pair
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene


def test_dlt_recovers_points_exactly():
    rng = np.random.default_rng(1)
    K_a = np.array([[900.0, 0, 640], [0, 880, 360], [0, 0, 1]])
    K_b = np.array([[700.0, 0, 500], [0, 720, 390], [0, 0, 1]])
    T_a = look_at(np.array([6.0, -2.0, 1.5]), np.array([0.0, 0.2, 1.0]))
    T_b = look_at(np.array([-3.0, 5.5, 2.5]), np.array([0.3, -0.1, 0.8]))
    X = rng.uniform(-1, 1, size=(50, 3)) + [0, 0, 1]
    x_a, x_b = project(K_a, T_a, X), project(K_b, T_b, X)
    P_a, P_b = projection_matrix(K_a, T_a), projection_matrix(K_b, T_b)
    Y = triangulate_dlt(P_a, P_b, x_a, x_b)
    np.testing.assert_allclose(Y, X, atol=1e-8)
    err, depth = reprojection_error(P_a, Y, x_a)
    assert err.max() < 1e-6 and (depth > 0).all()
    # NaN in, NaN out
    x_a[3] = np.nan
    assert np.isnan(triangulate_dlt(P_a, P_b, x_a, x_b)[3]).all()


def test_clip_lines_to_image():
    # horizontal line y = 100 and diagonal x = y in a 640x480 image; a line outside the image
    seg = clip_lines(np.array([[0.0, 1.0, -100.0], [1.0, -1.0, 0.0], [0.0, 1.0, 1000.0]]), 640, 480)
    np.testing.assert_allclose(sorted(seg[0, :, 0]), [0, 639])
    np.testing.assert_allclose(seg[0, :, 1], [100, 100])
    np.testing.assert_allclose(sorted(seg[1, :, 0]), [0, 479])
    assert np.isnan(seg[2]).all()


def _clean_scene():
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=1, variable_rate=1, seconds=4.0,
                                          points_per_object=10, noise_px=0.0, wrong_fraction=0.0,
                                          pose_error_deg=0.0, no_match_pairs=0, all_wrong_pair=False,
                                          seed=5))
    return dataclasses.replace(scene.bundle, cameras=scene.true_cameras), scene


def test_epipolar_sweep_lines_meet_points_only_at_true_offset():
    bundle, _ = _clean_scene()
    gt = bundle.gt_offsets_s
    for a, b in (("cam0", "cam1"), ("cam0", "cam2")):  # static-static(vfr), static-moving
        true = gt[b] - gt[a]
        offsets = np.array([true - 0.2, true - 0.1, true, true + 0.1, true + 0.2])
        sw = epipolar_sweep(bundle, a, b, offsets, true, max_lines=40)
        with np.errstate(all="ignore"):
            med = np.array([np.nanmedian(d) if np.isfinite(d).any() else np.nan for d in sw.distance_px])
        assert med[2] < 0.5, med  # exact cameras, no noise: lines through the points (interpolation only)
        wrong = np.delete(med, 2)
        assert np.isfinite(wrong).sum() >= 2, med
        assert (wrong[np.isfinite(wrong)] > 5 * max(med[2], 0.1)).all(), med
        assert sw.segments.shape == (5, len(sw.points_a), 2, 2)


def test_trajectories_reproject_at_true_offsets_and_break_at_wrong_ones():
    bundle, _ = _clean_scene()
    gt = bundle.gt_offsets_s
    good = triangulate_pair(bundle, "cam0", "cam1", gt["cam0"], gt["cam1"], max_pairs=60)
    assert good.reprojection_px < 0.5
    kept_good = np.isfinite(good.points_world).all(-1).sum()
    assert kept_good > 100
    bad = triangulate_pair(bundle, "cam0", "cam1", gt["cam0"], gt["cam1"] + 0.4, max_pairs=60)
    kept_bad = np.isfinite(bad.points_world).all(-1).sum()
    assert kept_bad < 0.7 * kept_good  # a wrong offset makes rays miss: many points are dropped
