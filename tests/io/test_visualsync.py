"""import-visualsync: files in the paper tools' formats, written here from a synthetic cue scene,
imported into a bundle that then synchronizes to the true offsets."""

from __future__ import annotations

import os
import pickle
import shutil

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.errors import InputError
from vs_inspect.io.bundle import read_bundle
from vs_inspect.io.video import VideoWriter
from vs_inspect.io.visualsync import ImportConfig, import_visualsync, load_pickle_restricted
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.sync.config import SyncConfig
from vs_inspect.pipeline.stage12 import sync_bundle

FPS = 25.0
STATIC_TOL_FRAMES = 0.25  # static cameras with 0.5° pose error, 0.8 px noise, 25 % wrong pairs
MOVING_TOL_FRAMES = 0.5  # the hand-held camera (per-frame poses, 3 of them invalid)


@pytest.fixture(scope="module")
def scene():
    cfg = CueSceneConfig(cameras=4, moving=1, variable_rate=1, seconds=4.0, max_offset_s=1.0,
                         fps_choices=(FPS,), no_match_pairs=0, all_wrong_pair=False,
                         points_per_object=25, pairs_per_view_pair=200, seed=5)
    return make_cue_scene(cfg)


def write_layout(scene, root, torch_for=()):
    """Write the scene's cues the way the paper's tools leave them on disk."""
    b = scene.bundle
    for v in b.videos:
        d = root / v.name
        d.mkdir(parents=True)
        xy = b.tracks[v.name].xy  # (N,T,2) NaN where unseen
        seen = np.isfinite(xy[..., 0]).T  # (T,N)
        pred = np.nan_to_num(xy.transpose(1, 0, 2), nan=0.0).astype(np.float32)  # (T,N,2)
        if v.name in torch_for:
            torch = pytest.importorskip("torch")
            data = {"pred_tracks": torch.from_numpy(pred)[None],  # (1,T,N,2) like CoTracker
                    "pred_visibilities": torch.from_numpy(seen)[None]}
        elif v.name == b.videos[0].name:
            data = {"pred_tracks": pred, "pred_valid": seen}
        else:  # visibility as a probability
            data = {"pred_tracks": pred, "pred_visibilities": np.where(seen, 0.9, 0.1).astype(np.float32)}
        with open(d / "tracks.pkl", "wb") as f:
            pickle.dump(data, f)
        cam = b.cameras[v.name]
        T = v.num_frames
        cfw = cam.pose_at(np.arange(T))
        c2w = np.linalg.inv(cfw).astype(np.float32)
        K = cam.K_at(np.arange(T)).astype(np.float32)
        valid = np.ones(T, bool)
        if cam.is_moving:
            valid[[3, 4, T - 1]] = False
            c2w[[3, 4, T - 1]] = np.nan  # what a failed frame may hold
        np.savez(d / "camera_parameters.npz", c2w=c2w, K=K, valid=valid)
        if v.fps is None:  # variable frame rate: the video file carries the frame times
            with VideoWriter(d / "clip.mp4", v.width, v.height, 30.0, preset="ultrafast") as vw:
                blank = np.zeros((v.height, v.width, 3), np.uint8)
                for t in v.timestamps_s:
                    vw.write(blank, t)
    (root / "pairs").mkdir()
    for (a, bb), tp in b.pairs.items():
        np.savez(root / "pairs" / f"{a}__{bb}.npz", filtered_corr_indices=tp.index)


@pytest.fixture(scope="module")
def layout(scene, tmp_path_factory):
    root = tmp_path_factory.mktemp("visualsync") / "vs"
    write_layout(scene, root, torch_for=("cam2",))
    return root


def copy_layout(layout, tmp_path):
    return shutil.copytree(layout, tmp_path / "vs")


def test_import_and_sync_recovers_offsets(scene, layout):
    orig = scene.bundle
    bundle = import_visualsync(layout, ImportConfig(fps=FPS))
    assert bundle.names == orig.names
    for v in orig.videos:
        got = bundle.video(v.name)
        assert got.num_frames == v.num_frames
        np.testing.assert_allclose(got.timestamps_s, v.timestamps_s, atol=1e-4)
        a, b = orig.tracks[v.name].xy, bundle.tracks[v.name].xy
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(b, a, atol=1e-3, equal_nan=True)  # float32 on disk
        cam, cam0 = bundle.cameras[v.name], orig.cameras[v.name]
        assert cam.is_moving == cam0.is_moving
        if cam.is_moving:
            assert cam.valid is not None and not cam.valid[3] and cam.valid[5]
            np.testing.assert_allclose(cam.cam_from_world[5], cam0.cam_from_world[5], atol=1e-4)
        else:
            np.testing.assert_allclose(cam.cam_from_world, cam0.cam_from_world, atol=1e-4)
    assert set(bundle.pairs) == set(orig.pairs)

    res = sync_bundle(bundle, SyncConfig(), progress=False)
    ref = res.reference
    frame = 1.0 / FPS
    for v, gt in orig.gt_offsets_s.items():
        est = res.offsets_s[v]
        assert est is not None, f"{v}: {res.unresolved_reason.get(v)}"
        true_rel = gt - orig.gt_offsets_s[ref]
        tol = MOVING_TOL_FRAMES if bundle.cameras[v].is_moving else STATIC_TOL_FRAMES
        assert abs(est - true_rel) < tol * frame, (v, est, true_rel)


def test_cli_writes_bundle(scene, layout, tmp_path):
    out = tmp_path / "bundle"
    assert main(["import-visualsync", str(layout), "--out", str(out), "--fps", str(FPS)]) == 0
    b = read_bundle(out)
    assert b.names == scene.bundle.names
    assert sum(c.is_moving for c in b.cameras.values()) == 1
    # without --fps a video folder lacking a video file has no clock: clear error, exit 2
    assert main(["import-visualsync", str(layout), "--out", str(tmp_path / "b2")]) == 2


class _Evil:
    def __reduce__(self):
        return (os.system, ("touch pwned_marker",))


def test_restricted_unpickler_refuses_code(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "tracks.pkl"
    p.write_bytes(pickle.dumps({"pred_tracks": _Evil()}))
    with pytest.raises(InputError, match="refused to load"):
        load_pickle_restricted(p)
    assert not (tmp_path / "pwned_marker").exists()
    ok = tmp_path / "ok.pkl"
    ok.write_bytes(pickle.dumps({"pred_tracks": np.zeros((2, 3, 2)), "x": np.float32(1)}))
    assert load_pickle_restricted(ok)["pred_tracks"].shape == (2, 3, 2)


def test_bad_layouts(scene, layout, tmp_path):
    root = copy_layout(layout, tmp_path)
    np.savez(root / "pairs" / "cam0__nobody.npz", filtered_corr_indices=np.zeros((1, 2), int))
    with pytest.raises(InputError, match="nobody"):
        import_visualsync(root, ImportConfig(fps=FPS))
    (root / "pairs" / "cam0__nobody.npz").unlink()
    n1 = scene.bundle.tracks["cam1"].num_tracks
    np.savez(root / "pairs" / "cam0__cam1.npz", filtered_corr_indices=np.array([[0, n1]]))
    with pytest.raises(InputError, match="out of range"):
        import_visualsync(root, ImportConfig(fps=FPS))
    with open(root / "cam1" / "tracks.pkl", "wb") as f:
        pickle.dump({"pred_tracks": np.zeros((5, 3))}, f)
    with pytest.raises(InputError, match=r"shape \(T,N,2\)"):
        import_visualsync(root, ImportConfig(fps=FPS))
    with pytest.raises(InputError, match="no video folders"):
        import_visualsync(tmp_path, ImportConfig(fps=FPS))


def test_import_with_calibration_instead_of_vggt(scene, layout, tmp_path):
    import json

    from vs_inspect.io.calibration import load_calibration, undistort_points
    b = scene.bundle
    cal = {v.name: {"K": b.cameras[v.name].K_at([0])[0].tolist(),
                    "dist": [0.05, -0.01, 0.0, 0.0, 0.0] if v.name == "cam0" else [],
                    "cam_from_world": b.cameras[v.name].pose_at([0])[0].tolist(),
                    "size": [v.width, v.height]} for v in b.videos}
    (tmp_path / "cal.json").write_text(json.dumps(cal))
    out = tmp_path / "bundle"
    assert main(["import-visualsync", str(layout), "--out", str(out), "--fps", str(FPS),
                 "--calib", str(tmp_path / "cal.json")]) == 0
    got = read_bundle(out)
    assert not any(c.is_moving for c in got.cameras.values())
    cals = load_calibration(tmp_path / "cal.json", b.names)
    want = undistort_points(cals["cam0"], b.tracks["cam0"].xy)
    np.testing.assert_allclose(got.tracks["cam0"].xy, want, atol=1e-3)
    assert np.nanmax(np.abs(want - b.tracks["cam0"].xy)) > 1.0  # the distortion was removed
    np.testing.assert_allclose(got.tracks["cam2"].xy, b.tracks["cam2"].xy, atol=1e-3)
