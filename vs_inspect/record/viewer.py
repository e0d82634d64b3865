"""Open a recording in the rerun viewer with its time cursor at the front pair's Δ.

A recording cannot say where the viewer's time cursor starts (the time panel's blueprint has no
such field): `rerun FILE.rrd` opens on the `offset_ms` timeline at the smallest candidate offset,
where the first pair's epipolar view usually shows no line. open_recording drives the viewer
(rerun.experimental.ViewerClient) instead: it opens the file, waits until it is loaded and moves
the cursor to the chosen Δ of the pair in front (the first pair container, failed pairs first), or
to its best Δ when it has no chosen one. `vs-inspect view` and the screenshot check
(record/screenshots.py) both open recordings this way.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ..io.recording_paths import TIMELINE_OFFSET_MS


def front_pair(rec) -> tuple[str, str] | None:
    """(a, b) of the pair in the layout's first container (io.recording.Recording), None when no
    pair was logged."""
    from .blueprint import shown_pairs
    shown = shown_pairs(rec.meta.get("pairs", []), rec.result)
    return (shown[0][0], shown[0][1]) if shown else None


def front_offset_ms(rec, pair: tuple[str, str] | None = None) -> int | None:
    """The chosen Δ (ms on offset_ms) of `pair` (default: the front pair), else its lowest energy's
    Δ; None when the pair has neither (or no pair has a landscape)."""
    from ..io.recording_paths import pair_key
    pair = pair or front_pair(rec)
    if pair is None:
        return None
    if rec.result is not None:
        p = rec.result.pair(*pair)
        if p is not None and math.isfinite(p.best_offset_s):
            return round(p.best_offset_s * 1000)
    e = rec.landscapes.get(pair_key(*pair), {}).get("energy")
    if e is not None and len(e.value) and np.isfinite(e.value).any():
        return int(e.offset_ms[np.nanargmin(e.value)])
    return None


def wait_loaded(client, path: Path, timeout_s: float = 60.0) -> str:
    """Open an .rrd in the viewer and wait until it is loaded; its store id."""
    res = client.open(str(Path(path).resolve()))
    ids = [s for s in res.store_ids if s.startswith("Recording:")]
    deadline = time.monotonic() + timeout_s
    while client.get_state().loading and time.monotonic() < deadline:
        time.sleep(0.2)
    if not ids:
        raise RuntimeError(f"the viewer opened no recording from {path}")
    return ids[0]


def open_recording(client, path: str | Path, pair: tuple[str, str] | None = None,
                   at_ms: int | None = None) -> tuple[str, int | None]:
    """Open `path` in the viewer behind `client` with the cursor, paused, at at_ms on offset_ms
    (default: front_offset_ms of `pair`, or of the front pair). Returns (store id, the cursor's
    offset_ms, None when the recording has no offset to go to)."""
    from ..io.recording import read_recording
    path = Path(path)
    if at_ms is None:
        at_ms = front_offset_ms(read_recording(path), pair)
    store = wait_loaded(client, path)
    if at_ms is not None:
        client.set_time(TIMELINE_OFFSET_MS, sequence=int(at_ms), play_state="paused", recording=store)
    return store, at_ms
