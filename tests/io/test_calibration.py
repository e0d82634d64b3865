"""Calibration import: caliscope TOML (real), JSON / anipose / Pose2Sim TOML written from it,
COLMAP text and binary models written by pycolmap, name mapping and the errors."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np  # noqa: I001  (before pycolmap)
import cv2
import pytest

from vs_inspect.errors import InputError
from vs_inspect.io.calibration import (fit_to_video, load_calibration, to_camera_track,
                                       undistort_points)

NAMES = ["cam_0", "cam_1", "cam_2", "cam_3"]


def _fmt(a) -> str:
    return json.dumps(np.asarray(a).tolist())


def _write_caliscope_style(path):
    """Four cameras in caliscope's [cameras.N] layout (for when the real file is absent)."""
    from vs_inspect.geometry.epipolar import look_at
    rng = np.random.default_rng(1)
    lines = []
    for i in range(4):
        ang = np.pi / 2 * i + 0.3
        T = look_at(np.array([1.2 * np.cos(ang), 1.2 * np.sin(ang), 0.4]), np.zeros(3))
        K = [[rng.uniform(600, 900), 0, 640 + rng.uniform(-20, 20)],
             [0, rng.uniform(600, 900), 360 + rng.uniform(-20, 20)], [0, 0, 1]]
        dist = [[-0.33, 0.046, -0.004, 0.004, 0.066], [0.18, -0.26, 0.003, 0.002, 0.12]][i % 2]
        lines += [f"[cameras.{i}]", f"cam_id = {i}", "size = [1280, 720]", f"matrix = {_fmt(K)}",
                  f"distortions = {_fmt(dist)}", f"translation = {_fmt(T[:3, 3])}",
                  f"rotation = {_fmt(T[:3, :3])}", ""]
    path.write_text("\n".join(lines))
    return path


@pytest.fixture(scope="module")
def caliscope(tmp_path_factory):
    """The real caliscope camera_array.toml when ../shared/data is there, else one in its format."""
    root = Path(os.environ.get("VS_INSPECT_DATA", Path(__file__).resolve().parents[3] / "shared" / "data"))
    path = root / "caliscope_post_optimization" / "camera_array.toml"
    if not path.is_file():
        path = _write_caliscope_style(tmp_path_factory.mktemp("cal") / "camera_array.toml")
    return path, load_calibration(path, NAMES)


def test_caliscope_toml(shared_data):
    path = shared_data / "caliscope_post_optimization" / "camera_array.toml"
    cals = load_calibration(path, NAMES)
    assert list(cals) == NAMES
    text = path.read_text()
    c0 = cals["cam_0"]
    # values straight from the file's [cameras.0] table
    assert c0.K[0, 0] == pytest.approx(903.550124089999)
    assert c0.dist[0] == pytest.approx(-0.3320992998866297)
    assert c0.cam_from_world[2, 3] == pytest.approx(1.208386461814154)
    assert c0.size == (1280, 720)
    assert "[cameras.0]" in text
    for cal in cals.values():
        R = cal.cam_from_world[:3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-6)
        track = to_camera_track(cal)
        assert not track.is_moving
        np.testing.assert_array_equal(track.K, cal.K)
    # the four cameras look at a common area about a metre away: centres are spread out
    centres = np.array([to_camera_track(c).centers()[0] for c in cals.values()])
    assert np.linalg.norm(centres - centres.mean(0), axis=1).min() > 0.2


def test_undistort_points_roundtrip(caliscope):
    """Undistorted points re-distorted by cv2.projectPoints land on the input pixels."""
    _, cals = caliscope
    rng = np.random.default_rng(0)
    for cal in cals.values():
        xy = rng.uniform([0, 0], [1280, 720], size=(7, 50, 2))
        xy[2, 5] = np.nan
        und = undistort_points(cal, xy)
        assert und.shape == xy.shape
        assert np.isnan(und[2, 5]).all() and np.isfinite(np.delete(und.reshape(-1, 2), 2 * 50 + 5, 0)).all()
        ok = np.isfinite(xy[..., 0])
        u = und[ok]
        norm = np.c_[(u - cal.K[:2, 2]) / np.diag(cal.K)[:2], np.ones(len(u))]
        back = cv2.projectPoints(norm, np.zeros(3), np.zeros(3), cal.K, cal.dist)[0].reshape(-1, 2)
        assert np.abs(back - xy[ok]).max() < 1e-6
        # distortion does move the points (the test is not trivially satisfied)
        assert np.abs(u - xy[ok]).max() > 1.0


def test_json_and_anipose_and_pose2sim_formats_agree(caliscope, tmp_path):
    _, cals = caliscope
    js = {n: {"K": c.K.tolist(), "dist": c.dist.tolist(), "cam_from_world": c.cam_from_world.tolist(),
              "size": list(c.size)} for n, c in cals.items()}
    (tmp_path / "cal.json").write_text(json.dumps(js))
    # anipose: [cam_0] tables with a name, Rodrigues rotation, and a [metadata] table
    lines = []
    for i, (n, c) in enumerate(cals.items()):
        rvec = cv2.Rodrigues(c.cam_from_world[:3, :3])[0].ravel()
        lines += [f"[cam_{i}]", f'name = "{n}"', f"size = {_fmt(c.size)}", f"matrix = {_fmt(c.K)}",
                  f"distortions = {_fmt(c.dist)}", f"rotation = {_fmt(rvec)}",
                  f"translation = {_fmt(c.cam_from_world[:3, 3])}", ""]
    lines += ["[metadata]", "adjusted = false", "error = 0.5"]
    (tmp_path / "anipose.toml").write_text("\n".join(lines))
    # Pose2Sim: [cam_01] ... names with two digits, 4 distortion coefficients, fisheye flag
    lines = []
    for i, (n, c) in enumerate(cals.items()):
        rvec = cv2.Rodrigues(c.cam_from_world[:3, :3])[0].ravel()
        lines += [f"[cam_{i + 1:02d}]", f'name = "cam_{i + 1:02d}"', f"size = {_fmt(c.size)}",
                  f"matrix = {_fmt(c.K)}", f"distortions = {_fmt(c.dist[:4])}",
                  f"rotation = {_fmt(rvec)}", f"translation = {_fmt(c.cam_from_world[:3, 3])}",
                  "fisheye = false", ""]
    (tmp_path / "pose2sim.toml").write_text("\n".join(lines))

    for fname, videos in (("cal.json", NAMES), ("anipose.toml", NAMES),
                          ("pose2sim.toml", ["cam1", "cam2", "cam3", "cam4"])):
        got = load_calibration(tmp_path / fname, videos[::-1])  # order of videos must not matter
        assert sorted(got) == sorted(videos)
        for v, n in zip(videos, NAMES):
            np.testing.assert_allclose(got[v].K, cals[n].K)
            np.testing.assert_allclose(got[v].cam_from_world, cals[n].cam_from_world, atol=1e-9)
            k = 4 if fname == "pose2sim.toml" else 5
            np.testing.assert_allclose(got[v].dist[:k], cals[n].dist[:k])
            assert got[v].size == (1280, 720)


def test_name_mapping_and_mismatch_errors(caliscope):
    path, cals = caliscope
    # names containing the camera name as whole tokens; cam0 == cam_0
    got = load_calibration(path, ["take2_cam_3", "cam0", "left_cam_1"])
    np.testing.assert_array_equal(got["cam0"].K, cals["cam_0"].K)
    np.testing.assert_array_equal(got["take2_cam_3"].K, cals["cam_3"].K)
    # no names match, same count: by order
    by_order = load_calibration(path, ["w", "x", "y", "z"])
    np.testing.assert_array_equal(by_order["y"].K, cals["cam_2"].K)
    with pytest.raises(InputError, match=r"4 cameras for 2 videos.*cam_0.*videos: \['a', 'b'\]"):
        load_calibration(path, ["a", "b"])
    with pytest.raises(InputError, match=r"cam_7"):
        load_calibration(path, ["cam_0", "cam_7"])
    with pytest.raises(InputError, match="same camera"):
        load_calibration(path, ["cam_0", "old_cam_0"])


def test_resolution_check(caliscope):
    path, cals = caliscope
    half = load_calibration(path, ["cam_0"], video_sizes={"cam_0": (640, 360)})["cam_0"]
    K = cals["cam_0"].K
    assert half.K[0, 0] == pytest.approx(K[0, 0] / 2)
    assert half.K[0, 2] == pytest.approx((K[0, 2] + 0.5) / 2 - 0.5)
    assert half.size == (640, 360)
    # the same physical ray: a point scaled with the image maps to the same normalized coordinate
    p_full = np.array([[1000.0, 600.0]])
    p_half = (p_full + 0.5) / 2 - 0.5
    n_full = cv2.undistortPoints(p_full[None], K, cals["cam_0"].dist).ravel()
    n_half = cv2.undistortPoints(p_half[None], half.K, half.dist).ravel()
    np.testing.assert_allclose(n_full, n_half, atol=1e-9)
    with pytest.raises(InputError, match="calibration for other cameras"):
        load_calibration(path, ["cam_0"], video_sizes={"cam_0": (640, 480)})
    assert fit_to_video(cals["cam_0"], 1280, 720) is cals["cam_0"]


def test_bad_values(tmp_path):
    good = {"K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]], "cam_from_world": np.eye(4).tolist()}
    cases = {
        "singular": ({**good, "K": [[0, 0, 320], [0, 500, 240], [0, 0, 1]]}, "singular"),
        "nan": ({**good, "dist": [0.1, float("nan"), 0, 0]}, "NaN"),
        "shape": ({**good, "K": [[500, 0], [0, 500]]}, "3x3"),
        "rot": ({**good, "cam_from_world": (2 * np.eye(4)).tolist()}, "rigid"),
        "ndist": ({**good, "dist": [0.1, 0.2, 0.3]}, "distortion coefficients"),
    }
    for name, (entry, msg) in cases.items():
        p = tmp_path / f"{name}.json"
        p.write_text(json.dumps({"v": entry}, allow_nan=True))
        with pytest.raises(InputError, match=msg):
            load_calibration(p, ["v"])
    (tmp_path / "bad.toml").write_text("[cam_0\nmatrix = 3")
    with pytest.raises(InputError, match="not valid TOML"):
        load_calibration(tmp_path / "bad.toml", ["v"])
    (tmp_path / "cal.yaml").write_text("a: 1")
    with pytest.raises(InputError, match="unknown calibration format"):
        load_calibration(tmp_path / "cal.yaml", ["v"])
    with pytest.raises(InputError, match="no such"):
        load_calibration(tmp_path / "missing.toml", ["v"])
    # no distortion given: zeros, and undistortion leaves points alone
    (tmp_path / "plain.json").write_text(json.dumps({"v": good}))
    cal = load_calibration(tmp_path / "plain.json", ["v"])["v"]
    assert not cal.dist.any()
    xy = np.array([[[1.0, 2.0], [np.nan, np.nan]]])
    np.testing.assert_array_equal(undistort_points(cal, xy), xy)


def test_colmap_text_and_binary(tmp_path):
    import pycolmap

    opts = pycolmap.SyntheticDatasetOptions()
    opts.num_rigs, opts.num_cameras_per_rig, opts.num_frames_per_rig = 3, 1, 1
    opts.num_points3D = 40
    opts.camera_model_id = pycolmap.CameraModelId.OPENCV
    opts.camera_width, opts.camera_height = 1000, 800
    opts.camera_params = [900.0, 880.0, 500.0, 390.0, 0.05, -0.02, 0.001, -0.002]
    rec = pycolmap.synthesize_dataset(opts)
    for i, im in enumerate(sorted(rec.images.values(), key=lambda im: im.image_id)):
        im.name = f"cam{i}.png"
    for sub, write in (("txt", rec.write_text), ("bin", rec.write_binary)):
        (tmp_path / sub).mkdir()
        write(str(tmp_path / sub))
        cals = load_calibration(tmp_path / sub, ["cam_2", "cam_0", "cam_1"])
        assert sorted(cals) == ["cam_0", "cam_1", "cam_2"]
        for v, cal in cals.items():
            im = rec.find_image_with_name(f"cam{v[-1]}.png")
            assert cal.size == (1000, 800)
            np.testing.assert_allclose(cal.dist[:4], [0.05, -0.02, 0.001, -0.002])
            # every 3D point projects (OpenCV, pixel centres at integers) where COLMAP projects it
            # (pixel centres at +0.5)
            X = np.array([rec.points3D[p.point3D_id].xyz for p in im.points2D if p.has_point3D()])
            assert len(X) > 5
            T = cal.cam_from_world
            uv = cv2.projectPoints(X, cv2.Rodrigues(T[:3, :3])[0], T[:3, 3], cal.K, cal.dist)[0].reshape(-1, 2)
            ref = np.array([im.project_point(x) for x in X]) - 0.5
            np.testing.assert_allclose(uv, ref, atol=1e-6)
    with pytest.raises(InputError, match="3 cameras for 2 videos"):
        load_calibration(tmp_path / "bin", ["x", "y"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="COLMAP model"):
        load_calibration(tmp_path / "empty", ["x"])


def test_undistort_outside_model_is_nan(tmp_path):
    """r_d = r (1 - 0.6 r²) peaks at r_d = 0.497: farther distorted radii have no preimage."""
    entry = {"K": [[300, 0, 640], [0, 300, 360], [0, 0, 1]], "dist": [-0.6, 0, 0, 0, 0],
             "cam_from_world": np.eye(4).tolist()}
    (tmp_path / "c.json").write_text(json.dumps({"v": entry}))
    cal = load_calibration(tmp_path / "c.json", ["v"])["v"]
    xy = np.array([[640.0 + 0.45 * 300, 360.0], [640.0 + 0.55 * 300, 360.0], [0.0, 0.0]])
    und = undistort_points(cal, xy)
    assert np.isfinite(und[0]).all() and np.isnan(und[1:]).all()
    r = (und[0, 0] - 640) / 300  # the preimage really distorts back to 0.45
    assert r * (1 - 0.6 * r * r) == pytest.approx(0.45, abs=1e-9)


def test_real_corners_sync_with_imported_calibration(shared_data):
    """Real data end to end through this module: caliscope's ChArUco corners (real tracks,
    matched by corner id) undistorted with the imported calibration, leading frames cut to make
    known offsets; the sync must land within 1/4 frame (median) — and undistortion must matter."""
    import csv

    from vs_inspect.io.video import open_video
    from vs_inspect.sync.config import SyncConfig
    from vs_inspect.pipeline.stage12 import sync_bundle
    from vs_inspect.types import CueBundle, TrackPairs, Tracks, VideoInfo

    d = shared_data / "caliscope_post_optimization"
    ext = d / "calibration" / "extrinsic"
    cals = load_calibration(d / "camera_array.toml", NAMES)
    frame_time: dict[str, dict[int, float]] = {n: {} for n in NAMES}
    with open(ext / "timestamps.csv") as f:
        for r in csv.DictReader(f):
            frame_time[f"cam_{r['cam_id']}"][int(r["sync_index"])] = float(r["frame_time"])
    order = {n: sorted(frame_time[n]) for n in NAMES}  # frame k of cam_N.mp4 = k-th sync_index
    with open(ext / "xy.csv") as f:
        rows = list(csv.DictReader(f))
    ids = sorted({int(r["keypoint_id"]) for r in rows})
    infos = {n: open_video(ext / f"{n}.mp4").info for n in NAMES}
    xy = {n: np.full((len(ids), infos[n].num_frames, 2), np.nan) for n in NAMES}
    for r in rows:
        n = f"cam_{r['cam_id']}"
        k = order[n].index(int(r["sync_index"]))
        xy[n][ids.index(int(r["keypoint_id"])), k] = [float(r["img_loc_x"]), float(r["img_loc_y"])]
    cuts = dict(zip(NAMES, (0, 3, 7, 12)))  # leading frames removed from each video
    t0 = {n: frame_time[n][order[n][cuts[n]]] for n in NAMES}
    gt = {n: t0[n] - t0["cam_0"] for n in NAMES}
    ident = np.stack([np.arange(len(ids))] * 2, axis=1)
    pairs = {(a, b): TrackPairs(a, b, ident) for i, a in enumerate(NAMES) for b in NAMES[i + 1:]}

    def errors_ms(undistort: bool) -> np.ndarray:
        videos = tuple(VideoInfo.constant_rate(n, 1280, 720, infos[n].num_frames - cuts[n],
                                               infos[n].fps) for n in NAMES)
        tracks = {n: Tracks(undistort_points(cals[n], xy[n][:, cuts[n]:]) if undistort
                            else xy[n][:, cuts[n]:].copy()) for n in NAMES}
        cams = {n: to_camera_track(cals[n]) for n in NAMES}
        res = sync_bundle(CueBundle(videos, cams, tracks, pairs), SyncConfig(), progress=False)
        assert all(res.offsets_s[n] is not None for n in NAMES), res.unresolved_reason
        return np.array([1000 * (res.offsets_s[n] - gt[n]) for n in NAMES[1:]])

    frame_ms = 1000 / infos["cam_0"].fps
    err = errors_ms(undistort=True)
    assert np.median(np.abs(err)) <= frame_ms / 4, err
    assert np.abs(err).max() <= frame_ms / 2, err
    raw = errors_ms(undistort=False)
    assert np.median(np.abs(raw)) > np.median(np.abs(err)), (raw, err)


def test_json_per_frame_poses_of_a_moving_camera(tmp_path):
    """A hand-held camera's cam_from_world may be a list of 4x4, one per frame."""
    import json

    import numpy as np

    from vs_inspect.geometry.epipolar import look_at
    from vs_inspect.io.calibration import load_calibration, to_camera_track

    poses = [look_at([5.0, 0.1 * k, 1.5], [0, 0, 1]).tolist() for k in range(6)]
    K = [[500.0, 0, 320], [0, 480, 240], [0, 0, 1]]
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({"static": {"K": K, "cam_from_world": poses[0]},
                                "handheld": {"K": K, "cam_from_world": poses}}))
    cal = load_calibration(path, ["static", "handheld"])
    assert cal["static"].cam_from_world.shape == (4, 4)
    assert cal["handheld"].cam_from_world.shape == (6, 4, 4)
    track = to_camera_track(cal["handheld"])
    assert track.is_moving and track.num_pose_frames == 6
    bad = [p for p in poses]
    bad[3] = np.diag([2.0, 1, 1, 1]).tolist()
    path.write_text(json.dumps({"static": {"K": K, "cam_from_world": poses[0]},
                                "handheld": {"K": K, "cam_from_world": bad}}))
    import pytest

    from vs_inspect.errors import InputError
    with pytest.raises(InputError, match="handheld"):
        load_calibration(path, ["static", "handheld"])
