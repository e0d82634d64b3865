"""Typed, frozen records passed between stages.

Every array field states its shape and unit. Constructors validate shapes and raise ValueError
naming what they received; the bundle reader turns those into BundleError with the file name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .geometry.epipolar import camera_centers

if TYPE_CHECKING:
    from .cue_stats import CueStats


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
# (cues/cameras/choice.py); a headline keeps that clause too
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


# ---- Stage 1 and Stage 2 results -------------------------------------------------------------


@dataclass(frozen=True)
class PairDecision:
    """Whether a pair's landscape is trusted, with the numbers behind it."""

    accepted: bool
    reason: str  # readable, e.g. "single clear minimum" or "ambiguous: 3 minima of similar depth"
    contrast: float  # 1 - E_best / E_baseline (0 = flat landscape, 1 = perfectly sharp)
    second_depth_ratio: float  # prominence of the strongest rival minimum / the best's (0 = none, 1 = tie)
    num_minima: int  # significant local minima (by prominence)
    num_pareto_minima: int  # minima Pareto-optimal in (energy, overlap)
    at_range_edge: bool  # best minimum lies on the border of the search range
    inlier_fraction: float = float("nan")  # share of terms at the best offset within inlier_tau_px
    inlier_tau_px: float = float("nan")  # Sampson distance counted as an inlier, px
    support_fraction: float = float("nan")  # terms at the best minimum / median terms over the landscape
    track_pairs_at_best: int = -1  # track pairs with at least one term at the best offset (-1: not counted)


@dataclass(frozen=True)
class PairLandscape:
    """Stage 1 result for one ordered pair (a, b)."""

    a: str
    b: str
    offsets_s: np.ndarray  # (D,) candidate Δ_ab = offset_s[b] - offset_s[a], seconds
    energy: np.ndarray  # (D,) normalized robust energy, NaN where overlap is too small
    support: np.ndarray  # (D,) int, number of (track pair, frame) terms behind each energy
    minima_idx: np.ndarray  # (M,) int, indices of significant local minima, best first
    best_offset_s: float  # sub-frame refined Δ_ab, seconds (NaN if none)
    best_energy: float  # energy at best_offset_s
    uncertainty_s: float  # 1-sigma of best_offset_s from the landscape curvature
    num_track_pairs: int
    decision: PairDecision
    residual: str = "sampson"
    robust_scale: float = float("nan")  # scale of the robust loss, in the residual's units
    rate: float = 1.0  # (1 + drift_b) / (1 + drift_a): τ_a = Δ + rate · τ_b (1 without the drift model)
    log_rate_std: float = float("nan")  # 1-sigma of log(rate); NaN without the drift model
    pivot_s: float = 0.0  # b's local time where pivot_offset_s is measured (middle of the overlap)
    pivot_offset_s: float = float("nan")  # τ_a - τ_b at τ_b = pivot_s (nearly uncorrelated with the rate)
    pivot_offset_std_s: float = float("nan")  # its 1-sigma
    rate_landscape: RateLandscape | None = None  # the energy over (Δ, rate), with the drift model
    pose_free: bool = False  # the pair's F came from its tracks (sync.posefree), not from cameras
    # (D,) energy of the pair's track pairs not marked unchecked, alone, on offsets_s (the check
    # of TrackPairs.unchecked); None: the check did not run
    confirm_energy: np.ndarray | None = None
    confirm_offset_s: float = float("nan")  # that landscape's refined best minimum, s (NaN: none accepted)
    window_s: tuple[float, float] | None = None  # (lo, hi) of Δ_ab the --around windows allow, s; None: no window


@dataclass(frozen=True)
class RateLandscape:
    """A pair's energy over (offset at the pivot, rate) around its minimum (the drift model)."""

    pivot_s: float  # b's local time about which the rows turn
    offsets_s: np.ndarray  # (U,) τ_a - τ_b at τ_b = pivot_s, seconds
    rates_ppm: np.ndarray  # (V,) (rate - 1) * 1e6
    energy: np.ndarray  # (V,U) normalized energy, NaN where the overlap is too small


@dataclass(frozen=True)
class SolveIteration:
    """One IRLS iteration of Stage 2."""

    residual_s: np.ndarray  # (E,) s_b - s_a - Δ_ab per accepted pair, seconds
    weight: np.ndarray  # (E,) Huber weight per accepted pair


@dataclass(frozen=True)
class SyncResult:
    """Stage 2 result: one offset per video (None when it cannot be synchronized)."""

    reference: str
    offsets_s: dict[str, float | None]
    uncertainty_s: dict[str, float | None]
    unresolved_reason: dict[str, str]  # video -> why it has no offset
    pairs: tuple[PairLandscape, ...]
    solve_pairs: tuple[tuple[str, str], ...]  # the accepted pairs, in the order of residuals
    iterations: tuple[SolveIteration, ...]
    solver: str = "irls"
    timings_s: dict[str, float] = field(default_factory=dict)
    drift_ppm: dict[str, float | None] | None = None  # with the drift model: (1 + drift) - 1 per video, ppm
    drift_std_ppm: dict[str, float | None] | None = None  # its 1-sigma, ppm


# ---- a whole run (Stage 0 + 1 + 2), as written to result.json --------------------------------


@dataclass(frozen=True)
class RunInputs:
    """What a run was given, as result.json's "input" records it (paths as the user gave them)."""

    bundle: str | None = None  # cue bundle folder read or written by the run
    videos: dict[str, str] = field(default_factory=dict)  # video name -> file or image folder
    scene: str | None = None  # rendered scene folder (demo)
    cues: str | None = None  # where the cues came from when not Stage 0 (e.g. "true cue bundle")
    fps: float | None = None  # --fps given for image folders, frames per second


@dataclass(frozen=True)
class RunResult:
    """A whole run: one offset per input video (None with a reason), and how it was reached.

    offsets_s covers every input video, including those Stage 0 left out (None, reason in
    unresolved). pairs, solve_pairs and iterations are Stage 1 and Stage 2's (SyncResult).
    """

    reference: str
    offsets_s: dict[str, float | None]  # video -> offset_s (DESIGN.md convention), seconds
    uncertainty_s: dict[str, float | None]  # video -> 1-sigma of offset_s, seconds
    unresolved: dict[str, str]  # video -> why it has no offset (the plain sentence, then the technical account)
    pairs: tuple[PairLandscape, ...]
    solver: str  # "irls" | "ls"
    solve_pairs: tuple[tuple[str, str], ...]  # the accepted pairs, in the order of residuals
    iterations: tuple[SolveIteration, ...]
    timings_s: dict[str, float]  # per stage, seconds ("total_s" for the whole run)
    inputs: RunInputs = field(default_factory=RunInputs)
    config: dict[str, Any] | None = None  # the run's config as saved (pipeline.RunConfig.to_dict)
    cues: CueStats | None = None  # None when the run started from a cue bundle
    gt_offsets_s: dict[str, float] | None = None  # true offsets when known (bundle gt.json, --gt)
    drift_ppm: dict[str, float | None] | None = None  # with the drift model (--drift), per video, ppm
    drift_std_ppm: dict[str, float | None] | None = None  # its 1-sigma, ppm
    gt_drift_ppm: dict[str, float] | None = None  # true drift when known (gt.json drift_ppm)
    unresolved_headline: dict[str, str] | None = None  # video -> why it has no offset and what to try,
    # one plain sentence (pipeline/reasons.py; unresolved holds it and then the whole technical
    # account); None in a result read from a file without it

    @property
    def resolved(self) -> list[str]:
        return [v for v, off in self.offsets_s.items() if off is not None]

    def headlines(self) -> dict[str, str]:
        """Each unresolved video's reason in one plain sentence (unresolved_headline), else in full."""
        return {v: (self.unresolved_headline or {}).get(v) or why for v, why in self.unresolved.items()}

    def pair(self, a: str, b: str) -> PairLandscape | None:
        for p in self.pairs:
            if (p.a, p.b) == (a, b):
                return p
        return None


@dataclass(frozen=True)
class VideoSpan:
    """One synchronized video's part of the common time span (analysis/common_span.py)."""

    name: str
    offset_s: float  # DESIGN.md convention: global time of the video's local time 0
    frame_interval_s: float  # median spacing of the video's frames, s
    first_frame: int  # first frame index inside the common span
    last_frame: int  # last frame index inside it (inclusive)
    first_time_s: float  # global time of first_frame, s
    last_time_s: float  # global time of last_frame, s

    @property
    def num_frames(self) -> int:
        return self.last_frame - self.first_frame + 1

    @property
    def offset_frames(self) -> float:
        """offset_s in frames of this video."""
        return self.offset_s / self.frame_interval_s


@dataclass(frozen=True)
class CommonSpan:
    """The time span every synchronized video covers, as a frame range of each."""

    reference: str
    start_s: float  # global time of the slowest video's first frame in the span, s
    end_s: float  # global time of its last frame in the span, s
    anchor: str  # the slowest video, whose frames set start_s and end_s
    videos: dict[str, VideoSpan]  # the synchronized videos (offset known), input order
    skipped: dict[str, str]  # video -> why it has no span


# ---- people as cross-view correspondences (cues/people_*.py, sync/people_pairs.py) ----------


@dataclass(frozen=True)
class VideoPeople:
    """The people followed over time in one video, one track per person (cues/people_tracking.py):
    BlazePose's 33 landmarks (geometry/skeleton.py) per frame."""

    name: str
    landmarks: np.ndarray  # (P,T,33,3) x px, y px (the video's full-resolution pixels), visibility 0..1;
    # NaN where person p is not found in frame t
    times_s: np.ndarray  # (T,) the video's local frame times, s
    min_visibility: float = 0.5  # a landmark counts as seen from this visibility on

    def __post_init__(self) -> None:
        lm = np.asarray(self.landmarks, dtype=np.float64)
        t = np.asarray(self.times_s, dtype=np.float64)
        object.__setattr__(self, "landmarks", lm)
        object.__setattr__(self, "times_s", t)
        _require_shape(f"{self.name}: times_s", t, (None,))
        _require_shape(f"{self.name}: landmarks", lm, (None, len(t), 33, 3))

    @property
    def num_people(self) -> int:
        return self.landmarks.shape[0]

    def seen_xy(self, landmarks: tuple[int, ...] | None = None) -> np.ndarray:
        """(P,T,L,2) px of the landmarks (indices; None: all 33), NaN where not seen."""
        lm = self.landmarks if landmarks is None else self.landmarks[:, :, list(landmarks)]
        seen = np.nan_to_num(lm[..., 2], nan=0.0) >= self.min_visibility
        return np.where(seen[..., None], lm[..., :2], np.nan)

    def frames_seen(self) -> np.ndarray:
        """(P,) frames in which each person is found."""
        return np.isfinite(self.landmarks[..., 0]).any(-1).sum(-1)


@dataclass(frozen=True)
class PeopleAssociation:
    """One person of video a who is one person of video b (sync/people_pairs.py)."""

    person_a: int  # track index in a's VideoPeople
    person_b: int  # track index in b's VideoPeople
    mirrored: bool  # b's labelling is left/right swapped against a's (most frames both see)


@dataclass(frozen=True)
class PeoplePair:
    """What the people of videos a and b gave: association, F_ab and Δ_ab (DESIGN.md convention),
    or a refusal with its reason; and the evidence at every candidate shift."""

    a: str
    b: str
    offset_s: float | None  # Δ_ab refined below the frame, s; None: refused (reason says why)
    reason: str  # why the shift was taken, or why it was refused
    noise_px: float  # the median noise unit of the person pairings (inlier: Sampson distance under one), px
    offsets_s: np.ndarray  # (D,) candidate Δ_ab, s
    cost: np.ndarray | None = None  # (D,) the chosen association's mean truncated squared Sampson distance in
    # noise units at each Δ, its F fitted there, 0..1; lower is better
    inliers: np.ndarray | None = None  # (D,) its inlier correspondences at each Δ (its F's inliers)
    evidence: np.ndarray | None = None  # (D,) (median cost - cost) x sqrt(correspondences) at each Δ: the
    # landscape the shift is chosen on (higher is better); NaN where the videos share too little time
    search_score: np.ndarray | None = None  # (D,) inliers per frame of the best association found at each Δ
    associations: tuple[PeopleAssociation, ...] = ()  # the people both videos see, at the chosen shift
    F_ab: np.ndarray | None = None  # (3,3) x_aᵀ F_ab x_b = 0, px (refined when accepted)
    best_grid_offset_s: float | None = None  # the best Δ on the candidate grid, s
    contrast: float | None = None  # (median - best) / median of cost
    indistinct_s: tuple[float, float] | None = None  # (lo, hi) Δ around the best that fit about as well, s
    second_offset_s: float | None = None  # the next-best distinct Δ of evidence, s
    margin: float | None = None  # prominence of the best peak of evidence / that of the next distinct peak
    rival_offset_s: float | None = None  # another association's best Δ, when it decided, s
    rival_margin: float | None = None  # the best evidence / that association's best
    offset_std_s: float | None = None  # 1-sigma of offset_s from the refinement's Jacobian, s
    refined_inliers: int | None = None  # inliers at the refined Δ and F

    @property
    def accepted(self) -> bool:
        return self.offset_s is not None


@dataclass(frozen=True)
class PeopleCue:
    """What the people in the videos gave Stage 0 (cues/people_cue.py): each video's people, every
    pair's association, F and shift (or refusal), the cameras made from them (or a refusal per
    video), and their landmarks as point tracks with cross-view track pairs (the CueBundle terms)."""

    videos: tuple[VideoInfo, ...]
    reference: str  # the video whose offset is 0
    people: dict[str, VideoPeople]  # video -> its people
    pairs: tuple[PeoplePair, ...]  # every pair of videos tried, accepted or refused
    offsets_s: dict[str, float]  # video -> offset_s from the accepted pairs (DESIGN.md convention), s
    cameras: dict[str, CameraTrack]  # video -> its camera, for the videos placed
    refused: dict[str, str]  # video -> why it has no camera
    tracks: dict[str, Tracks]  # placed video -> landmarks as tracks (P·L,T,2) px, instance = person track
    track_pairs: dict[tuple[str, str], TrackPairs]  # (a, b) -> the same landmark of one person in both
    points_world: np.ndarray  # (N,3) landmarks triangulated by the bundle adjustment, world frame
    reprojection_px: dict[str, float]  # placed video -> median reprojection distance of its landmarks, px
    landmarks: tuple[int, ...]  # the BlazePose landmarks each person's tracks hold, in order
    timings_s: dict[str, float]  # "people", "pairs", "cameras", "total"
    background_motion_px: dict[str, float] = field(default_factory=dict)  # video -> its background's motion
    # between frames (cues/video/motion.py), px: a moving camera is refused

    def bundle(self, gt_offsets_s: dict[str, float] | None = None) -> CueBundle:
        """The placed videos with their cameras, landmark tracks and track pairs, for Stage 1."""
        placed = tuple(v for v in self.videos if v.name in self.cameras)
        pairs = {k: tp for k, tp in self.track_pairs.items() if k[0] in self.cameras and k[1] in self.cameras}
        gt = None if gt_offsets_s is None else {v.name: gt_offsets_s[v.name] for v in placed if v.name in gt_offsets_s}
        return CueBundle(placed, {v.name: self.cameras[v.name] for v in placed},
                         {v.name: self.tracks[v.name] for v in placed}, pairs, gt)
