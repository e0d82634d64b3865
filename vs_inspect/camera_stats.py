"""Stage 0's records of the cameras it estimated: the kept model with its matches and frame
registrations, the moving points' own cameras and their fit, and every model tried, as
result.json's "cues" keeps them under "sfm" (written and read with json_records).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from .geometry.camera_model import Lens
from .json_records import NULL, from_json, to_json


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
class MovingPointsCameras:
    """Whether the moving points' own cameras were fitted and used instead of a model's."""

    why: str
    used: bool
    reference: str | None = None
    pairs: dict[str, MovingPointsPair] | None = None  # camera -> its geometry with the reference
    joint_offsets: JointCoarseOffsets | None = None
    joint_fit: JointFit | None = None

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

    features: str  # "sift", "xfeat", "aliked", "moving points"
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
