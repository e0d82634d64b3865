"""RerunSink: every stage's hooks written to an explicit rr.RecordingStream saved to an .rrd file.

A thin facade: each hook hands what the stages give it (their results, and the views that
analysis/record_views.py computed for the recording) to the part that logs it, at the entity
paths of io/recording_paths.py:

    videos.py      frames, masks, tracks and stills of each video
    cameras.py     cameras, frustums, moving cameras' poses, static points
    pairing.py     Stage 0's keyframe matches, pair votes, point-transfer and three-view checks
    landscapes.py  Stage 1: each pair's landscapes, decision and epipolar view
    solve.py       Stage 2: pair graph, IRLS iterations, offsets, pairs and loop tables, trajectories
    meta.py        meta/* records and the stages' events;  guide.py  the guide;  blueprint.py  the layout

They share a RecordingContext (context.py). The entity tree is documented in README.md
("Recordings"). The file is written through io/atomic.atomic_path, so a file with the final name
is always complete; abort() (or leaving a `with` block by an exception) deletes the temporary file.

Frames, masks and tracks are kept (JPEG-compressed) until the offsets are known, then logged once
with both the per-video `frame` timeline and the global `time` timeline (seconds, after sync).
Landscapes and epipolar views live on the `offset_ms` timeline, on which the viewer opens; so that
the video and 3D views are not empty there, each video's still frame and each moving camera's
middle pose are also logged once at the smallest candidate offset of the run.
"""

from __future__ import annotations

import functools
import logging
import os
import time
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr

from .. import signals
from ..analysis.colours import PALETTE, RAMP, distance_colors, instance_colors  # noqa: F401 - re-exported: imported from here
from ..analysis.run_result import run_result_from_sync
from ..io.atomic import atomic_path
from ..io.recording_paths import (
    APPLICATION_ID, CUES_THREE_VIEW, CUES_TRANSFER, TIMELINE_FRAME, TIMELINE_OFFSET_MS, TIMELINE_TIME,
    check_entity_names,
)
from ..analysis.record_options import RecordOptions
from ..people_types import PeopleCue
from ..result_types import PairLandscape, RunResult, SyncResult
from ..types import CameraTrack, CueBundle, VideoInfo
from . import meta, solve
from .blueprint import blueprint
from .cameras import CameraLog
from .context import RecordingContext
from .guide import log_guide
from .landscapes import PairLog
from .pairing import PairingLog
from .sink import Sink
from .style import ACCEPTED, REJECTED, TRUTH, annotation_context  # noqa: F401 - re-exported: imported from here
from .videos import VideoLog

if TYPE_CHECKING:
    from ..analysis.record_views import PairRecordView, RunRecordView

log = logging.getLogger(__name__)


def _writer_error(path: Path, exc: BaseException) -> OSError:
    """An OSError naming the recording for a failure of rerun's file writer (which reports only
    "File-writer thread shut down prematurely"): a full disk or a read-only folder when so."""
    import errno
    import shutil
    folder = path.parent
    try:
        full = shutil.disk_usage(folder).free < 1 << 20
    except OSError:
        full = False
    if full:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    if not os.access(folder, os.W_OK):
        return OSError(errno.EACCES, os.strerror(errno.EACCES), str(path))
    return OSError(errno.EIO, f"writing the recording failed ({exc})", str(path))


def _timed(fn):
    """Adds the wall time of a hook to self.hook_s (the cost of recording, without the stages)."""

    @functools.wraps(fn)
    def wrapper(self, *args, **kwargs):
        signals.checkpoint()  # every hook is a safe point to stop at
        t = time.perf_counter()
        try:
            return fn(self, *args, **kwargs)
        finally:
            self.hook_s += time.perf_counter() - t
    return wrapper


class RerunSink(Sink):
    """Writes a vs_inspect recording. Use as a context manager or call close()/abort().

    A hook is a @_timed method that hands its arguments to one part (a new hook: one such
    method, and its part's module if it logs something new)."""

    def __init__(self, path: str | os.PathLike, application_id: str = APPLICATION_ID,
                 options: RecordOptions | None = None, recording_id: str | None = None,
                 progress: bool = True):
        self.path = Path(path)
        self.options = options or RecordOptions()
        self.progress = progress
        # a hidden temporary file that becomes self.path when close() succeeds (io/atomic.py)
        self._file = ExitStack()
        self._tmp = self._file.enter_context(atomic_path(self.path))
        self._t0 = time.perf_counter()
        # a fresh recording id per run (unless given), so two runs opened together do not merge
        self.rec = rr.RecordingStream(application_id, recording_id=recording_id, send_properties=True)
        try:
            self.rec.save(str(self._tmp))
        except BaseException as exc:
            self._file.__exit__(type(exc), exc, exc.__traceback__)
            raise
        self._closed = False
        self._entities: dict[str, str] = {}  # entity path part -> video name (unique, see check_entity_names)
        self._ctx = RecordingContext(self.rec, self.options, progress)
        self._videos = VideoLog(self._ctx)
        self._cameras = CameraLog(self._ctx)
        self._pairing = PairingLog(self._ctx)
        self._people_logged: list[str] | None = None  # "a__b" with the people cue's shift evidence (None: not run)
        self._pairs = PairLog(self._ctx, self._videos.still_frames)
        self.hook_s = 0.0
        self.stats: dict[str, float] = {}

    @property
    def _pairs_logged(self) -> list[str]:
        """"a__b" of every pair logged so far, in order."""
        return self._pairs.logged

    def image_frames(self, name: str) -> set[int] | None:
        """Frames of a video this sink holds an image of (None: the video is unknown)."""
        return self._videos.image_frames(name)

    def display_names(self) -> dict[str, str]:
        """Video -> the short name panel titles and legends draw it by (analysis.display_names),
        from every video the run was given, in their order."""
        return self._ctx.display_names()

    # ---- Stage 0 hooks ----

    @_timed
    def video(self, info: VideoInfo, path: str | None) -> None:
        self._entities = check_entity_names([info.name], self._entities)  # before logging anything of it
        self._videos.add_video(info, path)

    @_timed
    def video_frame(self, name: str, frame_index: int, image_bgr: np.ndarray) -> None:
        self._videos.add_frame(name, frame_index, image_bgr)

    @_timed
    def dynamic_mask(self, name: str, frame_index: int, instances: np.ndarray) -> None:
        self._videos.add_mask(name, frame_index, instances)

    @_timed
    def cameras(self, cameras: dict[str, CameraTrack], points_world: np.ndarray | None,
                colors: np.ndarray | None) -> None:
        self._ctx.world_cameras = dict(cameras)
        self._cameras.log_static(cameras, [b.info for b in self._ctx.videos.values()])
        self._cameras.log_points(points_world, colors)

    @_timed
    def pair_matches(self, a: str, b: str, frames_a: np.ndarray, frames_b: np.ndarray,
                     counts: np.ndarray) -> None:
        self._pairing.matches(a, b, frames_a, frames_b, counts)

    @_timed
    def pair_votes(self, a: str, b: str, offsets_s: np.ndarray, votes: np.ndarray, z: np.ndarray,
                   chosen_s: float | None) -> None:
        self._pairing.votes(a, b, offsets_s, votes, z, chosen_s)

    @_timed
    def transfer_landscape(self, camera: str, offsets_s: np.ndarray, share: np.ndarray,
                           joint_offset_s: float, transfer_offset_s: float | None, confirmed: bool) -> None:
        self._pairing.transfer(camera, offsets_s, share, joint_offset_s, transfer_offset_s, confirmed)

    @_timed
    def three_view_landscape(self, camera: str, offsets_s: np.ndarray, supporters: np.ndarray,
                             joint_offset_s: float, passed: bool) -> None:
        self._pairing.three_view(camera, offsets_s, supporters, joint_offset_s, passed)

    # ---- Stage 1 and 2 hooks ----

    @_timed
    def people_cue(self, cue: PeopleCue) -> None:
        from .people import log_people_cue

        self._people_logged = log_people_cue(self.rec, cue)

    @_timed
    def bundle(self, bundle: CueBundle) -> None:
        self._entities = check_entity_names([v.name for v in bundle.videos], self._entities)
        self._ctx.bundle = bundle
        for v in bundle.videos:
            self._videos.add_bundle_video(v)
        meta.log_bundle(self._ctx, bundle)
        self._cameras.log_static(self._ctx.world_cameras or bundle.cameras, list(bundle.videos))

    @_timed
    def pair_landscape(self, landscape: PairLandscape, view: PairRecordView | None = None) -> None:
        self._pairs.log(landscape, view)

    @_timed
    def sync_result(self, result: SyncResult, view: RunRecordView | None = None) -> None:
        self._ctx.result, self._ctx.view = result, view
        if view is not None:
            solve.log_graph(self._ctx, result, view)
            solve.log_loops(self._ctx, view)
        solve.log_solve(self._ctx, result, self._pairs.logged)
        self._flush_videos(result.offsets_s)
        if view is not None:
            solve.log_trajectories(self._ctx, view)

    @_timed
    def stage_event(self, stage: str, message: str, **numbers: Any) -> None:
        meta.log_event(self._ctx, stage, message, numbers)

    @_timed
    def run_summary(self, result: RunResult) -> None:
        self._ctx.summary = result

    def _flush_videos(self, offsets: dict[str, float | None]) -> None:
        self._videos.flush(offsets, self._cameras.logged)
        self._cameras.log_moving(offsets)

    # ---- finishing ----

    def close(self) -> None:
        if self._closed:
            return
        t_close = time.perf_counter()
        try:
            self._log_at_close()
            self.rec.flush()
            self.rec.disconnect()
            self._file.close()  # renames the temporary file to self.path
            self._closed = True
            self.stats = {"write_s": self.hook_s + time.perf_counter() - t_close,
                          "open_s": time.perf_counter() - self._t0,
                          "size_mb": self.path.stat().st_size / 1e6}
            log.info("wrote %s (%.1f MB, %.1f s of logging)", self.path, self.stats["size_mb"],
                     self.stats["write_s"])
        except RuntimeError as exc:  # rerun's file writer failed (it logs the OS error itself)
            self._abort(exc)
            raise _writer_error(self.path, exc) from None
        except BaseException as exc:
            self._abort(exc)
            raise

    def _log_at_close(self) -> None:
        """What only the whole run decides: videos not yet flushed, the tables, meta, guide and layout."""
        ctx = self._ctx
        if not self._videos.flushed:
            self._flush_videos({})
        summary = ctx.summary
        if summary is None and ctx.result is not None:
            summary = run_result_from_sync(ctx.result, ctx.bundle.gt_offsets_s if ctx.bundle is not None else None)
        solve.log_final_offsets(ctx)
        meta.log_result(ctx, summary)
        meta.log_recording(ctx, summary is not None, self._pairs.logged)
        names = ctx.names()
        meta.log_notes_on_offsets(ctx, self._pairs.logged)
        solve.log_pairs_table(ctx)
        log_guide(ctx, names, self._pairs.logged)
        self.rec.send_blueprint(self.blueprint(names), make_active=True, make_default=True)

    def blueprint(self, names: list[str]):
        """The default blueprint of what was logged so far (record/blueprint.py)."""
        ctx = self._ctx
        timeline = (TIMELINE_OFFSET_MS if ctx.offset_ms_min is not None else
                    TIMELINE_TIME if self._videos.timed else TIMELINE_FRAME)
        rng = (ctx.offset_ms_min, ctx.offset_ms_max) if ctx.offset_ms_min is not None else None
        # a pair logged without a finite energy or an epipolar view gets its decision alone (the
        # blueprint assumes both for a pair it is not told about, and would open on empty views)
        views = {k: self._pairs.views.get(k, set()) for k in self._pairs.logged}
        pairing = self._pairing
        return blueprint(names, self._pairs.logged, ctx.result, views, timeline,
                         has_loops=bool(ctx.view is not None and ctx.view.triangles), range_ms=rng,
                         sizes={n: (b.info.width, b.info.height) for n, b in ctx.videos.items()},
                         eye=self._cameras.eye,
                         transfer_origin=CUES_TRANSFER if pairing.transfer_logged else None,
                         three_view_origin=CUES_THREE_VIEW if pairing.three_view_logged else None,
                         votes_logged=pairing.votes_logged, people_logged=self._people_logged,
                         show_world=bool(ctx.world_cameras) or ctx.bundle is not None,
                         offsets_logged=ctx.summary is not None, labels=self.display_names(),
                         with_frames=self._videos.framed)

    def abort(self) -> None:
        """Stop writing and delete the temporary file; nothing that looks complete is left."""
        self._abort(None)

    def _abort(self, exc: BaseException | None) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            self.rec.disconnect()
        finally:
            err = exc or RuntimeError("recording aborted")  # atomic_path deletes on any error
            self._file.__exit__(type(err), err, err.__traceback__)
