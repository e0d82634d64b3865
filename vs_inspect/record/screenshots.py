"""Screenshots of a recording in the real rerun viewer, and a check that every panel shows something.

The viewer is the native one from rerun-sdk (`rerun` beside the Python executable), rendered in
software (Mesa lavapipe through Vulkan): under Xvfb when it is on PATH, else in the viewer's own
headless mode. rerun.experimental.ViewerClient opens the recording as `vs-inspect view` does (the
cursor at the front pair's Δ, record/viewer.py), moves the time cursor on the `offset_ms`
timeline and takes a screenshot of the whole viewer and of each visible panel.

A panel counts as showing something when its pixels differ from the same panel of the same
layout over a recording that holds only the layout's scaffolding: the same timelines over the
same ranges with the cursor at the same offset, and the image borders the recording draws, but
no data. So a border, the time cursor, axes, grids and titles never count as content (the layout
is copied with get_blueprint/set_blueprint, so panel sizes and titles are identical); in plots,
a thin line across the whole height (a time cursor) is not content either.

    python -m vs_inspect.record.screenshots RUN.rrd --out shots/
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.recording_paths import TIMELINE_OFFSET_MS
from .layout_tabs import activate_tab, on_screen_views, tab_titles
from .native_viewer import _open, _paint, _png, viewer
from .panel_ink import MIN_INK, PLOTS, _locate, _scaffold_recording, ink
from .screenshot_offsets import default_offsets_ms


@dataclass(frozen=True)
class PanelShot:
    name: str  # the panel's title
    view_class: str  # rerun's view class, e.g. "TimeSeries"
    path: Path  # PNG of the panel
    ink: float  # share of its pixels that differ from the same panel over an empty recording
    reports: tuple[str, ...]  # warnings and errors the viewer reported for the panel

    @property
    def empty(self) -> bool:
        return self.ink < MIN_INK


@dataclass(frozen=True)
class Screenshots:
    label: str  # "chosen" or "wrong"
    offset_ms: int | None  # where the time cursor was, on the offset_ms timeline (None: as opened)
    full: Path  # PNG of the whole viewer
    panels: tuple[PanelShot, ...]  # every panel on screen
    timeline_on_open: str | None  # the timeline the viewer showed when the recording opened
    time_on_open: int | None = None  # where its cursor was then (record/viewer.open_recording's)

    @property
    def empty_panels(self) -> list[str]:
        return [p.name for p in self.panels if p.empty]


def take_screenshots(rrd: str | Path, out_dir: str | Path, offsets_ms: dict[str, int | None] | None = None,
                     mode: str = "auto", settle_s: float = 1.0,
                     pair: tuple[str, str] | None = None, tabs: tuple[str, ...] = ()) -> list[Screenshots]:
    """Open rrd in the native viewer (as `vs-inspect view`: at the front pair's Δ), take a
    screenshot of the viewer with the time cursor at each offset (label -> ms on the offset_ms
    timeline, None: where it opened; default: default_offsets_ms), cut out every panel on screen,
    and measure each panel's ink against the same layout over the recording's scaffolding alone
    (_scaffold_recording). PNGs go to out_dir as <label>.png and <label>/<panel>.png (and the
    scaffolding's as <label>/empty_layout.png).
    pair: (a, b) whose container is brought to the front (default: the layout's first, a failed
    pair when there is one). tabs: titles of views or containers brought to the front of their tabs
    (e.g. "point transfer (Stage 0: a camera's offset)").

    Panels are located once (a screenshot of each panel, found in the whole viewer's), then cut
    from one screenshot per offset: a screenshot costs about a second in software rendering.
    """
    rrd, out_dir = Path(rrd), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if offsets_ms is None:
        offsets_ms = default_offsets_ms(rrd, pair)
    from ..io.recording import read_recording
    labels = read_recording(rrd, with_structure=False).meta.get("labels") or {}
    capture = _capture(rrd, out_dir, offsets_ms, mode, settle_s, pair, tabs, labels)
    return _write_shots(out_dir, capture)


@dataclass(frozen=True)
class _Capture:
    """What one viewer session took: per label the time cursor's ms and the whole viewer's
    screenshot, the same over the scaffolding alone, the panels on screen and where each is."""

    fulls: dict[str, tuple[int | None, np.ndarray]]  # label -> (ms, (H,W,3) BGR of the viewer)
    blanks: dict[str, np.ndarray]  # label -> (H,W,3) BGR of the same layout over the scaffolding
    views: list  # the visible views on screen, as ViewerClient.get_state() gives them
    rects: dict[str, tuple[int, int, int, int]]  # view id -> (x, y, w, h) px in the screenshots
    timeline_on_open: str | None
    time_on_open: int | None


def _capture(rrd: Path, out_dir: Path, offsets_ms: dict[str, int | None], mode: str, settle_s: float,
             pair: tuple[str, str] | None, tabs: tuple[str, ...], labels: dict) -> _Capture:
    """Screenshots of rrd at each offset and of its scaffolding, in one viewer session."""
    from .viewer import open_recording
    fulls: dict[str, tuple[int, np.ndarray]] = {}
    blanks: dict[str, np.ndarray] = {}
    with tempfile.TemporaryDirectory(prefix="vs-inspect-shots-") as tmp, \
            viewer(mode, log_path=out_dir / "viewer.log") as client:
        # as `vs-inspect view` opens it: at the front pair's Δ
        store, _ = open_recording(client, rrd, pair if pair is not None else None)
        # blueprint applied, panels laid out, the static images decoded (once: they are cached)
        _paint(client, 2 * settle_s, min_rounds=4)
        state = next((r for r in client.get_state().recordings if r.store_id == store), None)
        opened_on = state.current_timeline if state is not None else None
        time_on_open = state.current_time if state is not None else None
        timelines = list(state.timelines) if state is not None else []
        if (state is not None and any(ms is not None for ms in offsets_ms.values())
                and not any(t.name == TIMELINE_OFFSET_MS and t.start is not None for t in state.timelines)):
            raise ValueError(f"{rrd} has no {TIMELINE_OFFSET_MS} timeline (no pair offset was searched): "
                             "no offset to move to")
        layout = client.get_blueprint(store_id=store).blueprint
        _bring_to_front(client, store, layout, pair, tabs, labels, settle_s)
        shown = set(on_screen_views(layout))
        views = [v for v in client.get_state().views if v.visible and v.view_id.replace("-", "") in shown]
        rects: dict[str, tuple[int, int, int, int]] = {}
        for label, ms in offsets_ms.items():
            if ms is not None:
                client.set_time(TIMELINE_OFFSET_MS, sequence=int(ms), play_state="paused", recording=store)
            _paint(client, settle_s)
            full = _png(client.take_screenshot())
            if not rects:
                rects = {v.view_id: _locate(full, _png(client.take_screenshot(v.view_id))) for v in views}
            fulls[label] = (None if ms is None else int(ms), full)
        # the same layout over the scaffolding alone, with the cursor where each screenshot had it
        empty = _open(client, _scaffold_recording(Path(tmp) / "empty.rrd", rrd, timelines))
        client.set_blueprint(layout, store_id=empty)
        for label, ms in offsets_ms.items():
            if ms is not None:
                client.set_time(TIMELINE_OFFSET_MS, sequence=int(ms), play_state="paused", recording=empty)
            _paint(client, settle_s)
            blanks[label] = _png(client.take_screenshot())
    return _Capture(fulls, blanks, views, rects, opened_on, time_on_open)


def _bring_to_front(client, store: str, layout: dict, pair: tuple[str, str] | None, tabs: tuple[str, ...],
                    labels: dict, settle_s: float) -> None:
    """Bring the pair's container and the titled tabs to the front of the recording's layout
    (ValueError when the layout has none such) and let the viewer paint it."""
    from .blueprint import pair_title
    if pair is not None:
        if not (activate_tab(layout, pair_title(*pair, labels), suffix=True)
                or activate_tab(layout, f"{pair[0]}→{pair[1]}", suffix=True)):
            raise ValueError(f"no container of pair {pair[0]}→{pair[1]} in the layout")
    for title in tabs:
        if not activate_tab(layout, title):
            raise ValueError(f"no tab titled {title!r} in the layout (titles: {', '.join(tab_titles(layout))})")
    if pair is not None or tabs:
        client.set_blueprint(layout, store_id=store)
        _paint(client, settle_s)


def _write_shots(out_dir: Path, capture: _Capture) -> list[Screenshots]:
    """Each label's screenshot, its panels cut out and their ink measured, written to out_dir."""
    import re

    import cv2

    shots: list[Screenshots] = []
    for label, (ms, full) in capture.fulls.items():
        full_path = out_dir / f"{label}.png"
        cv2.imwrite(str(full_path), full)
        (out_dir / label).mkdir(exist_ok=True)
        panels = []
        for v in capture.views:
            x, y, w, h = capture.rects[v.view_id]
            img, base = full[y:y + h, x:x + w], capture.blanks[label][y:y + h, x:x + w]
            safe = re.sub(r"[^A-Za-z0-9_.\-]+", "_", v.name or v.view_class)[:60]
            path = out_dir / label / f"{safe}.png"
            cv2.imwrite(str(path), img)
            panels.append(PanelShot(v.name, v.view_class, path, ink(img, base, v.view_class in PLOTS),
                                    tuple(f"{r.severity}: {r.summary}" for r in v.reports)))
        shots.append(Screenshots(label, ms, full_path, tuple(panels), capture.timeline_on_open,
                                 capture.time_on_open))
        cv2.imwrite(str(out_dir / label / "empty_layout.png"), capture.blanks[label])
    return shots


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m vs_inspect.record.screenshots",
                                description="Screenshots of a recording in the native rerun viewer "
                                            "(software rendering) at the chosen offset and at a wrong "
                                            "one; exit 1 when a visible panel is empty.")
    p.add_argument("rrd", type=Path)
    p.add_argument("--out", type=Path, required=True, help="folder for the PNGs")
    p.add_argument("--mode", choices=("auto", "xvfb", "headless"), default="auto",
                   help="virtual X display (Xvfb) or the viewer's headless mode (auto: Xvfb if on PATH)")
    p.add_argument("--at", type=int, action="append", metavar="MS",
                   help="offsets (ms on offset_ms) instead of the chosen and a wrong one; repeatable")
    p.add_argument("--pair", nargs=2, metavar=("A", "B"),
                   help="bring this pair's container to the front (default: the first, failed first)")
    p.add_argument("--tab", action="append", default=[], metavar="TITLE",
                   help="bring the view or container with this title (as its tab shows it, e.g. "
                        "\"pairs (failed first)\" or \"IRLS solve\") to the front of its tabs; repeatable")
    args = p.parse_args(argv)
    if shutil.which("ffmpeg") is None:
        print("note: ffmpeg is not on PATH: the native viewer shows no frame of embedded H.264 videos",
              file=sys.stderr)
    offsets = {f"at_{ms}ms": ms for ms in args.at} if args.at else None
    try:
        shots = take_screenshots(args.rrd, args.out, offsets, mode=args.mode,
                                 pair=tuple(args.pair) if args.pair else None, tabs=tuple(args.tab))
    except (ValueError, InputError) as exc:  # an unknown pair or tab, no offsets, not a recording
        print(f"error: {exc}", file=sys.stderr)
        return 2
    bad = 0
    for s in shots:
        print(f"{s.label} (offset_ms = {'as opened' if s.offset_ms is None else s.offset_ms}): {s.full}")
        for ps in s.panels:
            flag = "EMPTY" if ps.empty else "ok"
            bad += ps.empty
            print(f"  {flag:5s} ink {100 * ps.ink:5.1f}%  {ps.view_class:12s} {ps.name}"
                  + (f"  [{'; '.join(ps.reports)}]" if ps.reports else ""))
    print(json.dumps({"empty_panels": bad}))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
