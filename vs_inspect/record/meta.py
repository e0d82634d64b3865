"""The recording's own records, for `inspect`, the report and the examples to read back: the
videos, the cue bundle (zip), the run's result and config, and what the recording holds; and the
stages' events on the event timeline.

Entities: meta/* and log/<stage> (io/recording_paths.py).
"""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import rerun as rr

from .. import __version__
from ..io.atomic import json_default
from ..io.recording_paths import (
    META_BUNDLE, META_CONFIG, META_RECORDING, META_RESULT, META_VIDEOS, RECORDING_FORMAT, RECORDING_VERSION,
    TIMELINE_EVENT, entity_name, log_path,
)
from ..io.result import run_result_to_dict
from ..result_types import RunResult
from ..types import CueBundle
from .context import RecordingContext
from .style import at_offset_ms


def _json(rec: rr.RecordingStream, path: str, content, default=None) -> None:
    """content as a JSON text document (default: json.dumps's, for values JSON has no type for)."""
    rec.log(path, rr.TextDocument(json.dumps(content, default=default), media_type="text/plain"), static=True)


def log_bundle(ctx: RecordingContext, bundle: CueBundle) -> None:
    """The videos Stage 1 starts from, and the whole bundle when the options embed it."""
    _json(ctx.rec, META_VIDEOS, {
        "videos": [{"name": v.name, "entity": entity_name(v.name), "width": v.width,
                    "height": v.height, "num_frames": v.num_frames, "fps": v.fps,
                    "duration_s": v.duration_s} for v in bundle.videos],
        "gt_offsets_s": bundle.gt_offsets_s})
    if ctx.options.embed_bundle:
        from ..io.bundle_zip import bundle_to_zip_bytes
        raw = bundle_to_zip_bytes(bundle)
        ctx.rec.log(META_BUNDLE, rr.AnyValues(zip=np.frombuffer(raw, dtype=np.uint8)), static=True)


def log_event(ctx: RecordingContext, stage: str, message: str, numbers: dict) -> None:
    """A stage's note on the event timeline; kept for the guide (and for offset_ms, see log_notes_on_offsets)."""
    extra = ", ".join(f"{k}={v}" for k, v in numbers.items())
    ctx.notes.append(f"{stage}: {message}" + (f" ({extra})" if extra else ""))
    ctx.rec.reset_time()
    ctx.rec.set_time(TIMELINE_EVENT, sequence=ctx.next_event())
    ctx.rec.log(log_path(stage), rr.TextLog(f"{message}" + (f" ({extra})" if extra else ""),
                                            level=rr.TextLogLevel.INFO))
    ctx.rec.reset_time()


def log_notes_on_offsets(ctx: RecordingContext, pairs_logged: list[str]) -> None:
    """A run that stopped in Stage 0 has no pair decisions on offset_ms, where the viewer opens:
    its events (why each camera was refused) go there too."""
    if pairs_logged or not ctx.notes or ctx.offset_ms_min is None:
        return
    with at_offset_ms(ctx.rec, ctx.offset_ms_min):
        for note in ctx.notes:
            ctx.rec.log(log_path("stage0"), rr.TextLog(note, level=rr.TextLogLevel.INFO))


def log_result(ctx: RecordingContext, summary: RunResult | None) -> None:
    """result.json's content and the run's config, when the run's result is known."""
    if summary is not None:
        _json(ctx.rec, META_RESULT, run_result_to_dict(summary), json_default)
    if summary is not None and summary.config is not None:
        _json(ctx.rec, META_CONFIG, summary.config, json_default)


def log_recording(ctx: RecordingContext, has_result: bool, pairs_logged: list[str]) -> None:
    """What the recording is and holds: its format, the versions that wrote it, its options."""
    _json(ctx.rec, META_RECORDING, {
        "format": RECORDING_FORMAT, "version": RECORDING_VERSION,
        "vs_inspect_version": __version__, "rerun_version": rr.__version__,
        "has_result": has_result, "options": asdict(ctx.options),
        "pairs": pairs_logged, "labels": ctx.display_names()})
