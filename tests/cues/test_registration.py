"""Per-frame registration of a moving camera against the reconstruction (cues/cameras/registration.py)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np  # noqa: I001  (numpy before pycolmap)
import pytest

from vs_inspect.cues.cameras.registration import (Keyframe, affine_sift, colmap_sift, frame_features, register_frames)
from vs_inspect.geometry.epipolar import look_at
from vs_inspect.signals import import_pycolmap

from .scenes import texture

CLIP = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "visualsync_clips" / "fencing1" \
    / "fencing_aria01_3_138_2.mp4"


@pytest.mark.skipif(not CLIP.exists(), reason="needs ../shared/data/visualsync_clips")
def test_opencv_sift_converted_matches_colmaps_own_descriptors():
    """On a real frame, OpenCV's SIFT in COLMAP's L1-root form finds COLMAP's own features: ratio
    matches land on the keypoint COLMAP found there."""
    pycolmap = import_pycolmap()
    cap = cv2.VideoCapture(str(CLIP))
    ok, img = cap.read()
    assert ok
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    opt = pycolmap.FeatureExtractionOptions()
    opt.num_threads = 1
    kp_c, d_c = pycolmap.FeatureExtractor.create(opt, pycolmap.Device.cpu).extract_from_uint8_array(grey)
    xy_c = np.array([[k.x, k.y] for k in kp_c])  # COLMAP: pixel centres at +0.5
    d_c = np.asarray(d_c.data).astype(np.float32)  # the database's uint8 values
    ff = frame_features(grey[None], None, np.array([0]), (1.0, 1.0), 4096)
    assert ff.desc[0].dtype == np.uint8 and len(ff.desc[0]) > 100
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(ff.desc[0].astype(np.float32), d_c, k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < 0.8 * p[1].distance]
    dist = np.array([np.linalg.norm(ff.xy_full[0][m.queryIdx] + 0.5 - np.asarray(xy_c)[m.trainIdx, :2])
                     for m in good])
    assert len(good) > 100 and np.mean(dist < 2.0) > 0.9, (len(good), np.mean(dist < 2.0))
    # without the conversion (OpenCV's L2 form) the same descriptors match far worse
    raw = cv2.SIFT_create(4096, contrastThreshold=0.02).detectAndCompute(grey, None)[1]
    assert np.abs(colmap_sift(raw).astype(float) - raw).mean() > 5.0


def _floor_view(floor: np.ndarray, heading_deg: float, squash: float) -> np.ndarray:
    """(3,3) homography floor px -> 320x240 image px: the floor turned by heading_deg about its
    centre and squashed vertically by 1/squash (a camera looking at it from low down)."""
    c = floor.shape[0] / 2
    a = np.radians(heading_deg)
    turn = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    centre = np.array([[1, 0, -c], [0, 1, -c], [0, 0, 1.0]])
    return np.array([[0.6, 0, 160], [0, 0.6 / squash, 120], [0, 0, 1]]) @ turn @ centre


def _correct_ratio_matches(xa, da, xb, db, a_to_b: np.ndarray) -> int:
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(da.astype(np.float32), db.astype(np.float32), k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < 0.8 * p[1].distance]
    if not good:
        return 0
    pa = np.array([xa[m.queryIdx] for m in good], np.float64)
    pb = np.array([xb[m.trainIdx] for m in good], np.float64)
    return int((np.linalg.norm(cv2.perspectiveTransform(pa[None], a_to_b)[0] - pb, axis=1) < 3.0).sum())


def test_affine_sift_matches_a_floor_seen_from_another_heading_where_sift_does_not():
    """Two cameras 90° apart in heading, looking at one floor from low down: it is foreshortened
    along different directions in their images. SIFT's matches there are wrong; ASIFT's simulated
    tilts find the same floor points. Its mask holds, its descriptors are COLMAP's form, and the
    same image gives the same features."""
    floor = texture(480, 480, seed=3)
    ha, hb = _floor_view(floor, 0, 3.0), _floor_view(floor, 90, 3.0)
    a, b = (cv2.warpPerspective(floor, h, (320, 240)) for h in (ha, hb))
    a_to_b = hb @ np.linalg.inv(ha)
    sift = cv2.SIFT_create(3000, contrastThreshold=0.02)
    (ka, da), (kb, db) = sift.detectAndCompute(a, None), sift.detectAndCompute(b, None)
    plain = _correct_ratio_matches(np.array([k.pt for k in ka]), colmap_sift(da),
                                   np.array([k.pt for k in kb]), colmap_sift(db), a_to_b)
    (xa, dsa), (xb, dsb) = affine_sift(a, None, 100), affine_sift(b, None, 100)
    simulated = _correct_ratio_matches(xa, dsa, xb, dsb, a_to_b)
    assert plain < 10 and simulated > 50, (plain, simulated)
    assert xa.dtype == np.float32 and dsa.dtype == np.uint8 and dsa.shape == (len(xa), 128)
    root = dsa.astype(float) / 512.0  # L1-root: the squares of a descriptor sum to about 1
    assert np.all(np.abs((root ** 2).sum(1) - 1) < 0.05)
    again = affine_sift(a, None, 100)
    np.testing.assert_array_equal(again[0], xa)
    np.testing.assert_array_equal(again[1], dsa)
    mask = np.full(a.shape, 255, np.uint8)
    mask[:, 160:] = 0
    masked, _ = affine_sift(a, mask, 100)
    assert len(masked) > 100 and masked[:, 0].max() < 161


def _opencv_ratio_matches(q, kf, ratio=0.8):
    """The brute-force matcher's ratio matches, as ratio_matches returned them before its BLAS path."""
    good = [p[0] for p in cv2.BFMatcher(cv2.NORM_L2).knnMatch(q, kf, k=2)
            if len(p) == 2 and p[0].distance < ratio * p[1].distance]
    return (np.array([[m.queryIdx, m.trainIdx] for m in good], int).reshape(-1, 2),
            np.array([m.distance for m in good], float))


def test_ratio_matches_are_opencvs_brute_force_matches_bit_for_bit():
    """SIFT's uint8 descriptors take one BLAS product instead of OpenCV's brute-force matcher; the
    matches and their distances must be the matcher's exactly (exact ties, which the ratio test
    drops; ratios at the bar), and descriptors where the product would not be exact keep the
    matcher."""
    from vs_inspect.cues.cameras.registration import _exact_two_nearest, ratio_matches

    rng = np.random.default_rng(5)

    def sift_like(n):
        return colmap_sift(rng.gamma(0.5, 1.0, (n, 128)) ** 2).astype(np.float32)

    q = sift_like(900)
    near = np.clip(q[:300] + rng.integers(-3, 4, (300, 128)), 0, 255)  # true matches, a little off
    kf = np.concatenate([sift_like(500), near, near[:40], q[300:340]]).astype(np.float32)  # ties, exact
    kf[7] = kf[8]
    big = rng.integers(0, 256, (300, 128)).astype(np.float32)  # squared norms ~ 2.8e6: not exact
    cases = {"sift": (q, kf), "big": (big, big[::-1].copy() + 1), "float": (q + 0.25, kf)}
    for name, (a, b) in cases.items():
        want_pairs, want_cost = _opencv_ratio_matches(a, b)
        pairs, cost = ratio_matches()(a, b)
        assert np.array_equal(pairs, want_pairs) and np.array_equal(cost, want_cost), name
        assert (_exact_two_nearest(a, b) is not None) == (name == "sift"), name
    assert len(ratio_matches()(q, kf)[0]) > 250
    # a ratio of 1 keeps every query whose two nearest differ, and drops exact ties
    tie = np.concatenate([q[:5], q[:5]])
    assert ratio_matches(1.0)(q[:5], tie)[0].shape == (0, 2) == _opencv_ratio_matches(q[:5], tie, 1.0)[0].shape


def _scene(seed: int = 0, n: int = 400):
    """3D points with descriptors, a keyframe that sees them all, and the camera."""
    pycolmap = import_pycolmap()
    rng = np.random.default_rng(seed)
    cam = pycolmap.Camera(model="SIMPLE_RADIAL", width=640, height=480, params=[500.0, 320.0, 240.0, -0.05])
    X = rng.uniform([-3, -2, 4], [3, 2, 8], (n, 3))
    desc = rng.integers(0, 120, (n, 128)).astype(np.float32)
    return cam, X, desc, [Keyframe(10, desc, X)]


def _view(cam, pose, X, desc, rng, noise_px=0.3, outliers=0.3):
    """Features of a frame at pose: projections (full px = SfM px here) with their descriptors,
    a share of them replaced by random points, plus unrelated features."""
    x = np.asarray(cam.img_from_cam((pose[:3, :3] @ X.T + pose[:3, 3:4]).T))[:, :2] - 0.5
    x += rng.normal(0, noise_px, x.shape)
    bad = rng.random(len(x)) < outliers
    x[bad] = rng.uniform([0, 0], [640, 480], (bad.sum(), 2))
    d = desc + rng.normal(0, 3, desc.shape)
    extra_d = rng.integers(0, 120, (100, 128))
    return (np.concatenate([x, rng.uniform([0, 0], [640, 480], (100, 2))]),
            np.clip(np.concatenate([d, extra_d]), 0, 255).astype(np.uint8))


def test_frames_register_to_their_true_pose_and_weak_ones_are_refused():
    from vs_inspect.cues.cameras.registration import FrameFeatures

    cam, X, desc, kfs = _scene()
    rng = np.random.default_rng(1)
    truth = {k: look_at([0.05 * k, 0.3, -1.0], [0.02 * k, 0.0, 6.0]) for k in (8, 11, 12)}
    xys, ds = [], []
    for k, pose in truth.items():
        x, d = _view(cam, pose, X, desc, rng)
        xys.append(x), ds.append(d)
    # frame 13 sees only 12 of the points: fewer than min_inliers, not registered
    x, d = _view(cam, truth[12], X[:12], desc[:12], rng, outliers=0.0)
    xys.append(x[:12]), ds.append(d[:12])
    feats = FrameFeatures(np.array([8, 11, 12, 13]), xys, ds)
    reg = register_frames(feats, kfs, cam, 1.0, min_inliers=20)
    assert reg.tried == 4 and reg.frames.tolist() == [8, 11, 12]
    for k, pose, n in zip(reg.frames, reg.cam_from_world, reg.inliers):
        assert n >= 0.6 * len(X)
        R_err = np.degrees(np.arccos(np.clip((np.trace(pose[:3, :3].T @ truth[k][:3, :3]) - 1) / 2, -1, 1)))
        C = -pose[:3, :3].T @ pose[:3, 3]
        C_true = -truth[k][:3, :3].T @ truth[k][:3, 3]
        assert R_err < 0.2 and np.linalg.norm(C - C_true) < 0.02, (k, R_err, C, C_true)
    # no keyframes: nothing registered, nothing tried
    assert len(register_frames(feats, [], cam, 1.0).frames) == 0
    # a check before each frame (a cancelled side build) stops the loop where it raises
    seen = []

    def check():
        seen.append(len(seen))
        if len(seen) == 3:
            raise InterruptedError("cancelled")

    with pytest.raises(InterruptedError):
        register_frames(feats, kfs, cam, 1.0, min_inliers=20, check=check)
    assert seen == [0, 1, 2]


def test_learned_descriptors_register_by_mutual_cosine_matches():
    """A learned model's unit descriptors (64-D, as XFeat's) register with cosine_matches (mutual
    nearest neighbours above a cosine floor, the rule of the XFeat model's own matching)."""
    from vs_inspect.cues.cameras.registration import FrameFeatures, cosine_matches, ratio_matches

    cam, X, _, _ = _scene()
    rng = np.random.default_rng(2)
    desc = rng.normal(size=(len(X), 64)).astype(np.float32)
    desc /= np.linalg.norm(desc, axis=1, keepdims=True)
    kfs = [Keyframe(10, desc, X)]
    truth = {k: look_at([0.05 * k, 0.3, -1.0], [0.02 * k, 0.0, 6.0]) for k in (8, 11)}
    xys, ds = [], []
    for pose in truth.values():
        x = np.asarray(cam.img_from_cam((pose[:3, :3] @ X.T + pose[:3, 3:4]).T))[:, :2] - 0.5
        x += rng.normal(0, 0.3, x.shape)
        d = desc + rng.normal(0, 0.04, desc.shape).astype(np.float32)  # cosine about 0.95 to its own
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        xys.append(x), ds.append(d)
    feats = FrameFeatures(np.array(list(truth)), xys, ds)
    reg = register_frames(feats, kfs, cam, 1.0, match=cosine_matches(), min_inliers=20)
    assert reg.frames.tolist() == [8, 11]
    for k, pose, n in zip(reg.frames, reg.cam_from_world, reg.inliers):
        assert n >= 0.9 * len(X)
        R_err = np.degrees(np.arccos(np.clip((np.trace(pose[:3, :3].T @ truth[k][:3, :3]) - 1) / 2, -1, 1)))
        assert R_err < 0.2, (k, R_err)
    pairs, cost = cosine_matches()(ds[0], desc)
    assert len(pairs) >= 0.95 * len(X) and (pairs[:, 0] == pairs[:, 1]).all() and (cost < -0.82).all()
    # a cosine floor above every pair's similarity: nothing matches, nothing registers
    assert len(register_frames(feats, kfs, cam, 1.0, match=cosine_matches(0.999), min_inliers=20).frames) == 0
    # the SIFT rule takes any descriptor length: here too each descriptor finds its own
    pairs, _ = ratio_matches()(ds[0], desc)
    assert len(pairs) >= 0.9 * len(X) and (pairs[:, 0] == pairs[:, 1]).all()
