"""A video's tracks and camera at any local times: the paper's "video b at t − Δ" (pure).

One meaning everywhere, the energy landscape's (sync/landscape.py): at local time q a video is
read between the two frames around q (geometry.timing.frame_brackets). A track point is the
linear interpolation of those two frames and is NaN unless both see it; the camera is slerped
(rotation) and lerped (centre, intrinsics) between them and is valid only when both frames'
poses are. Outside the video's time span nothing is valid. The report, the recording and the
baselines read videos through these functions, so they show exactly what the energy uses.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._shapes import check_shape
from .timing import frame_brackets, interpolate_intrinsics, interpolate_poses

if TYPE_CHECKING:
    from ..types import CameraTrack


@dataclass(frozen=True)
class CameraAtTimes:
    """A camera between frames k and k+1 at weights w (any leading shape S of the queries)."""

    K: np.ndarray  # (*S,3,3) px, NaN where not valid
    cam_from_world: np.ndarray  # (*S,4,4) x_cam = R X + t, NaN where not valid
    valid: np.ndarray  # (*S,) bool: inside the video and both bracketing poses known


@dataclass(frozen=True)
class VideoAtTimes:
    """A video's track points and camera at Q local times."""

    xy: np.ndarray  # (N,Q,2) px, NaN where the point is not seen in both frames or the camera is invalid
    K: np.ndarray | None  # (Q,3,3) px, NaN where not valid; None when no camera was given
    cam_from_world: np.ndarray | None  # (Q,4,4), NaN where not valid; None when no camera was given
    valid: np.ndarray  # (Q,) bool: inside the video (and the camera, when given, is known)


def _brackets(k: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k, w = np.asarray(k), np.asarray(w, dtype=np.float64)
    if k.shape != w.shape:
        raise ValueError(f"k and w must have the same shape, got {k.shape} and {w.shape}")
    return k, w


def camera_between_frames(camera: CameraTrack, k: np.ndarray, w: np.ndarray) -> CameraAtTimes:
    """The camera at brackets (k, w) from frame_brackets (k == -1: outside the video).

    For callers that reuse one set of brackets many times (the energy landscape); others call
    sample_video.
    """
    k, w = _brackets(k, w)
    valid = k >= 0
    if camera.valid is not None:
        n = len(camera.valid)
        if n == 1:
            valid &= camera.valid[0]
        else:
            kc = np.clip(k, 0, n - 2)
            valid &= camera.valid[kc] & camera.valid[kc + 1]
    if camera.cam_from_world.ndim == 3:
        T = interpolate_poses(camera.cam_from_world, k, w)
    else:
        T = np.broadcast_to(camera.cam_from_world, k.shape + (4, 4)).copy()
    K = interpolate_intrinsics(camera.K, k, w)
    T[~valid] = np.nan
    K[~valid] = np.nan
    return CameraAtTimes(K, T, valid)


def camera_at_frames(camera: CameraTrack, frames: np.ndarray) -> CameraAtTimes:
    """The camera at integer frame indices (any shape S), exactly as stored: the energy's
    sampled video, read at its own frames. Frames out of range are an error.

    When every frame is valid, K and cam_from_world may be read-only views (no copy).
    """
    frames = np.asarray(frames)
    if not np.issubdtype(frames.dtype, np.integer):
        raise ValueError(f"frames must be integers, got {frames.dtype}")
    flat = frames.ravel()
    K = camera.K_at(flat).reshape(frames.shape + (3, 3))
    T = camera.pose_at(flat).reshape(frames.shape + (4, 4))
    if camera.valid is None:
        return CameraAtTimes(K, T, np.ones(frames.shape, bool))
    valid = camera.valid[np.minimum(frames, len(camera.valid) - 1)]
    if not valid.all():
        K, T = np.array(K), np.array(T)
        T[~valid] = np.nan
        K[~valid] = np.nan
    return CameraAtTimes(K, T, valid)


def tracks_between_frames(xy: np.ndarray, k: np.ndarray, w: np.ndarray,
                          rows: np.ndarray | None = None) -> np.ndarray:
    """(N,*S,2) px: track points xy (N,T,2) (or its rows) at brackets (k, w) of shape S.

    Linear between frames k and k+1; NaN outside the video or where either frame misses the point.
    """
    xy = check_shape("xy", xy, (None, None, 2), batched=False)
    k, w = _brackets(k, w)
    x = np.asarray(xy if rows is None else xy[rows], dtype=np.float64)
    T = x.shape[1]
    kc = np.clip(k, 0, max(T - 2, 0))
    k1 = np.minimum(kc + 1, T - 1)
    x0 = x[:, kc]
    out = x0 + w[None, ..., None] * (x[:, k1] - x0)
    out[:, k < 0] = np.nan
    return out


def sample_video(timestamps_s: np.ndarray, camera: CameraTrack | None, xy: np.ndarray | None,
                 query_s: np.ndarray, rows: np.ndarray | None = None) -> VideoAtTimes:
    """Track points and camera of one video at local times query_s (Q,).

    timestamps_s (T,): the video's frame times (VideoInfo.timestamps_s); xy (N,T,2) px, its
    tracks (Tracks.xy; None: camera only, xy comes out (0,Q,2)); rows: the track rows wanted;
    camera None: tracks only. Points are NaN where the camera is not valid too, so that they go
    only with a known camera.
    """
    q = check_shape("query_s", np.asarray(query_s, dtype=np.float64), (None,), batched=False)
    k, w = frame_brackets(timestamps_s, q)
    cam = camera_between_frames(camera, k, w) if camera is not None else CameraAtTimes(None, None, k >= 0)
    if xy is None:
        pts = np.zeros((0, len(q), 2))
    else:
        if np.shape(xy)[1:2] != np.shape(timestamps_s):
            raise ValueError(f"xy must be (N,{len(timestamps_s)},2) for {len(timestamps_s)} "
                             f"timestamps, got {np.shape(xy)}")
        pts = tracks_between_frames(xy, k, w, rows)
        pts[:, ~cam.valid] = np.nan
    return VideoAtTimes(pts, cam.K, cam.cam_from_world, cam.valid)
