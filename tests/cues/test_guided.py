"""Guided SIFT matching (cues/features/guided.py): the geometry decides which keypoints may match, so a
match that the plain ratio test loses to a look-alike elsewhere in the image is kept, and a
look-alike off the epipolar line (or off the homography) is not matched; on a real COLMAP
database it finds the matches of COLMAP's own guided matching."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from vs_inspect.cues.cameras import colmap
from vs_inspect.cues.features.guided import guided_matches
from vs_inspect.signals import import_pycolmap

from .test_cameras import _write_images


def _sift_like(rng, n):
    """(n,128) uint8 rows of L2 norm about 512, as COLMAP stores SIFT."""
    d = rng.random((n, 128)) ** 4
    return np.round(512 * d / np.linalg.norm(d, axis=1, keepdims=True)).clip(0, 255).astype(np.uint8)


def _perturb(rng, desc, noise):
    d = desc.astype(float) + rng.normal(0, noise, desc.shape)
    d = np.maximum(d, 0)
    return np.round(512 * d / np.linalg.norm(d, axis=1, keepdims=True)).clip(0, 255).astype(np.uint8)


def _two_views(rng, n):
    """n points seen by two cameras; F with x_bᵀ F x_a = 0."""
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    world = np.c_[rng.uniform(-2, 2, n), rng.uniform(-1.5, 1.5, n), rng.uniform(4, 8, n)]
    angle = np.radians(15)
    R = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]])
    t = np.array([-1.0, 0.1, 0.2])

    def project(X):
        x = X @ K.T
        return x[:, :2] / x[:, 2:]

    xy_a, xy_b = project(world), project(world @ R.T + t)
    tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
    Kinv = np.linalg.inv(K)
    return xy_a, xy_b, Kinv.T @ tx @ R @ Kinv


def test_guided_matching_keeps_what_a_look_alike_hides_from_the_ratio_test():
    rng = np.random.default_rng(0)
    n = 300
    xy_a, xy_b, F = _two_views(rng, n)
    desc_a = _sift_like(rng, n)
    desc_b = _perturb(rng, desc_a, 3.0)
    # every point of b has a look-alike elsewhere in b (a repeated texture), as similar
    lookalike_xy = rng.uniform([0, 0], [640, 480], (n, 2))
    lookalike = _perturb(rng, desc_a, 3.0)
    xy_b_all = np.r_[xy_b, lookalike_xy]
    desc_b_all = np.r_[desc_b, lookalike]
    truth = {(i, i) for i in range(n)}

    guided = {tuple(m) for m in guided_matches(xy_a, desc_a, xy_b_all, desc_b_all, F, False)}
    anywhere = {tuple(m) for m in guided_matches(xy_a, desc_a, xy_b_all, desc_b_all, F, False,
                                                  max_error_px=1e6)}
    # the look-alikes that happen to lie near their epipolar line still compete: most are not
    assert len(guided & truth) >= 0.9 * n
    assert len(guided - truth) <= 0.02 * n
    assert len(anywhere & truth) <= 0.3 * n, "the ratio test alone should lose most to the look-alikes"


def test_guided_matching_by_homography_refuses_matches_off_the_transfer():
    rng = np.random.default_rng(1)
    n = 200
    xy_a = rng.uniform([0, 0], [640, 480], (n, 2))
    H = np.array([[1.1, 0.05, 20.0], [-0.03, 0.95, -10.0], [1e-4, 0, 1.0]])
    x = np.c_[xy_a, np.ones(n)] @ H.T
    xy_b = x[:, :2] / x[:, 2:]
    desc_a = _sift_like(rng, n)
    desc_b = _perturb(rng, desc_a, 3.0)
    moved = xy_b.copy()
    moved[: n // 2] += 5.0  # 7 px off the transfer: beyond the 4 px default
    m = guided_matches(xy_a, desc_a, moved, desc_b, H, True)
    assert set(m[:, 0]) == set(range(n // 2, n))
    assert np.array_equal(m[:, 0], m[:, 1])


def test_a_keypoint_whose_line_or_transfer_is_at_infinity_fits_nothing_and_stops_nothing():
    """A keypoint of a with (F x_a)_3 = 0 (or a homography sending it to infinity) must not raise a
    division by zero. Its line is still a line; the homography's transfer is at infinity and fits
    no keypoint."""
    rng = np.random.default_rng(3)
    n = 40
    xy_a = np.c_[rng.uniform(0, 640, n), rng.uniform(0, 480, n)]
    xy_a[:5, 1] = 0.0  # on the top row: F's third row (0, 1, 0) gives them (F x_a)_3 = 0
    xy_b = xy_a + [30.0, 0.0]  # a sideways move: the epipolar lines are the rows
    F = np.array([[0.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # x_bᵀ F x_a = y_a - y_b
    desc_a = _sift_like(rng, n)
    desc_b = _perturb(rng, desc_a, 3.0)
    m = guided_matches(xy_a, desc_a, xy_b, desc_b, F, False)
    assert set(range(5)) <= set(m[:, 0]) and np.array_equal(m[:, 0], m[:, 1])
    H = np.array([[1.0, 0, 30.0], [0, 1, 0], [0, 1.0, 0]])  # sends the top row to infinity
    m = guided_matches(xy_a, desc_a, xy_b, desc_b, H, True)
    assert not set(range(5)) & set(m[:, 0])


def _best_two_by_numpy(desc_a, desc_b, xy_a, xy_b, M, homography, max_sq_px):
    """_best_two's answer from the full matrices: which pairs fit (the same float32 operations in
    the same order), their integer distances, each row's and column's two smallest."""
    f32 = np.float32
    u, v = xy_a[:, :1].astype(f32), xy_a[:, 1:2].astype(f32)
    p, q = xy_b[None, :, 0].astype(f32), xy_b[None, :, 1].astype(f32)
    M = M.astype(f32)
    l0, l1, l2 = (M[r, 0] * u + M[r, 1] * v + M[r, 2] for r in range(3))
    if homography:
        fits = (l0 / l2 - p) ** 2 + (l1 / l2 - q) ** 2 <= max_sq_px
    else:
        r0, r1 = M[0, 0] * p + M[1, 0] * q + M[2, 0], M[0, 1] * p + M[1, 1] * q + M[2, 1]
        fits = (p * l0 + q * l1 + l2) ** 2 <= max_sq_px * (l0 * l0 + l1 * l1 + r0 * r0 + r1 * r1)
    a, b = desc_a.astype(np.int64), desc_b.astype(np.int64)
    d = np.where(fits, (a * a).sum(1)[:, None] + (b * b).sum(1)[None] - 2 * a @ b.T, np.iinfo(np.int64).max)

    def rows(d, fits):
        top = np.sort(d, axis=1)[:, :2]
        return np.where(fits.any(1), np.argmin(d, axis=1), -1), top, fits.sum(1)
    return (*rows(d, fits), *rows(d.T, fits.T))


@pytest.mark.parametrize("homography", [False, True])
def test_best_two_is_the_full_matrix_answer(homography):
    """The fit test runs over all of b's keypoints, then only the fits are visited, eight flags
    at a time: every fit is found, in order (the first of equal distances is the nearest), up to
    the last keypoint of a count that is not a multiple of eight, and no padding is read."""
    from vs_inspect.cues.features.guided import _best_two

    rng = np.random.default_rng(4)
    xy_a, xy_b, F = _two_views(rng, 203)
    xy_b = xy_b[:-2]  # 201 keypoints: the last word half full
    desc_a, desc_b = _sift_like(rng, 203), _sift_like(rng, 201)
    desc_b[150] = desc_b[40]  # equal distances from every keypoint of a
    H = np.array([[1.02, 0.01, 25.0], [-0.01, 0.98, 3.0], [1e-5, 0.0, 1.0]])
    if homography:  # b's keypoints where H takes a's, a few px off
        x = np.c_[xy_a[:201], np.ones(201)] @ H.T
        xy_b = x[:, :2] / x[:, 2:] + rng.normal(0, 3.0, (201, 2))
    M, band = (H, 400.0) if homography else (F, 64.0)
    got = _best_two(desc_a, desc_b, xy_a.astype(np.float32), xy_b.astype(np.float32), M.astype(np.float32),
                    homography, np.float32(band))
    want = _best_two_by_numpy(desc_a, desc_b, xy_a, xy_b, M, homography, np.float32(band))
    for name, g, w in zip(["best_a", "top_a", "fit_a", "best_b", "top_b", "fit_b"], got, want):
        assert np.array_equal(g, w), name
    assert got[2].sum() > 300 and got[5][-1] > 0  # many fits, the last keypoint among them


def test_guided_matching_refuses_wrong_shapes():
    rng = np.random.default_rng(2)
    d = _sift_like(rng, 5)
    with pytest.raises(ValueError, match="one keypoint per descriptor"):
        guided_matches(np.zeros((4, 2)), d, np.zeros((5, 2)), d, np.eye(3), False)
    with pytest.raises(ValueError, match=r"\(3,3\)"):
        guided_matches(np.zeros((5, 2)), d, np.zeros((5, 2)), d, np.eye(2), False)
    assert guided_matches(np.zeros((0, 2)), d[:0], np.zeros((5, 2)), d, np.eye(3), False).shape == (0, 2)


def test_guided_rematch_finds_colmaps_own_guided_matches(tmp_path):
    """COLMAP's guided matching on a real database, then colmap.guided_rematch on a copy of it
    (each pair's stored geometry is the one COLMAP guided its matching with; on the 720p timing
    scene's database a fresh verification gave it bit for bit): the same matches."""
    pycolmap = import_pycolmap()
    _write_images(tmp_path / "images", tmp_path / "masks")
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = "SIMPLE_RADIAL"
    reader.mask_path = str(tmp_path / "masks")
    db = tmp_path / "colmap.db"
    pycolmap.Database.open(db).close()
    pycolmap.import_images(db, tmp_path / "images", camera_mode=pycolmap.CameraMode.PER_FOLDER, options=reader)
    ext = pycolmap.FeatureExtractionOptions()
    ext.sift.max_num_features = 1024
    pycolmap.extract_features(db, tmp_path / "images", camera_mode=pycolmap.CameraMode.PER_FOLDER,
                              reader_options=reader, extraction_options=ext, device=pycolmap.Device.cpu)
    mopt = pycolmap.FeatureMatchingOptions()
    mopt.guided_matching = True
    verification = colmap.seeded_verification(0)
    pycolmap.match_exhaustive(db, matching_options=mopt, verification_options=verification,
                              device=pycolmap.Device.cpu)
    ours = tmp_path / "ours.db"
    shutil.copy(db, ours)
    colmap.guided_rematch(ours, mopt.sift, verification)

    def verified(path):
        d = pycolmap.Database.open(path)
        try:
            return {pid: {tuple(m) for m in np.asarray(g.inlier_matches)}
                    for pid, g in zip(*d.read_two_view_geometries()) if len(g.inlier_matches)}
        finally:
            d.close()

    theirs, mine = verified(db), verified(ours)
    assert theirs.keys() == mine.keys() and len(theirs) >= 20
    jaccard = [len(theirs[p] & mine[p]) / len(theirs[p] | mine[p]) for p in theirs]
    # identical here; a float32 borderline may move a match on another machine
    assert sum(j == 1.0 for j in jaccard) >= 0.9 * len(jaccard) and min(jaccard) >= 0.95, jaccard
