"""Stage 0's typed records: what it found per video and per pair, the cameras it estimated and the
joint vote it took on them, as result.json's "cues" keeps them (the same keys as its JSON, written
and read by to_json/from_json here) and the recording shows them.

Every record is a frozen dataclass of plain values (numbers, strings, tuples, dicts of those,
other records). A field that is None is left out of the JSON, unless its metadata says "null"
(then it is written as null); a field marked "flat" is a record whose keys go into its owner's.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from dataclasses import dataclass, field
from typing import Any

from .geometry.camera_model import Lens
from .types import FROM_MOVING_POINTS, first_clause, pairs_by_reason

NULL = {"null": True}  # field metadata: written as null when None
FLAT = {"flat": True}  # field metadata: a record whose keys go into its owner's


# ---- JSON of records ---------------------------------------------------------------------------


def to_json(obj: Any) -> Any:
    """A record (or a value holding records) as JSON values."""
    if dataclasses.is_dataclass(obj):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if v is None and not f.metadata.get("null"):
                continue
            if f.metadata.get("flat"):
                out.update(to_json(v))
            else:
                out[f.name] = to_json(v)
        return out
    if isinstance(obj, dict):
        return {k: to_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json(v) for v in obj]
    return obj


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def from_json(tp: Any, data: Any) -> Any:
    """The value of type tp (a record, a container of records or a plain type) from to_json's output."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return None if data is None else from_json(args[0], data)
    if dataclasses.is_dataclass(tp):
        hints = _hints(tp)
        kwargs = {}
        for f in dataclasses.fields(tp):
            if f.metadata.get("flat"):  # left out (None) when none of its keys is there
                inner = [a for a in typing.get_args(hints[f.name]) if a is not type(None)] or [hints[f.name]]
                kwargs[f.name] = from_json(inner[0], data) if _has_any(data, inner[0]) else None
            elif f.name in data:
                kwargs[f.name] = from_json(hints[f.name], data[f.name])
        return tp(**kwargs)
    if origin is dict:
        _, vt = typing.get_args(tp)
        return {k: from_json(vt, v) for k, v in data.items()}
    if origin is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(from_json(args[0], v) for v in data)
        return tuple(from_json(a, v) for a, v in zip(args, data))
    if tp is float and data is not None:
        return float(data)
    return data


def _has_any(data: dict, cls: type) -> bool:
    """Whether data holds any key of record cls."""
    return any(f.name in data for f in dataclasses.fields(cls))


# ---- one video ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class VideoCueStats:
    """Stage 0's counts for one video."""

    path: str
    camera_motion: str  # "static" | "moving"
    background_motion_px: float  # median background motion between sampled frames, px
    moving_fraction: float  # share of pixels in moving regions, 0..1
    tracks: int
    instances: int  # moving regions (connected instances) found
    keyframe_features: int
    snapped_features: int  # keyframe features snapped to a track
    note: str | None = None  # why the video gives no cues (no moving regions, no tracks)


# ---- one pair of videos ------------------------------------------------------------------------


@dataclass(frozen=True)
class PairVoteSummary:
    """What the epipolar vote of one camera pair found and which of its track pairs were kept."""

    geometric_candidates: int  # track pairs checked
    geometric_informative: int  # consistent at a narrow band of offsets
    geometric_pairs: int  # geometric track pairs kept
    geometric_new: int  # of those, not among the descriptor pairs already
    geometric_peaks_s: tuple[float, ...]  # the vote's peaks Δ_ab, s
    geometric_peak_votes: tuple[int, ...]  # votes at each
    geometric_chosen_peak_s: float | None = None  # triangle closure: the peak whose supporters were kept
    geometric_joint_delta_s: float | None = None  # joint vote: the Δ_ab it implies
    geometric_joint_votes: int | None = None  # votes at that Δ_ab
    geometric_joint_margin: tuple[float, float] | None = None  # the two cameras' margins
    geometric_withheld: str | None = None  # why no geometric pair was kept, when the vote had some
    geometric_withheld_short: str | None = None  # that in a few words
    geometric_unchecked: int | None = None  # track pairs kept whose peak no triangle checked
    descriptor_pairs_kept: int | None = None  # descriptor pairs consistent at the chosen Δ
    descriptor_pairs_before: int | None = None


@dataclass(frozen=True)
class PairCueStats:
    """Stage 0's counts for one pair of videos."""

    matches: int  # descriptor matches over all keyframe pairs
    snapped: int  # matches whose both ends snapped to a track
    instance_pairs: int  # matched instance pairs kept
    track_pairs: int  # descriptor track pairs
    vote: PairVoteSummary | None = field(default=None, metadata=FLAT)  # None: the pair was not voted on
    transfer_new: int | None = None  # track pairs that point transfer added


# ---- the cameras -------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImagePairMatches:
    """Matches of one SfM image pair (which frames of which videos the reconstruction could tie)."""

    a: str  # "video/frame.jpg"
    b: str
    matches: int
    verified: int


@dataclass(frozen=True)
class FrameRegistration:
    """A moving camera's frames registered on their own against the reconstruction."""

    tried: int
    registered: int
    refused: int  # refused for a jump in rotation
    median_inliers: float
    frames: tuple[int, ...]  # frames registered
    check_frames: int  # reconstructed frames registered from their neighbours, as a check
    check_rotation_deg_median: float | None = field(default=None, metadata=NULL)
    check_slerp_rotation_deg_median: float | None = field(default=None, metadata=NULL)


@dataclass(frozen=True)
class MovingPointsPair:
    """The moving points' two-view geometry of one camera with the reference."""

    coarse_offset_s: float | None = None  # the offset its cameras were fitted at, s
    inlier_share: float | None = None
    correspondences: int | None = None
    focal_px: float | None = None
    scale_from_shared_points: bool | None = None


@dataclass(frozen=True)
class MovedOffset:
    alone_s: float  # its best coarse offset with the reference alone
    together_s: float  # the one chosen with every pair


@dataclass(frozen=True)
class JointCoarseOffsets:
    pairs: int
    summed_share: float
    moved: dict[str, MovedOffset]


@dataclass(frozen=True)
class JointFit:
    """One focal per camera and every pose fitted to all camera pairs' track pairs at once."""

    pairs: int
    cost: float | None = None  # scipy's robust cost
    median_px_before: float | None = None
    median_px_after: float | None = None
    focal_px: dict[str, float] | None = None
    start: str | None = None  # which start of the fit won


@dataclass(frozen=True)
class FittedOffsetPair:
    fitted_s: float  # Δ_ab the cameras were fitted at
    voted_s: float  # Δ_ab the epipolar vote chose
    agrees: bool


@dataclass(frozen=True)
class FittedOffsetCheck:
    """The moving points' cameras' fitted offsets against their own epipolar votes."""

    verdict: str
    tolerance_s: float | None = None
    pairs: dict[str, FittedOffsetPair] | None = None
    refused: tuple[str, ...] | None = None


@dataclass(frozen=True)
class MovingPointsCameras:
    """Whether the moving points' own cameras were fitted and used instead of a model's."""

    why: str
    used: bool
    reference: str | None = None
    pairs: dict[str, MovingPointsPair] | None = None  # camera -> its geometry with the reference
    joint_offsets: JointCoarseOffsets | None = None
    joint_fit: JointFit | None = None
    fitted_offsets_s: dict[str, float] | None = None
    check: FittedOffsetCheck | None = None

    def to_json(self) -> dict[str, Any]:
        """The diagnostics of the fit go under "pairs" with the cameras (result.json's shape)."""
        out = to_json(dataclasses.replace(self, pairs=None, joint_offsets=None, joint_fit=None))
        if self.reference is not None:
            pairs: dict[str, Any] = to_json(self.pairs or {})
            if self.joint_offsets is not None:
                pairs["joint_offsets"] = to_json(self.joint_offsets)
            if self.joint_fit is not None:
                pairs["joint_fit"] = to_json(self.joint_fit)
            out = {"reference": self.reference, "pairs": pairs, **{k: v for k, v in out.items() if k != "reference"}}
        return out

    @staticmethod
    def from_json(d: dict[str, Any]) -> MovingPointsCameras:
        pairs = dict(d.get("pairs") or {})
        joint_offsets, joint_fit = pairs.pop("joint_offsets", None), pairs.pop("joint_fit", None)
        plain = from_json(MovingPointsCameras, {k: v for k, v in d.items() if k != "pairs"})
        return dataclasses.replace(
            plain, pairs=from_json(dict[str, MovingPointsPair], pairs) if "pairs" in d else None,
            joint_offsets=from_json(JointCoarseOffsets | None, joint_offsets),
            joint_fit=from_json(JointFit | None, joint_fit))


@dataclass(frozen=True)
class ModelTried:
    """One camera set the joint vote was taken on."""

    features: str  # "sift", "xfeat", "aliked", "moving points", "sift own", ...
    cameras: int
    trusted: tuple[str, ...]  # videos the joint vote trusted on it
    kept: bool


@dataclass(frozen=True)
class SfmRecord:
    """Estimated cameras: the kept model, what the others made of the videos it gives no offset."""

    features: str  # what the kept reconstruction was built from
    images: int  # SfM images
    registered_images: int
    registered_frames: dict[str, tuple[int, ...]]  # video -> frames with a pose
    image_pairs: tuple[ImagePairMatches, ...]
    lens: dict[str, Lens]  # video -> its estimated lens (the tracks were undistorted with it)
    frame_registration: dict[str, FrameRegistration] | None = None
    static_images: str | None = None  # how the static cameras' images got their features
    fallback: MovingPointsCameras | None = None
    models: tuple[ModelTried, ...] | None = None  # every camera set voted on, when more than one
    models_failed: str | None = None
    models_skipped: str | None = None
    kept_model: str | None = None  # whose set was kept ("SIFT's model")
    other_models_headline: dict[str, dict[str, str]] | None = None  # video -> {whose: few words}
    other_models: dict[str, str] | None = None  # video placed but not trusted -> what the others made of it

    def to_json(self) -> dict[str, Any]:
        out = to_json(dataclasses.replace(self, fallback=None))
        if self.fallback is not None:
            out["fallback"] = self.fallback.to_json()
        return out

    @staticmethod
    def from_json(d: dict[str, Any]) -> SfmRecord:
        plain = from_json(SfmRecord, {k: v for k, v in d.items() if k != "fallback"})
        return dataclasses.replace(plain, fallback=MovingPointsCameras.from_json(d["fallback"])
                                   if d.get("fallback") is not None else None)


# ---- the joint vote ----------------------------------------------------------------------------


@dataclass(frozen=True)
class TransferSummary:
    """Point transfer's check of a camera the joint vote was unsure of, with its landscape."""

    joint_offset_s: float
    transfer_offset_s: float | None = field(default=None, metadata=NULL)
    z: float = 0.0
    trajectories: int = 0
    supporters: int = 0
    matches: int = 0
    confirmed: bool = False
    reason: str = ""
    offsets_s: tuple[float, ...] = ()
    share: tuple[float, ...] = ()


@dataclass(frozen=True)
class ThreeViewSummary:
    """The three-view check of a camera the joint vote was sure of, with its landscape."""

    joint_offset_s: float
    trajectories: int
    supporters: int
    best_supporters: int
    best_offset_s: float | None = field(default=None, metadata=NULL)
    needed: float = 0.0
    passed: bool = False
    reason: str = ""
    offsets_s: tuple[float, ...] = ()
    supporters_by_offset: tuple[int, ...] = ()


@dataclass(frozen=True)
class JointVoteRecord:
    """The joint vote on the kept camera set: every camera's offset chosen at once, which it was
    sure of, and what the checks after it said."""

    origin: str  # the camera whose offset is 0
    offsets_s: dict[str, float]
    score: float = 0.0
    margin: dict[str, float] = field(default_factory=dict)  # camera -> score lost by moving it
    sure: tuple[str, ...] = ()
    used: tuple[str, ...] = ()  # cameras with a pair whose Δ was trusted
    transfer: dict[str, TransferSummary] | None = None
    three_view: dict[str, ThreeViewSummary] | None = None
    dissent: dict[str, str] | None = None  # camera -> why its pairs (or another model) contradict it
    dissent_short: dict[str, str] | None = None
    overruled: dict[str, str] | None = None  # camera -> why another model's dispute was overruled

    def refused_in_three_views(self) -> list[str]:
        return sorted(v for v, chk in (self.three_view or {}).items() if not chk.passed)


@dataclass(frozen=True)
class HeadsRecord:
    """The person detector's run (None in CueStats: no camera moved, or turned off)."""

    skipped: str | None = None  # why it did not run
    detector: str | None = None
    frames_with_a_head: dict[str, int] | None = None
    found_ahead_s: dict[str, float] | None = None  # seconds spent beside the cameras, per video
    failed: dict[str, str] | None = None


@dataclass(frozen=True)
class PeoplePairRecord:
    """One pair of videos as their people timed it (people_types.PeoplePair, in short)."""

    reason: str  # why taken, or why refused
    people_associated: int  # people both videos see, paired up
    offset_s: float | None = None  # Δ_ab, s; None: refused
    offset_std_s: float | None = None  # its 1-sigma, s


@dataclass(frozen=True)
class PeopleRecord:
    """The people cue's run (None in CueStats: not tried)."""

    kept: bool  # its cameras were the ones used
    why: str  # why it was tried, and why its cameras were kept or not
    reference: str
    people: dict[str, int]  # video -> people followed
    pairs: dict[str, PeoplePairRecord]  # "a__b" -> its verdict
    offsets_s: dict[str, float]  # video -> offset from the accepted pairs, s
    refused: dict[str, str]  # video -> why the people give it no camera
    reprojection_px: dict[str, float]  # placed video -> median reprojection of its landmarks, px
    timings_s: dict[str, float]  # "people", "pairs", "cameras", "total"


# ---- Stage 0 as a whole ------------------------------------------------------------------------


@dataclass(frozen=True)
class CueStats:
    """What Stage 0 found and how long it took, for result.json's "cues" and the recording."""

    camera_source: str  # "calibration" | "estimated" | "estimated from moving points (...)"
    registered_cameras: int
    tracks: int
    track_pairs: int
    videos: dict[str, VideoCueStats]
    pairs: dict[str, PairCueStats]  # "a__b" -> counts
    dropped: dict[str, str]  # video -> why it was left out of the bundle
    timings_s: dict[str, float]  # per Stage 0 step, seconds
    geometric_peaks: str | None = None  # "joint" | "chosen" | "inconsistent" | "one triangle" | "no triangle" | "too many pairs" (None: not run)
    sfm: SfmRecord | None = None  # estimated cameras (None: calibrated)
    geometric_joint: JointVoteRecord | None = None
    heads: HeadsRecord | None = None
    people: PeopleRecord | None = None

    def to_json(self) -> dict[str, Any]:
        """result.json's "cues" (the timings go with the run's)."""
        out = to_json(dataclasses.replace(self, sfm=None, timings_s={}))
        out.pop("timings_s")
        if self.sfm is not None:
            out["sfm"] = self.sfm.to_json()
        return out

    @staticmethod
    def from_json(d: dict[str, Any], timings_s: dict[str, float] | None = None) -> CueStats:
        names = {f.name for f in dataclasses.fields(VideoCueStats)}
        videos = {n: VideoCueStats(**{k: v for k, v in s.items() if k in names})
                  for n, s in (d.get("videos") or {}).items()}
        pairs = {k: from_json(PairCueStats, {"matches": 0, "snapped": 0, "instance_pairs": 0, "track_pairs": 0, **p})
                 for k, p in (d.get("pairs") or {}).items()}
        return CueStats(str(d.get("camera_source", "")), int(d.get("registered_cameras", 0)),
                        int(d.get("tracks", 0)), int(d.get("track_pairs", 0)), videos, pairs,
                        dict(d.get("dropped") or {}), dict(timings_s or {}), d.get("geometric_peaks"),
                        SfmRecord.from_json(d["sfm"]) if d.get("sfm") else None,
                        from_json(JointVoteRecord | None, d.get("geometric_joint")),
                        from_json(HeadsRecord | None, d.get("heads")),
                        from_json(PeopleRecord | None, d.get("people")))

    def refused_in_three_views(self) -> list[str]:
        """The cameras Stage 0's three-view check refused, by name."""
        return self.geometric_joint.refused_in_three_views() if self.geometric_joint else []

    def geometric_refusal(self, video: str) -> str | None:
        """Why Stage 0 gave `video` no geometric track pairs (refusal_texts), or None."""
        refusal = refusal_texts(self.votes(), self.dropped, self.geometric_joint, video)
        return None if refusal is None else refusal[1]

    def refusal_headline(self, video: str) -> str | None:
        """geometric_refusal's cause in a few words, or None."""
        refusal = refusal_texts(self.votes(), self.dropped, self.geometric_joint, video)
        return None if refusal is None else refusal[0]

    def votes(self) -> dict[str, PairVoteSummary | None]:
        """"a__b" -> the pair's vote on the kept cameras (None: not voted on)."""
        return {k: p.vote for k, p in self.pairs.items()}

    def headline(self, video: str, later: str | None = None) -> str:
        """Why `video` has no offset, in a few words: why Stage 0 left it out, or the kept camera
        model's refusal (the model named when others were tried) and later's first clause (Stage 1
        and 2's reason), then what the other camera models made of it."""
        sfm = self.sfm
        if video in self.dropped:
            first, *rest = self.dropped[video].split("; ")
            cause, later = first_clause(first), None
            why = "; ".join([cause, *(first_clause(c) for c in rest if c.startswith(FROM_MOVING_POINTS))])
        else:
            cause = why = self.refusal_headline(video)
        others = ((sfm.other_models_headline if sfm else None) or {}).get(video) or {}
        parts = [f"{sfm.kept_model}: {why}" if why and others and sfm.kept_model else why,
                 first_clause(later) if later else None]
        if others:  # models whose cause is the kept one's are named, not repeated
            said = [(m, "the same" if c == cause else c) for m, c in others.items()]
            parts.append("other camera models: " + "; ".join(pairs_by_reason(said)))
        return "; ".join(p for p in parts if p) or "no offset"

    def other_models_note(self, video: str) -> str | None:
        """What the camera models Stage 0 tried and did not keep made of `video`, when the kept
        one placed its camera but did not trust its offset, or None."""
        return ((self.sfm.other_models if self.sfm else None) or {}).get(video)


def refusal_texts(votes: dict[str, PairVoteSummary | None], dropped: dict[str, str],
                  joint: JointVoteRecord | None, video: str) -> tuple[str, str] | None:
    """(few words, whole sentence) on why Stage 0 gave `video` no geometric track pairs, from
    the pairs' votes ("a__b" -> PairVoteSummary), the videos dropped and the joint vote (of the
    kept camera set, or of another one tried): its pairs' vote peaks were withheld, or its joint
    vote was unsure of it (with point transfer's verdict), sure of it but refuted in three views
    or by a pair of its own (dissent), or sure of too few cameras to close a triangle; else None
    (used, dropped, or no joint vote)."""
    withheld = [(k, v) for k, v in votes.items()
                if video in k.split("__") and v is not None and v.geometric_withheld]
    if withheld and video not in dropped:
        short = next((v.geometric_withheld_short for _, v in withheld if v.geometric_withheld_short),
                     "vote peaks unchecked")
        return short, "Stage 0 gave " + "; ".join(pairs_by_reason([(k, v.geometric_withheld) for k, v in withheld],
                                                                  " no geometric track pairs"))
    if joint is None or video not in joint.margin or video in joint.used or video in dropped:
        return None
    margin = joint.margin[video]
    if video in joint.refused_in_three_views():
        return ("refuted in three views",
                f"Stage 0's joint vote was sure of its offset (margin {margin:.1f}), but "
                f"not in three views ({joint.three_view[video].reason}), so it got no geometric track pairs")
    dissent = (joint.dissent or {}).get(video)
    if dissent:
        return ((joint.dissent_short or {}).get(video, "its offset disputed"),
                f"Stage 0's joint vote chose its offset (margin {margin:.1f}), but {dissent}, "
                f"so it got no geometric track pairs")
    if video in joint.sure:
        return (f"sure of {len(joint.sure)} camera(s) only, no triangle to confirm it",
                f"Stage 0's joint vote was sure of its offset (margin {margin:.1f}) but of "
                f"{len(joint.sure)} camera(s) only, so no triangle of sure cameras confirmed it and it "
                f"got no geometric track pairs")
    check = (joint.transfer or {}).get(video)
    return (f"joint vote unsure of it (margin {margin:.1f})",
            f"Stage 0's joint vote was not sure of its offset (margin {margin:.1f}), "
            f"so it got no geometric track pairs" + (f" ({check.reason})" if check else ""))
