"""The report from a run folder and from the .rrd alone: every image produced, of the expected
size, not blank, and the same images and numbers from both sources."""

from __future__ import annotations

import dataclasses
import re
from html import escape as html_escape
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.analysis.report_data import load_report_data
from vs_inspect.io.bundle import write_bundle
from vs_inspect.io.result import write_run_result
from vs_inspect.pipeline import run as run_pipeline
from vs_inspect.result_types import RunInputs
from vs_inspect.report.build import available, render_report
from vs_inspect.report.figure_layout import figure_size_px
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

REPO = Path(__file__).resolve().parents[2]
SCENE = CueSceneConfig(cameras=4, moving=1, variable_rate=1, seconds=5.0, points_per_object=15,
                       pairs_per_view_pair=150, seed=3)
EXPECTED = {"scene3d", "landscapes", "pair_graph", "timeline", "epipolar"}  # no videos: no mosaic


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A run folder (result.json + bundle/) and the .rrd written by RerunSink during the same sync."""
    from vs_inspect.record.rerun_sink import RerunSink

    root = tmp_path_factory.mktemp("report")
    scene = make_cue_scene(SCENE)
    bundle_dir = write_bundle(scene.bundle, root / "run" / "bundle")
    rrd = root / "run.rrd"
    with RerunSink(rrd, progress=False) as sink:
        result = run_pipeline(scene.bundle, sink=sink, progress=False,
                     recorded_inputs=RunInputs(bundle=str(bundle_dir)))
    write_run_result(result, root / "run" / "result.json")
    return root / "run", rrd, scene


def _pixels(path: Path) -> np.ndarray:
    import matplotlib.image as mpimg
    return mpimg.imread(path)


def _check_images(out: Path, data) -> set[str]:
    pngs = {p.stem for p in out.glob("*.png")}
    assert pngs == set(available(data))
    for key in pngs:
        img = _pixels(out / f"{key}.png")
        h, w = img.shape[:2]
        assert (w, h) == figure_size_px(key, data), key
        rgb = (img[..., :3].reshape(-1, 3) * 255).astype(np.uint32)
        packed = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
        # not blank: many colours, and a good share of pixels differ from the background
        assert len(np.unique(packed[::7])) > 50, key
        assert (packed != packed[0]).mean() > 0.01, key
    return pngs


def _numbers(html: str) -> list[str]:
    body = re.sub(r"<p class='source'>.*?</p>", "", html)
    return re.findall(r"[-+]?\d+\.?\d*", body)


@pytest.fixture(scope="module")
def reports(run, tmp_path_factory):
    """The report rendered from the run folder (library call) and from the .rrd alone (the CLI)."""
    from vs_inspect.cli import main as cli

    run_dir, rrd, _ = run
    out = tmp_path_factory.mktemp("reports")
    from_run = load_report_data(run_dir)
    render_report(from_run, out / "run")
    assert cli(["report", str(rrd), "--out", str(out / "rrd")]) == 0
    return from_run, out / "run", load_report_data(rrd), out / "rrd"


def test_report_from_run_folder(reports):
    data, out, _, _ = reports
    assert _check_images(out, data) == EXPECTED
    html = (out / "index.html").read_text()
    # the numbers behind the figures: every solved offset and every pair's decision
    for v, off in data.offsets_s.items():
        assert (f"{off:+.4f}" if off is not None else "—") in html
    for p in data.pairs:
        assert html_escape(p.reason) in html
    assert html.count("class='rej'") == sum(not p.accepted for p in data.pairs) > 0
    assert html.count("class='acc'") == sum(p.accepted for p in data.pairs) > 0
    assert "error [ms]" in html  # the truth is known
    # the epipolar panel tells the right offset from a wrong one
    e = data.epipolar
    assert e.chosen.median_sampson_px2 < 0.1 * e.wrong.median_sampson_px2
    assert len(data.trajectories) > 0


def test_report_from_rrd_alone_matches_run_folder(reports):
    from_run, run_out, from_rrd, rrd_out = reports
    assert _check_images(rrd_out, from_rrd) == _check_images(run_out, from_run) == EXPECTED
    a, b = (run_out / "index.html").read_text(), (rrd_out / "index.html").read_text()
    assert len(_numbers(a)) > 50
    assert _numbers(a) == _numbers(b)
    assert from_rrd.offsets_s == from_run.offsets_s
    assert [p.key for p in from_rrd.pairs] == [p.key for p in from_run.pairs]
    # the same drawing, byte for byte: every figure from the .rrd is the run folder's file
    for png in sorted(run_out.glob("*.png")):
        assert png.read_bytes() == (rrd_out / png.name).read_bytes(), png.name


def test_pair_choice_and_bad_input(run, tmp_path, capsys):
    from vs_inspect.cli import main as cli

    run_dir, rrd, _ = run
    data = load_report_data(rrd, pair=("cam3", "cam0"))  # either order names the stored pair
    assert (data.epipolar.a, data.epipolar.b) == ("cam0", "cam3")
    assert cli(["report", str(tmp_path / "nope"), "--out", str(tmp_path / "x")]) == 2
    assert "nope" in capsys.readouterr().err
    assert cli(["report", str(run_dir), "--out", str(tmp_path / "y"), "--pair", "cam0", "camX"]) == 2
    assert "camX" in capsys.readouterr().err
    (tmp_path / "junk.rrd").write_bytes(b"not a recording")
    assert cli(["report", str(tmp_path / "junk.rrd"), "--out", str(tmp_path / "z")]) == 2
    assert "junk.rrd" in capsys.readouterr().err


VIDEO_SCENE = CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=3.0, max_offset_s=1.0,
                             points_per_object=10, pairs_per_view_pair=120, no_match_pairs=0,
                             all_wrong_pair=False, fps_choices=(25.0,), seed=5)


def _write_videos(bundle, folder: Path) -> dict[str, str]:
    """Real H.264 files, one per camera: each frame shows the camera's track points as dots."""
    import cv2

    from vs_inspect.io.video import VideoWriter

    paths = {}
    for v in bundle.videos:
        xy = bundle.tracks[v.name].xy
        path = folder / f"{v.name}.mp4"
        with VideoWriter(path, v.width, v.height, v.fps, crf=30, preset="ultrafast") as w:
            for k in range(v.num_frames):
                img = np.full((v.height, v.width, 3), 90, np.uint8)
                cv2.putText(img, f"{v.name} frame {k}", (20, 60), cv2.FONT_HERSHEY_SIMPLEX, 1.5,
                            (255, 255, 255), 3)
                for x, y in xy[:, k][np.isfinite(xy[:, k, 0])]:
                    cv2.circle(img, (int(x), int(y)), 6, (40, 200, 255), -1)
                w.write(img)
        paths[v.name] = str(path)
    return paths


def test_report_with_videos_has_mosaic_and_real_frames(tmp_path):
    """With the video files named in result.json, the epipolar panel draws on the real frame and
    the mosaic shows one global moment across all videos; the .rrd with embedded video assets
    gives the same images."""
    from vs_inspect.record.rerun_sink import RerunSink

    scene = make_cue_scene(VIDEO_SCENE)
    videos = _write_videos(scene.bundle, tmp_path)
    bundle_dir = write_bundle(scene.bundle, tmp_path / "run" / "bundle")
    rrd = tmp_path / "run.rrd"
    with RerunSink(rrd, progress=False) as sink:
        for v in scene.bundle.videos:
            sink.video(v, videos[v.name])
        result = run_pipeline(scene.bundle, sink=sink, progress=False,
                     recorded_inputs=RunInputs(bundle=str(bundle_dir), videos=videos))
    write_run_result(result, tmp_path / "run" / "result.json")
    data = load_report_data(tmp_path / "run")
    assert data.mosaic is not None and data.epipolar.image_bgr is not None
    assert all(t.image_bgr is not None for t in data.mosaic.tiles)  # offsets within ±1 s of 3 s videos
    render_report(data, tmp_path / "out")
    assert _check_images(tmp_path / "out", data) == EXPECTED | {"mosaic"}
    # each tile is the frame nearest the moment: its local time + offset is within half a frame
    for t in data.mosaic.tiles:
        v = data.video(t.name)
        assert abs(t.frame / v.fps + data.offsets_s[t.name] - data.mosaic.time_s) <= 0.5 / v.fps + 1e-9
    from_rrd = load_report_data(rrd)
    render_report(from_rrd, tmp_path / "out_rrd")
    assert _check_images(tmp_path / "out_rrd", from_rrd) == EXPECTED | {"mosaic"}
    assert np.abs(from_rrd.epipolar.image_bgr.astype(int) - data.epipolar.image_bgr.astype(int)).mean() < 2


def test_formats_and_dpi(run, tmp_path):
    """--format png,pdf,svg writes each figure in each format; PNGs scale with --dpi."""
    from vs_inspect.cli import main as cli

    run_dir, _, _ = run
    assert cli(["report", str(run_dir), "--out", str(tmp_path / "r"), "--format", "png,pdf,svg",
                "--dpi", "150"]) == 0
    data = load_report_data(run_dir)
    for key in available(data):
        w, h = figure_size_px(key, data, 150)
        img = _pixels(tmp_path / "r" / f"{key}.png")
        assert (img.shape[1], img.shape[0]) == (w, h), key
        assert w == int(7.1 * 150)  # a page's text width (the default size) at 150 dpi
        assert abs(w - 0.75 * figure_size_px(key, data)[0]) < 1, key  # the default is 200 dpi
        assert abs(h - 0.75 * figure_size_px(key, data)[1]) < 1, key
        assert (tmp_path / "r" / f"{key}.pdf").read_bytes()[:5] == b"%PDF-", key
        assert "<svg" in (tmp_path / "r" / f"{key}.svg").read_text()[:2000], key
    assert cli(["report", str(run_dir), "--out", str(tmp_path / "x"), "--format", "png,gif"]) == 2
    assert cli(["report", str(run_dir), "--out", str(tmp_path / "y"), "--dpi", "0"]) == 2
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()
    # the library call checks the same way as the command (one check, one message)
    from vs_inspect.errors import InputError
    with pytest.raises(InputError, match="--dpi 5: must be between 10 and 1200"):
        render_report(data, tmp_path / "z", dpi=5)
    with pytest.raises(InputError, match="unknown format"):
        render_report(data, tmp_path / "z", formats=("png", "tiff"))
    assert not (tmp_path / "z").exists()


def test_readable_numbers_and_round_ticks():
    from vs_inspect.report.figure_style import fmt_error, fmt_px2
    from vs_inspect.report.scene3d import nice_ticks

    assert fmt_px2(3.77e-06) == "< 0.001"
    assert fmt_px2(0.00377) == "0.0038"
    assert fmt_px2(10.7) == "11" and fmt_px2(1893.0) == "1900" and fmt_px2(2.345) == "2.3"
    assert fmt_px2(float("nan")) == "—"
    assert fmt_error(13.46, 0.673) == "13.5 ms (0.67 frames)"
    lo, hi, n, dec = nice_ticks(-1.37, 7.93)
    assert (lo, hi, n, dec) == (-2.0, 8.0, 6, 0)
    lo, hi, n, dec = nice_ticks(0.12, 0.83)
    assert lo == 0.0 and hi == pytest.approx(1.0) and n == 6 and dec == 1


def test_rejected_pair_panel_and_demo_folder_layout(tmp_path):
    """A rejected pair's epipolar panel is marked rejected (not "chosen"); a folder laid out as
    `vs-inspect demo` writes it (result.json naming the rendered scene, its true bundle in
    OUT/scene/bundle) finds its bundle: all five figures, not two."""
    from vs_inspect.report.html import write_index

    scene = make_cue_scene(SCENE)
    out = tmp_path / "demo"
    write_bundle(scene.bundle, out / "scene" / "bundle")
    result = run_pipeline(scene.bundle, progress=False,
                          recorded_inputs=RunInputs(scene=str(out / "scene"), cues="true cue bundle"))
    write_run_result(result, out / "result.json")
    data = load_report_data(out)
    assert set(available(data)) == EXPECTED
    rejected = [p for p in data.pairs if not p.accepted and p.chosen_offset_s is not None]
    assert rejected, "the scene has a rejected pair with a minimum"
    r = load_report_data(out, pair=(rejected[0].a, rejected[0].b))
    assert r.epipolar is not None and r.epipolar.accepted is False
    html = write_index(r, {}, tmp_path / "i.html").read_text()
    assert "best of a rejected pair" in html and "(chosen)" not in html
    # a null's status: its few words, and the whole reason folded beneath
    why = "no reconstruction: too few matches (static background); from the moving points: 2 track pairs"
    v = r.names[-1]
    nulled = dataclasses.replace(r, offsets_s={**r.offsets_s, v: None}, unresolved={v: why},
                                 unresolved_headline={v: "no reconstruction: too few matches"})
    html = write_index(nulled, {}, tmp_path / "n.html").read_text()
    assert ("unresolved: no reconstruction: too few matches<details><summary>in full</summary>"
            + html_escape(why) + "</details>") in html
    ok = load_report_data(out)
    assert ok.epipolar.accepted is True


def test_point_transfer_checks_get_a_figure_with_the_truth(run, tmp_path):
    """A run whose Stage 0 checked a camera by point transfer (result.json's
    cues.geometric_joint.transfer) gets transfer.png: one panel per camera, truth from --gt."""
    import json
    import shutil

    run_dir, _, scene = run
    folder = tmp_path / "run"
    shutil.copytree(run_dir, folder)
    d = json.loads((folder / "result.json").read_text())
    offsets = np.round(np.arange(-2.0, 2.0, 0.02), 4)
    share = np.round(0.02 + 0.2 * np.exp(-((offsets - 0.4) / 0.05) ** 2), 4)
    check = {"joint_offset_s": 0.42, "transfer_offset_s": 0.4, "z": 9.0, "trajectories": 80,
             "supporters": 12, "matches": 12, "confirmed": True, "reason": "agree: confirmed",
             "offsets_s": offsets.tolist(), "share": share.tolist()}
    d["cues"] = {"camera_source": "calibration", "registered_cameras": 4, "tracks": 0, "track_pairs": 0,
                 "videos": {}, "pairs": {}, "dropped": {},
                 "geometric_joint": {"origin": "cam0", "offsets_s": {"cam0": 0.0, "cam1": 0.42},
                                     "transfer": {"cam1": check}}}
    (folder / "result.json").write_text(json.dumps(d))
    data = load_report_data(folder)
    assert len(data.transfer) == 1
    t = data.transfer[0]
    gt = scene.bundle.gt_offsets_s
    assert t.camera == "cam1" and t.confirmed and t.transfer_offset_s == 0.4
    assert t.true_offset_s == pytest.approx(gt["cam1"] - gt["cam0"])
    assert np.allclose(t.share, share)
    render_report(data, tmp_path / "report")
    assert "transfer" in _check_images(tmp_path / "report", data)
    assert "transfer.png" in (tmp_path / "report" / "index.html").read_text()


def test_three_view_checks_get_their_figure(run, tmp_path):
    """A run whose Stage 0 checked estimated sure cameras in three views (result.json
    cues.geometric_joint.three_view) gets three_view.png: one panel per camera, the bar each
    needed, truth from --gt; a run without them does not."""
    import json
    import shutil

    run_dir, _, scene = run
    folder = tmp_path / "run"
    shutil.copytree(run_dir, folder)
    assert "three_view" not in available(load_report_data(folder))
    d = json.loads((folder / "result.json").read_text())
    offsets = np.round(np.arange(-2.0, 2.0, 0.02), 4)
    followed = np.where(np.abs(offsets - 0.4) < 0.05, 12, 1)
    checks = {cam: {"joint_offset_s": joint, "trajectories": 40, "supporters": sup, "best_supporters": 12,
                    "best_offset_s": 0.4, "needed": 4.0, "passed": sup >= 4, "reason": why,
                    "offsets_s": offsets.tolist(), "supporters_by_offset": followed.tolist()}
              for cam, joint, sup, why in (("cam1", 0.42, 12, "agrees in three views"),
                                           ("cam2", -1.0, 1, "disagrees in three views"))}
    d["cues"] = {"camera_source": "estimated", "registered_cameras": 4, "tracks": 0, "track_pairs": 0,
                 "videos": {}, "pairs": {}, "dropped": {},
                 "geometric_joint": {"origin": "cam0", "offsets_s": {"cam0": 0.0, "cam1": 0.42, "cam2": -1.0},
                                     "three_view": checks}}
    (folder / "result.json").write_text(json.dumps(d))
    data = load_report_data(folder)
    assert [(t.camera, t.passed) for t in data.three_view] == [("cam1", True), ("cam2", False)]
    gt = scene.bundle.gt_offsets_s
    assert data.three_view[1].true_offset_s == pytest.approx(gt["cam2"] - gt["cam0"])
    assert np.array_equal(data.three_view[0].supporters, followed) and data.three_view[0].needed == 4.0
    render_report(data, tmp_path / "report")
    assert "three_view" in _check_images(tmp_path / "report", data)
    assert "three_view.png" in (tmp_path / "report" / "index.html").read_text()


def test_a_pair_checked_without_its_unchecked_track_pairs_shows_that_landscape(run, tmp_path):
    """The landscape panel of a pair whose unchecked track pairs were checked draws the
    appearance-matched pairs' own energy (dashed, over the pair's energy range) and its minimum;
    read from result.json like the rest of the panel."""
    import dataclasses

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vs_inspect.io.result import read_run_result
    from vs_inspect.report.curve_panels import _landscape_axes
    res = read_run_result(run[0])
    first = res.pairs[0]
    confirm = np.linspace(5.0, 50.0, len(first.offsets_s))
    res = dataclasses.replace(res, pairs=(dataclasses.replace(first, confirm_energy=confirm,
                                                              confirm_offset_s=float(first.offsets_s[0])),)
                              + tuple(res.pairs[1:]))
    write_run_result(res, tmp_path / "result.json")
    from vs_inspect.analysis.report_data import pair_views
    views = pair_views(read_run_result(tmp_path), None)
    assert views[0].confirm_energy is not None and views[1].confirm_energy is None
    fig, ax = plt.subplots()
    _landscape_axes(ax, views[0])
    dashed = [ln for ln in ax.get_lines() if ln.get_label() == "appearance pairs alone (rescaled)"]
    assert len(dashed) == 1
    y = dashed[0].get_ydata()
    full = views[0].energy[np.isfinite(views[0].energy)]
    assert np.isclose(np.nanmin(y), full.min()) and np.isclose(np.nanmax(y), full.max())
    assert any(np.allclose(ln.get_xdata(), first.offsets_s[0]) for ln in ax.get_lines() if ln.get_linestyle() == ":")
    plt.close(fig)


@pytest.mark.parametrize("refitted", [False, True])
def test_a_sighting_pair_says_what_its_curve_is(tmp_path, refitted):
    """A pair timed by worn-camera sightings draws 1 − the share of heads, not an epipolar energy:
    its panel says so, read back from result.json, and says when Δ was refitted off the counted
    peak (sync/sightings.refine_peak's note)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vs_inspect.analysis.report_data import pair_views
    from vs_inspect.io.result import read_run_result
    from vs_inspect.report.curve_panels import _landscape_axes
    from vs_inspect.sync.sightings import RefinedPeak
    from vs_inspect.result_types import PairDecision, PairLandscape, RunResult

    offsets = np.arange(-10, 11) * 0.1
    energy = 1.0 - np.exp(-((offsets - 0.3) / 0.15) ** 2)
    land = PairLandscape("a", "b", offsets, energy, np.full(21, 40), np.array([13]), 0.3, 0.0, 0.1, 0,
                         PairDecision(True, "sightings of a camera's carrier: 20 heads ..." + (
                             f"; {RefinedPeak(0.28, True, {'a': np.array([3.0, 2.0])}, 2.0, 2.0).note()}"
                             if refitted else ""), 0.9, 0.1, 2, 1, False),
                         residual="sighting")
    run = RunResult("a", {"a": 0.0, "b": 0.3}, {"a": 0.0, "b": 0.1}, {}, (land,), "irls", (("a", "b"),), (), {})
    write_run_result(run, tmp_path / "result.json")
    (view,) = pair_views(read_run_result(tmp_path), None)
    assert view.residual == "sighting" and view.accepted
    fig, ax = plt.subplots()
    _landscape_axes(ax, view)
    texts = [t.get_text().replace("\n", " ") for t in ax.texts]
    assert any("worn-camera sightings" in t for t in texts)
    assert any("refitted with a head-to-camera shift" in t for t in texts) == refitted
    plt.close(fig)
