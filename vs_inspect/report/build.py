"""Render every figure ReportData supports into a folder, with index.html."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

from .. import palette, signals
from ..io.atomic import atomic_dir
from . import figures
from .data import ReportData
from .figure_layout import figure_size_px
from .figure_style import DPI, checked_render_options
from .html import write_index

log = logging.getLogger(__name__)

def caption(key: str, data: ReportData) -> str:
    """What figure `key` shows, in the words of the colours and marks it draws (palette.WORDS)."""
    w = palette.WORDS
    acc, rej, truth, solved = w[palette.ACCEPTED], w[palette.REJECTED], w[palette.TRUTH], w[palette.SOLVED]
    truth_mark = f", dashed {truth} line = true Δ" if data.gt_offsets_s else ""
    names = ("; videos are drawn by short names (the full names are under each figure)"
             if data.label_legend() else "")
    text = {
        "scene3d": "3D scene: camera frustums, one colour per video (the colours of the timeline and "
                   "the pair graph; a moving camera with its path and frustums along it), the static "
                   "reconstruction when the source holds one, and the moving points triangulated at "
                   "the solved offsets, coloured by global time.",
        "landscapes": f"Energy landscape E(Δ) of every pair, its curve in a colour of its own: {acc} "
                      f"frame = accepted, {rej} frame = rejected; star = best minimum, white circles = "
                      f"other minima, solid line = chosen Δ, {solved} triangle = Δ implied by the "
                      f"global solve{truth_mark}. Under each panel: Δ, its error against the truth "
                      "when known, and a rejected pair's reason.",
        "pair_graph": f"Pair graph: videos as nodes in their colours with their solved offsets (and "
                      f"errors against the truth when known); accepted pairs as solid {acc} edges "
                      f"labelled with Δ near a, rejected pairs as dashed {rej} edges marked ✗.",
        "timeline": "Timeline of all videos before sync (each on its own clock) and after sync "
                    "(placed at the estimated offsets on the reference's clock"
                    + (f"; {truth} ticks: true starts" if data.gt_offsets_s else "")
                    + f"; hatched {rej}: unresolved).",
        "epipolar": "Epipolar panel: the same frame of video a at a wrong and at the chosen Δ; dots "
                    "are a's track points, lines of the same colour the epipolar lines of b's matched "
                    "points at t − Δ. At the right offset the lines pass through the points; each "
                    "title gives the median distance of a point from its line, px.",
        "mosaic": "Mosaic: the frame of every video nearest one global moment after sync.",
        "transfer": f"Point transfer (Stage 0): for each camera the joint vote was unsure of, the share "
                    f"of the other cameras' triangulated moving points that land on one of its tracks, "
                    f"over its candidate offset; star = the transfer's peak, {solved} line = the joint "
                    f"vote's offset{', dashed ' + truth + ' = truth' if data.gt_offsets_s else ''}. "
                    f"{acc.capitalize()}: the two agree and the camera is used; {rej}: refused (the "
                    "reason is under each panel).",
        "three_view": f"Three-view check (Stage 0): for each estimated camera the joint vote was sure "
                      f"of, how many of the other sure cameras' triangulated moving points one of its "
                      f"tracks follows, over its candidate offset; {solved} line = the joint vote's "
                      f"offset, dotted = what it needed there"
                      f"{', dashed ' + truth + ' = truth' if data.gt_offsets_s else ''}. "
                      f"{acc.capitalize()}: passed; {rej}: refused, so the camera got no geometric track "
                      "pairs (wrong estimated cameras, or a wrong offset; the reason is under each panel).",
    }[key]
    return text + names


def available(data: ReportData) -> list[str]:
    """The figures this data supports, in display order."""
    keys = []
    if data.cameras:
        keys.append("scene3d")
    keys += ["landscapes", "pair_graph"]
    if data.transfer:
        keys.append("transfer")
    if data.three_view:
        keys.append("three_view")
    if data.videos:
        keys.append("timeline")
    if data.epipolar is not None:
        keys.append("epipolar")
    if data.mosaic is not None:
        keys.append("mosaic")
    return keys


def render_report(data: ReportData, out_dir: str | Path, overwrite: bool = True,
                  formats: tuple[str, ...] = ("png",), dpi: float = DPI,
                  size: str = "page") -> dict[str, Path]:
    """Write <key>.<format> for every available figure and format (png, pdf, svg; PNG at dpi),
    index.html and render_times.json into a fresh folder (io.atomic.atomic_dir: nothing stale
    from an earlier report, nothing half-written on an error or an interrupt). size: "column"
    (3.5 in wide) or "page" (7.1 in), the printed width the figures' 7-9 pt text is for.
    overwrite=False: refuse a non-empty out_dir (FileExistsError). Returns {key: first format's file}."""
    formats = checked_render_options(formats, dpi, size)
    out = Path(out_dir)
    with atomic_dir(out, overwrite=overwrite) as tmp:
        paths = _render_into(data, Path(tmp), tuple(formats), float(dpi), size)
    return {k: out / p.name for k, p in paths.items()}


def _render_into(data: ReportData, out: Path, formats: tuple[str, ...] = ("png",),
                 dpi: float = DPI, size: str = "page") -> dict[str, Path]:
    paths: dict[str, Path] = {}
    times: dict[str, float] = {}
    for key in available(data):
        signals.checkpoint()  # between figures
        t0 = time.perf_counter()
        p = out / f"{key}.{formats[0]}"
        if key == "scene3d":
            from .scene3d import render_scene
            render_scene(data, p, figure_size_px("scene3d", data, dpi, size), dpi, formats)
        else:
            getattr(figures, key)(data, p, dpi, formats, size)
        times[key] = round(time.perf_counter() - t0, 3)
        paths[key] = p
        log.info("wrote %s (%.2f s)", p, times[key])
    # the page shows PNG (or SVG) pictures; a PDF-only report links the files
    shown = next((f for f in ("png", "svg") if f in formats), formats[0])
    captions = {k: (paths[k].with_suffix("." + shown).name, caption(k, data)) for k in paths}
    paths["index"] = write_index(data, captions, out / "index.html")
    (out / "render_times.json").write_text(json.dumps(times, indent=1))
    return paths
