"""2D report figures with matplotlib (Agg): landscapes, pair graph, timeline, epipolar panel.

Each function takes ReportData (or a part of it) and an output path, draws, and writes the figure
in each requested format (PNG at the given dpi, PDF, SVG); nothing is computed here. Figures are
sized for print: `size` "column" is 3.5 in wide, "page" 7.1 in, and their text is 7-9 pt at that
size. PDFs embed TrueType (Type 42) fonts and SVGs keep their text as <text>, so both pass
submission checks and stay editable. Videos are drawn by their short names (ReportData.labels)
with the full names below the figure. Colours: vs_inspect.palette (green accepted, vermillion
rejected, one colour per pair's curve and per video).
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from .. import palette, signals  # noqa: E402
from ..errors import InputError  # noqa: E402
from .data import EpipolarPanel, PairView, ReportData  # noqa: E402

DPI = 200  # default resolution of the PNGs (and of the 3D scene's picture in PDF/SVG)
FORMATS = ("png", "pdf", "svg")
DPI_RANGE = (10.0, 1200.0)
WIDTHS_IN = {"column": 3.5, "page": 7.1}  # a paper's column and its text width, inches
SIZES = tuple(WIDTHS_IN)
FONT_PT, TITLE_PT, SMALL_PT = 8.0, 8.5, 7.0  # text at the printed size
LINE_IN = SMALL_PT * 1.3 / 72  # height of one line of small text, inches


def checked_render_options(formats: str | tuple[str, ...], dpi: float, size: str = "page") -> tuple[str, ...]:
    """The formats (a tuple, or "png,pdf" as --format gives them), dpi and size checked once for
    the command and the library: InputError naming the bad value."""
    text = formats if isinstance(formats, str) else ",".join(formats)
    fmts = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    bad = [f for f in fmts if f not in FORMATS]
    if bad or not fmts:
        raise InputError(f"--format {text}: unknown format {bad or ''}; choose from "
                         f"{','.join(FORMATS)} (comma-separated)")
    if not (DPI_RANGE[0] <= dpi <= DPI_RANGE[1]):
        raise InputError(f"--dpi {dpi:g}: must be between {DPI_RANGE[0]:g} and {DPI_RANGE[1]:g}")
    if size not in WIDTHS_IN:
        raise InputError(f"--size {size}: choose {' or '.join(SIZES)}")
    return fmts


ACCEPT = palette.hex_of(palette.ACCEPTED)
REJECT = palette.hex_of(palette.REJECTED)
TRUTH = palette.hex_of(palette.TRUTH)
SOLVED = palette.hex_of(palette.SOLVED)  # Δ implied by the global solve
APPEARANCE_ONLY = "#555555"  # a pair's landscape without its unchecked track pairs
OTHER_MINIMA = "#555555"
ACCEPT_BG = palette.hex_of(palette.tint(palette.ACCEPTED, 0.1))
REJECT_BG = palette.hex_of(palette.tint(palette.REJECTED, 0.1))
plt.rcParams.update({
    "font.size": FONT_PT, "axes.titlesize": TITLE_PT, "axes.labelsize": FONT_PT,
    "xtick.labelsize": SMALL_PT, "ytick.labelsize": SMALL_PT, "legend.fontsize": SMALL_PT,
    "figure.titlesize": 9.0, "figure.labelsize": SMALL_PT, "axes.linewidth": 0.6,
    "xtick.major.width": 0.6, "ytick.major.width": 0.6, "xtick.major.size": 2.5, "ytick.major.size": 2.5,
    "lines.linewidth": 1.0, "lines.markersize": 4.0, "axes.titlepad": 3.0,
    # fonts: TrueType in PDF/PS (Type 3 fonts are refused by submission checkers), text in SVG
    "pdf.fonttype": 42, "ps.fonttype": 42, "svg.fonttype": "none",
})


def video_colors(names: list[str]) -> dict[str, tuple[float, float, float]]:
    """One stable colour per video, the recording's (vs_inspect.palette), as matplotlib floats."""
    return {n: palette.mpl(rgb) for n, rgb in palette.video_colours(names).items()}


def pair_colors(data: ReportData) -> dict[str, tuple[float, float, float]]:
    """One colour per pair's curve, in the result's order (as the recording's "all landscapes")."""
    return {k: palette.mpl(rgb) for k, rgb in palette.pair_colours([p.key for p in data.pairs]).items()}


def fmt_px2(x: float | None) -> str:
    """A squared pixel error for people: two significant digits, "< 0.001" below that."""
    if x is None or not math.isfinite(x):
        return "—"
    if x < 1e-3:
        return "< 0.001"
    d = math.floor(math.log10(x))
    r = round(x, 1 - d)
    return f"{r:.0f}" if d >= 1 else f"{r:.{1 - d}f}"


def fmt_px(x: float | None) -> str:
    """A distance in pixels for people: two significant digits, "< 0.01" below that."""
    if x is None or not math.isfinite(x):
        return "—"
    if x < 1e-2:
        return "< 0.01"
    return fmt_px2(x)


def fmt_error(ms: float | None, frames: float | None = None) -> str:
    """'13.5 ms (0.67 frames)'; '—' when unknown."""
    if ms is None or not math.isfinite(ms):
        return "—"
    return f"{ms:.1f} ms" + (f" ({frames:.2f} frames)" if frames is not None else "")


def landscape_grid_shape(n: int, size: str = "page") -> tuple[int, int]:
    """(rows, columns) of a grid of n panels: 2 columns in a paper column, 3 across a page."""
    cols = min(2 if size == "column" else 3, max(1, n))
    return max(1, math.ceil(n / cols)), cols


NOTE_INSET_IN = 0.55  # a panel's width less its axes' (tick labels, y label, gaps), inches


def _chars(width_in: float, pt: float = SMALL_PT) -> int:
    """About how many characters of pt-sized text fit in width_in inches."""
    return max(12, int(width_in * 72 / (0.52 * pt)))


def _wrap(text: str, width: int) -> str:
    """The whole text in lines of at most width characters (never cut)."""
    return "\n".join(textwrap.wrap(text, width))


def _lines(text: str) -> int:
    return text.count("\n") + 1 if text else 0


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


def _fmt(x: float | None, unit: str = " s", digits: int = 3) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:+.{digits}f}{unit}"


def _note_below(ax, text: str, below_pt: float) -> None:
    """Small text under an axes (below its tick labels and x label), outside the data: it is an
    axes child, so the constrained layout keeps room for it."""
    if text:
        ax.annotate(text, xy=(0.0, 0.0), xycoords="axes fraction", xytext=(0.0, -below_pt),
                    textcoords="offset points", ha="left", va="top", fontsize=SMALL_PT, color="#222222")


# ---- energy landscapes ----------------------------------------------------------------------


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


def _panels(kind: str, data: ReportData, n: int, size: str):
    """(figure, its first n axes, rows, cols) of a grid of n panels (landscape_grid_shape); the
    grid's spare axes are hidden."""
    fig = _fig(kind, data, size)
    rows, cols = landscape_grid_shape(n, size)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax in axes[n:]:
        ax.axis("off")
    return fig, axes[:n], rows, cols


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


def _check_note(reason: str, width_in: float) -> str:
    return _wrap(reason, _chars(width_in - NOTE_INSET_IN))


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
