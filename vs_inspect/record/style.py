"""How the recording's parts draw and write numbers: the colours by meaning (vs_inspect.palette,
shared with the report), the masks' annotation context, offsets as offset_ms values, and the
signed number format of tables and labels."""

from __future__ import annotations

import math
from contextlib import contextmanager
from typing import Any, Iterator

import numpy as np
import rerun as rr

from .. import palette
from ..analysis.colours import GREY, PALETTE
from ..io.recording_paths import TIMELINE_OFFSET_MS

# green and red mean only accepted/rejected
ACCEPTED, REJECTED = palette.ACCEPTED, palette.REJECTED
MINIMA = palette.OTHER_MINIMA
TRUTH = palette.TRUTH_ON_DARK  # the viewer's background is dark
APPEARANCE_ONLY = GREY  # a pair's landscape without its unchecked track pairs
WINDOW = palette.SOLVED  # the --around window of a pair's Δ


def annotation_context(max_id: int = 255) -> "rr.AnnotationContext":
    """Mask ids: 0 is the static background (transparent), k ≥ 1 is moving instance k in PALETTE."""
    classes = [rr.AnnotationInfo(id=0, label="static background", color=(0, 0, 0, 0))]
    classes += [rr.AnnotationInfo(id=k, label=f"instance {k}", color=tuple(int(c) for c in PALETTE[k % len(PALETTE)]))
                for k in range(1, max_id + 1)]
    return rr.AnnotationContext(classes)


def offset_ms(offsets_s) -> np.ndarray:
    """Candidate offsets (D,) s as the offset_ms timeline's integer milliseconds."""
    return np.round(np.asarray(offsets_s, np.float64) * 1000.0).astype(np.int64)


def fmt(x: Any, unit: str = "", prec: int = 4) -> str:
    """A signed number with its unit, "n/a" for None, NaN or inf."""
    v = None if x is None or not math.isfinite(float(x)) else float(x)
    return "n/a" if v is None else f"{v:+.{prec}f}{unit}"


@contextmanager
def at_offset_ms(rec: rr.RecordingStream, ms: int) -> Iterator[None]:
    """Logs inside go to offset_ms = ms only (no other timeline of an earlier set_time)."""
    rec.reset_time()
    rec.set_time(TIMELINE_OFFSET_MS, sequence=ms)
    try:
        yield
    finally:
        rec.reset_time()


def image_border(width: int, height: int) -> rr.LineStrips2D:
    """An image's border in full-resolution pixels, so a view without frames still has extent."""
    W, H = width, height
    return rr.LineStrips2D([[[0, 0], [W, 0], [W, H], [0, H], [0, 0]]], colors=[GREY])


def scaled_to(width: int, height: int, shape_wh: tuple[int, int]) -> rr.Transform3D:
    """Scale an image of (w, h) pixels up to the video's full (width, height)."""
    w, h = shape_wh
    return rr.Transform3D(scale=[width / w, height / h, 1.0])
