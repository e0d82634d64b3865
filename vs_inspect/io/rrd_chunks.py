"""Chunks and columns of an .rrd file, read with rerun.chunk.RrdReader (rerun-sdk 0.41); a
missing, corrupt or empty file is an InputError."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .recording_paths import APPLICATION_ID


def _column(rb, name: str) -> list:
    if name not in rb.schema.names:
        return []
    return rb.column(name).to_pylist()


def _first_text(rb) -> str | None:
    for v in _column(rb, "TextDocument:text"):
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


def _last_row(column) -> Any:
    """The last non-null row of a chunk column (a list array)."""
    for i in range(len(column) - 1, -1, -1):
        if column[i].is_valid:
            return column[i]
    return None


def _blob_bytes(row) -> bytes:
    """The bytes of one row of a (possibly nested) list<uint8> column."""
    import pyarrow as pa
    vals = row.values
    while pa.types.is_list(vals.type) or pa.types.is_large_list(vals.type):
        vals = vals.flatten()
    return vals.to_numpy(zero_copy_only=False).astype(np.uint8).tobytes()


def _reader(path: Path):
    """(RrdReader, the vs_inspect store); InputError for a missing, corrupt or empty file."""
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
    store = next((s for s in stores if s.application_id == APPLICATION_ID), stores[0])
    return reader, store


def _chunks(path: Path, content: list[str]) -> list:
    reader, store = _reader(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return reader.stream(store=store).filter(content=content).to_chunks()
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{path}: the .rrd is damaged or incomplete ({exc})") from None


def _entity_rows(path: Path, entity: str) -> list:
    """Record batches of one entity (InputError if the file cannot be read)."""
    return [c.to_record_batch() for c in _chunks(path, [f"/{entity}"])
            if c.entity_path.lstrip("/") == entity]


def read_chunks(path: str | Path, entities: list[str]) -> list:
    """The chunks of the given entities (exact paths), as rerun.chunk.Chunk (InputError if the
    file cannot be read); for copying a recording's parts into another."""
    wanted = {e.strip("/") for e in entities}
    return [c for c in _chunks(Path(path), [f"/{e}" for e in sorted(wanted)])
            if c.entity_path.strip("/") in wanted]
