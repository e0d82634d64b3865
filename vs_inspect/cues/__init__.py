"""Stage 0's steps on real videos: each video's own cues (moving regions, KLT tracks, keyframe
features), cross-view track pairs, and the cameras (imported or estimated) with the joint vote
on them. The Stage 0 controller (pipeline/stage0.py) calls them in order and reports their records."""

from .config import CameraConfig, CueConfig

__all__ = ["CameraConfig", "CueConfig"]
