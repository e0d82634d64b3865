"""Per-frame poses of a moving camera: every frame registered against the scene's reconstruction.

The reconstruction (cues/cameras.py) holds a few dozen frames of each moving video. Between them
a head-worn or hand-held camera turns and walks, and a pose slerped over 3 frames at 10 fps is
off by degrees: the epipolar lines of the moving points, which pairing and the energy read at
every frame, move with it. So each frame of a moving video is registered on its own: its SIFT
features (OpenCV, converted to COLMAP's L1-root descriptors so they match the reconstruction's
own) are matched to the features of the nearest reconstructed frames of the same video that
carry a 3D point, and pycolmap's LO-RANSAC absolute pose with non-linear refinement
(estimate_and_refine_absolute_pose) gives the pose from those 2D-3D matches. A frame with too
few inliers keeps the slerped pose of its neighbours (reported).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np  # noqa: I001  (numpy before pycolmap, see ENVIRONMENT.md)

from ..signals import import_pycolmap


@dataclass(frozen=True)
class FrameFeatures:
    """SIFT features of the frames of one video that may be registered."""

    frames: np.ndarray  # (F,) int, video frame indices
    xy_full: list  # F × (M,2) float64 full-resolution px (OpenCV: pixel centres at integers)
    desc: list  # F × (M,128) uint8, COLMAP's L1-root SIFT descriptors


@dataclass(frozen=True)
class Keyframe:
    """A reconstructed frame's features that see a 3D point (from COLMAP's database)."""

    frame: int  # video frame index
    desc: np.ndarray  # (M,128) float32 descriptors (uint8 values)
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


def frame_features(grey: np.ndarray, moving: np.ndarray | None, frames: np.ndarray,
                   scale_xy: tuple[float, float], max_features: int,
                   dilate_px: int = 15) -> FrameFeatures:
    """SIFT on the given frames of a video, on the background. grey (T,H,W) uint8 working frames;
    moving (T,H,W) instance ids (> 0: a moving region, masked out after dilating by dilate_px,
    as for the reconstruction's own frames) or None; scale_xy: full px per working px."""
    # COLMAP's peak threshold (0.02 / 3 octave layers): the reconstruction's own detections
    sift = cv2.SIFT_create(nfeatures=max_features, contrastThreshold=0.02)
    kernel = np.ones((dilate_px, dilate_px), np.uint8)
    s = np.asarray(scale_xy, np.float64)
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
        xys.append((xy + 0.5) * s - 0.5)
        descs.append(colmap_sift(d))
    return FrameFeatures(np.asarray(frames, int), xys, descs)


def keyframes_of(rec, database_path, video: str) -> list[Keyframe]:
    """The registered images of `video` (image name "video/NNNNNN.jpg") with the database
    descriptors of their keypoints that see a 3D point of rec."""
    pycolmap = import_pycolmap()

    out = []
    database = pycolmap.Database.open(str(database_path))
    try:
        for iid in rec.reg_image_ids():
            im = rec.images[iid]
            folder, fn = im.name.split("/")
            if folder != video:
                continue
            ids = np.array([p.point3D_id if p.has_point3D() else -1 for p in im.points2D], np.int64)
            has = np.nonzero(ids >= 0)[0]
            if not len(has):
                continue
            desc = database.read_descriptors(iid)
            desc = np.asarray(getattr(desc, "data", desc))  # pycolmap 4: FeatureDescriptors
            xyz = np.array([rec.points3D[int(i)].xyz for i in ids[has]])
            out.append(Keyframe(int(fn.split(".")[0]), desc[has].astype(np.float32), xyz))
    finally:
        database.close()
    return sorted(out, key=lambda kf: kf.frame)


def register_frames(features: FrameFeatures, keyframes: list[Keyframe], camera, sfm_scale: float,
                    neighbours: int = 2, ratio: float = 0.8, min_inliers: int = 15,
                    max_error_px: float = 4.0, seed: int = 0) -> FrameRegistration:
    """Each frame of `features` registered from its matches to the `neighbours` nearest keyframes
    (in frame index) of the same video: ratio-tested nearest neighbours, one 3D point per feature
    (the best match), then pycolmap's absolute pose on `camera` (pycolmap.Camera at SfM
    resolution, sfm_scale SfM px per full px). A frame with fewer than min_inliers inliers is not
    registered. A frame that is itself a keyframe is registered from the other keyframes only.
    """
    pycolmap = import_pycolmap()

    if not keyframes:
        return FrameRegistration(np.zeros(0, int), np.zeros((0, 4, 4)), np.zeros(0, int), 0)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    kf_frames = np.array([kf.frame for kf in keyframes])
    est = pycolmap.AbsolutePoseEstimationOptions()
    est.ransac.max_error = max_error_px
    est.ransac.random_seed = seed  # same input, same poses
    ref = pycolmap.AbsolutePoseRefinementOptions()
    ref.refine_focal_length = False
    ref.refine_extra_params = False
    frames, poses, inl = [], [], []
    for k, xy, d in zip(features.frames, features.xy_full, features.desc):
        if len(d) < min_inliers:
            continue
        # never its own keyframe: a reconstructed frame is registered from its neighbours, as a
        # check of the registration against the reconstruction's pose
        dist = np.where(kf_frames == int(k), np.iinfo(np.int64).max, np.abs(kf_frames - int(k)))
        near = np.argsort(dist, kind="stable")[:neighbours]
        best: dict[int, tuple[float, np.ndarray]] = {}  # feature -> (distance, its 3D point)
        q = d.astype(np.float32)
        for n in near:
            kf = keyframes[n]
            if len(kf.desc) < 2:
                continue
            for pair in matcher.knnMatch(q, kf.desc, k=2):
                if len(pair) < 2 or pair[0].distance >= ratio * pair[1].distance:
                    continue
                m = pair[0]
                if m.queryIdx not in best or m.distance < best[m.queryIdx][0]:
                    best[m.queryIdx] = (m.distance, kf.xyz[m.trainIdx])
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
