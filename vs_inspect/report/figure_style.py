"""The report figures' printed style: sizes, fonts, colours, render options, number formats.

Figures are sized for print: `size` "column" is 3.5 in wide, "page" 7.1 in, and their text is 7-9 pt
at that size. PDFs embed TrueType (Type 42) fonts and SVGs keep their text as <text>, so both pass
submission checks and stay editable. Colours: vs_inspect.palette (green accepted, vermillion
rejected, one colour per pair's curve and per video).
"""

from __future__ import annotations

import math
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .. import palette  # noqa: E402
from ..errors import InputError  # noqa: E402
from .data import ReportData  # noqa: E402

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


NOTE_INSET_IN = 0.55  # a panel's width less its axes' (tick labels, y label, gaps), inches


def _chars(width_in: float, pt: float = SMALL_PT) -> int:
    """About how many characters of pt-sized text fit in width_in inches."""
    return max(12, int(width_in * 72 / (0.52 * pt)))


def _wrap(text: str, width: int) -> str:
    """The whole text in lines of at most width characters (never cut)."""
    return "\n".join(textwrap.wrap(text, width))


def _lines(text: str) -> int:
    return text.count("\n") + 1 if text else 0


def _fmt(x: float | None, unit: str = " s", digits: int = 3) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:+.{digits}f}{unit}"

