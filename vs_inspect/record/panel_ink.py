"""Whether a panel shows something: its pixels against the same panel of the same layout over a
recording that holds only the layout's scaffolding (the same timelines over the same ranges, the
image borders the recording draws, no data), so that borders, the time cursor, axes, grids and
titles never count as content; in plots, a thin line across the whole height (a time cursor) is
not content either."""

from __future__ import annotations

from pathlib import Path

import numpy as np

INK_DIFF = 40  # a pixel is ink when a channel differs from the empty panel by more than this (0-255)
MIN_INK = 0.002  # a panel shows something when at least this share of its pixels is ink
CURSOR_PX = 4  # in a plot, ink columns at most this wide across most of its height are a time cursor
PLOTS = ("TimeSeries", "BarChart")  # view classes whose vertical lines may be a cursor
SCAFFOLD_APP = "vs_inspect_empty_layout"  # the scaffold recording's application id


def ink(panel_bgr: np.ndarray, empty_bgr: np.ndarray, plot: bool = False) -> float:
    """Share of pixels that differ (any channel by more than INK_DIFF) from the empty panel; in a
    plot (plot=True), not counting thin vertical lines across most of its height (a time cursor
    where the empty panel has none or has it elsewhere)."""
    if panel_bgr.shape != empty_bgr.shape:
        import cv2
        empty_bgr = cv2.resize(empty_bgr, (panel_bgr.shape[1], panel_bgr.shape[0]))
    mask = np.abs(panel_bgr.astype(np.int16) - empty_bgr.astype(np.int16)).max(-1) > INK_DIFF
    if plot:
        mask = _without_cursor(mask)
    return float(mask.mean())


def _without_cursor(mask: np.ndarray) -> np.ndarray:
    """mask with runs of at most CURSOR_PX columns that are ink over most of the height cleared."""
    tall = mask.mean(0) > 0.6
    out = mask.copy()
    c = 0
    while c < len(tall):
        if not tall[c]:
            c += 1
            continue
        end = c
        while end < len(tall) and tall[end]:
            end += 1
        if end - c <= CURSOR_PX:
            out[:, c:end] = False
        c = end
    return out


def _locate(full: np.ndarray, tile: np.ndarray) -> tuple[int, int, int, int]:
    """(x, y, w, h) of a panel's screenshot inside the screenshot of the whole viewer."""
    import cv2
    h, w = tile.shape[:2]
    if h > full.shape[0] or w > full.shape[1]:
        raise RuntimeError(f"a panel ({w}x{h}) is larger than the viewer ({full.shape[1]}x{full.shape[0]})")
    res = cv2.matchTemplate(full, tile, cv2.TM_SQDIFF_NORMED)
    _, _, (x, y), _ = cv2.minMaxLoc(res)
    return x, y, w, h


def _scaffold_recording(path: Path, rrd: Path, timelines) -> Path:
    """An .rrd with only what the layout of `rrd` shows before any data: the image borders `rrd`
    draws (its entities named border, copied) and its timelines over the same ranges (on an entity
    no panel shows), so that time panel, cursor and axes look the same; no data."""
    import rerun as rr

    from ..io.recording import read_recording
    from ..io.recording_paths import pair_epipolar_path, video_path
    from ..io.rrd_chunks import read_chunks
    rec_in = read_recording(rrd, with_structure=False)
    borders = [f"{video_path(v.name)}/border" for v in rec_in.videos]
    borders += [f"{pair_epipolar_path(*k.split('__', 1))}/border" for k in rec_in.meta.get("pairs", [])]
    rec = rr.RecordingStream(SCAFFOLD_APP)
    rec.save(str(path))
    chunks = read_chunks(rrd, borders) if borders else []
    if chunks:
        rec.send_chunks(chunks)
    for t in timelines:
        if t.start is None or t.end is None:
            continue
        if t.time_type == "sequence":
            col = rr.TimeColumn(t.name, sequence=[t.start, t.end])
        elif t.time_type == "duration":
            col = rr.TimeColumn(t.name, duration=np.array([t.start, t.end], dtype="timedelta64[ns]"))
        else:
            col = rr.TimeColumn(t.name, timestamp=np.array([t.start, t.end], dtype="datetime64[ns]"))
        rec.send_columns(f"zz_scaffold/{t.name}", [col], rr.Scalars.columns(scalars=[0.0, 0.0]))
    rec.log("zz_scaffold/doc", rr.TextDocument("-"), static=True)
    rec.flush()
    rec.disconnect()
    return path
