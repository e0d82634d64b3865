"""Figures drawn over video frames: the epipolar panel (one pair at a wrong and at the chosen
offset) and the mosaic of one global moment."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .data import EpipolarPanel, ReportData  # noqa: E402
from .figure_layout import _fig, _finish, _mosaic_grid, _save  # noqa: E402
from .figure_style import ACCEPT, DPI, FONT_PT, REJECT, SMALL_PT, WIDTHS_IN, _chars, _wrap, fmt_px, video_colors  # noqa: E402


# ---- epipolar panel ------------------------------------------------------------------------


def _epipolar_axes(ax, e: EpipolarPanel, state, title: str, good: bool) -> None:
    """One state of the panel; good = drawn in the accepted colour (a rejected pair's best
    offset is not). The median distance is in the title, outside the picture."""
    W, H = e.width, e.height
    if e.image_bgr is not None:
        ax.imshow(e.image_bgr[..., ::-1], extent=(-0.5, W - 0.5, H - 0.5, -0.5))
    else:
        ax.add_patch(plt.Rectangle((-0.5, -0.5), W, H, fc="#f4f4f4", ec="#999999"))
    cmap = plt.get_cmap("tab20")
    for i, (p, l) in enumerate(zip(state.points_a, state.lines_a)):
        c = cmap(i % 20)
        if np.all(np.isfinite(l)) and (abs(l[0]) > 0 or abs(l[1]) > 0):
            # a·x + b·y + c = 0: a point on it and its slope
            if abs(l[1]) > 1e-12:
                ax.axline((0.0, -l[2] / l[1]), slope=-l[0] / l[1], color=c, lw=0.9, alpha=0.9)
            else:
                ax.axvline(-l[2] / l[0], color=c, lw=0.9, alpha=0.9)
        ax.scatter([p[0]], [p[1]], s=14, color=c, edgecolors="black", linewidths=0.5, zorder=4)
    ax.set_xlim(-0.5, W - 0.5)
    ax.set_ylim(H - 0.5, -0.5)
    ax.set_aspect("equal")
    col = ACCEPT if good else REJECT
    ax.set_title(f"{title}\nmedian distance to the line {fmt_px(state.median_distance_px)} px",
                 color=col, fontsize=FONT_PT, fontweight="bold")
    ax.set_xlabel("x [px]", labelpad=1.0)
    ax.set_ylabel("y [px]", labelpad=1.0)


def epipolar(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
             size: str = "page") -> Path:
    e = data.epipolar
    fig = _fig("epipolar", data, size)
    first, second = fig.subplots(2, 1) if size == "column" else fig.subplots(1, 2)
    _epipolar_axes(first, e, e.wrong, f"wrong offset Δ = {e.wrong.offset_s:+.3f} s", False)
    if e.accepted:
        _epipolar_axes(second, e, e.chosen, f"chosen offset Δ = {e.chosen.offset_s:+.3f} s", True)
    else:
        _epipolar_axes(second, e, e.chosen, f"best Δ of a REJECTED pair = {e.chosen.offset_s:+.3f} s", False)
    a, b = data.label(e.a), data.label(e.b)
    backdrop = "" if e.image_bgr is not None else " (video not available: blank canvas)"
    fig.suptitle(_wrap(f"{a} frame {e.frame_a} (t = {e.time_a_s:.3f} s){backdrop}. Dots: {a}'s track "
                       f"points; lines, same colour: epipolar lines of {b}'s matched points at t − Δ. "
                       "At the right Δ each line passes through its dot.",
                       _chars(WIDTHS_IN[size] - 0.1, FONT_PT)), fontsize=FONT_PT)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)


# ---- mosaic of one moment --------------------------------------------------------------------


def mosaic(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
           size: str = "page") -> Path:
    m = data.mosaic
    fig = _fig("mosaic", data, size)
    rows, cols = _mosaic_grid(len(m.tiles))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    colors = video_colors(data.names)
    for i, ax in enumerate(axes):
        ax.set_xticks([])
        ax.set_yticks([])
        if i >= len(m.tiles):
            ax.axis("off")
            continue
        t = m.tiles[i]
        if t.image_bgr is not None:
            ax.imshow(t.image_bgr[..., ::-1])
            ax.set_title(f"{data.label(t.name)}, frame {t.frame}", fontsize=SMALL_PT,
                         color=colors.get(t.name, "k"), fontweight="bold")
        else:
            ax.set_facecolor("#eeeeee")
            why = "not synchronized or\nnot recording then" if t.frame is None else "frame not readable"
            ax.text(0.5, 0.5, f"{data.label(t.name)}\n{why}", ha="center", va="center", transform=ax.transAxes,
                    fontsize=SMALL_PT, color=REJECT)
        for side in ax.spines.values():
            side.set_edgecolor(colors.get(t.name, "k"))
            side.set_linewidth(1.5)
    fig.suptitle(f"one global moment across all videos after sync: t = {m.time_s:.3f} s", fontsize=FONT_PT)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)
