"""Typed, frozen records passed between stages: a cue bundle's videos, cameras, tracks and
cross-view track pairs (what Stage 0 gives Stage 1), and the few words a reason is shortened to.
Stage 1 and 2's results and a run's are in result_types.py, the people cue's in people_types.py.

Every array field states its shape and unit. Constructors validate shapes and raise ValueError
naming what they received; the bundle reader turns those into BundleError with the file name.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry.epipolar import camera_centers


def frame_length_s(fps: float | None, duration_s: float, num_frames: int) -> float:
    """A frame's length for counting errors in frames, the one definition used by sync, inspect,
    diagnose and report: 1/fps, else the mean spacing of the frames (inf for a single frame)."""
    if fps:
        return 1.0 / fps
    return duration_s / (num_frames - 1) if num_frames > 1 and duration_s > 0 else float("inf")


def pairs_by_reason(items: list[tuple[str, str]], verb: str = "", max_names: int = 6) -> list[str]:
    """'k1, k2 and k3<verb>: reason' once per distinct reason, in the order the reasons first come,
    from (pair name, reason) items; past max_names pairs the rest are counted ('… and 5 more').
    A video's pairs often share one reason word for word, and repeating it made a null's
    explanation hard to read."""
    names: dict[str, list[str]] = {}
    for name, why in items:
        names.setdefault(why, []).append(name)
    out = []
    for why, ks in names.items():
        if len(ks) > max_names:
            listed = ", ".join(ks[:max_names]) + f" and {len(ks) - max_names} more"
        else:
            listed = ks[0] if len(ks) == 1 else ", ".join(ks[:-1]) + " and " + ks[-1]
        out.append(f"{listed}{verb}: {why}")
    return out


# how a dropped video's reason adds why the moving points' own cameras did not place it either
# (cues/cameras/model_or_points.py); a headline keeps that clause too
FROM_MOVING_POINTS = "from the moving points: "


def first_clause(reason: str, max_chars: int = 160) -> str:
    """A reason's first clause, before its first "; " or " (" (what follows details it), cut to
    max_chars: the few words a null's headline gives."""
    cut = min((i for i in (reason.find("; "), reason.find(" (")) if i > 0), default=len(reason))
    clause = reason[:cut]
    return clause if len(clause) <= max_chars else clause[:max_chars - 1].rstrip() + "…"


def _require_shape(name: str, array: np.ndarray, shape: tuple) -> None:
    """Raise ValueError unless array matches shape (None = any length)."""
    ok = array.ndim == len(shape) and all(s is None or s == d for s, d in zip(shape, array.shape))
    if not ok:
        want = "(" + ",".join("N" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want}, got {tuple(array.shape)}")


@dataclass(frozen=True)
class VideoInfo:
    """One video's clock and image size."""

    name: str
    width: int  # px
    height: int  # px
    num_frames: int
    timestamps_s: np.ndarray  # (T,) float64, local time of each frame, strictly increasing
    fps: float | None = None  # nominal rate when the video has a constant one

    def __post_init__(self) -> None:
        ts = np.asarray(self.timestamps_s, dtype=np.float64)
        object.__setattr__(self, "timestamps_s", ts)
        _require_shape(f"{self.name}: timestamps_s", ts, (self.num_frames,))
        if self.num_frames < 1:
            raise ValueError(f"{self.name}: num_frames must be >= 1, got {self.num_frames}")
        if not np.all(np.isfinite(ts)):
            raise ValueError(f"{self.name}: timestamps_s has NaN or inf")
        if self.num_frames > 1 and not np.all(np.diff(ts) > 0):
            bad = int(np.argmin(np.diff(ts) > 0))
            raise ValueError(
                f"{self.name}: timestamps_s must be strictly increasing "
                f"(frame {bad + 1} at {ts[bad + 1]:.6f} s after frame {bad} at {ts[bad]:.6f} s)"
            )

    @staticmethod
    def constant_rate(name: str, width: int, height: int, num_frames: int, fps: float) -> VideoInfo:
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"{name}: fps must be positive, got {fps}")
        return VideoInfo(name, width, height, num_frames, np.arange(num_frames) / fps, float(fps))

    @property
    def duration_s(self) -> float:
        """Local time of the last frame (first frame is at 0 by convention, but not required)."""
        return float(self.timestamps_s[-1] - self.timestamps_s[0])

    @property
    def frame_interval_s(self) -> float:
        """Median spacing of frames; 1/fps for constant-rate video."""
        if self.fps:
            return 1.0 / self.fps
        if self.num_frames < 2:
            return float("inf")
        return float(np.median(np.diff(self.timestamps_s)))

    @property
    def frame_length_s(self) -> float:
        """frame_length_s(): 1/fps or the mean spacing, for errors in frames (the median above
        sets search steps)."""
        return frame_length_s(self.fps, self.duration_s, self.num_frames)


@dataclass(frozen=True)
class CameraCalibration:
    """One camera's intrinsics, lens distortion and pose (OpenCV conventions)."""

    K: np.ndarray  # (3,3) px, at the image size `size`
    dist: np.ndarray  # (k,) OpenCV order k1 k2 p1 p2 [k3 [k4 k5 k6 ...]], zeros if none
    cam_from_world: np.ndarray  # (4,4) or (T,4,4) per frame (moving camera), x_cam = R X + t
    size: tuple[int, int] | None  # (width, height) px the calibration was made at; None = unknown


@dataclass(frozen=True)
class CameraTrack:
    """Intrinsics and pose of one camera, static or per frame (OpenCV pinhole, undistorted)."""

    K: np.ndarray  # (3,3) or (T,3,3) px
    cam_from_world: np.ndarray  # (4,4) or (T,4,4), x_cam = R X + t, metres or arbitrary scale
    valid: np.ndarray | None = None  # (T,) bool for per-frame poses; None = all valid

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        T = np.asarray(self.cam_from_world, dtype=np.float64)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "cam_from_world", T)
        if K.shape not in ((3, 3),) and not (K.ndim == 3 and K.shape[1:] == (3, 3)):
            raise ValueError(f"K must have shape (3,3) or (T,3,3), got {K.shape}")
        if T.shape != (4, 4) and not (T.ndim == 3 and T.shape[1:] == (4, 4)):
            raise ValueError(f"cam_from_world must have shape (4,4) or (T,4,4), got {T.shape}")
        if not np.all(np.isfinite(K)):
            raise ValueError("K has NaN or inf")
        if not np.all(np.isfinite(T)):
            raise ValueError("cam_from_world has NaN or inf")
        dets = np.linalg.det(K.reshape(-1, 3, 3))
        if np.any(np.abs(dets) < 1e-9):
            raise ValueError("K is singular")
        R = T.reshape(-1, 4, 4)[:, :3, :3]
        ortho = np.abs(np.einsum("nij,nkj->nik", R, R) - np.eye(3)).max()
        if ortho > 1e-4 or np.any(np.linalg.det(R) < 0):
            raise ValueError(f"cam_from_world rotation is not a rotation (|RRᵀ-I| = {ortho:.2g})")
        if K.ndim == 3 and T.ndim == 3 and K.shape[0] != T.shape[0]:
            raise ValueError(f"K has {K.shape[0]} frames but cam_from_world has {T.shape[0]}")
        if self.valid is not None:
            v = np.asarray(self.valid, dtype=bool)
            object.__setattr__(self, "valid", v)
            n = self.num_pose_frames
            if v.shape != (n,):
                raise ValueError(f"valid must have shape ({n},), got {v.shape}")

    @property
    def is_moving(self) -> bool:
        return self.cam_from_world.ndim == 3 or self.K.ndim == 3

    @property
    def num_pose_frames(self) -> int:
        """Number of per-frame entries (1 for a static camera)."""
        if self.cam_from_world.ndim == 3:
            return self.cam_from_world.shape[0]
        if self.K.ndim == 3:
            return self.K.shape[0]
        return 1

    def K_at(self, frames: np.ndarray) -> np.ndarray:
        """(len(frames),3,3) intrinsics at integer frame indices."""
        frames = np.asarray(frames, dtype=int)
        return self.K[frames] if self.K.ndim == 3 else np.broadcast_to(self.K, (len(frames), 3, 3))

    def pose_at(self, frames: np.ndarray) -> np.ndarray:
        """(len(frames),4,4) cam_from_world at integer frame indices."""
        frames = np.asarray(frames, dtype=int)
        T = self.cam_from_world
        return T[frames] if T.ndim == 3 else np.broadcast_to(T, (len(frames), 4, 4))

    def centers(self) -> np.ndarray:
        """(F,3) camera centres in world coordinates (F = num_pose_frames)."""
        return camera_centers(self.cam_from_world.reshape(-1, 4, 4))


@dataclass(frozen=True)
class Tracks:
    """2D point tracks of one video."""

    xy: np.ndarray  # (N,T,2) float32/64 px, undistorted, NaN where the point is not seen
    instance: np.ndarray | None = None  # (N,) int, moving-object instance of each track

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy)
        if not np.issubdtype(xy.dtype, np.floating):
            xy = xy.astype(np.float64)
        object.__setattr__(self, "xy", xy)
        _require_shape("xy", xy, (None, None, 2))
        if np.isinf(xy).any():
            raise ValueError("xy has inf values (use NaN for unseen points)")
        if self.instance is not None:
            inst = np.asarray(self.instance)
            if not np.issubdtype(inst.dtype, np.integer):
                raise ValueError(f"instance must be integers, got {inst.dtype}")
            _require_shape("instance", inst, (xy.shape[0],))
            object.__setattr__(self, "instance", inst)

    @property
    def num_tracks(self) -> int:
        return self.xy.shape[0]

    @property
    def num_frames(self) -> int:
        return self.xy.shape[1]


@dataclass(frozen=True)
class TrackPairs:
    """Cross-view track pairs between videos a and b: rows follow the same physical point."""

    a: str
    b: str
    index: np.ndarray  # (P,2) int, (track index in a, track index in b)
    weight: np.ndarray | None = None  # (P,) float, optional confidence per pair
    # (P,) bool, rows an epipolar vote chose at an offset that no third camera checked (two
    # cameras): Stage 1 accepts the pair only if the other rows alone give the same minimum;
    # None = no such row
    unchecked: np.ndarray | None = None
    # Δ_ab (s) at which Stage 0 kept every row, each consistent with the cameras' epipolar
    # geometry there (the joint vote's Δ): Stage 1 refuses a minimum far from it; None = the rows
    # were not all chosen at one Δ
    chosen_at_offset_s: float | None = None

    def __post_init__(self) -> None:
        idx = np.asarray(self.index)
        if idx.size == 0:
            idx = idx.reshape(0, 2).astype(np.int64)
        if not np.issubdtype(idx.dtype, np.integer):
            raise ValueError(f"index must be integers, got {idx.dtype}")
        _require_shape("index", idx, (None, 2))
        object.__setattr__(self, "index", idx.astype(np.int64))
        if self.weight is not None:
            w = np.asarray(self.weight, dtype=np.float64)
            _require_shape("weight", w, (idx.shape[0],))
            if not np.all(np.isfinite(w)) or np.any(w < 0):
                raise ValueError("weight must be finite and non-negative")
            object.__setattr__(self, "weight", w)
        if self.unchecked is not None:
            u = np.asarray(self.unchecked)
            _require_shape("unchecked", u, (idx.shape[0],))
            if u.dtype != bool and not np.isin(u, (0, 1)).all():
                raise ValueError("unchecked must be booleans (0 or 1)")
            object.__setattr__(self, "unchecked", u.astype(bool))
        if self.chosen_at_offset_s is not None:
            d = float(self.chosen_at_offset_s)
            if not np.isfinite(d):
                raise ValueError("chosen_at_offset_s must be a finite number of seconds")
            object.__setattr__(self, "chosen_at_offset_s", d)

    @property
    def key(self) -> tuple[str, str]:
        return (self.a, self.b)


@dataclass(frozen=True)
class CueBundle:
    """Everything Stage 1 needs: videos, cameras, tracks and cross-view track pairs."""

    videos: tuple[VideoInfo, ...]
    cameras: dict[str, CameraTrack]
    tracks: dict[str, Tracks]
    pairs: dict[tuple[str, str], TrackPairs]
    gt_offsets_s: dict[str, float] | None = None  # true offsets when known (DESIGN.md convention)
    pose_free: frozenset[str] = frozenset()  # videos whose camera has K only (cam_from_world a placeholder)
    gt_drift_ppm: dict[str, float] | None = None  # true clock drift when known (gt.json drift_ppm)
    # per video: (T,2) float64 undistorted px of the head a person detector found in a frame
    # (NaN: none, or not looked at), the worn-camera sightings' cue (geometry/sightings.py);
    # empty: not detected
    heads: dict[str, np.ndarray] = field(default_factory=dict)
    # the static reconstruction of estimated cameras (drawn in the 3D scene, not used to synchronize):
    # (N,3) float world points and their (N,3) uint8 colours; None: none
    static_points: np.ndarray | None = None
    static_colors: np.ndarray | None = None

    def __post_init__(self) -> None:
        names = [v.name for v in self.videos]
        object.__setattr__(self, "pose_free", frozenset(self.pose_free))
        if not names:
            raise ValueError("bundle has no videos")
        if len(set(names)) != len(names):
            raise ValueError(f"video names must be unique, got {names}")
        for v in self.videos:
            if v.name not in self.cameras:
                raise ValueError(f"no camera for video {v.name!r}")
            if v.name not in self.tracks:
                raise ValueError(f"no tracks for video {v.name!r}")
            tr, cam = self.tracks[v.name], self.cameras[v.name]
            if tr.num_frames != v.num_frames:
                raise ValueError(
                    f"tracks of {v.name!r} have {tr.num_frames} frames, video has {v.num_frames}"
                )
            if cam.is_moving and cam.num_pose_frames != v.num_frames:
                raise ValueError(
                    f"camera of {v.name!r} has {cam.num_pose_frames} per-frame poses, "
                    f"video has {v.num_frames} frames"
                )
        for (a, b), tp in self.pairs.items():
            for n in (a, b):
                if n not in names:
                    raise ValueError(f"pair {a}__{b} names unknown video {n!r}")
            if a == b:
                raise ValueError(f"pair {a}__{b} pairs a video with itself")
            for col, n in ((0, a), (1, b)):
                if tp.index.shape[0] == 0:
                    continue
                lo, hi = int(tp.index[:, col].min()), int(tp.index[:, col].max())
                nt = self.tracks[n].num_tracks
                if lo < 0 or hi >= nt:
                    raise ValueError(
                        f"pair {a}__{b}: track index {hi if hi >= nt else lo} out of range "
                        f"for {n!r} with {nt} tracks"
                    )
        heads = {n: np.asarray(xy, dtype=np.float64) for n, xy in self.heads.items()}
        object.__setattr__(self, "heads", heads)
        for n, xy in heads.items():
            if n not in names:
                raise ValueError(f"heads name unknown video {n!r}")
            T = next(v.num_frames for v in self.videos if v.name == n)
            _require_shape(f"heads of {n!r}", xy, (T, 2))

    @property
    def names(self) -> list[str]:
        return [v.name for v in self.videos]

    def video(self, name: str) -> VideoInfo:
        for v in self.videos:
            if v.name == name:
                return v
        raise KeyError(f"unknown video {name!r}; known: {self.names}")

    def pair(self, a: str, b: str) -> TrackPairs | None:
        """Track pairs between a and b in that order (swapping a stored b__a file if needed)."""
        if (a, b) in self.pairs:
            return self.pairs[(a, b)]
        if (b, a) in self.pairs:
            tp = self.pairs[(b, a)]
            return TrackPairs(a, b, tp.index[:, ::-1].copy(), tp.weight, tp.unchecked,
                              None if tp.chosen_at_offset_s is None else -tp.chosen_at_offset_s)
        return None
