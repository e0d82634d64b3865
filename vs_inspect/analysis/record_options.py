"""How much a recording keeps. Imports nothing heavy, so the CLI can build options cheaply."""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class RecordOptions:
    """What RerunSink logs. The defaults keep a 4-video, 10 s, 720p run well under 150 MB."""

    frames: bool = True
    """Log video frames (H.264/AV1 input as a video asset, anything else as JPEG images)."""
    max_image_width_px: int = 640
    """Downscale JPEG frames to at most this width (0 = full resolution)."""
    jpeg_quality: int = 75
    """JPEG quality of logged frames (1-100)."""
    video_assets: bool = True
    """Embed H.264/AV1 input files as rr.AssetVideo (exact frames, small) instead of JPEGs."""
    max_asset_mb: float = 60.0
    """Larger input files are logged as JPEG frames instead of being embedded whole."""
    masks: bool = True
    """Log moving-region masks (downscaled, nearest neighbour)."""
    max_mask_width_px: int = 320
    """Downscale masks to at most this width."""
    max_tracks_per_video: int = 400
    """Tracks logged per video (0 = none, -1 = all); tracks used by pairs come first."""
    epipolar_offsets: int = 41
    """Candidate offsets shown in each pair's epipolar view (0 = none, -1 = all candidates)."""
    epipolar_lines: int = 60
    """Track pairs drawn as epipolar lines in each pair's epipolar view."""
    trajectories: bool = True
    """Triangulate accepted pairs' track pairs at the solved offsets (world/trajectories)."""
    max_trajectory_pairs: int = 150
    """Track pairs triangulated per accepted pair."""
    max_trajectory_video_pairs: int = 12
    """Accepted video pairs whose trajectories are triangulated (best contrast first)."""

    embed_bundle: bool = True
    """Embed the cue bundle (zip) at meta/cue_bundle, so a report can be made from the .rrd alone."""

    def __post_init__(self) -> None:
        from ..errors import check_fields
        check_fields(self, nonnegative=("max_image_width_px", "max_asset_mb", "max_mask_width_px",
                                        "epipolar_lines", "max_trajectory_pairs",
                                        "max_trajectory_video_pairs"),
                     at_least={"max_tracks_per_video": -1, "epipolar_offsets": -1, "jpeg_quality": 1},
                     at_most={"jpeg_quality": 100})

    @staticmethod
    def minimal() -> "RecordOptions":
        """Decisions, landscapes, graph, solve and cameras only: no frames, tracks or 3D tracks."""
        return RecordOptions(frames=False, masks=False, max_tracks_per_video=0, epipolar_offsets=0,
                             trajectories=False)

    def with_flags(self, all_offsets: bool = False, full_frames: bool = False,
                   all_tracks: bool = False) -> "RecordOptions":
        out = self
        if all_offsets:
            out = replace(out, epipolar_offsets=-1)
        if full_frames:
            out = replace(out, max_image_width_px=0, jpeg_quality=90, max_mask_width_px=0)
        if all_tracks:
            out = replace(out, max_tracks_per_video=-1, epipolar_lines=100000,
                          max_trajectory_pairs=100000)
        return out
