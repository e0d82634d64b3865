"""Per-frame poses of a moving camera: every frame registered against the scene's reconstruction.

The reconstruction (cues/cameras/sfm.py) holds a few dozen frames of each moving video. Between them
a head-worn or hand-held camera turns and walks, and a pose slerped over 3 frames at 10 fps is
off by degrees: the epipolar lines of the moving points, which pairing and the energy read at
every frame, move with it. So each frame of a moving video is registered on its own: its
features are matched to the features of the nearest reconstructed frames of the same video that
carry a 3D point, and pycolmap's LO-RANSAC absolute pose with non-linear refinement (estimate_and_refine_absolute_pose)
gives the pose from those 2D-3D matches. The features are the reconstruction's kind: SIFT
(OpenCV, converted to COLMAP's L1-root descriptors so they match the database's own; ratio test)
or a learned model's (XFeat, ALIKED, DISK on the frame at SfM resolution; mutual nearest
neighbours by cosine, the rule of the XFeat model's own matching). A frame with too few inliers
keeps the slerped pose of its neighbours (reported).

Also here, as the other OpenCV SIFT in COLMAP's form: ASIFT (affine_sift), which SIFT's
reconstruction uses for a static camera's image.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np  # noqa: I001  (numpy before pycolmap, see ENVIRONMENT.md)
from tqdm import tqdm

from ...camera_stats import FrameRegistration as FrameRegistrationRecord
from ...geometry.camera_model import scale_points
from ...geometry.timing import frame_brackets, interpolate_poses
from ...signals import import_pycolmap
from ..config import CameraConfig

log = logging.getLogger(__name__)

REGISTER_MIN_INLIERS = 20  # 2D-3D inliers a frame needs to be registered (fewer: it keeps the slerped pose)


@dataclass(frozen=True)
class FrameFeatures:
    """Features of the frames of one video that may be registered."""

    frames: np.ndarray  # (F,) int, video frame indices
    xy_full: list  # F × (M,2) float64 full-resolution px (OpenCV: pixel centres at integers)
    desc: list  # F × (M,D): COLMAP's L1-root SIFT (uint8, D=128) or a learned model's (float32, unit length)


@dataclass(frozen=True)
class Keyframe:
    """A reconstructed frame's features that see a 3D point (from COLMAP's database)."""

    frame: int  # video frame index
    desc: np.ndarray  # (M,D) float32 descriptors (SIFT: the database's uint8 values)
    xyz: np.ndarray  # (M,3) world points they see


@dataclass(frozen=True)
class FrameRegistration:
    """Frames of one video registered against the reconstruction."""

    frames: np.ndarray  # (R,) int, video frames that registered
    cam_from_world: np.ndarray  # (R,4,4)
    inliers: np.ndarray  # (R,) int, 2D-3D inliers of each
    tried: int  # frames tried


def colmap_sift(descriptors: np.ndarray) -> np.ndarray:
    """(M,128) OpenCV SIFT descriptors -> COLMAP's uint8 L1-root form (L1 normalise, square root,
    × 512, clipped to 255), so that they match the descriptors in COLMAP's database."""
    d = np.asarray(descriptors, np.float64)
    d = np.sqrt(d / np.maximum(d.sum(1, keepdims=True), 1e-12))
    return np.clip(np.round(512.0 * d), 0, 255).astype(np.uint8)


def _colmap_like_sift(max_features: int):
    # COLMAP's peak threshold (0.02 / 3 octave layers): the reconstruction's own detections
    return cv2.SIFT_create(nfeatures=max_features, contrastThreshold=0.02)


def affine_sift(grey: np.ndarray, mask: np.ndarray | None, per_view: int) -> tuple[np.ndarray, np.ndarray]:
    """ASIFT (Morel & Yu 2009, OpenCV's AffineFeature): SIFT on the image seen with simulated
    tilts and turns, each view's keypoints mapped back. grey (H,W) uint8; mask (H,W) uint8, > 0
    where features may be; per_view: SIFT features kept per view. Returns ((N,2) float32 px,
    pixel centres at integers; (N,128) COLMAP's uint8 L1-root descriptors). Same image, same
    features (OpenCV concatenates the views in order)."""
    kp, d = cv2.AffineFeature_create(_colmap_like_sift(per_view)).detectAndCompute(grey, mask)
    if d is None or not len(kp):
        return np.zeros((0, 2), np.float32), np.zeros((0, 128), np.uint8)
    return np.array([p.pt for p in kp], np.float32), colmap_sift(d)


def frame_features(grey: np.ndarray, moving: np.ndarray | None, frames: np.ndarray,
                   scale_xy: tuple[float, float], max_features: int,
                   dilate_px: int = 15) -> FrameFeatures:
    """SIFT on the given frames of a video, on the background. grey (T,H,W) uint8 working frames;
    moving (T,H,W) instance ids (> 0: a moving region, masked out after dilating by dilate_px,
    as for the reconstruction's own frames) or None; scale_xy: full px per working px."""
    sift = _colmap_like_sift(max_features)
    kernel = np.ones((dilate_px, dilate_px), np.uint8)
    xys, descs = [], []
    for k in frames:
        m = None if moving is None else \
            np.where(cv2.dilate((moving[k] > 0).astype(np.uint8), kernel) > 0, 0, 255).astype(np.uint8)
        kp, d = sift.detectAndCompute(grey[k], m)
        if d is None or not len(kp):
            xys.append(np.zeros((0, 2)))
            descs.append(np.zeros((0, 128), np.uint8))
            continue
        xy = np.array([p.pt for p in kp], np.float64)
        xys.append(scale_points(xy, *scale_xy))
        descs.append(colmap_sift(d))
    return FrameFeatures(np.asarray(frames, int), xys, descs)


@contextlib.contextmanager
def sift_descriptors(database_path):
    """A function image id -> (N,128) uint8 descriptors of that image in COLMAP's database, while
    the database is open."""
    pycolmap = import_pycolmap()

    database = pycolmap.Database.open(str(database_path))
    try:
        def read(image_id: int) -> np.ndarray:
            d = database.read_descriptors(image_id)
            return np.asarray(getattr(d, "data", d))  # pycolmap 4: FeatureDescriptors
        yield read
    finally:
        database.close()


def keyframes_of(rec, video: str, descriptors_of: Callable[[int], np.ndarray]) -> list[Keyframe]:
    """The registered images of `video` (image name "video/NNNNNN.jpg") with the descriptors of
    their keypoints that see a 3D point of rec; descriptors_of: image id -> (N,D) descriptors of
    all its keypoints, in the order of its points2D (sift_descriptors, or a learned model's)."""
    out = []
    for iid in rec.reg_image_ids():
        im = rec.images[iid]
        folder, fn = im.name.split("/")
        if folder != video:
            continue
        ids = np.array([p.point3D_id if p.has_point3D() else -1 for p in im.points2D], np.int64)
        has = np.nonzero(ids >= 0)[0]
        if not len(has):
            continue
        desc = descriptors_of(iid)
        xyz = np.array([rec.points3D[int(i)].xyz for i in ids[has]])
        out.append(Keyframe(int(fn.split(".")[0]), desc[has].astype(np.float32), xyz))
    return sorted(out, key=lambda kf: kf.frame)


# (query descriptors (M,D) float32, a keyframe's (K,D) float32) -> ((P,2) int index pairs (query,
# keyframe), (P,) cost: lower is a better match)
Match = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


# below this squared norm, integer descriptors give exact float32 dot products and distances
# (every partial sum < 2^24), and distinct squared distances (< 2^22) distinct float32 roots
_EXACT_NORM_SQ = 2.0 ** 20


def _exact_two_nearest(q: np.ndarray, kf: np.ndarray) -> tuple[np.ndarray, ...] | None:
    """The nearest keyframe row of each query row by L2 distance, ties to the lower index, with
    the float32 distances to it and to the second nearest: ((M,) first, (M,) its distance, (M,)
    the second's distance), or None when the descriptors are not integer-valued with squared
    norms under _EXACT_NORM_SQ. Then the result is OpenCV's brute-force matcher's, bit for bit
    (|a|^2 + |b|^2 - 2ab is exact), from one BLAS product: 2-3x faster on SIFT's uint8
    descriptors."""
    nq = np.einsum("ij,ij->i", q, q)
    nk = np.einsum("ij,ij->i", kf, kf)
    if (nq.max(initial=0.0) >= _EXACT_NORM_SQ or nk.max(initial=0.0) >= _EXACT_NORM_SQ
            or not (np.array_equal(q, np.rint(q)) and np.array_equal(kf, np.rint(kf)))):
        return None
    d_sq = q @ kf.T
    d_sq *= -2.0
    d_sq += nq[:, None]
    d_sq += nk[None, :]
    rows = np.arange(len(q))
    first = np.argmin(d_sq, axis=1)  # the lowest index among equals, as OpenCV's
    first_d = np.sqrt(d_sq[rows, first])
    d_sq[rows, first] = np.inf
    return first, first_d, np.sqrt(d_sq.min(axis=1))


def ratio_matches(ratio: float = 0.8) -> Match:
    """SIFT's matching: nearest neighbour by L2 distance, Lowe's ratio test; cost = distance.
    OpenCV's brute-force matcher, or the same answer from _exact_two_nearest where it is exact."""
    matcher = cv2.BFMatcher(cv2.NORM_L2)

    def match(q: np.ndarray, kf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if len(kf) < 2 or not len(q):
            return np.zeros((0, 2), int), np.zeros(0)
        q, kf = np.asarray(q, np.float32), np.asarray(kf, np.float32)
        nearest = _exact_two_nearest(q, kf)
        if nearest is not None:
            first, first_d, second_d = nearest
            # compared in float64, as DMatch's float distances are in Python
            good = np.nonzero(first_d.astype(np.float64) < ratio * second_d.astype(np.float64))[0]
            return np.stack([good, first[good]], 1).astype(int), first_d[good].astype(float)
        good = [p[0] for p in matcher.knnMatch(q, kf, k=2) if len(p) == 2 and p[0].distance < ratio * p[1].distance]
        return (np.array([[m.queryIdx, m.trainIdx] for m in good], int).reshape(-1, 2),
                np.array([m.distance for m in good], float))
    return match


def cosine_matches(min_cossim: float = 0.82) -> Match:
    """A learned model's matching: mutual nearest neighbours of unit descriptors above a cosine
    similarity (learned.mutual_cosine_matches); cost = -cosine."""
    from ..features.learned import mutual_cosine_matches

    def match(q: np.ndarray, kf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m, cos = mutual_cosine_matches(q, kf, min_cossim)
        return m.astype(int), -cos
    return match


def learned_frame_features(images: Iterable[tuple[int, np.ndarray, np.ndarray | None]], matcher,
                           sfm_scale: float, progress: str | None = None, total: int | None = None
                           ) -> FrameFeatures:
    """A learned model's features (matcher: learned.XFeatMatcher or LightGlueMatcher) on frames
    at SfM resolution: images yields (frame index, (H,W,3) uint8 BGR, (H,W) bool where features
    may be found or None); sfm_scale: SfM px per full px, as for the reconstruction's images.
    progress: a progress bar's label (None: no bar) over total frames."""
    frames, xys, descs = [], [], []
    for k, img, mask in tqdm(images, desc=progress, total=total, unit="frame", disable=progress is None,
                             leave=False):
        f = matcher.features(img, mask)
        frames.append(int(k))
        xys.append(scale_points(f.keypoints, 1 / sfm_scale, 1 / sfm_scale))
        descs.append(f.descriptors.astype(np.float32))
    return FrameFeatures(np.array(frames, int), xys, descs)


def register_frames(features: FrameFeatures, keyframes: list[Keyframe], camera, sfm_scale: float,
                    neighbours: int = 2, match: Match | None = None, min_inliers: int = 15,
                    max_error_px: float = 4.0, seed: int = 0, progress: str | None = None,
                    check: Callable[[], None] | None = None) -> FrameRegistration:
    """Each frame of `features` registered from its matches to the `neighbours` nearest keyframes
    (in frame index) of the same video: `match` (default: SIFT's ratio test, ratio_matches), one
    3D point per feature (its best match), then pycolmap's absolute pose on `camera`
    (pycolmap.Camera at SfM resolution, sfm_scale SfM px per full px). A frame with fewer than
    min_inliers inliers is not registered. A frame that is itself a keyframe is registered from
    the other keyframes only. progress: a progress bar's label (None: no bar). check: called before
    each frame; it raises to stop (a cancelled build).
    """
    pycolmap = import_pycolmap()

    if not keyframes:
        return FrameRegistration(np.zeros(0, int), np.zeros((0, 4, 4)), np.zeros(0, int), 0)
    match = match or ratio_matches()
    kf_frames = np.array([kf.frame for kf in keyframes])
    est = pycolmap.AbsolutePoseEstimationOptions()
    est.ransac.max_error = max_error_px
    est.ransac.random_seed = seed  # same input, same poses
    ref = pycolmap.AbsolutePoseRefinementOptions()
    ref.refine_focal_length = False
    ref.refine_extra_params = False
    frames, poses, inl = [], [], []
    for k, xy, d in tqdm(zip(features.frames, features.xy_full, features.desc), desc=progress,
                         total=len(features.frames), unit="frame", disable=progress is None, leave=False):
        if check is not None:
            check()
        if len(d) < min_inliers:
            continue
        # never its own keyframe: a reconstructed frame is registered from its neighbours, as a
        # check of the registration against the reconstruction's pose
        dist = np.where(kf_frames == int(k), np.iinfo(np.int64).max, np.abs(kf_frames - int(k)))
        near = np.argsort(dist, kind="stable")[:neighbours]
        best: dict[int, tuple[float, np.ndarray]] = {}  # feature -> (cost, its 3D point)
        q = d.astype(np.float32)
        for n in near:
            kf = keyframes[n]
            pairs, cost = match(q, kf.desc)
            for (i, j), c in zip(pairs.tolist(), cost.tolist()):
                if i not in best or c < best[i][0]:
                    best[i] = (c, kf.xyz[j])
        if len(best) < min_inliers:
            continue
        idx = np.fromiter(best.keys(), int)
        p2 = (xy[idx] + 0.5) * sfm_scale  # COLMAP: pixel centres at +0.5
        p3 = np.stack([best[i][1] for i in idx.tolist()])
        res = pycolmap.estimate_and_refine_absolute_pose(p2, p3, camera, est, ref)
        if res is None or int(res["num_inliers"]) < min_inliers:
            continue
        M = np.eye(4)
        M[:3, :4] = np.asarray(res["cam_from_world"].matrix())
        frames.append(int(k))
        poses.append(M)
        inl.append(int(res["num_inliers"]))
    return FrameRegistration(np.array(frames, int), np.array(poses).reshape(-1, 4, 4),
                             np.array(inl, int), len(features.frames))


def registration_inputs(rec, database: Path, name: str, learned, sfm_scale: float,
                         frame_features: dict | None, frame_images: dict | None, progress: bool = False,
                         cancel=None):
    """(keyframes, frame features, match) to register a moving video's frames against rec with,
    or None when its frames are not available: SIFT's (frame_features, computed where the video
    was decoded; the database's descriptors) or, for a learned database (learned: (matcher, image
    id -> descriptors)), the matcher's own features on frame_images (name -> (a function giving
    the frames, their number))."""
    from .registration import (cosine_matches, keyframes_of, learned_frame_features, ratio_matches, sift_descriptors)

    if learned is None:
        if not frame_features or name not in frame_features:
            return None
        with sift_descriptors(database) as read:
            return keyframes_of(rec, name, read), frame_features[name], ratio_matches()
    if not frame_images or name not in frame_images:
        return None
    matcher, descriptors = learned
    images, total = frame_images[name]
    label = f"{name}: features to register" if progress else None
    frames = images() if cancel is None else cancel.each(images())
    feats = learned_frame_features(frames, matcher, sfm_scale, label, total)
    return keyframes_of(rec, name, descriptors.__getitem__), feats, cosine_matches()


def register_others(rec, name: str, keyframes, features, match, camera, sfm_scale: float, fk: np.ndarray,
                     poses: np.ndarray, cfg: CameraConfig, seed: int, progress: bool = False,
                     cancel=None):
    """A moving video's frames outside the reconstruction registered against it: (frames (R,),
    cam_from_world (R,4,4) of the SfM frames and the newly registered ones, report). A frame
    whose rotation is farther from its nearest SfM frame's than a head can turn (10° per frame
    between them, plus 5°) is refused as a wrong registration."""
    from scipy.spatial.transform import Rotation

    from .registration import register_frames

    def angle_deg(Ra, Rb):
        return float(np.degrees((Rotation.from_matrix(Ra) * Rotation.from_matrix(Rb).inv()).magnitude()))

    reg = register_frames(features, keyframes, camera, sfm_scale, match=match,
                          min_inliers=REGISTER_MIN_INLIERS, seed=seed,
                          progress=f"{name}: registering frames" if progress else None,
                          check=None if cancel is None else cancel.check)
    own = np.isin(reg.frames, fk)  # reconstructed frames registered from their neighbours: a check
    keep = ~own
    for r, k in enumerate(reg.frames):
        if own[r]:
            continue
        n = int(np.argmin(np.abs(fk - k)))
        keep[r] = angle_deg(reg.cam_from_world[r, :3, :3], poses[n, :3, :3]) <= 10.0 * abs(int(fk[n]) - int(k)) + 5.0
    # the check: on the reconstructed frames (not the first or last), the registration from the
    # neighbours and the slerp between the neighbouring reconstructed frames, against the
    # reconstruction's own pose (degrees)
    err_reg, err_slerp = [], []
    order = np.argsort(fk)
    for r in np.nonzero(own)[0]:
        k = int(reg.frames[r])
        i = int(np.nonzero(fk == k)[0][0])
        others = np.array([j for j in order if j != i])
        if len(others) < 2 or k <= fk[others].min() or k >= fk[others].max():
            continue
        err_reg.append(angle_deg(reg.cam_from_world[r, :3, :3], poses[i, :3, :3]))
        T = slerp_poses(fk[others], poses[others], k + 1)[k]
        err_slerp.append(angle_deg(T[:3, :3], poses[i, :3, :3]))
    new_frames = reg.frames[keep]
    info = FrameRegistrationRecord(int((~np.isin(features.frames, fk)).sum()), int(keep.sum()), int((~own).sum() - keep.sum()),
                             float(np.median(reg.inliers[keep])) if keep.any() else 0.0,
                             tuple(new_frames.tolist()), len(err_reg),
                             round(float(np.median(err_reg)), 3) if err_reg else None,
                             round(float(np.median(err_slerp)), 3) if err_slerp else None)
    log.info("%s: %d of %d other frames registered against the reconstruction (median %.0f inliers, "
             "%d refused for a jump); on %d reconstructed frames, registered from their neighbours: "
             "median rotation error %s° (slerp between neighbours: %s°)", name, info.registered,
             info.tried, info.median_inliers, info.refused, len(err_reg),
             info.check_rotation_deg_median, info.check_slerp_rotation_deg_median)
    fk = np.concatenate([fk, new_frames])
    poses = np.concatenate([poses, reg.cam_from_world[keep]])
    return fk, poses, info


def slerp_poses(frames_known: np.ndarray, poses: np.ndarray, T: int) -> np.ndarray:
    """(T,4,4) cam_from_world at every frame: rotation slerp and centre lerp between known frames
    (held constant before the first and after the last)."""
    order = np.argsort(frames_known)
    fk = frames_known[order].astype(float)
    k, w = frame_brackets(fk, np.clip(np.arange(T), fk[0], fk[-1]))
    return interpolate_poses(poses[order], k, w)
