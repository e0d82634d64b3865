"""What a report shows, as typed frozen records. analysis/report_data.py computes these; the
renderers (figures.py, scene3d.py, mosaic.py, html.py) only draw them.

Time convention (DESIGN.md): a frame at local time τ of video v shows global time τ + offset_s[v];
Δ_ab = offset_s[b] - offset_s[a], so x_a(t + Δ_ab) and x_b(t) show the same moment.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..eval.metrics import offset_errors_ms
from ..geometry.epipolar import camera_centers
from ..types import frame_length_s


@dataclass(frozen=True)
class VideoClock:
    """One video: its image size and its clock."""

    name: str
    width: int  # px
    height: int  # px
    num_frames: int
    start_s: float  # local time of the first frame, seconds
    end_s: float  # local time of the last frame, seconds
    fps: float | None  # nominal rate, None for variable frame rate
    path: str | None = None  # video file or image folder when it can be read, else None

    @property
    def frame_interval_s(self) -> float:
        """types.frame_length_s: 1/fps, or the mean spacing of a variable-rate video's frames, s."""
        return frame_length_s(self.fps, self.end_s - self.start_s, self.num_frames)


@dataclass(frozen=True)
class CameraView:
    """A camera's intrinsics and pose(s) in the common world frame."""

    name: str
    K: np.ndarray  # (3,3) px, or (F,3,3) for per-frame intrinsics
    cam_from_world: np.ndarray  # (F,4,4); F = 1 for a static camera, else one per frame
    width: int  # px
    height: int  # px

    @property
    def is_moving(self) -> bool:
        return self.cam_from_world.shape[0] > 1

    def centers(self) -> np.ndarray:
        """(F,3) camera centres in world coordinates."""
        return camera_centers(self.cam_from_world)


@dataclass(frozen=True)
class Trajectory:
    """A triangulated moving point: positions on the global time axis."""

    points_world: np.ndarray  # (T,3) world units
    time_s: np.ndarray  # (T,) global time, seconds (after sync)
    pair: tuple[str, str]  # the pair of videos it was triangulated from


@dataclass(frozen=True)
class PairView:
    """One pair's Stage 1 result, as the landscape grid and the pair graph show it."""

    a: str
    b: str
    offsets_s: np.ndarray  # (D,) candidate Δ_ab, seconds
    energy: np.ndarray  # (D,) normalized energy, NaN where undefined
    minima_offsets_s: np.ndarray  # (M,) significant local minima, best first, seconds
    minima_energy: np.ndarray  # (M,) their energy
    accepted: bool
    reason: str
    chosen_offset_s: float | None  # refined Δ_ab of the pair alone (None = no minimum)
    uncertainty_s: float | None  # 1-sigma of chosen_offset_s
    solved_offset_s: float | None  # offset_s[b] - offset_s[a] of the global solve
    true_offset_s: float | None  # Δ_ab from the ground truth, when known
    num_track_pairs: int
    contrast: float  # 1 - E_best / E_median (0 = flat)
    # (D,) energy of the pair's track pairs found by appearance alone, when its unchecked ones
    # were checked (PairLandscape.confirm_energy), mapped onto energy's range for drawing (its
    # robust scale differs); None otherwise
    confirm_energy: np.ndarray | None = None
    confirm_offset_s: float | None = None  # that landscape's accepted minimum (None: none)
    residual: str = "sampson"  # what the energy measures; "sighting": 1 − the share of heads on a worn camera's centre

    @property
    def key(self) -> str:
        return f"{self.a}__{self.b}"

    @property
    def disagreement_ms(self) -> float | None:
        """|chosen - solved| in ms: how far the global solve moved this pair (None if unknown)."""
        if self.chosen_offset_s is None or self.solved_offset_s is None:
            return None
        return 1000.0 * abs(self.chosen_offset_s - self.solved_offset_s)

    @property
    def error_ms(self) -> float | None:
        """|chosen - true| in ms when both are known."""
        if self.chosen_offset_s is None or self.true_offset_s is None:
            return None
        # Δ_ab is b's offset when a's is 0: the per-video error of b against the truth
        return offset_errors_ms({self.a: 0.0, self.b: self.chosen_offset_s},
                                {self.a: 0.0, self.b: self.true_offset_s}, self.a)[self.b]


@dataclass(frozen=True)
class EpipolarState:
    """Frame f of video a with the epipolar lines of b's matched points at one candidate Δ."""

    offset_s: float  # Δ_ab used, seconds
    points_a: np.ndarray  # (N,2) px, a's track points at frame f
    lines_a: np.ndarray  # (N,3) epipolar lines in a of b's points at τ_a - Δ (l·(x,y,1) = 0), NaN rows where b is unseen
    points_b: np.ndarray  # (N,2) px, b's matched points at τ_a - Δ (interpolated), NaN where unseen
    sampson_px2: np.ndarray  # (N,) Sampson error of each match, px², NaN where undefined
    median_sampson_px2: float  # median over finite entries, px² (NaN if none)

    @property
    def median_distance_px(self) -> float:
        """The median Sampson distance, px: the square root of the median Sampson error, the
        first-order distance of a match from its epipolar geometry (what decisions speak in)."""
        return float(np.sqrt(self.median_sampson_px2)) if np.isfinite(self.median_sampson_px2) else float("nan")


@dataclass(frozen=True)
class EpipolarPanel:
    """What the epipolar panel draws for one pair: the same frame of a at a wrong and at the chosen offset."""

    a: str
    b: str
    frame_a: int  # frame index of video a
    time_a_s: float  # its local time, seconds
    width: int  # px, size of a's image
    height: int  # px
    wrong: EpipolarState
    chosen: EpipolarState
    image_bgr: np.ndarray | None = None  # (H,W,3) uint8 frame of a when the video could be read
    accepted: bool = True  # the pair's decision: a rejected pair's "chosen" Δ is only its best


@dataclass(frozen=True)
class MosaicTile:
    """One video's frame at the mosaic's global moment."""

    name: str
    frame: int | None  # frame index shown (None: the video does not cover that moment)
    image_bgr: np.ndarray | None  # (h,w,3) uint8, downscaled; None when not covered or not readable


@dataclass(frozen=True)
class Mosaic:
    """One global moment across all videos after sync."""

    time_s: float  # global time, seconds
    tiles: tuple[MosaicTile, ...]


@dataclass(frozen=True)
class TransferView:
    """Stage 0's point-transfer check of a camera the joint vote was unsure of (cues/transfer.py)."""

    camera: str
    offsets_s: np.ndarray  # (D,) candidate offset_s of the camera, seconds, relative to `origin`
    share: np.ndarray  # (D,) share of the projected samples that land on one of its tracks
    origin: str  # the camera whose offset the joint vote set to 0
    joint_offset_s: float  # the joint vote's offset, seconds (same origin)
    transfer_offset_s: float | None  # the transfer's own peak (None: no trajectory followed)
    true_offset_s: float | None  # the truth relative to origin, when known
    confirmed: bool
    reason: str


@dataclass(frozen=True)
class ThreeViewView:
    """Stage 0's three-view check of an estimated camera the joint vote was sure of
    (cues/transfer.py, check_in_three_views)."""

    camera: str
    offsets_s: np.ndarray  # (D,) candidate offset_s of the camera, seconds, relative to `origin`
    supporters: np.ndarray  # (D,) trajectories of the other sure cameras followed by one of its tracks
    origin: str  # the camera whose offset the joint vote set to 0
    joint_offset_s: float  # the joint vote's offset, seconds (same origin)
    needed: float  # supporters the joint offset needed
    true_offset_s: float | None  # the truth relative to origin, when known
    passed: bool
    reason: str


@dataclass(frozen=True)
class ReportData:
    """Everything the report draws, already computed."""

    source: str  # run folder or .rrd the data came from
    reference: str
    videos: tuple[VideoClock, ...]
    offsets_s: dict[str, float | None]  # solved offsets (None = unresolved)
    uncertainty_s: dict[str, float | None]  # 1-sigma of each offset
    unresolved: dict[str, str]  # video -> why it has no offset
    pairs: tuple[PairView, ...]
    gt_offsets_s: dict[str, float] | None  # true offsets when known (same convention)
    cameras: tuple[CameraView, ...] = ()  # empty when the recording has no cameras
    static_points: np.ndarray | None = None  # (N,3) world, static reconstruction, None if absent
    static_colors: np.ndarray | None = None  # (N,3) uint8 RGB
    trajectories: tuple[Trajectory, ...] = ()
    epipolar: EpipolarPanel | None = None
    mosaic: Mosaic | None = None  # only when the video files can be read
    transfer: tuple[TransferView, ...] = ()  # Stage 0's point-transfer checks (none: nothing unsure)
    notes: tuple[str, ...] = ()  # readable notes on what could not be shown and why
    timings_s: dict[str, float] = field(default_factory=dict)
    three_view: tuple[ThreeViewView, ...] = ()  # Stage 0's three-view checks (none: no estimated camera sure)
    unresolved_headline: dict[str, str] = field(default_factory=dict)  # video -> why, one plain sentence
    # (RunResult.headlines, which falls back to the whole reason where the run gave no headline)
    labels: dict[str, str] = field(default_factory=dict)  # video -> short name figures draw it by
    # (analysis.display_names; a video missing here is drawn by its name)

    @property
    def names(self) -> list[str]:
        return [v.name for v in self.videos]

    def label(self, name: str) -> str:
        """The short name `name` is drawn by."""
        return self.labels.get(name, name)

    def label_legend(self) -> list[str]:
        """"short = full name" for each video drawn by a short name (none when no name was cut)."""
        return [f"{s} = {n}" for n, s in self.labels.items() if s != n]

    def video(self, name: str) -> VideoClock:
        for v in self.videos:
            if v.name == name:
                return v
        raise KeyError(name)

    def errors_ms(self) -> dict[str, float | None]:
        """Per-video error after aligning the reference with the truth (empty without truth)."""
        gt = self.gt_offsets_s
        if not gt or self.reference not in gt:
            return {}
        errors = offset_errors_ms({v: self.offsets_s.get(v) for v in self.names}, gt, self.reference)
        return {v: errors.get(v) for v in self.names}

    def errors_frames(self) -> dict[str, float | None]:
        """errors_ms() in frames of each video (empty without truth)."""
        out: dict[str, float | None] = {}
        for v, e in self.errors_ms().items():
            dt = self.video(v).frame_interval_s
            out[v] = e / (1000.0 * dt) if e is not None and np.isfinite(dt) and dt > 0 else None
        return out
