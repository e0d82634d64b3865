"""What the recording's parts share while a run is written: the stream and options, the run's
inputs and results as the stages hand them over, the videos held until the offsets are known, and
the bookkeeping more than one part reads (the offset_ms range logged, the event counter, the
stages' notes, the videos' display names).

Mutable, unlike the records between stages: the hooks arrive one by one, and each adds what a
later hook or close() logs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr

from .. import palette
from ..analysis.display_names import display_names as short_names_of
from ..analysis.record_options import RecordOptions
from ..result_types import RunResult, SyncResult
from ..types import CameraTrack, CueBundle, VideoInfo

if TYPE_CHECKING:
    from ..analysis.record_views import RunRecordView


@dataclass(eq=False)
class VideoBuffer:
    """What one video contributed before the offsets were known."""

    info: VideoInfo
    path: str | None
    asset: bool = False  # frames come from an rr.AssetVideo
    asset_timestamps_ns: np.ndarray | None = None  # (T,) int64 ns of the asset's frames
    jpeg: dict[int, bytes] = field(default_factory=dict)  # frame index -> JPEG
    image_size: tuple[int, int] | None = None  # (w, h) of logged images, px
    masks: dict[int, np.ndarray] = field(default_factory=dict)  # frame index -> (h,w) instance ids


@dataclass(eq=False)
class RecordingContext:
    """The stream every part logs to, and what the run has handed the sink so far."""

    rec: rr.RecordingStream
    options: RecordOptions
    progress: bool
    videos: dict[str, VideoBuffer] = field(default_factory=dict)
    bundle: CueBundle | None = None
    world_cameras: dict[str, CameraTrack] | None = None  # Stage 0's cameras in one world frame
    result: SyncResult | None = None
    view: RunRecordView | None = None
    summary: RunResult | None = None
    offset_ms_min: int | None = None  # smallest candidate offset logged on offset_ms
    offset_ms_max: int | None = None
    events: int = 0  # entries on the event timeline so far
    notes: list[str] = field(default_factory=list)  # stage events, repeated in the guide
    _labels: dict[str, str] | None = None

    def names(self) -> list[str]:
        """Every video the run was given, in its order."""
        return list(self.videos) or (self.bundle.names if self.bundle else [])

    def display_names(self) -> dict[str, str]:
        """Video -> the short name panel titles and legends draw it by (analysis.display_names)."""
        names = self.names()
        if self._labels is None or list(self._labels) != names:
            self._labels = short_names_of(names)
        return self._labels

    def short(self, name: str) -> str:
        return self.display_names().get(name, name)

    def camera_color(self, name: str) -> tuple[int, int, int]:
        names = self.names()
        return palette.category(names.index(name) if name in names else len(names))

    def cameras(self) -> dict[str, CameraTrack]:
        """Stage 0's world cameras, else the bundle's."""
        return self.world_cameras or (self.bundle.cameras if self.bundle else {})

    def truth(self) -> dict[str, float] | None:
        """The true offsets when the run knows them (its cue bundle's, or the run summary's)."""
        if self.bundle is not None and self.bundle.gt_offsets_s:
            return self.bundle.gt_offsets_s
        return self.summary.gt_offsets_s if self.summary is not None else None

    def extend_offset_range(self, ms: np.ndarray) -> None:
        """Widen the range of candidate offsets logged on offset_ms (the stills are logged at its
        start, and the viewer opens on that timeline when it is not empty)."""
        if len(ms):
            lo, hi = int(np.min(ms)), int(np.max(ms))
            self.offset_ms_min = lo if self.offset_ms_min is None else min(lo, self.offset_ms_min)
            self.offset_ms_max = hi if self.offset_ms_max is None else max(hi, self.offset_ms_max)

    def next_event(self) -> int:
        self.events += 1
        return self.events
