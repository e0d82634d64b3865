"""The run at a glance: the pair graph (accepted and rejected pairs, each video's offset) and the
timeline (the videos before and after sync)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import palette
from .data import ReportData
from .figure_layout import _fig, _finish, _save
from .figure_style import ACCEPT, DPI, FONT_PT, REJECT, SMALL_PT, TITLE_PT, TRUTH, WIDTHS_IN, _chars, _wrap, fmt_error, video_colors


# ---- pair graph ----------------------------------------------------------------------------


def _node_diameter_pt(label: str) -> float:
    """A node wide enough to hold its label (bold, FONT_PT) inside, so the label is always on the
    node's own colour."""
    return max(24.0, 0.66 * FONT_PT * len(label) + 9.0)


def pair_graph(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
               size: str = "page") -> Path:
    fig = _fig("pair_graph", data, size)
    ax = fig.add_subplot()
    names = data.names or sorted({n for p in data.pairs for n in (p.a, p.b)})
    colors = video_colors(names)
    errs, frames = data.errors_ms(), data.errors_frames() if data.videos else {}
    n = len(names)
    ang = np.pi / 2 - 2 * np.pi * np.arange(n) / max(n, 1)
    pos = {v: (np.cos(a), np.sin(a)) for v, a in zip(names, ang)}
    for p in sorted(data.pairs, key=lambda p: p.accepted):  # accepted on top
        (x0, y0), (x1, y1) = pos[p.a], pos[p.b]
        if p.accepted:
            ax.plot([x0, x1], [y0, y1], color=ACCEPT, lw=1.6, zorder=2, solid_capstyle="round")
            label = f"{p.chosen_offset_s:+.3f} s"
        else:
            ax.plot([x0, x1], [y0, y1], color=REJECT, lw=1.3, ls=(0, (4, 3)), zorder=1)
            label = "✗"
        t = 0.32 if p.accepted else 0.5
        ax.text(x0 + t * (x1 - x0), y0 + t * (y1 - y0), label, fontsize=SMALL_PT, ha="center",
                va="center", color=ACCEPT if p.accepted else REJECT, zorder=5,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.9))
    for v in names:
        x, y = pos[v]
        off = data.offsets_s.get(v)
        label = data.label(v)
        d = _node_diameter_pt(label)
        ax.scatter([x], [y], s=d * d, color=colors[v], edgecolors="black", linewidths=0.8, zorder=6)
        ax.text(x, y, label, ha="center", va="center", fontsize=FONT_PT, fontweight="bold", zorder=7,
                color=palette.text_on(tuple(round(255 * c) for c in colors[v])))
        sub = "reference (0 s)" if v == data.reference else ("unresolved" if off is None else f"{off:+.3f} s")
        if v in errs and v != data.reference:
            sub += f"\nerror {fmt_error(errs[v], frames.get(v))}"
        # centred above the top node, below the others: half its width on each side of the node
        above = y > 0.9
        ax.annotate(sub, (x, y), xytext=(0, (1 if above else -1) * (d / 2 + 2)), textcoords="offset points",
                    ha="center", va="bottom" if above else "top", fontsize=SMALL_PT, zorder=7,
                    color="black" if off is not None else REJECT)
    ax.set_xlim(-1.9, 1.9)
    ax.set_ylim(-1.55, 1.45)
    ax.set_aspect("equal")
    ax.axis("off")
    acc = sum(p.accepted for p in data.pairs)
    ax.set_title(_wrap(f"{acc} accepted pairs (solid, labelled with Δ near a), "
                       f"{len(data.pairs) - acc} rejected (dashed)", _chars(WIDTHS_IN[size] - 0.2, FONT_PT)),
                 fontsize=FONT_PT)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)


# ---- timeline ------------------------------------------------------------------------------


def timeline(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",),
             size: str = "page") -> Path:
    fig = _fig("timeline", data, size)
    before, after = fig.subplots(2, 1, sharex=True, height_ratios=[1, 1])
    colors = video_colors(data.names)
    n = len(data.videos)
    gt = data.gt_offsets_s or {}
    ref_gt = gt.get(data.reference, 0.0)
    errs, frames = data.errors_ms(), data.errors_frames()
    for i, v in enumerate(data.videos):
        y = n - 1 - i
        before.barh(y, v.end_s - v.start_s, left=v.start_s, color=colors[v.name], height=0.6,
                    edgecolor="black", lw=0.5)
        off = data.offsets_s.get(v.name)
        if off is None:
            after.barh(y, v.end_s - v.start_s, left=v.start_s, color="white", height=0.6,
                       edgecolor=REJECT, hatch="//", lw=0.8)
            after.text(v.start_s + 0.1, y, "unresolved: not placed", va="center", fontsize=SMALL_PT,
                       color=REJECT, fontweight="bold",
                       bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none"))
        else:
            after.barh(y, v.end_s - v.start_s, left=v.start_s + off, color=colors[v.name],
                       height=0.6, edgecolor="black", lw=0.5)
            if v.name in gt:
                x = gt[v.name] - ref_gt + v.start_s
                after.plot([x, x], [y - 0.42, y + 0.42], color=TRUTH, lw=1.4)
            if errs.get(v.name) is not None and v.name != data.reference:
                after.text(v.end_s + off + 0.1, y, f"error {fmt_error(errs[v.name], frames.get(v.name))}",
                           va="center", fontsize=SMALL_PT)
        rate = f"{v.fps:g} fps" if v.fps else "variable fps"
        before.text(v.end_s + 0.1, y, f"{v.num_frames} frames, {rate}", va="center", fontsize=SMALL_PT)
    ref = data.label(data.reference)
    for ax, title in ((before, "before sync: each video on its own clock"),
                      (after, f"after sync: placed at the estimated offsets on {ref}'s clock"
                              + (" (black tick: true start)" if gt else ""))):
        ax.set_yticks(range(n), [data.label(v.name) for v in reversed(data.videos)])
        ax.set_title(_wrap(title, _chars(WIDTHS_IN[size] - 0.8, TITLE_PT)), loc="left", fontsize=TITLE_PT)
        ax.grid(True, axis="x", alpha=0.3, lw=0.5)
        ax.set_ylim(-0.6, n - 0.4)
    after.set_xlabel(f"time [s] ({ref} starts at 0)")
    lo = min([v.start_s + (data.offsets_s.get(v.name) or 0.0) for v in data.videos] + [0.0])
    hi = max([v.end_s + (data.offsets_s.get(v.name) or 0.0) for v in data.videos] + [1.0])
    room = 0.3 if size == "page" else 0.55  # the text right of the bars
    after.set_xlim(lo - 0.3, hi + room * (hi - lo) + 0.5)
    _finish(fig, data, size)
    return _save(fig, path, dpi, formats)

