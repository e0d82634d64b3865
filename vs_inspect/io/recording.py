"""The vs_inspect recording (.rrd) read back, without recomputing anything: the run's result
(result.json, at META_RESULT, turned into a RunResult), the recording's own metadata, the
structured entities (landscape series, decisions, solve iterations) and the embedded cue bundle.

Its entity paths are named in recording_paths.py; other parts are read by recorded_series.py
(rate landscapes, epipolar sweeps, static points) and recorded_frames.py (video frames).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..result_types import RunResult
from ..types import CueBundle, frame_length_s
from .recording_paths import (
    META_BUNDLE, META_CONFIG, META_RECORDING, META_RESULT, META_VIDEOS, PAIRS, RECORDING_FORMAT, SYNC_SOLVE,
    TIMELINE_ITERATION, TIMELINE_OFFSET_MS, entity_name,
)
from .result import run_result_from_dict
from .rrd_chunks import _blob_bytes, _chunks, _first_text, _last_row, _reader, _scalars


# ---- what the reader returns ------------------------------------------------------------------


@dataclass(frozen=True)
class LandscapeSeries:
    """One series of a pair's landscape as logged (offset in whole milliseconds)."""

    offset_ms: np.ndarray  # (D,) int, the `offset_ms` timeline values
    value: np.ndarray  # (D,) float


@dataclass(frozen=True)
class RecordedVideo:
    """One video as META_VIDEOS describes it (no timestamps: the cue bundle has those)."""

    name: str
    entity: str  # its entity-path part (entity_name)
    width: int  # px
    height: int  # px
    num_frames: int
    fps: float | None  # None for variable frame rate
    duration_s: float  # local time of the last frame minus the first, seconds

    @property
    def frame_length_s(self) -> float:
        """types.frame_length_s: 1/fps, else the mean spacing of frames (inf for a single frame)."""
        return frame_length_s(self.fps, self.duration_s, self.num_frames)

    @property
    def frame_interval_s(self) -> float:
        """frame_length_s (a recording has no timestamps to take a median of)."""
        return self.frame_length_s


@dataclass
class Recording:
    path: Path
    meta: dict[str, Any]  # META_RECORDING: format, versions, options, pairs logged
    result: RunResult | None  # META_RESULT (None: the run stopped before Stage 2)
    config: dict[str, Any] | None  # META_CONFIG
    videos: tuple[RecordedVideo, ...] = ()  # META_VIDEOS
    gt_offsets_s: dict[str, float] | None = None  # the truth logged with the videos, when known
    decisions: dict[str, str] = field(default_factory=dict)  # pair_key -> markdown
    landscapes: dict[str, dict[str, LandscapeSeries]] = field(default_factory=dict)  # pair_key -> series
    solve: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  # residual_ms/weight -> pair_key -> (I,)
    bundle_zip: bytes | None = None  # META_BUNDLE (only when read with bundle=True)
    entities: list[str] = field(default_factory=list)


def read_recording(path: str | Path, with_structure: bool = True, bundle: bool = False) -> Recording:
    """Read a recording; InputError for a missing, corrupt or non-vs_inspect file.

    with_structure: also the landscapes, decisions and solve iterations (else metadata only).
    bundle: also the embedded cue bundle's zip bytes (Recording.bundle_zip).
    """
    path = Path(path)
    _, store = _reader(path)
    content = [f"/{p}/**" for p in (("meta", PAIRS, SYNC_SOLVE) if with_structure else ("meta",))]
    texts: dict[str, str] = {}
    rec = Recording(path, {}, None, None)
    entities = set()
    for ch in _chunks(path, content):
        ent = ch.entity_path.lstrip("/")
        entities.add(ent)
        rb = ch.to_record_batch()
        if ent == META_BUNDLE:
            col = next((c for c in rb.schema.names if c.split(":")[-1] == "zip"), None)
            row = _last_row(rb.column(col)) if col and bundle else None
            if row is not None:
                rec.bundle_zip = _blob_bytes(row)
            continue
        if ent.startswith("meta/") or ent.endswith("/decision"):
            txt = _first_text(rb)
            if txt is not None:
                texts[ent] = txt
            continue
        parts = ent.split("/")
        if len(parts) == 4 and parts[0] == PAIRS and parts[2] == "landscape":
            t, v = _scalars(rb, TIMELINE_OFFSET_MS)
            if len(t):
                old = rec.landscapes.setdefault(parts[1], {}).get(parts[3])
                if old is not None:
                    t, v = np.concatenate([old.offset_ms, t]), np.concatenate([old.value, v])
                order = np.argsort(t, kind="stable")
                rec.landscapes[parts[1]][parts[3]] = LandscapeSeries(t[order], v[order])
        elif len(parts) == 4 and f"{parts[0]}/{parts[1]}" == SYNC_SOLVE:
            t, v = _scalars(rb, TIMELINE_ITERATION)
            if len(t):
                rec.solve.setdefault(parts[2], {})[parts[3]] = v[np.argsort(t)]
    rec.entities = sorted(entities)
    if META_RECORDING not in texts:
        raise InputError(f"{path}: not a vs_inspect recording (no {META_RECORDING}; application "
                         f"{store.application_id!r})")
    try:
        rec.meta = json.loads(texts[META_RECORDING])
        result = json.loads(texts[META_RESULT]) if META_RESULT in texts else None
        rec.config = json.loads(texts[META_CONFIG]) if META_CONFIG in texts else None
        videos = json.loads(texts[META_VIDEOS]) if META_VIDEOS in texts else {}
    except (json.JSONDecodeError, RecursionError) as exc:
        raise InputError(f"{path}: damaged vs_inspect metadata ({type(exc).__name__}: {exc})") from None
    if not isinstance(rec.meta, dict) or rec.meta.get("format") != RECORDING_FORMAT:
        shown = rec.meta.get("format") if isinstance(rec.meta, dict) else type(rec.meta).__name__
        raise InputError(f"{path}: not a vs_inspect recording ({META_RECORDING}: format {shown!r})")
    if rec.config is not None and not isinstance(rec.config, dict):
        raise InputError(f"{path}: {META_CONFIG} must be a JSON object, got {type(rec.config).__name__}")
    if result is not None:
        rec.result = run_result_from_dict(result, f"{path}:{META_RESULT}")
    try:
        if not isinstance(videos, dict) or not isinstance(videos.get("videos", []), list):
            raise TypeError(f"must be an object with a list 'videos', got {type(videos).__name__}")
        rec.videos = tuple(RecordedVideo(str(v["name"]), str(v.get("entity", entity_name(v["name"]))),
                                         int(v["width"]), int(v["height"]), int(v["num_frames"]),
                                         None if v.get("fps") is None else float(v["fps"]),
                                         float(v.get("duration_s") or 0.0))
                           for v in videos.get("videos", []))
        gt = videos.get("gt_offsets_s")
        rec.gt_offsets_s = {str(k): float(v) for k, v in gt.items()} if isinstance(gt, dict) else None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"{path}: damaged {META_VIDEOS} ({type(exc).__name__}: {exc})") from None
    rec.decisions = {k.split("/")[1]: v for k, v in texts.items() if k.startswith(f"{PAIRS}/")}
    return rec


def read_recorded_bundle(rec: Recording) -> CueBundle | None:
    """The cue bundle embedded at META_BUNDLE (read_recording(..., bundle=True)); None if absent."""
    if rec.bundle_zip is None:
        return None
    from .bundle_zip import bundle_from_zip_bytes
    return bundle_from_zip_bytes(rec.bundle_zip, f"{rec.path}:{META_BUNDLE}")
