"""Figures made for print: a paper's column (3.5 in) or page (7.1 in) wide, text of 7 pt or more
at that size, nothing cut at an edge or run into another label, also with long real file names;
PDFs with TrueType (Type 42) fonts and no Type 3; SVGs with their text as <text>; the HTML page in
the figures' colours and words."""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from vs_inspect.analysis.report_data import build_report_data  # noqa: E402
from vs_inspect.pipeline import run as run_pipeline  # noqa: E402
from vs_inspect.report import curve_panels, figures, frame_panels, sync_overview  # noqa: E402
from vs_inspect.report.figure_layout import figure_size_in  # noqa: E402
from vs_inspect.report.figure_style import DPI, FONT_PT, WIDTHS_IN  # noqa: E402
from vs_inspect.report.build import available, render_report  # noqa: E402
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene  # noqa: E402
from vs_inspect.types import CueBundle  # noqa: E402

SCENE = CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=4.0, points_per_object=10,
                       pairs_per_view_pair=100, no_match_pairs=0, all_wrong_pair=True, seed=7)
LONG = {"cam0": "blenderbox_cam06_13_282_0", "cam1": "blenderbox_cam10_15_284_1",
        "cam2": "blenderbox_cam13_12_281_2"}


def _renamed(bundle: CueBundle, names: dict[str, str]) -> CueBundle:
    """The bundle with its videos called by other names (everything keyed by name follows)."""
    n = names.get
    return dataclasses.replace(
        bundle, videos=tuple(dataclasses.replace(v, name=n(v.name, v.name)) for v in bundle.videos),
        cameras={n(k, k): c for k, c in bundle.cameras.items()},
        tracks={n(k, k): t for k, t in bundle.tracks.items()},
        pairs={(n(a, a), n(b, b)): p for (a, b), p in bundle.pairs.items()},
        gt_offsets_s={n(k, k): g for k, g in (bundle.gt_offsets_s or {}).items()} or None)


@pytest.fixture(scope="module")
def long_names():
    """ReportData of a run whose videos have long real file names (one pair planted wrong)."""
    from vs_inspect.report.data import ThreeViewView, TransferView
    bundle = _renamed(make_cue_scene(SCENE).bundle, LONG)
    result = run_pipeline(bundle, progress=False)
    data = build_report_data(result, bundle, source="test")
    # Stage 0's checks of each camera, as a video run's result.json keeps them
    offsets = np.round(np.arange(-26.0, 26.0, 0.05), 3)
    peak = np.exp(-(offsets / 0.3) ** 2)
    a, b, c = LONG.values()
    three = tuple(ThreeViewView(cam, offsets, 100 * peak + 20, a, 0.25 * i, 31.67, None, True,
                                "93 of the 105 trajectories the other sure cameras triangulate are followed "
                                "by a track of it at its joint offset: agrees in three views")
                  for i, cam in enumerate((a, b, c)))
    transfer = (TransferView(c, offsets, 0.2 * peak, a, -0.05, -0.06, None, False,
                             "point transfer puts it at -0.060 s (112 trajectories, z 4.7), the joint vote "
                             "at -0.050 s: its peak is not clear (z < 5)"),)
    return dataclasses.replace(data, three_view=three, transfer=transfer)


def _captured(monkeypatch):
    """The figures the report draws, kept open instead of written (figure_layout._save, as each
    drawing module holds it)."""
    kept = {}

    def keep(fig, path, dpi=DPI, formats=("png",)):
        kept[Path(path).stem] = fig
        return Path(path)
    for module in (curve_panels, sync_overview, frame_panels):
        monkeypatch.setattr(module, "_save", keep)
    return kept


def _drawn_texts(fig) -> list:
    """The texts a figure draws: its own, each shown axes' titles, labels, texts, legend and the
    tick labels inside its view (matplotlib keeps labels of ticks it does not draw)."""
    out = list(fig.texts) + [t for t in (fig._suptitle, fig._supxlabel, fig._supylabel) if t is not None]
    for leg in fig.legends:
        out += leg.get_texts()
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison and not ax.texts:
            continue
        out += [ax.title, ax._left_title, ax._right_title] + list(ax.texts)
        if ax.axison:
            out += [ax.xaxis.label, ax.yaxis.label]
            for axis in (ax.xaxis, ax.yaxis):
                out += [tk.label1 for tk in axis._update_ticks() if tk.label1.get_visible()]
        if ax.get_legend() is not None:
            out += ax.get_legend().get_texts()
    unique = {id(t): t for t in out}
    return [t for t in unique.values() if t.get_visible() and t.get_text().strip()]


def _check_text(fig, key: str) -> None:
    """Every text at least 7 pt, inside the figure, and not over another text."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    W, H = fig.bbox.width, fig.bbox.height
    boxes = []
    for t in _drawn_texts(fig):
        assert t.get_fontsize() >= 7.0, (key, t.get_text(), t.get_fontsize())
        bb = t.get_window_extent(r)
        assert bb.x0 >= -1 and bb.y0 >= -1 and bb.x1 <= W + 1 and bb.y1 <= H + 1, (key, t.get_text(), bb, W, H)
        boxes.append((t.get_text(), bb))
    for i, (t1, b1) in enumerate(boxes):
        for t2, b2 in boxes[i + 1:]:
            inter = max(0.0, min(b1.x1, b2.x1) - max(b1.x0, b2.x0)) * max(0.0, min(b1.y1, b2.y1) - max(b1.y0, b2.y0))
            assert inter <= 0.05 * min(b1.width * b1.height, b2.width * b2.height) + 1, (key, t1, t2)


@pytest.mark.parametrize("size", ["column", "page"])
def test_figures_fit_their_printed_width_with_long_names(long_names, monkeypatch, tmp_path, size):
    data = long_names
    assert data.labels == {v: f"cam{v.split('cam')[1][:2]}" for v in LONG.values()}
    kept = _captured(monkeypatch)
    for key in available(data):
        if key == "scene3d":
            continue  # a picture with matplotlib text: checked in test_scene_and_fonts below
        getattr(figures, key)(data, tmp_path / f"{key}.png", DPI, ("png",), size)
    assert set(kept) == set(available(data)) - {"scene3d"}
    assert {"three_view", "transfer", "epipolar", "pair_graph"} <= set(kept)
    for key, fig in kept.items():
        w, h = fig.get_size_inches()
        assert w == pytest.approx(WIDTHS_IN[size]), key
        assert (w, h) == pytest.approx(figure_size_in(key, data, size)), key
        _check_text(fig, key)
        text = " ".join(t.get_text() for t in fig.findobj(matplotlib.text.Text))
        # drawn by short names, the full names once, under the figure
        assert "cam06" in text and text.count("blenderbox_cam06_13_282_0") == 1, key
        matplotlib.pyplot.close(fig)


def test_pair_graph_labels_fit_inside_their_node():
    """A node is as wide as its bold label, so the label sits on the node's own colour (a label
    wider than its node would run onto the white page, in white)."""
    import matplotlib.pyplot as plt
    fig = plt.figure(dpi=72)
    r = fig.canvas.get_renderer()
    for label in ("cam0", "cam06", "head_right", "blenderbox_cam06_13_282_0"):
        t = fig.text(0, 0, label, fontsize=FONT_PT, fontweight="bold")
        width_pt = t.get_window_extent(r).width  # 72 dpi: px are points
        assert width_pt <= sync_overview._node_diameter_pt(label) - 4, label
    plt.close(fig)


def test_landscape_notes_leave_the_minima_uncovered(long_names, monkeypatch, tmp_path):
    """What a landscape panel says (Δ, error, a rejected pair's reason) is under the plot, not on
    it: no marker of a minimum is behind a text."""
    kept = _captured(monkeypatch)
    figures.landscapes(long_names, tmp_path / "l.png", size="page")
    fig = kept["l"]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    for ax in fig.axes:
        marks = [c for c in ax.collections if len(c.get_offsets())]
        for t in ax.texts:
            bb = t.get_window_extent(r)
            for c in marks:
                xy = ax.transData.transform(np.asarray(c.get_offsets()))
                inside = (xy[:, 0] >= bb.x0) & (xy[:, 0] <= bb.x1) & (xy[:, 1] >= bb.y0) & (xy[:, 1] <= bb.y1)
                assert not inside.any(), t.get_text()
            assert bb.y1 <= ax.get_window_extent(r).y0 + 1, t.get_text()  # below the axes
    matplotlib.pyplot.close(fig)


def test_scene_and_fonts_for_print(long_names, tmp_path):
    """Every PDF embeds TrueType fonts (Type 42), none Type 3; every SVG keeps its text as <text>;
    a page-size figure is 7.1 in wide in both; the 3D scene's title and colour bar are text too."""
    paths = render_report(long_names, tmp_path / "r", formats=("pdf", "svg"), size="page")
    for key in available(long_names):
        pdf = (tmp_path / "r" / f"{key}.pdf").read_bytes()
        assert b"/Type3" not in pdf and b"/FontType 3" not in pdf, key
        assert b"/FontFile2" in pdf and b"/CIDFontType2" in pdf, key  # embedded TrueType
        assert re.search(rb"/MediaBox \[ *0 0 511\.2", pdf), key  # 7.1 in = 511.2 pt wide
        svg = (tmp_path / "r" / f"{key}.svg").read_text()
        assert "<text" in svg and 'width="511.2pt"' in svg, key
        sizes = [float(x) for x in re.findall(r"font-size:\s*([\d.]+)px", svg)]
        sizes += [float(x) for x in re.findall(r"font:[^;\"]*?([\d.]+)px", svg)]
        assert sizes and min(sizes) >= 7.0, (key, sorted(set(sizes))[:3])
        if shutil.which("pdffonts"):
            out = subprocess.run(["pdffonts", str(tmp_path / "r" / f"{key}.pdf")], capture_output=True,
                                 text=True, check=True).stdout
            assert "Type 3" not in out and "TrueType" in out, (key, out)
    assert "cam06" in (tmp_path / "r" / "scene3d.svg").read_text()
    assert paths["index"].is_file()


def test_html_speaks_in_the_figures_colours(long_names, tmp_path):
    """index.html colours verdicts as the figures do, its captions name the marks the figures
    draw, the epipolar check is in px, and the short names are told."""
    from vs_inspect import palette
    render_report(long_names, tmp_path / "r")
    html = (tmp_path / "r" / "index.html").read_text()
    assert palette.hex_of(palette.ACCEPTED) in html and palette.hex_of(palette.REJECTED) in html
    assert "#0072B2" not in html and "blue edges" not in html
    assert "solid green edges" in html and "dashed vermillion edges" in html
    assert "[px]</th>" in html and "px²" not in html
    assert "<th>in the figures</th>" in html and "<td class='l'>cam06</td>" in html


def test_static_points_of_a_recording_are_drawn_not_denied(tmp_path):
    """A recording that holds the static reconstruction (world/points) gets it in its 3D scene;
    no note says there is none."""
    from vs_inspect.analysis.report_data import report_data_from_recording
    from vs_inspect.record.rerun_sink import RerunSink
    from vs_inspect.report.scene3d import _title

    scene = make_cue_scene(SCENE)
    rng = np.random.default_rng(1)
    points = rng.normal(size=(211, 3))
    with RerunSink(tmp_path / "run.rrd", progress=False) as sink:
        sink.cameras(scene.bundle.cameras, points, np.full((211, 3), 120, np.uint8))
        run_pipeline(scene.bundle, sink=sink, progress=False)
    data = report_data_from_recording(tmp_path / "run.rrd")
    assert data.static_points is not None and len(data.static_points) == 211
    assert np.allclose(data.static_points, points, atol=1e-5)
    assert not any("static reconstruction" in n for n in data.notes)
    assert "211 static points" in _title(data)
