"""Stage 0 on real videos: moving regions, KLT tracks, cross-view track pairs and cameras
(imported or estimated with pycolmap), written as a cue bundle."""

from .config import CameraConfig, CueConfig, MatchConfig, MotionConfig, TrackConfig
from .extract import extract_cues

__all__ = ["CameraConfig", "CueConfig", "MatchConfig", "MotionConfig", "TrackConfig", "extract_cues"]
