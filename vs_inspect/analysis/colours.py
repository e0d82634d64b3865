"""Colours computed from data (instance ids, point-to-line distances), shared by the recording and
anything else that draws them. Numbers only: no rerun here."""

from __future__ import annotations

import numpy as np

from .. import palette

PALETTE = np.array(palette.INSTANCE, dtype=np.uint8)  # moving instances (masks, tracks, lines)
GREY = palette.NEUTRAL  # unknown, no data
# point-to-line distance in the epipolar views: blue (far) through grey to yellow (on the line)
RAMP = np.array([palette.FAR, (150, 150, 160), palette.ON_LINE], dtype=float)  # visible on black
MIN_RAMP_PX = 1.0  # the distance ramp spans at least this many px, so sub-pixel noise keeps one colour


def instance_colors(instance: np.ndarray) -> np.ndarray:
    """(N,3) uint8: PALETTE by instance id (the same colours as the masks' annotation context);
    GREY for -1 (unknown)."""
    inst = np.asarray(instance, dtype=np.int64)
    out = PALETTE[np.mod(inst, len(PALETTE))].copy()
    out[inst < 0] = GREY
    return out


def distance_colors(distance_px: np.ndarray, scale_px: float) -> np.ndarray:
    """(...,3) uint8 on RAMP: yellow at 0 px, blue at scale_px and beyond, GREY for NaN."""
    d = np.asarray(distance_px, dtype=float)
    x = 1.0 - np.clip(np.nan_to_num(d, nan=np.inf) / max(scale_px, 1e-9), 0.0, 1.0)
    stops = np.linspace(0.0, 1.0, len(RAMP))
    out = np.stack([np.interp(x, stops, RAMP[:, c]) for c in range(3)], -1).round().astype(np.uint8)
    out[~np.isfinite(d)] = GREY
    return out


def distance_ramp_px(distance_px: np.ndarray) -> float:
    """The far end of the distance ramp: the median finite distance (any shape), at least
    MIN_RAMP_PX. Relative, so that points are yellow only where they are much closer to their
    lines than usual (an absolute threshold paints every point "on its line" at every offset when
    the points barely move)."""
    d = np.asarray(distance_px, dtype=float)
    fin = d[np.isfinite(d)]
    return max(float(np.median(fin)) if len(fin) else MIN_RAMP_PX, MIN_RAMP_PX)
