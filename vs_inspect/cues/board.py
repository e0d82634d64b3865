"""Cameras from a ChArUco calibration board seen in unsynchronized videos (a lab rig).

A rig of static cameras filmed while someone waves a board (the usual calibration session of caliscope, anipose
or Pose2Sim) has its cameras in the videos themselves, but the usual extrinsic calibration
needs synchronized frames. Here the time offset is searched instead:

- corners: OpenCV's CharucoDetector per frame (ids make the correspondences exact);
- intrinsics per camera: `cv2.calibrateCamera` on its own board views (k1, k2; no tangential
  terms: a 12-corner board does not constrain more);
- board pose per frame: `cv2.solvePnP`;
- relative pose of b to a: at every candidate offset Δ (half a frame apart, then an eighth around
  the best), each frame of b is paired with a's board pose interpolated at τ_b + Δ; every
  pairing proposes T_b←a = P_b P_a⁻¹ and the proposal that most pairings fit (MSAC: each
  pairing adds cap - min(error, cap), error = mean reprojection of the board into b) wins, the Δ with the highest such score is kept, and the pose
  is refined by scipy's least_squares (soft-L1) on the pairings that fit (within cap). At a wrong
  Δ the board has moved between the paired frames, so only its still moments fit.
- cameras are chained from the first video (its camera is the world frame, metres) through the
  pairs with the highest score.

The board's offsets are coarse (a frame at best); Stage 1 searches the offsets again from the
moving points with these cameras. Pure functions of frames and arrays; no I/O.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..geometry.offsets import grid_around, grid_between, overlap_bounds, span_of
from ..geometry.sampling import sample_video
from ..io.board import BoardSpec
from ..types import CameraCalibration
from ..types import CameraTrack, VideoInfo

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BoardDetections:
    """Corners found in every frame of one video."""

    ids: tuple[np.ndarray, ...]  # per frame (M,) int corner ids, empty if no board
    xy: tuple[np.ndarray, ...]  # per frame (M,2) px, full resolution, distorted


class BoardDetector:
    """OpenCV's ChArUco detector for one board; call it on greyscale frames."""

    def __init__(self, spec: BoardSpec):
        self.spec = spec
        self._det = cv2.aruco.CharucoDetector(spec.board())

    def __call__(self, grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        img = 255 - grey if self.spec.inverted else grey
        xy, ids, _, _ = self._det.detectBoard(img)
        if ids is None:
            return np.zeros(0, np.int64), np.zeros((0, 2))
        return ids.ravel().astype(np.int64), xy.reshape(-1, 2).astype(np.float64)


def detect_frames(frames, detector: BoardDetector) -> BoardDetections:
    """Corners of every frame of an iterable of (index, BGR or grey image), in order."""
    ids, xy = [], []
    for _, img in frames:
        grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
        i, x = detector(grey)
        ids.append(i)
        xy.append(x)
    return BoardDetections(tuple(ids), tuple(xy))


@dataclass(frozen=True)
class Intrinsics:
    K: np.ndarray  # (3,3) px
    dist: np.ndarray  # (5,) k1 k2 p1 p2 k3 (p1 = p2 = k3 = 0)
    rms_px: float  # reprojection RMS of the calibration
    views: int  # frames used


@dataclass(frozen=True)
class BoardViewsPose:
    b_from_a: np.ndarray  # (4,4) x_b = T x_a, metres
    offset_s: float  # coarse Δ_ab at which the board poses agree
    median_px: float  # median reprojection error of the board into b at that Δ, px
    pairings: int  # frame pairings with the board in both views at that Δ
    inliers: int  # pairings within cap_px, used for the refinement
    support: float  # MSAC score of the pose at that Δ (sum of cap - min(error, cap)), px


def calibrate_intrinsics(det: BoardDetections, spec: BoardSpec, size: tuple[int, int],
                         min_corners: int = 6, min_views: int = 5) -> Intrinsics | None:
    """Zhang's calibration on the frames showing at least min_corners corners; None if too few."""
    corners = spec.corners_m()
    obj, img = [], []
    for ids, xy in zip(det.ids, det.xy):
        if len(ids) >= min_corners:
            obj.append(corners[ids].astype(np.float32))
            img.append(xy.astype(np.float32))
    if len(obj) < min_views:
        return None
    w, h = size
    K0 = np.array([[max(w, h), 0, w / 2], [0, max(w, h), h / 2], [0, 0, 1]], np.float64)
    flags = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
    try:
        rms, K, dist, _, _ = cv2.calibrateCamera(obj, img, (w, h), K0, None, flags=flags)
    except cv2.error as exc:
        log.warning("board calibration failed: %s", exc)
        return None
    return Intrinsics(K, dist.ravel()[:5], float(rms), len(obj))


def board_poses(det: BoardDetections, spec: BoardSpec, intr: Intrinsics,
                min_corners: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """(T,4,4) cam_from_board per frame and (T,) valid (enough corners and a PnP solution)."""
    corners = spec.corners_m()
    T = len(det.ids)
    poses = np.tile(np.eye(4), (T, 1, 1))
    valid = np.zeros(T, bool)
    for k, (ids, xy) in enumerate(zip(det.ids, det.xy)):
        if len(ids) < min_corners:
            continue
        ok, rvec, tvec = cv2.solvePnP(corners[ids], xy, intr.K, intr.dist)
        if ok:
            poses[k, :3, :3] = cv2.Rodrigues(rvec)[0]
            poses[k, :3, 3] = tvec.ravel()
            valid[k] = True
    return poses, valid


@dataclass(frozen=True)
class BoardView:
    """One video's board observations with its intrinsics and per-frame board poses."""

    info: VideoInfo
    det: BoardDetections
    intr: Intrinsics
    poses: np.ndarray  # (T,4,4) cam_from_board, metres
    valid: np.ndarray  # (T,) bool, pose known


def board_view(info: VideoInfo, det: BoardDetections, intr: Intrinsics, spec: BoardSpec) -> BoardView:
    return BoardView(info, det, intr, *board_poses(det, spec, intr))


def _board_in_b(b_from_a: np.ndarray, pose_a: np.ndarray, corners: np.ndarray,
                intr_b: Intrinsics) -> np.ndarray:
    """(M,2) px: board corners (M,3) posed by a (cam_from_board), moved into b and projected."""
    T = b_from_a @ pose_a
    proj, _ = cv2.projectPoints(corners, cv2.Rodrigues(T[:3, :3])[0], T[:3, 3], intr_b.K, intr_b.dist)
    return proj.reshape(-1, 2)


def _poses_at(view: BoardView, query_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cam_from_board (Q,4,4) at local times query_s (Q,), between the two frames around each,
    and whether both frames had the board (the board is the world of this camera track)."""
    at = sample_video(view.info.timestamps_s, CameraTrack(view.intr.K, view.poses, view.valid), None,
                      query_s)
    return at.cam_from_world, at.valid


def _fit_at(delta_s: float, a: BoardView, b: BoardView, corners: np.ndarray, cap_px: float):
    """Best proposal at one Δ: (MSAC support, b_from_a, b's frames, a's poses there, errors)."""
    pose_a, ok = _poses_at(a, b.info.timestamps_s + delta_s)
    fb = np.nonzero(ok & b.valid)[0]
    if not len(fb):
        return None
    proposals = b.poses[fb] @ np.linalg.inv(pose_a[fb])  # (P,4,4) b_from_a per pairing
    err = np.array([[np.linalg.norm(_board_in_b(Tp, pose_a[j], corners[b.det.ids[j]], b.intr)
                                    - b.det.xy[j], axis=1).mean()
                     for j in fb] for Tp in proposals])  # (proposal, pairing) mean px error
    # MSAC: a pairing that fits adds up to cap_px; at a wrong Δ only the moments when the board
    # stood still fit (a median would accept a Δ where it stood still half of the time)
    support = np.sum(cap_px - np.minimum(err, cap_px), axis=1)
    k = int(np.argmax(support))
    return float(support[k]), proposals[k], fb, pose_a[fb], err[k]


def pose_between_board_views(a: BoardView, b: BoardView, spec: BoardSpec, min_pairings: int = 4,
                             cap_px: float = 10.0) -> BoardViewsPose | None:
    """Estimates b's pose relative to a from the board seen by both, and the offset at which the board poses agree; None when no offset
    has at least min_pairings frames of b, with the board in both videos, that fit one pose.

    a's board pose is interpolated at b's frame times + Δ, so Δ is found below a frame: first on
    a half-frame grid, then on an eighth of a frame around the best."""
    corners = spec.corners_m()
    ta, tb = a.info.timestamps_s, b.info.timestamps_s
    step = 0.5 * min(a.info.frame_interval_s, b.info.frame_interval_s)
    coarse = grid_between(*overlap_bounds(span_of(ta), span_of(tb)), step)
    best, best_d = None, 0.0
    for grid in (coarse, None):
        if grid is None:
            if best is None:
                return None
            grid = grid_around(best_d, step, step / 4)
        for d in grid:
            fit = _fit_at(float(d), a, b, corners, cap_px)
            if fit is not None and np.sum(fit[4] <= cap_px) >= min_pairings \
                    and (best is None or fit[0] > best[0]):
                best, best_d = fit, float(d)
    if best is None:
        return None
    support, T, fb, pose_a, err = best
    keep = err <= cap_px
    T = _refine(T, pose_a[keep], fb[keep], b, corners)
    return BoardViewsPose(T, best_d, float(np.median(err)), len(fb), int(keep.sum()), support)


def _refine(T: np.ndarray, pose_a: np.ndarray, fb: np.ndarray, b: BoardView,
            corners: np.ndarray) -> np.ndarray:
    """b_from_a minimizing the reprojection of the board (posed by a) into b's detected corners,
    with a soft-L1 loss (scipy least_squares) over the pairings that fit."""
    def residuals(x):
        Tx = np.eye(4)
        Tx[:3, :3] = Rotation.from_rotvec(x[:3]).as_matrix()
        Tx[:3, 3] = x[3:]
        return np.concatenate([(_board_in_b(Tx, P, corners[b.det.ids[j]], b.intr) - b.det.xy[j]).ravel()
                               for P, j in zip(pose_a, fb)])

    x0 = np.concatenate([Rotation.from_matrix(T[:3, :3]).as_rotvec(), T[:3, 3]])
    sol = least_squares(residuals, x0, loss="soft_l1", f_scale=2.0)
    refined = np.eye(4)
    refined[:3, :3] = Rotation.from_rotvec(sol.x[:3]).as_matrix()
    refined[:3, 3] = sol.x[3:]
    return refined


@dataclass(frozen=True)
class RigEstimate:
    cameras: dict[str, CameraCalibration]  # name -> intrinsics and cam_from_world (world = first camera)
    intrinsics: dict[str, Intrinsics]
    links: dict[str, tuple[str, BoardViewsPose]]  # name -> (the camera it was placed from, the pose)
    unregistered: dict[str, str]  # name -> why it has no camera


def estimate_rig(infos: list[VideoInfo], detections: dict[str, BoardDetections],
                 spec: BoardSpec) -> RigEstimate:
    """Every (static) camera's calibration from the board; the camera of the first video with
    enough board views is the world frame.

    A camera joins through the placed camera whose pairings fit best (highest MSAC score).
    """
    intr: dict[str, Intrinsics] = {}
    why: dict[str, str] = {}
    for v in infos:
        got = calibrate_intrinsics(detections[v.name], spec, (v.width, v.height))
        if got is None:
            n = sum(len(i) >= 6 for i in detections[v.name].ids)
            why[v.name] = f"the board is seen in {n} frames (at least 5 with 6 corners needed)"
        else:
            intr[v.name] = got
    views = {v.name: board_view(v, detections[v.name], intr[v.name], spec)
             for v in infos if v.name in intr}  # board poses once per camera
    placed: dict[str, np.ndarray] = {}
    links: dict[str, tuple[str, BoardViewsPose]] = {}
    order = list(views)
    if order:
        placed[order[0]] = np.eye(4)
    cache: dict[tuple[str, str], BoardViewsPose | None] = {}
    while True:
        best = None
        for b in order:
            if b in placed:
                continue
            for a in placed:
                if (a, b) not in cache:
                    cache[(a, b)] = pose_between_board_views(views[a], views[b], spec)
                rp = cache[(a, b)]
                if rp is not None and (best is None or rp.support > best[2].support):
                    best = (a, b, rp)
        if best is None:
            break
        a, b, rp = best
        placed[b] = rp.b_from_a @ placed[a]
        links[b] = (a, rp)
    for b in order:
        if b not in placed:
            why[b] = ("at no offset do 4 frames showing the board to it and to a placed camera "
                      "agree on one relative pose")
    cams = {n: CameraCalibration(intr[n].K, intr[n].dist, placed[n], (views[n].info.width, views[n].info.height))
            for n in order if n in placed}
    return RigEstimate(cams, intr, links, why)
