"""Read a vs_inspect recording (.rrd) back without recomputing anything.

Everything comes from the file: the result dictionary logged at meta/result_json, the recording's
own metadata, and the structured entities (landscape series, decisions, solve iterations), so
that a recording made on another machine is enough. Uses rerun.chunk.RrdReader (rerun-sdk 0.41).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .rerun_sink import META_CONFIG, META_RECORDING, META_RESULT, RECORDING_FORMAT


@dataclass(frozen=True)
class LandscapeSeries:
    """One series of a pair's landscape as logged (offset in whole milliseconds)."""

    offset_ms: np.ndarray  # (D,) int, the `offset_ms` timeline values
    value: np.ndarray  # (D,) float


@dataclass
class Recording:
    path: Path
    meta: dict[str, Any]  # meta/recording_json
    result: dict[str, Any] | None  # meta/result_json (result.json content)
    config: dict[str, Any] | None
    videos: dict[str, Any] | None  # meta/videos_json
    decisions: dict[str, str] = field(default_factory=dict)  # "a__b" -> markdown
    landscapes: dict[str, dict[str, LandscapeSeries]] = field(default_factory=dict)  # "a__b" -> series
    solve: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  # residual_ms/weight -> key -> (I,)
    entities: list[str] = field(default_factory=list)


def _column(rb, name: str) -> list:
    if name not in rb.schema.names:
        return []
    return rb.column(name).to_pylist()


def _first_text(rb) -> str | None:
    vals = _column(rb, "TextDocument:text")
    for v in vals:
        if isinstance(v, list):
            v = v[0] if v else None
        if v is not None:
            return str(v)
    return None


def _scalars(rb, timeline: str) -> tuple[np.ndarray, np.ndarray]:
    t = _column(rb, timeline)
    s = _column(rb, "Scalars:scalars")
    vals = [(x[0] if isinstance(x, list) and x else x) for x in s]
    keep = [i for i, v in enumerate(vals) if v is not None and t and t[i] is not None]
    return np.array([t[i] for i in keep], dtype=np.int64), np.array([vals[i] for i in keep], dtype=float)


def read_recording(path: str | Path, with_structure: bool = True) -> Recording:
    """Read a recording; InputError for a missing, corrupt or non-vs_inspect file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such recording file")
    try:
        import rerun.chunk as rrc
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = rrc.RrdReader(str(path))
            stores = reader.recordings()
    except Exception as exc:  # noqa: BLE001 - rerun raises RuntimeError/ValueError with a message
        raise InputError(f"{path}: not a readable .rrd recording ({exc})") from None
    if not stores:
        raise InputError(f"{path}: the .rrd holds no recording")
    content = ["/meta/**", "/pairs/**", "/sync/**"] if with_structure else ["/meta/**"]
    store = next((s for s in stores if s.application_id == "vs_inspect"), stores[0])
    try:
        chunks = reader.stream(store=store).filter(content=content).to_chunks()
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{path}: the .rrd is damaged or incomplete ({exc})") from None
    texts: dict[str, str] = {}
    rec = Recording(path, {}, None, None, None)
    entities = set()
    for ch in chunks:
        ent = ch.entity_path.lstrip("/")
        entities.add(ent)
        rb = ch.to_record_batch()
        if ent.startswith("meta/") or ent.endswith("/decision"):
            txt = _first_text(rb)
            if txt is not None:
                texts[ent] = txt
            continue
        parts = ent.split("/")
        if len(parts) == 4 and parts[0] == "pairs" and parts[2] == "landscape":
            t, v = _scalars(rb, "offset_ms")
            if len(t):
                old = rec.landscapes.setdefault(parts[1], {}).get(parts[3])
                if old is not None:
                    t, v = np.concatenate([old.offset_ms, t]), np.concatenate([old.value, v])
                order = np.argsort(t, kind="stable")
                rec.landscapes[parts[1]][parts[3]] = LandscapeSeries(t[order], v[order])
        elif len(parts) == 4 and parts[0] == "sync" and parts[1] == "solve":
            t, v = _scalars(rb, "iteration")
            if len(t):
                rec.solve.setdefault(parts[2], {})[parts[3]] = v[np.argsort(t)]
    rec.entities = sorted(entities)
    if META_RECORDING not in texts:
        raise InputError(f"{path}: not a vs_inspect recording (no {META_RECORDING}; application "
                         f"{store.application_id!r})")
    try:
        rec.meta = json.loads(texts[META_RECORDING])
        rec.result = json.loads(texts[META_RESULT]) if META_RESULT in texts else None
        rec.config = json.loads(texts[META_CONFIG]) if META_CONFIG in texts else None
        rec.videos = json.loads(texts["meta/videos_json"]) if "meta/videos_json" in texts else None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: damaged vs_inspect metadata ({exc})") from None
    if rec.meta.get("format") != RECORDING_FORMAT:
        raise InputError(f"{path}: not a vs_inspect recording (format {rec.meta.get('format')!r})")
    rec.decisions = {k.split("/")[1]: v for k, v in texts.items() if k.startswith("pairs/")}
    return rec


def _entity_rows(path: Path, entity: str) -> list:
    """Record batches of one entity (InputError if the file cannot be read)."""
    import rerun.chunk as rrc
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chunks = rrc.RrdReader(str(path)).stream().filter(content=[f"/{entity}"]).to_chunks()
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{path}: not a readable .rrd recording ({exc})") from None
    return [c.to_record_batch() for c in chunks if c.entity_path.lstrip("/") == entity]


def read_video_frames(path: str | Path, video: str) -> dict[int, np.ndarray]:
    """{frame index: BGR image} of the JPEG frames logged at videos/<video>/image.

    Images are as logged (downscaled by default): multiply pixel coordinates by
    video width / image width to get full-resolution pixels. Empty when the video was logged as an
    embedded video asset or without frames.
    """
    import cv2

    from .rerun_sink import entity_name
    out: dict[int, np.ndarray] = {}
    for rb in _entity_rows(Path(path), f"videos/{entity_name(video)}/image"):
        frames, blobs = _column(rb, "frame"), _column(rb, "EncodedImage:blob")
        for k, blob in zip(frames, blobs):
            if k is None or not blob:
                continue
            data = np.asarray(blob[0] if isinstance(blob[0], list) else blob, dtype=np.uint8)
            img = cv2.imdecode(data, cv2.IMREAD_COLOR)
            if img is not None:
                out[int(k)] = img
    return out


def read_static_points(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(N,3) static 3D points of the reconstruction at world/points and their (N,3) uint8 colours."""
    pts, cols = np.zeros((0, 3)), None
    for rb in _entity_rows(Path(path), "world/points"):
        p = _column(rb, "Points3D:positions")
        if p and p[-1]:
            pts = np.asarray(p[-1], dtype=float)
        c = _column(rb, "Points3D:colors")
        if c and c[-1]:
            rgba = np.asarray(c[-1], dtype=np.uint32)
            cols = np.stack([(rgba >> 24) & 255, (rgba >> 16) & 255, (rgba >> 8) & 255], -1).astype(np.uint8)
    return pts, cols
