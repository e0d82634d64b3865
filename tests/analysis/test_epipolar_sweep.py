"""The epipolar offset sweep: lines pass through the points only at the true offset."""

from __future__ import annotations

import numpy as np

from vs_inspect.analysis.epipolar_sweep import epipolar_sweep


def test_epipolar_sweep_lines_meet_points_only_at_true_offset(clean_bundle):
    bundle = clean_bundle
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
