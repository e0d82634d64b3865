"""One set of cameras for the videos (calibrated, estimated or from the people) and what the
joint vote's pairing made of them (cues/cameras/choice.py chooses among such sets)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ...camera_stats import SfmRecord
from ...types import CameraTrack, Tracks
from ..pairing.pairing import GeometricPairing
from ..records import Note


@dataclass
class CameraSet:
    """One set of cameras for the videos and what the pairing made of them."""

    cameras: dict[str, CameraTrack]
    tracks: dict[str, Tracks]  # undistorted with the cameras' lenses
    points: np.ndarray | None  # (P,3) static points of the reconstruction, None without one
    colors: np.ndarray | None  # (P,3) uint8
    undistort: dict  # name -> function undistorting (...,2) full-resolution px
    dropped: dict = dataclasses.field(default_factory=dict)  # video -> why this set has no camera for it
    source: str = "estimated"  # where the cameras came from (CueStats.camera_source)
    sfm: SfmRecord | None = None  # the estimate's record (None: calibrated)
    pairs: dict | None = None  # (a, b) -> TrackPairs after the pairing
    used: frozenset = frozenset()  # cameras with a pair whose geometric Δ the pairing trusted
    voting_s: float = 0.0  # seconds spent voting
    pairing: GeometricPairing | None = None  # what the pairing made of the set (None: not run)
    notes: tuple[Note, ...] = ()  # what was decided on the set, in words, in order (its pairing's included)

    def votes(self) -> dict:
        """"a__b" -> the pair's PairVoteSummary on these cameras."""
        return {f"{a}__{b}": v for (a, b), v in (self.pairing.votes if self.pairing else {}).items()}
