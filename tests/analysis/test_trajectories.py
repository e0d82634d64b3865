"""Trajectories of a run: triangulated at the true offsets they reproject, at a wrong one they
break; the recording and the report get the same segments from run_trajectories."""

from __future__ import annotations

import numpy as np

from vs_inspect.analysis.trajectories import (MIN_SEGMENT_SAMPLES, run_trajectories, split_segments,
                                              triangulate_pair)


def test_trajectories_reproject_at_true_offsets_and_break_at_wrong_ones(clean_bundle):
    bundle = clean_bundle
    gt = bundle.gt_offsets_s
    good = triangulate_pair(bundle, "cam0", "cam1", gt["cam0"], gt["cam1"], max_tracks=60)
    assert good.reprojection_px < 0.5
    kept_good = np.isfinite(good.points_world).all(-1).sum()
    assert kept_good > 100
    assert good.points_world.shape[:2] == (60, bundle.video("cam0").num_frames)
    np.testing.assert_allclose(good.time_s, bundle.video("cam0").timestamps_s + gt["cam0"])
    bad = triangulate_pair(bundle, "cam0", "cam1", gt["cam0"], gt["cam1"] + 0.4, max_tracks=60)
    kept_bad = np.isfinite(bad.points_world).all(-1).sum()
    assert kept_bad < 0.7 * kept_good  # a wrong offset makes rays miss: many points are dropped


def test_every_finite_point_lies_in_exactly_one_segment(clean_bundle):
    bundle = clean_bundle
    gt = bundle.gt_offsets_s
    tj = triangulate_pair(bundle, "cam0", "cam2", gt["cam0"], gt["cam2"], max_tracks=40)  # moving cam2
    covered = np.zeros(tj.points_world.shape[:2], int)
    for sg in tj.segments:
        assert sg.stop - sg.start >= MIN_SEGMENT_SAMPLES
        covered[sg.track, sg.start:sg.stop] += 1
    np.testing.assert_array_equal(covered, np.isfinite(tj.points_world).all(-1).astype(int))


def test_split_segments_cuts_at_gaps_and_jumps_and_drops_short_runs():
    X = np.zeros((1, 20, 3))
    X[0, :, 0] = np.arange(20.0)  # unit steps along x
    X[0, 12:, 0] += 100.0  # a jump between frames 11 and 12
    X[0, 6, :] = np.nan  # a gap at frame 6: frames 0-5 and 7-11
    Y, segs = split_segments(X)
    assert [(s.start, s.stop) for s in segs] == [(0, 6), (7, 12), (12, 20)]
    X[0, 3, :] = np.nan  # now 0-2 and 4-5 are too short
    Y, segs = split_segments(X)
    assert [(s.start, s.stop) for s in segs] == [(7, 12), (12, 20)]
    assert np.isnan(Y[0, :7]).all() and np.isfinite(Y[0, 7:]).all()


def test_run_trajectories_orders_by_contrast_and_skips_unsolved(clean_bundle):
    bundle = clean_bundle
    gt = dict(bundle.gt_offsets_s)
    accepted = [("cam0", "cam1", 0.2), ("cam0", "cam2", 0.9), ("cam1", "cam2", 0.5)]
    out = run_trajectories(bundle, accepted, gt, max_video_pairs=2, max_tracks=30)
    assert [(t.a, t.b) for t in out] == [("cam0", "cam2"), ("cam1", "cam2")]
    gt["cam2"] = None
    out = run_trajectories(bundle, accepted, gt, max_video_pairs=2, max_tracks=30)
    assert [(t.a, t.b) for t in out] == [("cam0", "cam1")]
