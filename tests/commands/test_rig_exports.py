"""On a rendered rig with known offsets (real H.264 videos, one at a variable frame rate):
synchronizing with videos 8 columns narrower than their calibration gives the same offsets as
with the exact sizes; the run folder holds the cameras it used; export --offsets and --trimmed
write what other tools read, and the trimmed videos (decoded back) begin at the same moment
within half a frame of the slower video by the run's offsets (in true time, plus those offsets' errors)."""

from __future__ import annotations

import csv
import json
import logging

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.io.calib import read_named
from vs_inspect.io.video import VideoWriter, iter_frames, open_video
from vs_inspect.synth.world import SceneConfig

RIG = SceneConfig(cameras=4, moving=0, seconds=4.0, width=416, height=240, fps=None,
                  variable_rate=1, max_offset_s=0.5, arc_deg=150.0, seed=1)
CROP_PX = 8  # columns cut at the right of two videos (a 1088 -> 1080 style encoder crop)
CROPPED = ("cam1", "cam3")  # cam1 is the variable-rate camera
MAX_ERROR_FRAMES = 0.5  # each video's offset error, in its own frames
NOT_WORSE_FRAMES = 0.25  # the cropped run's error may exceed the exact-size run's by this, per video


def _errors_frames(run_dir, truth) -> dict[str, float]:
    res = json.loads((run_dir / "result.json").read_text())
    out = {}
    for v, off in res["offsets_s"].items():
        info = open_video(run_dir.parent / "scene" / f"{v}.mp4").info
        assert off is not None, (v, res["unresolved"].get(v))
        out[v] = abs(off - truth[v]) / info.frame_interval_s
    return out


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    from vs_inspect.synth.videos import render_scene
    from vs_inspect.synth.world import make_scene
    root = tmp_path_factory.mktemp("rig")
    scene = root / "scene"
    render_scene(make_scene(RIG), scene, progress=False)
    truth = json.loads((scene / "gt.json").read_text())["offsets_s"]
    videos = [str(scene / f"cam{i}.mp4") for i in range(RIG.cameras)]
    assert main(["sync", *videos, "--calib", str(scene / "calibration.json"), "--out",
                 str(root / "exact"), "--no-progress", "--no-rrd"]) == 0
    return root, scene, truth


def _crop(src_path, dst_path, px: int) -> None:
    src = open_video(src_path)
    info = src.info
    with VideoWriter(dst_path, info.width - px, info.height, info.fps or 1.0 / info.frame_interval_s,
                     crf=12) as w:
        for k, img in iter_frames(src):
            w.write(np.ascontiguousarray(img[:, : info.width - px]),
                    None if info.fps else float(info.timestamps_s[k]))


def test_videos_narrower_than_calibration_synchronize_as_exact(rig, caplog):
    root, scene, truth = rig
    cropped = root / "cropped_videos"
    cropped.mkdir()
    videos = []
    for i in range(RIG.cameras):
        name = f"cam{i}"
        if name in CROPPED:
            _crop(scene / f"{name}.mp4", cropped / f"{name}.mp4", CROP_PX)
            videos.append(str(cropped / f"{name}.mp4"))
        else:
            videos.append(str(scene / f"{name}.mp4"))
    assert open_video(cropped / "cam1.mp4").info.width == RIG.width - CROP_PX
    with caplog.at_level(logging.WARNING, logger="vs_inspect.io.calibration"):
        assert main(["sync", *videos, "--calib", str(scene / "calibration.json"), "--out",
                     str(root / "cropped"), "--no-progress", "--no-rrd"]) == 0
    crop_warnings = [r for r in caplog.records if "assumed a crop" in r.getMessage()]
    assert sorted(r.getMessage().split(":")[0] for r in crop_warnings) == sorted(CROPPED)
    exact = _errors_frames(root / "exact", truth)
    crop = _errors_frames(root / "cropped", truth)
    print("errors in frames, exact sizes:", exact, "cropped:", crop)
    for v in exact:
        assert exact[v] < MAX_ERROR_FRAMES and crop[v] < MAX_ERROR_FRAMES, (v, exact[v], crop[v])
        assert crop[v] < exact[v] + NOT_WORSE_FRAMES, (v, exact[v], crop[v])
    assert np.mean(list(crop.values())) < np.mean(list(exact.values())) + 0.1
    # the cropped run's cameras.json: the calibration fitted to each video (8 columns narrower)
    used = read_named(root / "cropped" / "cameras.json")
    assert used["cam1"].size == (RIG.width - CROP_PX, RIG.height)
    assert used["cam0"].size == (RIG.width, RIG.height)


def test_run_folder_holds_the_cameras_it_used(rig, tmp_path):
    root, scene, _ = rig
    used = read_named(root / "exact" / "cameras.json")
    given = read_named(scene / "calibration.json")
    assert sorted(used) == sorted(given)
    for n in given:
        np.testing.assert_allclose(used[n].K, given[n].K)
        np.testing.assert_allclose(used[n].cam_from_world, given[n].cam_from_world)
    assert main(["calib", "convert", str(root / "exact" / "cameras.json"), str(tmp_path / "Calib.toml")]) == 0
    back = read_named(tmp_path / "Calib.toml")
    for n in given:
        np.testing.assert_allclose(back[n].cam_from_world, given[n].cam_from_world, atol=1e-9)


def test_export_offsets_and_trimmed_videos(rig, capsys):
    root, scene, truth = rig
    run = root / "exact"
    res = json.loads((run / "result.json").read_text())
    assert main(["export", str(run), "--offsets", str(root / "offsets.csv"), "--trimmed",
                 str(root / "trimmed"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "starts" in out and ("after cam0" in out or "before cam0" in out)
    assert main(["export", str(run), "--offsets", str(root / "offsets.json")]) == 0
    lines = (root / "offsets.csv").read_text().splitlines()
    assert lines[0].startswith("# reference cam0;") and "positive: the video started after cam0" in lines[0]
    rows = {r["video"]: r for r in csv.DictReader(lines[1:])}
    js = json.loads((root / "offsets.json").read_text())
    assert "started after cam0" in js["sign"]
    infos = {v: open_video(scene / f"{v}.mp4").info for v in rows}
    for v, r in rows.items():
        assert float(r["offset_s"]) == pytest.approx(res["offsets_s"][v], abs=1e-6)
        assert float(r["offset_frames"]) == pytest.approx(res["offsets_s"][v] / infos[v].frame_interval_s, abs=1e-3)
        assert js["videos"][v]["first_frame"] == int(r["first_frame"])

    # the trimmed videos: which original frame each starts with (decoded and matched), and the
    # true moment of that frame
    trim = json.loads((root / "trimmed" / "trim.json").read_text())
    starts_est, starts_true, dt = {}, {}, {}
    for v in rows:
        t = open_video(root / "trimmed" / f"{v}.mp4")
        k0, k1 = int(rows[v]["first_frame"]), int(rows[v]["last_frame"])
        assert t.info.num_frames == k1 - k0 + 1
        ts = infos[v].timestamps_s
        np.testing.assert_allclose(t.info.timestamps_s, ts[k0:k1 + 1] - ts[k0], atol=2e-4)
        if infos[v].fps is None:  # variable rate: the timestamps file beside it
            stamps = np.loadtxt(root / "trimmed" / trim["videos"][v]["timestamps"])
            np.testing.assert_allclose(stamps, ts[k0:k1 + 1] - ts[k0], atol=1e-6)
        first = next(iter_frames(t))[1].astype(np.float32)
        orig = open_video(scene / f"{v}.mp4")
        diffs = {k: np.abs(img.astype(np.float32) - first).mean()
                 for k, img in iter_frames(orig) if abs(k - k0) <= 2}
        assert min(diffs, key=diffs.get) == k0, (v, diffs)  # frame-accurate cut
        starts_est[v] = ts[k0] + res["offsets_s"][v]
        starts_true[v] = ts[k0] + truth[v]
        dt[v] = infos[v].frame_interval_s
    anchor = max(dt, key=dt.get)  # the slowest video sets the span's frames
    print("start of each trimmed video (s), by the run's offsets:", starts_est, "true:", starts_true,
          "anchor", anchor)
    for v in rows:
        slower = max(dt[v], dt[anchor])
        # the cut's promise, in the offsets it was given: the same moment within half a frame
        assert abs(starts_est[v] - starts_est[anchor]) <= 0.5 * slower + 1e-6, (v, starts_est)
        # in true time, the two offsets' own errors add to that
        est_error = abs(res["offsets_s"][v] - truth[v]) + abs(res["offsets_s"][anchor] - truth[anchor])
        assert abs(starts_true[v] - starts_true[anchor]) <= 0.5 * slower + est_error + 1e-6, (v, starts_true)


def test_export_refusals(rig, tmp_path, capsys):
    root, _, _ = rig
    run = str(root / "exact")
    assert main(["export", run]) == 2
    assert "nothing to export" in capsys.readouterr().err
    assert main(["export", run, "--offsets", str(tmp_path / "o.txt")]) == 2
    (tmp_path / "o.csv").write_text("x")
    assert main(["export", run, "--offsets", str(tmp_path / "o.csv")]) == 2
    assert (tmp_path / "o.csv").read_text() == "x"
