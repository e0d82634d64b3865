"""Stage 0's typed records: what it found per video and per pair, the joint vote it took on the
cameras, the person detector's and the people cue's runs, as result.json's "cues" keeps them (the
same keys as its JSON, written and read with json_records) and the recording shows them. The
records of the cameras it estimated are in camera_stats.py.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from .camera_stats import SfmRecord
from .json_records import FLAT, NULL, from_json, to_json
from .types import FROM_MOVING_POINTS, first_clause, pairs_by_reason


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
    dissent: dict[str, str] | None = None  # camera -> why a check after the vote contradicts it
    dissent_short: dict[str, str] | None = None

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
