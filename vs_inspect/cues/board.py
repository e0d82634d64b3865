"""Cameras from a ChArUco calibration board seen in unsynchronized videos (a lab rig).

A rig filmed while someone waves a board (the usual calibration session of caliscope, anipose
or Pose2Sim) has its cameras in the videos themselves, but the usual extrinsic calibration
needs synchronized frames. Here the time offset is searched instead:

- corners: OpenCV's CharucoDetector per frame (ids make the correspondences exact);
- intrinsics per camera: `cv2.calibrateCamera` on its own board views (k1, k2; no tangential
  terms: a 12-corner board does not constrain more);
- board pose per frame: `cv2.solvePnP`;
- relative pose of b to a: at every candidate offset Δ (on the finer frame grid), each frame of b
  is paired with a's frame at τ_b + Δ; every pairing proposes T_b←a = P_b P_a⁻¹ and the
  proposal that most pairings fit (MSAC: each pairing adds cap - min(error, cap), error = mean
  reprojection of the board into b) wins, the Δ with the highest such score is kept, and the pose
  is refined by `cv2.stereoCalibrate` on the pairings that fit (within cap). At a wrong Δ the
  board has moved between the paired frames, so only its still moments fit.
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

from ..io.calibration import CameraCalibration
from ..types import VideoInfo

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BoardSpec:
    columns: int  # squares along x
    rows: int  # squares along y
    square_m: float  # side of a square, metres
    marker_m: float  # side of an ArUco marker, metres
    dictionary: str  # OpenCV name, e.g. "DICT_4X4_1000"
    inverted: bool = False  # printed white-on-black: detect on the inverted image

    def __post_init__(self) -> None:
        if self.columns < 2 or self.rows < 2:
            raise ValueError(f"a ChArUco board needs at least 2x2 squares, got {self.columns}x{self.rows}")
        if not 0 < self.marker_m < self.square_m:
            raise ValueError(f"marker side {self.marker_m} m must be positive and below the square "
                             f"side {self.square_m} m")
        if not hasattr(cv2.aruco, self.dictionary):
            raise ValueError(f"unknown ArUco dictionary {self.dictionary!r} (e.g. DICT_4X4_1000)")

    def board(self):
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.columns, self.rows), self.square_m, self.marker_m, d)

    def corners_m(self) -> np.ndarray:
        """(C,3) inner corners in the board frame, metres, indexed by corner id."""
        return np.asarray(self.board().getChessboardCorners(), dtype=np.float64)


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
class RelativePose:
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


def _pairings(ta: np.ndarray, tb: np.ndarray, delta_s: float, interval_a: float,
              valid_a: np.ndarray, valid_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frames (i of a, j of b) with a's frame within half a frame of τ_b[j] + Δ, board in both."""
    want = tb + delta_s
    i = np.clip(np.searchsorted(ta, want), 1, len(ta) - 1)
    i = np.where(np.abs(ta[i - 1] - want) < np.abs(ta[i] - want), i - 1, i)
    ok = (np.abs(ta[i] - want) <= 0.5 * interval_a + 1e-9) & valid_b & valid_a[i]
    j = np.nonzero(ok)[0]
    return i[j], j


def _reprojection_px(b_from_a: np.ndarray, pose_a: np.ndarray, corners: np.ndarray,
                     ids_b: np.ndarray, xy_b: np.ndarray, intr_b: Intrinsics) -> float:
    """Mean px error of b's detected corners against the board seen by a, moved into b."""
    T = b_from_a @ pose_a
    rvec = cv2.Rodrigues(T[:3, :3])[0]
    proj, _ = cv2.projectPoints(corners[ids_b], rvec, T[:3, 3], intr_b.K, intr_b.dist)
    return float(np.mean(np.linalg.norm(proj.reshape(-1, 2) - xy_b, axis=1)))


def relative_pose(info_a: VideoInfo, det_a: BoardDetections, intr_a: Intrinsics,
                  info_b: VideoInfo, det_b: BoardDetections, intr_b: Intrinsics,
                  spec: BoardSpec, min_pairings: int = 4, cap_px: float = 10.0
                  ) -> RelativePose | None:
    """b's pose relative to a and the coarse offset at which the board poses agree; None when
    no offset has at least min_pairings frame pairings that show the board in both videos and fit."""
    corners = spec.corners_m()
    pa, va = board_poses(det_a, spec, intr_a)
    pb, vb = board_poses(det_b, spec, intr_b)
    ta, tb = info_a.timestamps_s, info_b.timestamps_s
    step = min(info_a.frame_interval_s, info_b.frame_interval_s)
    offsets = np.arange(np.ceil((ta[0] - tb[-1]) / step), np.floor((ta[-1] - tb[0]) / step) + 1) * step
    best = None
    for d in offsets:
        fa, fb = _pairings(ta, tb, float(d), info_a.frame_interval_s, va, vb)
        if len(fa) < min_pairings:
            continue
        proposals = pb[fb] @ np.linalg.inv(pa[fa])  # (P,4,4) b_from_a per pairing
        err = np.array([[_reprojection_px(Tp, pa[i], corners, det_b.ids[j], det_b.xy[j], intr_b)
                         for i, j in zip(fa, fb)] for Tp in proposals])  # (proposal, pairing)
        # MSAC score: a pairing that fits adds up to cap_px; at a wrong Δ only the moments
        # when the board stood still fit (a median would accept Δ where it stood still half the time)
        support = np.sum(cap_px - np.minimum(err, cap_px), axis=1)
        k = int(np.argmax(support))
        if best is None or support[k] > best[0]:
            best = (float(support[k]), float(d), proposals[k], fa, fb, err[k])
    if best is None:
        return None
    support, d, T, fa, fb, err = best
    keep = err <= cap_px
    if keep.sum() < min_pairings:
        return None
    T = _refine(T, fa[keep], fb[keep], det_a, intr_a, det_b, intr_b, corners, info_a, info_b)
    return RelativePose(T, d, float(np.median(err)), len(fa), int(keep.sum()), support)


def _refine(T: np.ndarray, fa: np.ndarray, fb: np.ndarray, det_a: BoardDetections,
            intr_a: Intrinsics, det_b: BoardDetections, intr_b: Intrinsics, corners: np.ndarray,
            info_a: VideoInfo, info_b: VideoInfo) -> np.ndarray:
    """Stereo calibration with fixed intrinsics on the paired frames (their common corners)."""
    obj, img_a, img_b = [], [], []
    for i, j in zip(fa, fb):
        common, ia, ib = np.intersect1d(det_a.ids[i], det_b.ids[j], return_indices=True)
        if len(common) >= 6:
            obj.append(corners[common].astype(np.float32))
            img_a.append(det_a.xy[i][ia].astype(np.float32))
            img_b.append(det_b.xy[j][ib].astype(np.float32))
    if len(obj) < 2:
        return T
    size = (max(info_a.width, info_b.width), max(info_a.height, info_b.height))
    try:
        out = cv2.stereoCalibrate(obj, img_a, img_b, intr_a.K, intr_a.dist, intr_b.K, intr_b.dist,
                                  size, T[:3, :3].copy(), T[:3, 3].reshape(3, 1).copy(),
                                  flags=cv2.CALIB_FIX_INTRINSIC)
    except cv2.error as exc:
        log.warning("stereo refinement failed, keeping the median pose: %s", exc)
        return T
    R, t = out[5], out[6]
    refined = np.eye(4)
    refined[:3, :3] = R
    refined[:3, 3] = t.ravel()
    return refined


@dataclass(frozen=True)
class RigEstimate:
    cameras: dict[str, CameraCalibration]  # name -> intrinsics and cam_from_world (world = first camera)
    intrinsics: dict[str, Intrinsics]
    links: dict[str, tuple[str, RelativePose]]  # name -> (the camera it was placed from, the pose)
    unregistered: dict[str, str]  # name -> why it has no camera


def estimate_rig(infos: list[VideoInfo], detections: dict[str, BoardDetections],
                 spec: BoardSpec) -> RigEstimate:
    """Every camera's calibration from the board; the first video's camera is the world frame.

    A camera joins through the placed camera whose pairings fit best (highest MSAC score).
    """
    intr: dict[str, Intrinsics] = {}
    why: dict[str, str] = {}
    by_name = {v.name: v for v in infos}
    for v in infos:
        got = calibrate_intrinsics(detections[v.name], spec, (v.width, v.height))
        if got is None:
            n = sum(len(i) >= 6 for i in detections[v.name].ids)
            why[v.name] = f"the board is seen in {n} frames (at least 5 with 6 corners needed)"
        else:
            intr[v.name] = got
    placed: dict[str, np.ndarray] = {}
    links: dict[str, tuple[str, RelativePose]] = {}
    order = [v.name for v in infos if v.name in intr]
    if order:
        placed[order[0]] = np.eye(4)
    cache: dict[tuple[str, str], RelativePose | None] = {}
    while True:
        best = None
        for b in order:
            if b in placed:
                continue
            for a in placed:
                if (a, b) not in cache:
                    cache[(a, b)] = relative_pose(by_name[a], detections[a], intr[a], by_name[b],
                                                  detections[b], intr[b], spec)
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
    cams = {n: CameraCalibration(intr[n].K, intr[n].dist, placed[n], (by_name[n].width, by_name[n].height))
            for n in order if n in placed}
    return RigEstimate(cams, intr, links, why)
