"""A rendered scene on disk: real H.264 videos with the right clocks, consistent ground truth, and
a true cue bundle from which `vs-inspect sync --bundle` recovers the true offsets; the demo renders
once and reuses the cache."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.io.bundle import read_bundle
from vs_inspect.io.video import open_video
from vs_inspect.synth.videos import is_complete
from vs_inspect.synth.world import SceneConfig

TINY = SceneConfig(cameras=3, moving=1, seconds=2.0, width=160, height=120, fps=None,
                   variable_rate=1, max_offset_s=0.4, exposure=True, points_per_object=30, seed=5)
MAX_MEDIAN_ERROR_MS = 2.0


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    from vs_inspect.commands.demo import run_demo
    out = tmp_path_factory.mktemp("demo")
    data = run_demo(out, TINY, progress=False)
    return out, data


def test_scene_files_and_clocks(demo_run):
    out, _ = demo_run
    scene_dir = out / "scene"
    assert is_complete(scene_dir)
    scene = json.loads((scene_dir / "scene.json").read_text())
    gt = json.loads((scene_dir / "gt.json").read_text())["offsets_s"]
    calib = json.loads((scene_dir / "calibration.json").read_text())
    assert gt["cam0"] == 0.0 and set(gt) == {c["name"] for c in scene["cameras"]}
    vfr = 0
    for cam in scene["cameras"]:
        src = open_video(scene_dir / cam["file"])
        assert (src.info.width, src.info.height) == (cam["width"], cam["height"])
        assert src.info.num_frames == cam["num_frames"]
        want = np.asarray(cam["timestamps_s"]) if "timestamps_s" in cam else \
            np.arange(cam["num_frames"]) / cam["fps"]
        np.testing.assert_allclose(src.info.timestamps_s, want, atol=2e-5)
        vfr += "timestamps_s" in cam
        T = np.asarray(calib[cam["name"]]["cam_from_world"])
        assert T.shape == ((cam["num_frames"], 4, 4) if cam["moving"] else (4, 4))
    assert vfr == 1
    tr = np.load(scene_dir / "trajectories.npz")
    assert tr["points_world"].shape[0] == len(tr["point_instance"])
    assert np.isfinite(tr["points_world"]).all()


def test_rendering_again_gives_the_same_files(demo_run, tmp_path):
    """Same scene settings, same bytes: renderer, look and encoder are deterministic (the
    rendered benchmarks rely on it to compare settings on fresh renderings)."""
    from vs_inspect.synth.videos import render_scene
    from vs_inspect.synth.world import make_scene

    out, _ = demo_run
    render_scene(make_scene(TINY), tmp_path / "again", progress=False)
    videos = sorted(p.name for p in (out / "scene").glob("cam*.mp4"))
    assert len(videos) == TINY.cameras
    for name in videos:
        assert (tmp_path / "again" / name).read_bytes() == (out / "scene" / name).read_bytes(), name
    assert (tmp_path / "again" / "gt.json").read_text() == (out / "scene" / "gt.json").read_text()


def test_true_bundle_recovers_offsets(demo_run, tmp_path):
    out, data = demo_run
    bundle = read_bundle(out / "scene" / "bundle")
    # occlusion and visibility leave gaps, but every camera sees every moving object
    for v in bundle.names:
        seen = np.isfinite(bundle.tracks[v].xy[..., 0]).mean()
        assert 0.05 < seen < 0.95, (v, seen)
        assert len(np.unique(bundle.tracks[v].instance)) == 4
    # the demo's result ...
    truth = bundle.gt_offsets_s
    errs = [abs(data.offsets_s[v] - truth[v]) * 1000 for v in truth if v != "cam0"]
    assert np.median(errs) < MAX_MEDIAN_ERROR_MS, errs
    # ... and the CLI on the same bundle
    assert main(["sync", "--bundle", str(out / "scene" / "bundle"), "--out", str(tmp_path),
                 "--no-progress", "--no-rrd"]) == 0
    res = json.loads((tmp_path / "result.json").read_text())
    errs = [abs(res["offsets_s"][v] - truth[v]) * 1000 for v in truth if v != "cam0"]
    assert np.median(errs) < MAX_MEDIAN_ERROR_MS, errs


def test_demo_second_run_uses_cache(demo_run, capsys):
    from vs_inspect.commands.demo import run_demo
    out, _ = demo_run
    mp4 = out / "scene" / "cam0.mp4"
    before = mp4.stat().st_mtime_ns
    run_demo(out, TINY, progress=False)
    text = capsys.readouterr().out
    assert "cached rendered scene" in text
    assert "Stage 1 + 2 on the scene's true cues" in text
    assert "error_ms" in text
    assert mp4.stat().st_mtime_ns == before
    assert (out / "result.json").is_file()


def test_demo_rerenders_when_the_scene_settings_change(demo_run, capsys, tmp_path):
    import shutil

    from vs_inspect.commands.demo import ensure_scene
    out, _ = demo_run
    copy = tmp_path / "scene"
    shutil.copytree(out / "scene", copy)
    assert ensure_scene(copy, TINY, progress=False) is False  # same settings: cached
    other = SceneConfig(**{**TINY.__dict__, "seconds": 1.0, "cameras": 2, "moving": 0})
    assert ensure_scene(copy, other, progress=False) is True
    assert "rendered with other settings" in capsys.readouterr().out
    assert json.loads((copy / "scene.json").read_text())["config"]["cameras"] == 2
    assert not (copy / "cam2.mp4").exists()  # the old scene's third video is gone
    assert (copy / "cam1.mp4").exists()


def test_demo_runs_the_rendered_videos_through_the_whole_pipeline(demo_run, capsys):
    """The demo's second part: the mp4 files through Stage 0 + 1 + 2 with the scene's
    calibration (including the hand-held camera's per-frame poses), printed against the truth.
    Tiny 160x120 frames give Stage 0 little to work with, so only the mechanics are checked."""
    from vs_inspect.commands.demo import run_video_pipeline
    out, _ = demo_run
    rc = run_video_pipeline(out / "videos", out / "scene", progress=False)
    res = json.loads((out / "videos" / "result.json").read_text())
    gt = json.loads((out / "scene" / "gt.json").read_text())["offsets_s"]
    assert set(res["offsets_s"]) == set(gt)
    assert rc == (0 if sum(v is not None for v in res["offsets_s"].values()) >= 2 else 2)
    for name, off in res["offsets_s"].items():
        assert off is not None or res["unresolved"][name]
    assert "true_s" in capsys.readouterr().out
