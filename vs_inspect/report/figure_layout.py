"""The report figures' layout: each figure's size, the notes under its panels, and its making
and saving (each requested format, the same bytes for the same drawing).

Videos are drawn by their short names (ReportData.labels) with the full names below the figure.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .. import signals  # noqa: E402
from .data import PairView, ReportData  # noqa: E402
from .figure_style import (  # noqa: E402
    DPI, FONT_PT, LINE_IN, NOTE_INSET_IN, SMALL_PT, WIDTHS_IN, _chars, _fmt, _lines, _wrap,
)


def landscape_grid_shape(n: int, size: str = "page") -> tuple[int, int]:
    """(rows, columns) of a grid of n panels: 2 columns in a paper column, 3 across a page."""
    cols = min(2 if size == "column" else 3, max(1, n))
    return max(1, math.ceil(n / cols)), cols


def _legend_note(data: ReportData, width_in: float) -> str:
    """The full names of the videos drawn by a short name, wrapped to the figure's width."""
    legend = data.label_legend()
    return _wrap("names: " + "; ".join(legend), _chars(width_in - 0.1)) if legend else ""


def figure_size_in(kind: str, data: ReportData, size: str = "page") -> tuple[float, float]:
    """(width, height) of each figure in inches at the printed size."""
    W = WIDTHS_IN[size]
    note = LINE_IN * _lines(_legend_note(data, W))
    if kind == "landscapes":
        return W, _grid_height(data, size, [_landscape_note(p, data, _panel_width(W, len(data.pairs), size))
                                            for p in data.pairs], 1.45) + 0.45 + note
    if kind == "transfer":
        return W, _grid_height(data, size, [_check_note(t.reason, _panel_width(W, len(data.transfer), size))
                                            for t in data.transfer], 1.55) + 0.3 + note
    if kind == "three_view":
        return W, _grid_height(data, size, [_check_note(f"needed {t.needed:g}. {t.reason}",
                                                        _panel_width(W, len(data.three_view), size))
                                            for t in data.three_view], 1.55) + 0.3 + note
    if kind == "pair_graph":
        return W, (3.3 if size == "column" else 4.3) + note
    if kind == "timeline":
        return W, 0.9 + 2 * (0.2 * max(1, len(data.videos)) + 0.25) + note
    if kind == "epipolar":
        e = data.epipolar
        aspect = e.height / e.width if e else 0.56
        if size == "column":
            return W, 2 * (W - 0.5) * aspect + 1.15 + note
        return W, (W / 2 - 0.45) * aspect + 0.95 + note
    if kind == "scene3d":
        return W, round(0.62 * W, 2)
    if kind == "mosaic":
        rows, cols = _mosaic_grid(len(data.mosaic.tiles) if data.mosaic else 1)
        return W, 0.35 + rows * (W / cols * 0.75 + 0.22) + note
    raise KeyError(kind)


def figure_size_px(kind: str, data: ReportData, dpi: float = DPI, size: str = "page") -> tuple[int, int]:
    """(width, height) in pixels of each figure's PNG at dpi, so that tests can check it."""
    w, h = figure_size_in(kind, data, size)
    # as matplotlib sizes the canvas: inches times dpi, truncated
    return int(w * dpi + 1e-6), int(h * dpi + 1e-6)


def size_of_width(width_in: float) -> str:
    """The size ("column" or "page") whose width is nearest width_in inches."""
    return min(WIDTHS_IN, key=lambda k: abs(WIDTHS_IN[k] - width_in))


def _panel_width(W: float, n: int, size: str) -> float:
    return W / landscape_grid_shape(n, size)[1]


def _grid_height(data: ReportData, size: str, notes: list[str], panel_in: float) -> float:
    """Height of a grid of panels whose notes (under each panel) take their lines of text."""
    rows, cols = landscape_grid_shape(len(notes), size)
    total = 0.0
    for r in range(rows):
        row = notes[r * cols:(r + 1) * cols]
        total += panel_in + LINE_IN * max((_lines(n) for n in row), default=0)
    return total


def _mosaic_grid(n: int) -> tuple[int, int]:
    """The grid of the exported mosaic video (report/mosaic.py), so both look alike."""
    from .mosaic import grid_shape
    return grid_shape(max(1, n))


def _fig(kind: str, data: ReportData, size: str):
    w, h = figure_size_in(kind, data, size)
    return plt.figure(figsize=(w, h), dpi=DPI, layout="constrained")


def _finish(fig, data: ReportData, size: str) -> None:
    """The full names of the short-named videos under the figure (in the constrained layout)."""
    note = _legend_note(data, WIDTHS_IN[size])
    if note:
        fig.supxlabel(note, x=0.01, ha="left", fontsize=SMALL_PT, color="#333333")


def _save(fig, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    """Write path with each format's suffix; returns the first. No bbox_inches: the size stays
    what figure_size_px says, and constrained layout keeps every label inside it."""
    out = []
    for fmt in formats:
        signals.checkpoint()  # between files
        p = Path(path).with_suffix("." + fmt)
        fig.savefig(p, dpi=dpi, format=fmt, metadata=_METADATA.get(fmt))
        out.append(p)
    plt.close(fig)
    return out[0]


# no creation date: the same drawing gives the same bytes (a report from a run folder and from
# its .rrd can be compared file by file)
_METADATA = {"pdf": {"CreationDate": None}, "svg": {"Date": None}}


def _note_below(ax, text: str, below_pt: float) -> None:
    """Small text under an axes (below its tick labels and x label), outside the data: it is an
    axes child, so the constrained layout keeps room for it."""
    if text:
        ax.annotate(text, xy=(0.0, 0.0), xycoords="axes fraction", xytext=(0.0, -below_pt),
                    textcoords="offset points", ha="left", va="top", fontsize=SMALL_PT, color="#222222")


def _landscape_note(p: PairView, data: ReportData | None, width_in: float) -> str:
    """What a landscape panel says under its plot: Δ, its error, how far the solve moved it, and
    a rejected pair's reason, in lines that fit the panel."""
    if p.offsets_s.size == 0 or not np.isfinite(p.energy).any():
        return _wrap(p.reason, _chars(width_in - NOTE_INSET_IN))
    if p.chosen_offset_s is None:
        return _wrap(f"no Δ: {p.reason}", _chars(width_in - NOTE_INSET_IN))
    txt = f"Δ = {_fmt(p.chosen_offset_s)}"
    if p.error_ms is not None:
        txt += f", error {p.error_ms:.1f} ms"
    if p.disagreement_ms is not None and p.disagreement_ms > 100.0:
        txt += f", {p.disagreement_ms:.0f} ms off the global solve"
    if p.residual == "sighting":  # not an epipolar energy: say what the curve is
        txt += "; worn-camera sightings: 1 − share of heads on its centre"
        if "refined to" in p.reason:  # sync/sightings.refine_peak moved Δ off the counted peak
            txt += "; Δ refitted with a head-to-camera shift"
    if not p.accepted:
        txt += f"; rejected: {p.reason}"
    return _wrap(txt, _chars(width_in - NOTE_INSET_IN))


def _check_note(reason: str, width_in: float) -> str:
    return _wrap(reason, _chars(width_in - NOTE_INSET_IN))


def _panels(kind: str, data: ReportData, n: int, size: str):
    """(figure, its first n axes, rows, cols) of a grid of n panels (landscape_grid_shape); the
    grid's spare axes are hidden."""
    fig = _fig(kind, data, size)
    rows, cols = landscape_grid_shape(n, size)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax in axes[n:]:
        ax.axis("off")
    return fig, axes[:n], rows, cols

