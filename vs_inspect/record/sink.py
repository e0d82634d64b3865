"""The sink interface stages report through. Library code never logs to a global recording.

A stage calls these hooks with its typed results; a sink decides what to keep. NullSink keeps
nothing. Hooks have no return value and must not change their arguments. A sink that records has
RecordOptions in `options` (None: it keeps nothing): only then does a stage compute the views the
recording shows (analysis/record_views.py) and hand them over with its results.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

    from ..analysis.record_views import PairRecordView, RunRecordView
    from ..people_types import PeopleCue
    from ..result_types import PairLandscape, RunResult, SyncResult
    from ..types import CameraTrack, CueBundle, VideoInfo
    from ..analysis.record_options import RecordOptions


class Sink:
    """Base class: every hook is a no-op, so sinks override only what they record."""

    options: RecordOptions | None = None  # what the sink records; None: no views are computed for it

    def image_frames(self, name: str) -> set[int] | None:
        """Frames of a video the sink holds an image of (None: none or unknown)."""
        return None

    # ---- Stage 0 (cue extraction from videos) ----

    def video(self, info: VideoInfo, path: str | None) -> None:
        """An input video (path to the file or image folder, None for synthetic input)."""

    def video_frame(self, name: str, frame_index: int, image_bgr: np.ndarray) -> None:
        """One frame (h,w,3) uint8 BGR as the recording keeps it (analysis.record_views.record_frame)."""

    def dynamic_mask(self, name: str, frame_index: int, instances: np.ndarray) -> None:
        """(h,w) uint8/uint16 instance ids of moving regions at a frame (0 = static background), as
        the recording keeps them (analysis.record_views.record_mask)."""

    def pair_matches(self, a: str, b: str, frames_a: np.ndarray, frames_b: np.ndarray,
                     counts: np.ndarray) -> None:
        """Descriptor matches between every keyframe of a (frames_a (Ka,)) and of b (frames_b (Kb,)):
        counts (Ka,Kb) int."""

    def pair_votes(self, a: str, b: str, offsets_s: np.ndarray, votes: np.ndarray, z: np.ndarray,
                   chosen_s: float | None) -> None:
        """The geometric pairing's votes of pair (a, b) (cues/pairing/votes.py): informative
        candidates per Δ_ab (offsets_s (D,) s, votes (D,)), their robust z-scores (D,) that the
        joint vote sums, and the Δ_ab whose supporters Stage 0 kept (None: none)."""

    def transfer_landscape(self, camera: str, offsets_s: np.ndarray, share: np.ndarray,
                           joint_offset_s: float, transfer_offset_s: float | None, confirmed: bool) -> None:
        """Point transfer's check of a camera the joint vote was unsure of (cues/pairing/transfer.py):
        share (D,) of the projected samples that land on their track at each candidate offset_s
        (D,) of the camera, the joint vote's offset, the transfer's peak and the verdict."""

    def three_view_landscape(self, camera: str, offsets_s: np.ndarray, supporters: np.ndarray,
                             joint_offset_s: float, passed: bool) -> None:
        """The three-view check of a camera the joint vote was sure of (cues/pairing/transfer.py,
        check_in_three_views): supporters (D,) over its candidate offset_s (D,), the joint
        vote's offset and the verdict."""

    def cameras(self, cameras: dict[str, CameraTrack], points_world: np.ndarray | None,
                colors: np.ndarray | None) -> None:
        """Cameras of all videos in one world frame, and the static 3D points (N,3) with (N,3) uint8 colours."""

    # ---- Stage 1 and 2 ----

    def people_cue(self, cue: PeopleCue) -> None:
        """What the people in view gave Stage 0: their landmarks per video, each pair's shift
        evidence and verdict, the cameras they placed."""

    def bundle(self, bundle: CueBundle) -> None:
        """Videos, cameras and tracks that Stage 1 starts from."""

    def pair_landscape(self, landscape: PairLandscape, view: PairRecordView | None = None) -> None:
        """One pair's landscape and decision, with its recording view (None when options is None)."""

    def sync_result(self, result: SyncResult, view: RunRecordView | None = None) -> None:
        """Stage 2's offsets and IRLS iterations, with the run's recording view (None when options is None)."""

    def stage_event(self, stage: str, message: str, **numbers: Any) -> None:
        """A readable note from any stage (e.g. a camera that could not be registered)."""

    def run_summary(self, result: RunResult) -> None:
        """The whole run's result (result.json's content, with config and inputs)."""

    def close(self) -> None:
        """Flush and finish the recording."""

    def abort(self) -> None:
        """Stop after a failure: leave nothing that looks like a complete recording."""

    def __enter__(self) -> "Sink":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


class NullSink(Sink):
    """Records nothing (the default)."""
