"""The drone dataset importer: detections, calibration and the README's ground truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vs_inspect.io.bundle import read_bundle
from vs_inspect.io.drone import (gt_from_tables, import_drone, pair_time_model, parse_gt_tables,
                                 read_gt_drift_ppm, read_pose_free, write_drone_bundle)

README_TABLES = """
### Time scale (alpha)
|Ref. camera | 0 | 1 | 2 |
| --- | --- | --- | --- |
| 0 | 1.0000 |0.5005 |0.4171 |
| 1 | 1.9982 |1.0000 |0.8333 |
| 2 | 2.3978 |1.2000 |1.0000 |

### Time shift (beta)
|Ref. camera | 0 | 1 | 2 |
| --- | --- | --- | --- |
| 0 | 0.00 |1013.95 |251.16 |
| 1 | -2026.04 |0.00 |-593.82 |
| 2 | -602.21 |712.57 |0.00 |
"""


def _local_frame(gt_offset_s, drift, fps, g):
    """1-based frame number a camera shows at global time g under its time model."""
    return 1 + (g - gt_offset_s) / (1 + drift) * fps


def test_pair_time_model_reproduces_the_frame_mapping():
    # README row 0: frame i of cam0 (59.94 fps) is frame 0.5005 i + 1013.95 of cam1 (30 fps)
    fps0, fps1 = 59.940060, 30.0
    offset_s, drift = pair_time_model(0.5005, 1013.95, fps0, fps1)
    for i in (1.0, 777.0, 30000.0):
        g = (i - 1) / fps0  # the reference's local time is global time
        assert _local_frame(offset_s, drift, fps1, g) == pytest.approx(0.5005 * i + 1013.95, abs=1e-9)
    # cam1 started about 33.8 s before cam0 (frame 1 of cam0 is frame ~1014.5 of cam1)
    assert offset_s == pytest.approx(-(1013.95 + 0.5005 - 1) / (0.5005 * fps0))
    assert drift * 1e6 == pytest.approx((fps1 / (0.5005 * fps0) - 1) * 1e6)


def test_tables_parse_and_rows_agree_within_rounding():
    alpha, beta = parse_gt_tables(README_TABLES)
    assert alpha.shape == beta.shape == (3, 3)
    assert alpha[2, 0] == 2.3978 and beta[1, 2] == -593.82
    gt = gt_from_tables(["cam0", "cam1", "cam3"], {"cam0": 59.940060, "cam1": 30.0, "cam3": 25.0}, alpha, beta)
    assert gt.offsets_s["cam0"] == 0.0 and gt.drift_ppm["cam0"] == 0.0
    o, d = pair_time_model(0.4171, 251.16, 59.940060, 25.0)
    assert gt.offsets_s["cam3"] == pytest.approx(o) and gt.drift_ppm["cam3"] == pytest.approx(d * 1e6)
    # the other rows predict frames within a few frames over 10,000 (4-digit alphas)
    assert 0 < gt.row_inconsistency_frames < 5


@pytest.fixture(scope="module")
def drone_dir(shared_data):
    d = shared_data / "drone_tracking_dataset3"
    if not (d / "detections").is_dir():
        pytest.skip(f"drone dataset not found at {d}")
    return d


def test_import_real_dataset(drone_dir, tmp_path):
    bundle, gt = import_drone(drone_dir)
    assert bundle.names == [f"cam{k}" for k in range(6)]
    v0, v3 = bundle.video("cam0"), bundle.video("cam3")
    assert (v0.fps, v0.width, v0.height, v0.num_frames) == (59.94006, 1920, 1080, 33875)
    assert (v3.fps, v3.width, v3.num_frames) == (25.0, 1440, 14196)
    assert bundle.tracks["cam2"].xy.shape == (1, 17166, 2)
    assert len(bundle.pairs) == 15 and bundle.pair("cam0", "cam5").index.tolist() == [[0, 0]]
    # row "1.000000 742.82211823 897.10093596" of cam0, undistorted: the GoPro's barrel
    # distortion pushes a point below-left of the centre further out once removed
    x0 = bundle.tracks["cam0"].xy[0, 0]
    assert x0[0] < 742.8 and x0[1] > 897.1
    # "0 0" rows are unseen; cam2's repeated frame 12770 keeps its detection
    assert np.isnan(bundle.tracks["cam1"].xy[0, 0]).all()
    assert np.isfinite(bundle.tracks["cam2"].xy[0, 12770 - 1]).all()
    # ground truth from the README's row 0, checked against its cam1 and cam5 entries
    for name, alpha, beta, fps in (("cam1", 0.5005, 1013.95, 30.0), ("cam5", 0.8341, 137.51, 50.0)):
        for i in (1.0, 20000.0):
            g = (i - 1) / 59.940060
            j = _local_frame(gt.offsets_s[name], gt.drift_ppm[name] * 1e-6, fps, g)
            assert j == pytest.approx(alpha * i + beta, abs=1e-6)

    out = write_drone_bundle(bundle, gt, tmp_path / "b")
    back = read_bundle(out)  # the v1 reader reads it (pose_free and drift_ppm are optional keys)
    assert back.names == bundle.names and back.gt_offsets_s == pytest.approx(gt.offsets_s)
    assert read_pose_free(out) == set(bundle.names)
    assert read_gt_drift_ppm(out) == pytest.approx(gt.drift_ppm)
    meta = json.loads((out / "bundle.json").read_text())
    assert meta["version"] == 1
    np.testing.assert_array_equal(back.cameras["cam4"].cam_from_world, np.eye(4))


def test_import_drone_command(drone_dir, tmp_path, capsys):
    from vs_inspect.cli import main

    out = tmp_path / "bundle"
    assert main(["import-drone", str(drone_dir), "--out", str(out)]) == 0
    assert "6 pose-free cameras" in capsys.readouterr().out
    assert read_pose_free(out) == {f"cam{k}" for k in range(6)}
    assert main(["import-drone", str(drone_dir), "--out", str(out)]) == 2  # exists, no --overwrite
    assert main(["import-drone", str(tmp_path / "nothing"), "--out", str(tmp_path / "b2")]) == 2
