"""Series a recording logged beside its result: a pair's (Δ, rate) landscape, its epipolar
view's sweep over the offsets, and the reconstruction's static points."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .recording_paths import TIMELINE_OFFSET_MS, WORLD_POINTS, pair_epipolar_path, pair_rate_landscape_path
from .rrd_chunks import _column, _entity_rows, _scalars


def read_rate_landscape(path: str | Path, a: str, b: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(the (H,W,3) uint8 RGB image, the (V,U) float32 energy) logged at pair_rate_landscape_path
    (the drift model's (Δ, rate) landscape of pair (a, b)); None for what is not there."""
    base = pair_rate_landscape_path(a, b)
    image = energy = None
    for rb in _entity_rows(Path(path), f"{base}/image"):
        buf, fmt = _column(rb, "Image:buffer"), _column(rb, "Image:format")
        if buf and buf[-1] and fmt and fmt[-1]:
            f = fmt[-1][0] if isinstance(fmt[-1], list) else fmt[-1]
            data = np.asarray(buf[-1][0] if isinstance(buf[-1][0], list) else buf[-1], dtype=np.uint8)
            image = data.reshape(int(f["height"]), int(f["width"]), -1)
    for rb in _entity_rows(Path(path), f"{base}/energy"):
        col = _column(rb, "Tensor:data")
        if col and col[-1]:
            t = col[-1][0] if isinstance(col[-1], list) else col[-1]
            shape = [int(s) for s in t["shape"]]
            energy = np.asarray(t["buffer"], dtype=np.float32).reshape(shape)
    return image, energy


@dataclass(frozen=True)
class EpipolarSweepSeries:
    """What a pair's epipolar view shows over the offsets it was logged at."""

    offset_ms: np.ndarray  # (D,) int, candidate Δ_ab on the offset_ms timeline
    lines: np.ndarray  # (D,) int, epipolar line segments drawn over a's image at each offset
    median_px: np.ndarray  # (D,) median distance of a's points from their lines, px (NaN: none)


def read_epipolar_sweep(path: str | Path, a: str, b: str) -> EpipolarSweepSeries | None:
    """The line counts and median point-line distances of pair (a, b)'s epipolar view (None:
    the pair has no epipolar view)."""
    base = pair_epipolar_path(a, b)
    counts: dict[int, int] = {}
    for rb in _entity_rows(Path(path), f"{base}/lines"):
        t = _column(rb, TIMELINE_OFFSET_MS)
        for ms, strips in zip(t, _column(rb, "LineStrips2D:strips")):
            if ms is not None and strips is not None:
                counts[int(ms)] = len(strips)
    if not counts:
        return None
    med: dict[int, float] = {}
    for rb in _entity_rows(Path(path), f"{base}/median_distance_px"):
        t, v = _scalars(rb, TIMELINE_OFFSET_MS)
        med.update(zip(t.tolist(), v.tolist()))
    ms = np.array(sorted(counts), dtype=np.int64)
    return EpipolarSweepSeries(ms, np.array([counts[m] for m in ms], dtype=np.int64),
                               np.array([med.get(int(m), np.nan) for m in ms], dtype=float))


def read_static_points(path: str | Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(N,3) static 3D points of the reconstruction at WORLD_POINTS and their (N,3) uint8 colours."""
    pts, cols = np.zeros((0, 3)), None
    for rb in _entity_rows(Path(path), WORLD_POINTS):
        p = _column(rb, "Points3D:positions")
        if p and p[-1]:
            pts = np.asarray(p[-1], dtype=float)
        c = _column(rb, "Points3D:colors")
        if c and c[-1]:
            rgba = np.asarray(c[-1], dtype=np.uint32)
            cols = np.stack([(rgba >> 24) & 255, (rgba >> 16) & 255, (rgba >> 8) & 255], -1).astype(np.uint8)
    return pts, cols
