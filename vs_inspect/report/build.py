"""Render every figure ReportData supports into a folder, with index.html."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

from .. import signals
from ..io.atomic import atomic_dir
from . import figures
from .data import ReportData
from .html import write_index

log = logging.getLogger(__name__)

CAPTIONS = {
    "scene3d": "3D scene: camera frustums coloured per video (a moving camera with its path and "
               "frustums along it), the static reconstruction when there is one, and the moving "
               "points triangulated at the solved offsets, coloured by global time.",
    "landscapes": "Energy landscape E(Δ) of every pair: green frame = accepted, vermillion frame = "
                  "rejected (with the reason); star = best minimum, circles = other minima, solid "
                  "line = chosen Δ, purple triangle = Δ implied by the global solve, dashed black line = "
                  "true Δ when known.",
    "pair_graph": "Pair graph: videos as nodes (with their solved offsets, and their errors when "
                  "the truth is known), accepted pairs as solid blue edges labelled with Δ, rejected "
                  "pairs as dashed vermillion edges.",
    "timeline": "Timeline of all videos before sync (each on its own clock) and after sync "
                "(placed on the global time axis).",
    "epipolar": "Epipolar panel: the same frame of video a; b's matched points at t − Δ give "
                "epipolar lines in a. At the right offset the lines pass through a's points.",
    "mosaic": "Mosaic: the frame of every video nearest one global moment after sync.",
    "transfer": "Point transfer (Stage 0): for each camera the joint vote was unsure of, the share "
                "of the other cameras' triangulated moving points that land on one of its tracks, "
                "over its candidate offset; star = the transfer's peak, solid line = the joint "
                "vote's offset, dashed = truth. Green: the two agree and the camera is used; "
                "vermillion: refused (the reason above each panel).",
    "three_view": "Three-view check (Stage 0): for each estimated camera the joint vote was sure of, "
                  "how many of the other sure cameras' triangulated moving points one of its tracks "
                  "follows, over its candidate offset; solid line = the joint vote's offset, dotted = "
                  "what it needed there, dashed = truth. Green: passed; vermillion: refused, so the "
                  "camera got no geometric track pairs (wrong estimated cameras, or a wrong offset).",
}


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
                  formats: tuple[str, ...] = ("png",), dpi: float = figures.DPI) -> dict[str, Path]:
    """Write <key>.<format> for every available figure and format (png, pdf, svg; PNG at dpi),
    index.html and render_times.json into a fresh folder (io.atomic.atomic_dir: nothing stale
    from an earlier report, nothing half-written on an error or an interrupt). overwrite=False:
    refuse a non-empty out_dir (FileExistsError). Returns {key: first format's file}."""
    formats = figures.checked_render_options(formats, dpi)
    out = Path(out_dir)
    with atomic_dir(out, overwrite=overwrite) as tmp:
        paths = _render_into(data, Path(tmp), tuple(formats), float(dpi))
    return {k: out / p.name for k, p in paths.items()}


def _render_into(data: ReportData, out: Path, formats: tuple[str, ...] = ("png",),
                 dpi: float = figures.DPI) -> dict[str, Path]:
    paths: dict[str, Path] = {}
    times: dict[str, float] = {}
    for key in available(data):
        signals.checkpoint()  # between figures
        t0 = time.perf_counter()
        p = out / f"{key}.{formats[0]}"
        if key == "scene3d":
            from .scene3d import render_scene
            render_scene(data, p, figures.figure_size_px("scene3d", data, dpi), dpi, formats)
        else:
            getattr(figures, key)(data, p, dpi, formats)
        times[key] = round(time.perf_counter() - t0, 3)
        paths[key] = p
        log.info("wrote %s (%.2f s)", p, times[key])
    # the page shows PNG (or SVG) pictures; a PDF-only report links the files
    shown = next((f for f in ("png", "svg") if f in formats), formats[0])
    captions = {k: (paths[k].with_suffix("." + shown).name, CAPTIONS[k]) for k in paths}
    paths["index"] = write_index(data, captions, out / "index.html")
    (out / "render_times.json").write_text(json.dumps(times, indent=1))
    return paths
