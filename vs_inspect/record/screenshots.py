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
import contextlib
import json
import math
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.recording_paths import TIMELINE_OFFSET_MS

INK_DIFF = 40  # a pixel is ink when a channel differs from the empty panel by more than this (0-255)
MIN_INK = 0.002  # a panel shows something when at least this share of its pixels is ink
CURSOR_PX = 4  # in a plot, ink columns at most this wide across most of its height are a time cursor
PLOTS = ("TimeSeries", "BarChart")  # view classes whose vertical lines may be a cursor
SCAFFOLD_APP = "vs_inspect_empty_layout"  # the scaffold recording's application id
WINDOW = (1920, 1080)  # logical points


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


def rerun_executable() -> Path | None:
    """The viewer that comes with the installed rerun-sdk (beside this Python), else on PATH."""
    here = Path(sys.executable).parent / "rerun"
    if here.is_file():
        return here
    found = shutil.which("rerun")
    return Path(found) if found else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _software_env(base: dict[str, str]) -> dict[str, str]:
    """Software rendering: Mesa's lavapipe Vulkan driver when installed, llvmpipe GL otherwise."""
    env = dict(base)
    icd = Path("/usr/share/vulkan/icd.d/lvp_icd.x86_64.json")
    if icd.is_file():
        env.setdefault("VK_ICD_FILENAMES", str(icd))
        env.setdefault("WGPU_BACKEND", "vulkan")
    else:
        env.setdefault("WGPU_BACKEND", "gl")
    env.setdefault("LIBGL_ALWAYS_SOFTWARE", "1")
    return env


@contextlib.contextmanager
def viewer(mode: str = "auto", size: tuple[int, int] = WINDOW, log_path: Path | None = None):
    """A running native viewer and a ViewerClient connected to it; both are stopped on exit.

    mode: "xvfb" (a virtual X display), "headless" (the viewer's offscreen mode) or "auto" (xvfb
    when Xvfb is on PATH). RuntimeError with the viewer's output when it does not come up.
    """
    from rerun.experimental import ViewerClient

    exe = rerun_executable()
    if exe is None:
        raise RuntimeError("no rerun viewer executable (install rerun-sdk)")
    if mode == "auto":
        mode = "xvfb" if shutil.which("Xvfb") else "headless"
    env = _software_env(os.environ)
    tmp = tempfile.TemporaryDirectory(prefix="vs-inspect-viewer-")
    env.setdefault("XDG_RUNTIME_DIR", tmp.name)
    env.setdefault("XDG_CONFIG_HOME", str(Path(tmp.name) / "config"))
    env.setdefault("XDG_DATA_HOME", str(Path(tmp.name) / "data"))
    procs: list[subprocess.Popen] = []
    log = open(log_path or Path(tmp.name) / "viewer.log", "w")
    try:
        if mode == "xvfb":
            xvfb = shutil.which("Xvfb")
            if xvfb is None:
                raise RuntimeError("Xvfb is not on PATH (apt-get install xvfb), or use mode='headless'")
            # -displayfd: Xvfb picks a free display number and writes it to the pipe
            r, w = os.pipe()
            procs.append(subprocess.Popen([xvfb, "-displayfd", str(w), "-screen", "0",
                                           f"{size[0]}x{size[1]}x24", "-nolisten", "tcp"],
                                          pass_fds=(w,), stdout=log, stderr=log, start_new_session=True))
            os.close(w)
            with os.fdopen(r) as f:
                display = f.readline().strip()
            if not display:
                raise RuntimeError("Xvfb did not start")
            env["DISPLAY"] = f":{display}"
            env.pop("WAYLAND_DISPLAY", None)
        port = _free_port()
        cmd = [str(exe), "--port", str(port), "--hide-welcome-screen", "--window-size",
               f"{size[0]}x{size[1]}", "--memory-limit", "2GB"]
        if mode == "headless":
            cmd.append("--headless")
        procs.append(subprocess.Popen(cmd, env=env, stdout=log, stderr=log, start_new_session=True))
        deadline = time.monotonic() + 30
        while True:
            try:
                client = ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy")
                client.get_state()
                break
            except Exception:  # noqa: BLE001 - not listening yet
                if procs[-1].poll() is not None or time.monotonic() > deadline:
                    log.flush()
                    text = Path(log.name).read_text(errors="replace")[-2000:]
                    raise RuntimeError(f"the rerun viewer did not come up ({mode}):\n{text}") from None
                time.sleep(0.3)
        yield client
    finally:
        for p in reversed(procs):  # only the processes started here, each by its own group
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, 15)
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, 9)
                p.wait(timeout=5)
        log.close()
        tmp.cleanup()


def _open(client, path: Path, timeout_s: float = 30.0) -> str:
    """Open an .rrd, wait until it is loaded; its store id."""
    from .viewer import wait_loaded
    return wait_loaded(client, path, timeout_s)


def _png(data: bytes) -> np.ndarray:
    import cv2
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise RuntimeError("the viewer returned no image")
    return img


def ink(panel_bgr: np.ndarray, empty_bgr: np.ndarray, plot: bool = False) -> float:
    """Share of pixels that differ (any channel by more than INK_DIFF) from the empty panel; in a
    plot (plot=True), not counting thin vertical lines across most of its height (a time cursor
    where the empty panel has none or has it elsewhere)."""
    if panel_bgr.shape != empty_bgr.shape:
        import cv2
        empty_bgr = cv2.resize(empty_bgr, (panel_bgr.shape[1], panel_bgr.shape[0]))
    mask = np.abs(panel_bgr.astype(np.int16) - empty_bgr.astype(np.int16)).max(-1) > INK_DIFF
    if plot:
        mask = _without_cursor(mask)
    return float(mask.mean())


def _without_cursor(mask: np.ndarray) -> np.ndarray:
    """mask with runs of at most CURSOR_PX columns that are ink over most of the height cleared."""
    tall = mask.mean(0) > 0.6
    out = mask.copy()
    c = 0
    while c < len(tall):
        if not tall[c]:
            c += 1
            continue
        end = c
        while end < len(tall) and tall[end]:
            end += 1
        if end - c <= CURSOR_PX:
            out[:, c:end] = False
        c = end
    return out


def _scaffold_recording(path: Path, rrd: Path, timelines) -> Path:
    """An .rrd with only what the layout of `rrd` shows before any data: the image borders `rrd`
    draws (its entities named border, copied) and its timelines over the same ranges (on an entity
    no panel shows), so that time panel, cursor and axes look the same; no data."""
    import rerun as rr

    from ..io.recording import read_recording
    from ..io.recording_paths import pair_epipolar_path, video_path
    from ..io.rrd_chunks import read_chunks
    rec_in = read_recording(rrd, with_structure=False)
    borders = [f"{video_path(v.name)}/border" for v in rec_in.videos]
    borders += [f"{pair_epipolar_path(*k.split('__', 1))}/border" for k in rec_in.meta.get("pairs", [])]
    rec = rr.RecordingStream(SCAFFOLD_APP)
    rec.save(str(path))
    chunks = read_chunks(rrd, borders) if borders else []
    if chunks:
        rec.send_chunks(chunks)
    for t in timelines:
        if t.start is None or t.end is None:
            continue
        if t.time_type == "sequence":
            col = rr.TimeColumn(t.name, sequence=[t.start, t.end])
        elif t.time_type == "duration":
            col = rr.TimeColumn(t.name, duration=np.array([t.start, t.end], dtype="timedelta64[ns]"))
        else:
            col = rr.TimeColumn(t.name, timestamp=np.array([t.start, t.end], dtype="datetime64[ns]"))
        rec.send_columns(f"zz_scaffold/{t.name}", [col], rr.Scalars.columns(scalars=[0.0, 0.0]))
    rec.log("zz_scaffold/doc", rr.TextDocument("-"), static=True)
    rec.flush()
    rec.disconnect()
    return path


def default_offsets_ms(rrd: Path, pair: tuple[str, str] | None = None) -> dict[str, int | None]:
    """The offsets take_screenshots shows by default: {"chosen": ms, "wrong": ms}
    (chosen_and_wrong_ms), or {"opened": None} when no pair has a landscape (a run that
    synchronized nothing, the one most worth a look): there is no chosen Δ, often no offset_ms
    timeline at all, and the viewer is shot as it opens."""
    from ..io.recording import read_recording
    rec = read_recording(rrd)
    if not rec.landscapes:
        return {"opened": None}
    chosen, wrong = chosen_and_wrong_ms(rec, pair)
    return {"chosen": chosen, "wrong": wrong}


def chosen_and_wrong_ms(rec, pair: tuple[str, str] | None = None) -> tuple[int, int]:
    """(chosen, wrong) of a recording with landscapes (io.recording.Recording): the chosen (or
    best) Δ in ms of the pair (default: the front pair, the layout's active tab), and a wrong Δ
    that teaches: its epipolar lines are on screen and miss the points (wrong_ms), else an offset
    a third of the search range away."""
    from .viewer import front_offset_ms, front_pair
    pair = pair or front_pair(rec)
    all_ms = np.concatenate([s.offset_ms for p in rec.landscapes.values() for s in p.values()])
    lo, hi = int(all_ms.min()), int(all_ms.max())
    chosen = front_offset_ms(rec, pair) if pair else None
    if chosen is None:
        chosen = (lo + hi) // 2
    wrong = None
    if pair is not None:
        from ..io.recorded_series import read_epipolar_sweep
        sweep = read_epipolar_sweep(rec.path, *pair)
        wrong = wrong_ms(sweep, chosen) if sweep is not None else None
    if wrong is None:
        step = max(1, (hi - lo) // 3)
        wrong = chosen + step if chosen + step <= hi else chosen - step
    return chosen, wrong


def wrong_ms(sweep, chosen_ms: int) -> int | None:
    """A wrong Δ of an epipolar sweep (io.recorded_series.EpipolarSweepSeries) worth a screenshot: the
    offset nearest the chosen one whose lines are on screen (at least half as many as at the
    chosen Δ, and 3) but miss the points (median distance at least 4 times the smallest one near
    the chosen Δ, and 5 px more); None when no logged offset is such."""
    ms, lines, med = sweep.offset_ms, sweep.lines, sweep.median_px
    if not len(ms):
        return None
    i = int(np.argmin(np.abs(ms - chosen_ms)))
    # the best the lines meet the points near the chosen Δ (the sweep's offsets are the search
    # grid's: the nearest may be half a frame off the refined Δ)
    near = med[max(0, i - 2):i + 3]
    at = np.nanmin(near) if np.isfinite(near).any() else np.nan
    if not np.isfinite(at):
        return None
    ok = (lines >= max(3, 0.5 * lines[i])) & np.isfinite(med) & (med >= max(4 * at, at + 5.0))
    ok &= np.abs(np.arange(len(ms)) - i) >= 2
    if not ok.any():
        return None
    cand = np.flatnonzero(ok)
    return int(ms[cand[np.argmin(np.abs(ms[cand] - chosen_ms))]])


def _contents(container: dict) -> list[str]:
    """A blueprint container's children ("view/<id>" or "container/<id>"): the viewer gives a
    single child as a string, not a one-element list (a recording whose run accepted no pair)."""
    contents = container.get("contents", [])
    return [contents] if isinstance(contents, str) else list(contents)


def on_screen_views(layout: dict) -> list[str]:
    """View ids (32 hex digits) that a blueprint (ViewerClient.get_blueprint) puts on screen:
    every view under the root container, but only the active tab of a Tabs container."""
    containers = {k.split("/", 2)[2]: v["ContainerBlueprint"] for k, v in layout.items()
                  if k.startswith("/container/") and "ContainerBlueprint" in v}
    inside = {c.split("/", 1)[1] for v in containers.values() for c in _contents(v)}
    roots = [cid for cid in containers if cid not in inside]
    out: list[str] = []

    def walk(item: str) -> None:
        kind, _, ident = item.partition("/")
        if kind == "view":
            out.append(ident.replace("-", ""))
            return
        c = containers.get(ident, {})
        contents = _contents(c)
        if c.get("container_kind") == "Tabs" and contents:
            contents = [c.get("active_tab") or contents[0]]
        for child in contents:
            walk(child)

    for r in roots:
        walk(f"container/{r}")
    return out


def tab_titles(layout: dict) -> list[str]:
    """The titles of the views and containers that are tabs of a Tabs container (what --tab takes)."""
    names = {k.lstrip("/"): str((v.get("ContainerBlueprint") or v.get("ViewBlueprint") or {}).get("display_name", ""))
             for k, v in layout.items() if k.startswith(("/container/", "/view/"))}
    return [names[i] for k, v in layout.items() if v.get("ContainerBlueprint", {}).get("container_kind") == "Tabs"
            for i in _contents(v["ContainerBlueprint"]) if names.get(i)]


def _title_matches(name: str, title: str, suffix: bool) -> bool:
    """A view's or container's title is `title` (a pair container's also without its ✓/✗ mark),
    or ends with it (suffix=True)."""
    names = {name, name[2:] if name[:2] in ("✓ ", "✗ ") else name}
    return any(n.endswith(title) if suffix else n == title for n in names)


def activate_tab(layout: dict, title: str, suffix: bool = False) -> bool:
    """Make the container or view titled `title` (its title as the viewer shows it; or whose title
    ends with it, suffix=True) the active tab of its Tabs container (in place). True when one is
    in front now (also when a view of that title is not in tabs at all, so always on screen);
    False if there is none such."""
    targets = [k.lstrip("/") for k, v in layout.items() if k.startswith(("/container/", "/view/"))
               and _title_matches(str((v.get("ContainerBlueprint") or v.get("ViewBlueprint") or {})
                                      .get("display_name", "")), title, suffix)]
    if not targets:
        return False
    tabs = [(k, v["ContainerBlueprint"]) for k, v in layout.items() if k.startswith("/container/")
            and v.get("ContainerBlueprint", {}).get("container_kind") == "Tabs"]
    for item in targets:
        for _, c in tabs:
            if item in _contents(c):
                c["active_tab"] = item
                return True
    inside = {i for _, c in tabs for i in _contents(c)}
    return any(t.startswith("view/") and t not in inside for t in targets)


def _locate(full: np.ndarray, tile: np.ndarray) -> tuple[int, int, int, int]:
    """(x, y, w, h) of a panel's screenshot inside the screenshot of the whole viewer."""
    import cv2
    h, w = tile.shape[:2]
    if h > full.shape[0] or w > full.shape[1]:
        raise RuntimeError(f"a panel ({w}x{h}) is larger than the viewer ({full.shape[1]}x{full.shape[0]})")
    res = cv2.matchTemplate(full, tile, cv2.TM_SQDIFF_NORMED)
    _, _, (x, y), _ = cv2.minMaxLoc(res)
    return x, y, w, h


def _paint(client, settle_s: float, min_rounds: int = 2, max_rounds: int = 6) -> None:
    """Let the viewer paint until two frames in a row look the same, after at least min_rounds
    (images and videos are decoded in the background and appear some frames later; the viewer
    paints only when asked), at most max_rounds times. A screenshot the viewer does not deliver in
    time (a new layout in software rendering on a busy machine) counts as a round."""
    prev = None
    for i in range(max_rounds):
        time.sleep(settle_s / 2)
        try:
            img = _png(client.take_screenshot(max_size=480))
        except TimeoutError:
            prev = None
            continue
        if i + 1 >= min_rounds and prev is not None and img.shape == prev.shape and \
                np.abs(img.astype(np.int16) - prev.astype(np.int16)).max() <= 8:
            return
        prev = img


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
    import re

    import cv2

    rrd, out_dir = Path(rrd), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if offsets_ms is None:
        offsets_ms = default_offsets_ms(rrd, pair)
    from ..io.recording import read_recording
    from .blueprint import pair_title
    from .viewer import open_recording
    labels = read_recording(rrd, with_structure=False).meta.get("labels") or {}
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
    shots: list[Screenshots] = []
    for label, (ms, full) in fulls.items():
        full_path = out_dir / f"{label}.png"
        cv2.imwrite(str(full_path), full)
        (out_dir / label).mkdir(exist_ok=True)
        panels = []
        for v in views:
            x, y, w, h = rects[v.view_id]
            img, base = full[y:y + h, x:x + w], blanks[label][y:y + h, x:x + w]
            safe = re.sub(r"[^A-Za-z0-9_.\-]+", "_", v.name or v.view_class)[:60]
            path = out_dir / label / f"{safe}.png"
            cv2.imwrite(str(path), img)
            panels.append(PanelShot(v.name, v.view_class, path, ink(img, base, v.view_class in PLOTS),
                                    tuple(f"{r.severity}: {r.summary}" for r in v.reports)))
        shots.append(Screenshots(label, ms, full_path, tuple(panels), opened_on, time_on_open))
        cv2.imwrite(str(out_dir / label / "empty_layout.png"), blanks[label])
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
