"""2D report figures with matplotlib (Agg): landscapes, pair graph, timeline, epipolar panel.

Each function takes ReportData (or a part of it) and an output path, draws, and writes the figure
in each requested format (PNG of a size fixed by figure_size_px at the given dpi, PDF, SVG);
nothing is computed here. Colours: vs_inspect.palette, the recording's (Okabe-Ito, safe for
colour-blind readers): accepted = bluish green, rejected = vermillion, videos in neither.
"""

from __future__ import annotations

import math
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

DPI = 100  # default resolution; figure_size_px is in pixels at this dpi
FORMATS = ("png", "pdf", "svg")
DPI_RANGE = (10.0, 1200.0)


def checked_render_options(formats: str | tuple[str, ...], dpi: float) -> tuple[str, ...]:
    """The formats (a tuple, or "png,pdf" as --format gives them) and dpi checked once for the
    command and the library: InputError naming the bad value."""
    text = formats if isinstance(formats, str) else ",".join(formats)
    fmts = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    bad = [f for f in fmts if f not in FORMATS]
    if bad or not fmts:
        raise InputError(f"--format {text}: unknown format {bad or ''}; choose from "
                         f"{','.join(FORMATS)} (comma-separated)")
    if not (DPI_RANGE[0] <= dpi <= DPI_RANGE[1]):
        raise InputError(f"--dpi {dpi:g}: must be between {DPI_RANGE[0]:g} and {DPI_RANGE[1]:g}")
    return fmts
ACCEPT = palette.hex_of(palette.ACCEPTED)
REJECT = palette.hex_of(palette.REJECTED)
TRUTH = "#222222"
SOLVED = "#CC79A7"  # Okabe-Ito reddish purple: Δ implied by the global solve
APPEARANCE_ONLY = "#555555"  # a pair's landscape without its unchecked track pairs
ACCEPT_BG = palette.hex_of(palette.tint(palette.ACCEPTED, 0.1))
REJECT_BG = palette.hex_of(palette.tint(palette.REJECTED, 0.1))
plt.rcParams.update({"font.size": 11, "axes.titlesize": 11, "axes.labelsize": 10,
                     "xtick.labelsize": 9, "ytick.labelsize": 9, "legend.fontsize": 9})


def video_colors(names: list[str]) -> dict[str, tuple[float, float, float]]:
    """One stable colour per video, the recording's (vs_inspect.palette), as matplotlib floats."""
    return {n: tuple(c / 255 for c in rgb) for n, rgb in palette.video_colours(names).items()}


def fmt_px2(x: float | None) -> str:
    """A squared pixel error for people: two significant digits, "< 0.001" below that."""
    if x is None or not math.isfinite(x):
        return "—"
    if x < 1e-3:
        return "< 0.001"
    d = math.floor(math.log10(x))
    r = round(x, 1 - d)
    return f"{r:.0f}" if d >= 1 else f"{r:.{1 - d}f}"


def fmt_error(ms: float | None, frames: float | None = None) -> str:
    """'13.5 ms (0.67 frames)'; '—' when unknown."""
    if ms is None or not math.isfinite(ms):
        return "—"
    return f"{ms:.1f} ms" + (f" ({frames:.2f} frames)" if frames is not None else "")


def landscape_grid_shape(n: int) -> tuple[int, int]:
    cols = min(4, max(1, n))
    return max(1, math.ceil(n / cols)), cols


def figure_size_px(kind: str, data: ReportData, dpi: float = DPI) -> tuple[int, int]:
    """(width, height) in pixels of each figure's PNG at dpi, so that tests can check it."""
    w, h = _size_px(kind, data)
    # as matplotlib sizes the canvas: inches (px / DPI) times dpi, truncated
    return int((w / DPI) * dpi + 1e-6), int((h / DPI) * dpi + 1e-6)


def _size_px(kind: str, data: ReportData) -> tuple[int, int]:
    if kind == "landscapes":
        rows, cols = landscape_grid_shape(len(data.pairs))
        return max(760, 380 * cols), 110 + 300 * rows
    if kind == "pair_graph":
        return 1000, 900
    if kind == "timeline":
        return 1300, 220 + 2 * 42 * max(1, len(data.videos))
    if kind == "epipolar":
        e = data.epipolar
        aspect = e.height / e.width if e else 0.56
        return 1600, int(round(150 + 780 * aspect))
    if kind == "scene3d":
        return 1600, 1000
    if kind == "transfer":
        rows, cols = landscape_grid_shape(len(data.transfer))
        return max(760, 420 * cols), 110 + 320 * rows
    if kind == "three_view":
        rows, cols = landscape_grid_shape(len(data.three_view))
        return max(760, 420 * cols), 110 + 320 * rows
    if kind == "mosaic":
        rows, cols = _mosaic_grid(len(data.mosaic.tiles) if data.mosaic else 1)
        return 480 * cols, 70 + 320 * rows
    raise KeyError(kind)


def _mosaic_grid(n: int) -> tuple[int, int]:
    """The grid of the exported mosaic video (report/mosaic.py), so both look alike."""
    from .mosaic import grid_shape
    return grid_shape(max(1, n))


def _fig(kind: str, data: ReportData):
    w, h = figure_size_px(kind, data)
    return plt.figure(figsize=(w / DPI, h / DPI), dpi=DPI, layout="constrained")


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


# ---- energy landscapes ----------------------------------------------------------------------


def _landscape_axes(ax, p: PairView) -> None:
    col = ACCEPT if p.accepted else REJECT
    ax.set_facecolor(ACCEPT_BG if p.accepted else REJECT_BG)
    for side in ax.spines.values():
        side.set_edgecolor(col)
        side.set_linewidth(2.0)
    mark = "accepted" if p.accepted else "REJECTED"
    # long names (e.g. VisualSync clip names) would run into the next panel's title: two lines
    sep = " – " if len(p.a) + len(p.b) <= 36 else " –\n"
    ax.set_title(f"{p.a}{sep}{p.b}   {mark}", color=col, fontweight="bold", loc="left", fontsize=11)
    if p.offsets_s.size == 0 or not np.isfinite(p.energy).any():
        ax.text(0.5, 0.5, "no landscape\n" + _wrap(p.reason, 44), ha="center", va="center",
                transform=ax.transAxes, fontsize=8.5, color=REJECT)
        ax.set_xticks([])
        ax.set_yticks([])
        return
    ax.plot(p.offsets_s, p.energy, color="#3b4cc0" if p.accepted else "#7f7f7f", lw=1.2)
    if p.confirm_energy is not None:
        _confirm_curve(ax, p)
    if p.minima_offsets_s.size:
        ax.scatter(p.minima_offsets_s[1:], p.minima_energy[1:], s=28, facecolors="white",
                   edgecolors="#555555", zorder=3, label="other minima")
        ax.scatter(p.minima_offsets_s[:1], p.minima_energy[:1], s=90, marker="*", color=col,
                   edgecolors="black", linewidths=0.5, zorder=4, label="best minimum")
    if p.chosen_offset_s is not None:
        ax.axvline(p.chosen_offset_s, color=col, lw=1.2, alpha=0.8)
    if p.true_offset_s is not None:
        ax.axvline(p.true_offset_s, color=TRUTH, lw=1.2, ls=(0, (4, 3)))
    if p.solved_offset_s is not None:
        ax.plot([p.solved_offset_s], [0.0], marker="^", ms=10, color=SOLVED, mec="black", mew=0.6,
                transform=ax.get_xaxis_transform(), clip_on=False, zorder=5)
    txt = f"Δ = {_fmt(p.chosen_offset_s)}"
    if p.residual == "sighting":  # not an epipolar energy: say what the curve is
        txt += "\nworn-camera sightings:\n1 − share of heads on its centre"
        if "refined to" in p.reason:  # sync/sightings.refine_peak moved Δ off the counted peak
            txt += "\nΔ refitted with a head-to-camera shift"
    if p.error_ms is not None:
        txt += f"\nerror vs truth {p.error_ms:.1f} ms"
    if p.disagreement_ms is not None and p.disagreement_ms > 100.0:
        txt += f"\n{p.disagreement_ms:.0f} ms off the global solve"
    if not p.accepted:
        txt += "\n" + _wrap(p.reason, 50)
    ax.text(0.02, 0.04, txt, transform=ax.transAxes, fontsize=7.5 if not p.accepted else 8.5,
            va="bottom", ha="left", bbox=dict(boxstyle="round,pad=0.25", fc="white", ec=col, alpha=0.9))
    ax.margins(x=0.01)
    ax.grid(True, alpha=0.3)


def _confirm_curve(ax, p: PairView) -> None:
    """The energy of the pair's appearance-matched track pairs alone (its unchecked ones left
    out), dashed (already drawn over the pair's energy range), and its minimum, dotted."""
    if not np.isfinite(p.confirm_energy).any():
        return
    ax.plot(p.offsets_s, p.confirm_energy, color=APPEARANCE_ONLY, lw=1.0, ls="--",
            label="appearance pairs alone (rescaled)")
    if p.confirm_offset_s is not None:
        ax.axvline(p.confirm_offset_s, color=APPEARANCE_ONLY, lw=1.0, ls=":")


def _wrap(text: str, width: int) -> str:
    """The whole text in lines of at most width characters (never cut)."""
    import textwrap
    return "\n".join(textwrap.wrap(text, width))


def _panels(kind: str, data: ReportData, n: int):
    """(figure, its first n axes, rows, cols) of a grid of n panels (landscape_grid_shape); the
    grid's spare axes are hidden."""
    fig = _fig(kind, data)
    rows, cols = landscape_grid_shape(n)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    for ax in axes[n:]:
        ax.axis("off")
    return fig, axes[:n], rows, cols


def landscapes(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    fig, axes, rows, cols = _panels("landscapes", data, len(data.pairs))
    for i, ax in enumerate(axes):
        _landscape_axes(ax, data.pairs[i])
        if i // cols == rows - 1 or i + cols >= len(data.pairs):
            ax.set_xlabel("Δ = offset(b) − offset(a)  [s]")
        if i % cols == 0:
            ax.set_ylabel("energy E(Δ)")
    handles = [Patch(fc=ACCEPT_BG, ec=ACCEPT, lw=2, label="accepted pair"),
               Patch(fc=REJECT_BG, ec=REJECT, lw=2, label="rejected pair"),
               Line2D([], [], marker="*", color="w", markerfacecolor=ACCEPT, markeredgecolor="k",
                      markersize=12, label="best minimum"),
               Line2D([], [], marker="o", color="w", markerfacecolor="white", markeredgecolor="#555",
                      label="other minima")]
    handles.append(Line2D([], [], marker="^", color="w", markerfacecolor=SOLVED,
                          markeredgecolor="k", markersize=10, label="Δ of the global solve"))
    if data.gt_offsets_s:
        handles.append(Line2D([], [], color=TRUTH, ls=(0, (4, 3)), label="true Δ"))
    if any(p.confirm_energy is not None for p in data.pairs):
        handles.append(Line2D([], [], color=APPEARANCE_ONLY, lw=1.0, ls="--", label="appearance pairs alone"))
    # as many legend entries per row as the figure's width holds (about 190 px each)
    ncol = max(1, min(len(handles), _size_px("landscapes", data)[0] // 190))
    fig.legend(handles=handles, loc="outside upper center", ncol=ncol, frameon=False)
    return _save(fig, path, dpi, formats)


# ---- point transfer (Stage 0) ----------------------------------------------------------------


def transfer(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    """One panel per camera Stage 0's joint vote was unsure of: the share of the other cameras'
    triangulated samples that land on one of its tracks, over its candidate offset."""
    fig, axes, _, cols = _panels("transfer", data, len(data.transfer))
    for i, ax in enumerate(axes):
        t = data.transfer[i]
        color = ACCEPT if t.confirmed else REJECT
        ax.set_facecolor(ACCEPT_BG if t.confirmed else REJECT_BG)
        ax.plot(t.offsets_s, t.share, color=color, lw=1.4)
        ax.axvline(t.joint_offset_s, color=SOLVED, lw=1.6, label="joint vote")
        if t.transfer_offset_s is not None:
            j = int(np.argmin(np.abs(t.offsets_s - t.transfer_offset_s)))
            ax.plot([t.offsets_s[j]], [t.share[j]], marker="*", ms=13, color=color, mec="k",
                    ls="none", label="transfer peak")
        if t.true_offset_s is not None:
            ax.axvline(t.true_offset_s, color=TRUTH, ls=(0, (4, 3)), lw=1.2, label="truth")
        if t.transfer_offset_s is not None:  # the peak's neighbourhood, where the two cues are compared
            zoom = ax.inset_axes([0.03, 0.52, 0.3, 0.44])
            near = np.abs(t.offsets_s - t.transfer_offset_s) <= 0.25
            zoom.plot(t.offsets_s[near], t.share[near], color=color, lw=1.2)
            zoom.axvline(t.joint_offset_s, color=SOLVED, lw=1.4)
            zoom.plot([t.offsets_s[j]], [t.share[j]], marker="*", ms=10, color=color, mec="k", ls="none")
            if t.true_offset_s is not None:
                zoom.axvline(t.true_offset_s, color=TRUTH, ls=(0, (4, 3)), lw=1.0)
            zoom.set_xlim(t.transfer_offset_s - 0.25, t.transfer_offset_s + 0.25)
            zoom.tick_params(labelsize=6)
            zoom.set_title("± 0.25 s", fontsize=6)
        _label_check(ax, t.camera, t.origin, "confirmed" if t.confirmed else "refused", t.reason,
                     "samples on their track (share)" if i % cols == 0 else None)
    return _save(fig, path, dpi, formats)


def _label_check(ax, camera: str, origin: str, verdict: str, reason: str, ylabel: str | None) -> None:
    """Title (verdict and reason), axis labels and legend of one camera's Stage 0 check panel
    (ylabel None: not the first column)."""
    ax.set_title(f"{camera}: {verdict}\n{_wrap(reason, 58)}", fontsize=8, loc="left")
    ax.set_xlabel(f"offset of {camera} with {origin} at 0  [s]")
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    ax.legend(fontsize=7, loc="upper right", frameon=False)


# ---- three-view check (Stage 0) --------------------------------------------------------------


def three_view(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    """One panel per estimated camera Stage 0's joint vote was sure of: how many trajectories
    of the other sure cameras its tracks follow, over its candidate offset, against what the
    joint offset needed."""
    fig, axes, _, cols = _panels("three_view", data, len(data.three_view))
    for i, ax in enumerate(axes):
        t = data.three_view[i]
        color = ACCEPT if t.passed else REJECT
        ax.set_facecolor(ACCEPT_BG if t.passed else REJECT_BG)
        ax.plot(t.offsets_s, t.supporters, color=color, lw=1.4, drawstyle="steps-mid")
        ax.axvline(t.joint_offset_s, color=SOLVED, lw=1.6, label="joint vote")
        ax.axhline(t.needed, color="0.35", ls=":", lw=1.2, label=f"needed ({t.needed:g})")
        if t.true_offset_s is not None:
            ax.axvline(t.true_offset_s, color=TRUTH, ls=(0, (4, 3)), lw=1.2, label="truth")
        ax.set_ylim(bottom=0)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of trajectories
        _label_check(ax, t.camera, t.origin, "passed" if t.passed else "refused", t.reason,
                     "trajectories followed" if i % cols == 0 else None)
    return _save(fig, path, dpi, formats)


# ---- pair graph ----------------------------------------------------------------------------


def pair_graph(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    fig = _fig("pair_graph", data)
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
            ax.plot([x0, x1], [y0, y1], color=ACCEPT, lw=2.2, zorder=2, solid_capstyle="round")
            label = f"{p.chosen_offset_s:+.3f} s"
        else:
            ax.plot([x0, x1], [y0, y1], color=REJECT, lw=2.0, ls=(0, (5, 4)), zorder=1)
            label = "✗ rejected"
        t = 0.3 if p.accepted else 0.5
        ax.text(x0 + t * (x1 - x0), y0 + t * (y1 - y0), label, fontsize=8.5, ha="center",
                va="center", color=ACCEPT if p.accepted else REJECT, zorder=5,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))
    for v in names:
        x, y = pos[v]
        off = data.offsets_s.get(v)
        ax.scatter([x], [y], s=1500, color=colors[v], edgecolors="black", linewidths=1.2, zorder=6)
        ax.text(x, y, v, ha="center", va="center", fontsize=10, fontweight="bold", zorder=7,
                color=palette.text_on(tuple(round(255 * c) for c in colors[v])))
        sub = "reference (0 s)" if v == data.reference else ("unresolved" if off is None else f"{off:+.3f} s")
        if v in errs and v != data.reference:
            sub += f"\nerror {fmt_error(errs[v], frames.get(v))}"
        # outside the node, on the side away from the centre
        ha = "left" if x > 0.3 else "right" if x < -0.3 else "center"
        va = "bottom" if y > 0.3 else "top" if y < -0.3 else "center"
        ax.text(1.14 * x, 1.14 * y, sub, ha=ha, va=va, fontsize=10, zorder=7,
                color="black" if off is not None else REJECT)
    ax.set_xlim(-1.6, 1.6)
    ax.set_ylim(-1.45, 1.45)
    ax.set_aspect("equal")
    ax.axis("off")
    acc = sum(p.accepted for p in data.pairs)
    ax.set_title(f"Pair graph: {acc} accepted (solid, Δ = offset(b) − offset(a) along a→b in "
                 f"name order, label near a),\n{len(data.pairs) - acc} rejected (dashed)"
                 + ("; errors against the truth under the offsets" if errs else ""), fontsize=11)
    return _save(fig, path, dpi, formats)


# ---- timeline ------------------------------------------------------------------------------


def timeline(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    fig = _fig("timeline", data)
    before, after = fig.subplots(2, 1, sharex=True, height_ratios=[1, 1])
    colors = video_colors(data.names)
    n = len(data.videos)
    gt = data.gt_offsets_s or {}
    ref_gt = gt.get(data.reference, 0.0)
    errs, frames = data.errors_ms(), data.errors_frames()
    for i, v in enumerate(data.videos):
        y = n - 1 - i
        before.barh(y, v.end_s - v.start_s, left=v.start_s, color=colors[v.name], height=0.6,
                    edgecolor="black", lw=0.6)
        off = data.offsets_s.get(v.name)
        if off is None:
            after.barh(y, v.end_s - v.start_s, left=v.start_s, color="white", height=0.6,
                       edgecolor=REJECT, hatch="//", lw=1.0)
            after.text(v.start_s + 0.1, y, "unresolved: not placed", va="center", fontsize=9.5,
                       color=REJECT, fontweight="bold",
                       bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none"))
        else:
            after.barh(y, v.end_s - v.start_s, left=v.start_s + off, color=colors[v.name],
                       height=0.6, edgecolor="black", lw=0.6)
            if v.name in gt:
                x = gt[v.name] - ref_gt + v.start_s
                after.plot([x, x], [y - 0.42, y + 0.42], color=TRUTH, lw=2.0)
            if errs.get(v.name) is not None and v.name != data.reference:
                after.text(v.end_s + off + 0.1, y, f"error {fmt_error(errs[v.name], frames.get(v.name))}",
                           va="center", fontsize=8.5)
        rate = f"{v.fps:g} fps" if v.fps else "variable fps"
        before.text(v.end_s + 0.1, y, f"{v.num_frames} frames, {rate}", va="center", fontsize=8.5)
    for ax, title in ((before, "before sync: every video starts at its own local 0"),
                      (after, "after sync: bars placed at their estimated offsets on the global "
                              "time axis" + (" (black tick: true start)" if gt else ""))):
        ax.set_yticks(range(n), [v.name for v in reversed(data.videos)])
        ax.set_title(title, loc="left", fontsize=11)
        ax.grid(True, axis="x", alpha=0.3)
        ax.set_ylim(-0.6, n - 0.4)
    after.set_xlabel(f"time [s]  (global axis: {data.reference} starts at 0)")
    lo = min([v.start_s + (data.offsets_s.get(v.name) or 0.0) for v in data.videos] + [0.0])
    hi = max([v.end_s + (data.offsets_s.get(v.name) or 0.0) for v in data.videos] + [1.0])
    after.set_xlim(lo - 0.3, hi + 0.22 * (hi - lo) + 0.5)
    return _save(fig, path, dpi, formats)


# ---- epipolar panel ------------------------------------------------------------------------


def _epipolar_axes(ax, e: EpipolarPanel, state, title: str, good: bool) -> None:
    """One state of the panel; good = drawn in the accepted colour (a rejected pair's best
    offset is not)."""
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
                ax.axline((0.0, -l[2] / l[1]), slope=-l[0] / l[1], color=c, lw=1.4, alpha=0.9)
            else:
                ax.axvline(-l[2] / l[0], color=c, lw=1.4, alpha=0.9)
        ax.scatter([p[0]], [p[1]], s=60, color=c, edgecolors="black", linewidths=0.8, zorder=4)
    ax.set_xlim(-0.5, W - 0.5)
    ax.set_ylim(H - 0.5, -0.5)
    ax.set_aspect("equal")
    col = ACCEPT if good else REJECT
    ax.set_title(title, color=col, fontsize=11, fontweight="bold")
    ax.set_xlabel("x [px]")
    ax.set_ylabel("y [px]")
    ax.text(0.01, 0.99, f"median Sampson error {fmt_px2(state.median_sampson_px2)} px²",
            transform=ax.transAxes, va="top", ha="left", fontsize=11,
            bbox=dict(boxstyle="round,pad=0.3", fc="white", ec=col, alpha=0.92))


def epipolar(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    e = data.epipolar
    fig = _fig("epipolar", data)
    left, right = fig.subplots(1, 2)
    _epipolar_axes(left, e, e.wrong, f"wrong offset Δ = {e.wrong.offset_s:+.3f} s", False)
    if e.accepted:
        _epipolar_axes(right, e, e.chosen, f"chosen offset Δ = {e.chosen.offset_s:+.3f} s", True)
    else:
        _epipolar_axes(right, e, e.chosen, f"best offset of a REJECTED pair Δ = {e.chosen.offset_s:+.3f} s",
                       False)
    backdrop = "video frame" if e.image_bgr is not None else "blank canvas: video not available"
    fig.suptitle(f"{e.a} frame {e.frame_a} (t = {e.time_a_s:.3f} s; {backdrop}).  Dots: {e.a}'s "
                 f"track points.  Lines (same colour): epipolar lines of the matched points of "
                 f"{e.b} at t − Δ.\nAt the right Δ each line passes through its dot; matches that "
                 f"are wrong miss at every Δ.", fontsize=11)
    return _save(fig, path, dpi, formats)


# ---- mosaic of one moment --------------------------------------------------------------------


def mosaic(data: ReportData, path: Path, dpi: float = DPI, formats: tuple[str, ...] = ("png",)) -> Path:
    m = data.mosaic
    fig = _fig("mosaic", data)
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
            ax.set_title(f"{t.name}, frame {t.frame}", fontsize=10, color=colors.get(t.name, "k"),
                         fontweight="bold")
        else:
            ax.set_facecolor("#eeeeee")
            why = "not synchronized or not recording then" if t.frame is None else "frame not readable"
            ax.text(0.5, 0.5, f"{t.name}\n{why}", ha="center", va="center", transform=ax.transAxes,
                    fontsize=10, color=REJECT)
        for side in ax.spines.values():
            side.set_edgecolor(colors.get(t.name, "k"))
            side.set_linewidth(3)
    fig.suptitle(f"one global moment across all videos after sync: t = {m.time_s:.3f} s", fontsize=12)
    return _save(fig, path, dpi, formats)
