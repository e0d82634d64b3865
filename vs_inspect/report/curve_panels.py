"""Grids of panels drawing a curve over candidate offsets: Stage 1's energy landscapes and
Stage 0's point-transfer and three-view checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from .data import PairView, ReportData
from .figure_layout import _check_note, _finish, _landscape_note, _note_below, _panel_width, _panels, _save
from .figure_style import (
    ACCEPT, ACCEPT_BG, APPEARANCE_ONLY, DPI, FONT_PT, NOTE_INSET_IN, OTHER_MINIMA, REJECT, REJECT_BG,
    SMALL_PT, SOLVED, TRUTH, WIDTHS_IN, _chars, pair_colors,
)


# ---- energy landscapes ----------------------------------------------------------------------


def _landscape_axes(ax, p: PairView, label=lambda n: n, curve="#0072B2", note_width_in: float = 2.3,
                    xlabel: bool = True) -> None:
    col = ACCEPT if p.accepted else REJECT
    ax.set_facecolor(ACCEPT_BG if p.accepted else REJECT_BG)
    for side in ax.spines.values():
        side.set_edgecolor(col)
        side.set_linewidth(1.2)
    mark = "✓" if p.accepted else "✗"
    title = f"{label(p.a)} – {label(p.b)}  {mark}"
    if len(title) > _chars(note_width_in - NOTE_INSET_IN, 1.15 * FONT_PT):  # bold: wider letters
        title = f"{label(p.a)} –\n{label(p.b)}  {mark}"
    ax.set_title(title, color=col, fontweight="bold", loc="left", fontsize=FONT_PT)
    below = SMALL_PT + 4 + (FONT_PT + 3 if xlabel else 0)
    if p.offsets_s.size == 0 or not np.isfinite(p.energy).any():
        ax.text(0.5, 0.5, "no landscape", ha="center", va="center", transform=ax.transAxes,
                fontsize=FONT_PT, color=REJECT)
        ax.set_xticks([])
        ax.set_yticks([])
        _note_below(ax, _landscape_note(p, None, note_width_in), 6)
        return
    if xlabel:
        ax.set_xlabel("Δ [s]", labelpad=1.0)
    ax.plot(p.offsets_s, p.energy, color=curve, lw=1.0, label="E(Δ)")
    if p.confirm_energy is not None:
        _confirm_curve(ax, p)
    if p.minima_offsets_s.size:
        ax.scatter(p.minima_offsets_s[1:], p.minima_energy[1:], s=10, facecolors="white",
                   edgecolors=OTHER_MINIMA, linewidths=0.6, zorder=3, label="other minima")
        ax.scatter(p.minima_offsets_s[:1], p.minima_energy[:1], s=40, marker="*", color=col,
                   edgecolors="black", linewidths=0.4, zorder=4, label="best minimum")
    if p.chosen_offset_s is not None:
        ax.axvline(p.chosen_offset_s, color=col, lw=0.9, alpha=0.8)
    if p.true_offset_s is not None:
        ax.axvline(p.true_offset_s, color=TRUTH, lw=0.9, ls=(0, (3, 2)))
    if p.solved_offset_s is not None:
        ax.plot([p.solved_offset_s], [0.0], marker="^", ms=5, color=SOLVED, mec="black", mew=0.4,
                transform=ax.get_xaxis_transform(), clip_on=False, zorder=5)
    _note_below(ax, _landscape_note(p, None, note_width_in), below)
    ax.margins(x=0.01)
    ax.grid(True, alpha=0.3, lw=0.5)


def _confirm_curve(ax, p: PairView) -> None:
    """The energy of the pair's appearance-matched track pairs alone (its unchecked ones left
    out), dashed (already drawn over the pair's energy range), and its minimum, dotted."""
    if not np.isfinite(p.confirm_energy).any():
        return
    ax.plot(p.offsets_s, p.confirm_energy, color=APPEARANCE_ONLY, lw=0.8, ls="--",
            label="appearance pairs alone (rescaled)")
    if p.confirm_offset_s is not None:
        ax.axvline(p.confirm_offset_s, color=APPEARANCE_ONLY, lw=0.8, ls=":")


def landscapes(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
               size: str = "page") -> Path:
    fig, axes, rows, cols = _panels("landscapes", data, len(data.pairs), size)
    colors = pair_colors(data)
    width = _panel_width(WIDTHS_IN[size], len(data.pairs), size)
    for i, ax in enumerate(axes):
        p = data.pairs[i]
        _landscape_axes(ax, p, data.label, colors[p.key], width)
        if i % cols == 0:
            ax.set_ylabel("energy E(Δ)")
    handles = [Patch(fc=ACCEPT_BG, ec=ACCEPT, lw=1.2, label="accepted"),
               Patch(fc=REJECT_BG, ec=REJECT, lw=1.2, label="rejected"),
               Line2D([], [], marker="*", color="w", markerfacecolor=ACCEPT, markeredgecolor="k",
                      markersize=7, label="best minimum (chosen Δ: solid line)"),
               Line2D([], [], marker="o", color="w", markerfacecolor="white", markeredgecolor=OTHER_MINIMA,
                      markersize=4, label="other minima"),
               Line2D([], [], marker="^", color="w", markerfacecolor=SOLVED,
                      markeredgecolor="k", markersize=5, label="Δ of the global solve")]
    if data.gt_offsets_s:
        handles.append(Line2D([], [], color=TRUTH, lw=0.9, ls=(0, (3, 2)), label="true Δ"))
    if any(p.confirm_energy is not None for p in data.pairs):
        handles.append(Line2D([], [], color=APPEARANCE_ONLY, lw=0.8, ls="--", label="appearance pairs alone"))
    ncol = max(1, min(len(handles), int(WIDTHS_IN[size] / 1.75)))
    fig.legend(handles=handles, loc="outside upper center", ncol=ncol, frameon=False,
               handlelength=1.6, columnspacing=1.0)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)


# ---- point transfer (Stage 0) ----------------------------------------------------------------


def transfer(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
             size: str = "page") -> Path:
    """One panel per camera Stage 0's joint vote was unsure of: the share of the other cameras'
    triangulated samples that land on one of its tracks, over its candidate offset."""
    fig, axes, _, cols = _panels("transfer", data, len(data.transfer), size)
    width = _panel_width(WIDTHS_IN[size], len(data.transfer), size)
    for i, ax in enumerate(axes):
        t = data.transfer[i]
        color = ACCEPT if t.confirmed else REJECT
        ax.set_facecolor(ACCEPT_BG if t.confirmed else REJECT_BG)
        ax.plot(t.offsets_s, t.share, color=color, lw=1.0)
        ax.axvline(t.joint_offset_s, color=SOLVED, lw=1.1, label="joint vote")
        if t.transfer_offset_s is not None:
            j = int(np.argmin(np.abs(t.offsets_s - t.transfer_offset_s)))
            ax.plot([t.offsets_s[j]], [t.share[j]], marker="*", ms=7, color=color, mec="k", mew=0.4,
                    ls="none", label="transfer peak")
        if t.true_offset_s is not None:
            ax.axvline(t.true_offset_s, color=TRUTH, ls=(0, (3, 2)), lw=0.9, label="truth")
        _label_check(ax, data.label(t.camera), data.label(t.origin), "confirmed" if t.confirmed else "refused",
                     _check_note(t.reason, width), "share on its tracks" if i % cols == 0 else None, width)
    _check_legend(fig, axes, size)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)


def _check_legend(fig, axes, size: str) -> None:
    """One legend above the panels (in a panel it would hide the curve's peak)."""
    handles, labels = axes[0].get_legend_handles_labels() if len(axes) else ([], [])
    if handles:
        fig.legend(handles, labels, loc="outside upper center", frameon=False, handlelength=1.6,
                   ncol=max(1, min(len(handles), int(WIDTHS_IN[size] / 1.4))))


def _label_check(ax, camera: str, origin: str, verdict: str, note: str, ylabel: str | None,
                 width_in: float) -> None:
    """Title (verdict), axis labels, legend and reason (under the panel) of one camera's Stage 0
    check panel (ylabel None: not the first column; width_in: the panel's width)."""
    ax.set_title(f"{camera}: {verdict}", fontsize=FONT_PT, loc="left", fontweight="bold",
                 color=ACCEPT if verdict in ("confirmed", "passed") else REJECT)
    xlabel = f"offset of {camera} [s], {origin} at 0"
    fits = len(xlabel) <= _chars(width_in - NOTE_INSET_IN, FONT_PT)
    ax.set_xlabel(xlabel if fits else f"offset of {camera} [s]\n{origin} at 0", labelpad=1.0)
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3, lw=0.5)
    _note_below(ax, note, SMALL_PT + 4 + (FONT_PT + 3) * (1 if fits else 2))


# ---- three-view check (Stage 0) --------------------------------------------------------------


def three_view(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
               size: str = "page") -> Path:
    """One panel per estimated camera Stage 0's joint vote was sure of: how many trajectories
    of the other sure cameras its tracks follow, over its candidate offset, against what the
    joint offset needed."""
    fig, axes, _, cols = _panels("three_view", data, len(data.three_view), size)
    width = _panel_width(WIDTHS_IN[size], len(data.three_view), size)
    for i, ax in enumerate(axes):
        t = data.three_view[i]
        color = ACCEPT if t.passed else REJECT
        ax.set_facecolor(ACCEPT_BG if t.passed else REJECT_BG)
        ax.plot(t.offsets_s, t.supporters, color=color, lw=1.0, drawstyle="steps-mid")
        ax.axvline(t.joint_offset_s, color=SOLVED, lw=1.1, label="joint vote")
        ax.axhline(t.needed, color="0.35", ls=":", lw=0.9, label="needed at the joint vote's offset")
        if t.true_offset_s is not None:
            ax.axvline(t.true_offset_s, color=TRUTH, ls=(0, (3, 2)), lw=0.9, label="truth")
        ax.set_ylim(bottom=0)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of trajectories
        _label_check(ax, data.label(t.camera), data.label(t.origin), "passed" if t.passed else "refused",
                     _check_note(f"needed {t.needed:g}. {t.reason}", width),
                     "trajectories followed" if i % cols == 0 else None, width)
    _check_legend(fig, axes, size)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)

