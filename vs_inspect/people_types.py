"""Typed, frozen records of the people cue: the people followed in each video, which person of
one video is which of another, each pair's shift (or its refusal), and the cameras and track pairs
Stage 0 makes of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo, _require_shape


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
