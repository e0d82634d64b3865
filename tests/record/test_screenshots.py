"""The recording in the real rerun viewer: a small run with a planted failure (one pair whose
matches are all wrong), real frames (an H.264 file embedded as a video asset, JPEG frames, masks),
opened in the native viewer rendered in software; screenshots at the chosen offset and at a wrong
one; every panel on screen must show something, compared with the same layout over an empty
recording."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.record.native_viewer import rerun_executable
from vs_inspect.record.panel_ink import MIN_INK
from vs_inspect.record.screenshots import take_screenshots

SHOTS_ENV = "VS_INSPECT_SCREENSHOTS"  # keep the PNGs here (default: pytest's temporary folder)


def _write_h264(path: Path, frames: list[np.ndarray], fps: float) -> None:
    """libx264 through PyAV at the codec's default time base (1/fps)."""
    import av
    with av.open(str(path), "w") as c:
        s = c.add_stream("libx264", rate=int(round(fps)))
        s.width, s.height, s.pix_fmt = frames[0].shape[1], frames[0].shape[0], "yuv420p"
        s.options = {"crf": "30", "preset": "ultrafast"}
        for f in frames:
            for pkt in s.encode(av.VideoFrame.from_ndarray(f, format="bgr24")):
                c.mux(pkt)
        for pkt in s.encode():
            c.mux(pkt)


def make_recording(path: Path):
    """4 cameras (one moving), one pair with all-wrong matches; frames drawn from the tracks."""
    import cv2

    from vs_inspect.analysis.record_views import record_frame, record_mask
    from vs_inspect.pipeline import run as run_pipeline
    from vs_inspect.record.rerun_sink import RerunSink
    from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

    scene = make_cue_scene(CueSceneConfig(cameras=4, moving=1, variable_rate=0, seconds=3.0,
                                          max_offset_s=1.0, points_per_object=10,
                                          pairs_per_view_pair=120, no_match_pairs=0,
                                          all_wrong_pair=True, fps_choices=(15.0,), seed=3))
    b = scene.bundle
    with RerunSink(path, progress=False) as sink:
        for v in b.videos:
            xy, inst = b.tracks[v.name].xy, b.tracks[v.name].instance
            inst = inst if inst is not None else np.zeros(len(xy), int)
            frames, masks = [], []
            for k in range(v.num_frames):
                img = np.full((v.height, v.width, 3), 70, np.uint8)
                cv2.putText(img, f"{v.name} frame {k}", (20, 60), cv2.FONT_HERSHEY_SIMPLEX, 1.5,
                            (255, 255, 255), 3)
                mask = np.zeros((v.height, v.width), np.uint8)
                for (x, y), i in zip(xy[:, k], inst):
                    if np.isfinite(x):
                        cv2.circle(img, (int(x), int(y)), 6, (40, 200, 255), -1)
                        cv2.circle(mask, (int(x), int(y)), 14, int(i) + 1 if i >= 0 else 0, -1)
                frames.append(img)
                masks.append(mask)
            if v.name == "cam0":
                _write_h264(path.parent / "cam0.mp4", frames, v.fps)
                sink.video(v, str(path.parent / "cam0.mp4"))
            else:
                sink.video(v, None)
                for k, img in enumerate(frames):
                    sink.video_frame(v.name, k, record_frame(img, sink.options))
            for k, m in enumerate(masks):
                sink.dynamic_mask(v.name, k, record_mask(m, sink.options))
        result = run_pipeline(b, sink=sink, progress=False)
    return scene, result


def test_every_panel_shows_something_at_the_chosen_and_a_wrong_offset(tmp_path):
    if rerun_executable() is None:
        pytest.skip("no rerun viewer executable beside this Python or on PATH")
    import os
    t0 = time.perf_counter()
    rrd = tmp_path / "run" / "planted.rrd"
    rrd.parent.mkdir()
    scene, result = make_recording(rrd)
    t_rec = time.perf_counter() - t0
    out = Path(os.environ.get(SHOTS_ENV) or tmp_path / "shots")
    try:
        shots = take_screenshots(rrd, out, mode="headless", settle_s=0.6)
    except RuntimeError as exc:
        if "did not come up" in str(exc):  # no Vulkan/GL adapter, not even a software one
            pytest.skip(f"the rerun viewer cannot render here: {str(exc).splitlines()[0]}")
        raise
    t_all = time.perf_counter() - t0
    bad_pair = "{}→{}".format(*scene.all_wrong_pair)
    assert [s.label for s in shots] == ["chosen", "wrong"]
    assert all(s.timeline_on_open == "offset_ms" for s in shots)  # the layout opens on the offsets
    for s in shots:
        names = {p.name for p in s.panels}
        # the planted failure is the pair on screen: failed pairs first
        assert {f"landscape {bad_pair}", f"epipolar {bad_pair}", f"decision {bad_pair}"} <= names, names
        assert {"how to read this recording", "all landscapes", "3D"} | set(result.offsets_s) <= names
        assert s.empty_panels == [], (s.label, {p.name: p.ink for p in s.panels})
        errors = [r for p in s.panels for r in p.reports if r.startswith("error")]
        assert errors == []
        assert all(p.ink >= MIN_INK for p in s.panels)
        assert s.full.is_file() and all(p.path.is_file() for p in s.panels)
    import cv2
    # the frames themselves are on screen (grey 70 in the frames drawn above; the viewer's
    # background is near black): a video panel is not only tracks and a mask
    # cam0 is an embedded H.264 file: the native viewer decodes it with the ffmpeg executable
    h264 = {"cam0", "epipolar cam0"} if shutil.which("ffmpeg") is None else set()
    for s in shots:
        for p in s.panels:
            if any(p.name.startswith(n) for n in h264):
                continue
            if p.name in result.offsets_s or p.name.startswith("epipolar"):
                img = cv2.imread(str(p.path))
                frame_grey = (np.abs(img.astype(int) - 70).max(-1) <= 12).mean()
                assert frame_grey > 0.2, (s.label, p.name, frame_grey)
    # the cursor moved: the epipolar lines (and the cursor in the landscape) changed on screen
    epi = [cv2.imread(str(next(p.path for p in s.panels if p.name.startswith("epipolar")))) for s in shots]
    assert np.mean(np.abs(epi[0].astype(int) - epi[1].astype(int)).max(-1) > 40) > 0.01
    (out / "timing.json").write_text(json.dumps({"recording_s": t_rec, "total_s": t_all}))
    assert t_all < 90, f"recording + screenshots took {t_all:.0f} s"
    if out != tmp_path / "shots":
        shutil.copy(rrd, out / rrd.name)


def test_activate_tab_brings_a_titled_view_or_container_to_the_front():
    from vs_inspect.record.layout_tabs import activate_tab, on_screen_views

    v1, v2, c1 = "view/" + "1" * 32, "view/" + "2" * 32, "container/" + "3" * 32
    layout = {
        "/container/root": {"ContainerBlueprint": {"container_kind": "Horizontal", "contents": [
            "container/tabs", "container/pairs"]}},
        "/container/tabs": {"ContainerBlueprint": {"container_kind": "Tabs", "contents": [v1, v2], "active_tab": v1}},
        "/container/pairs": {"ContainerBlueprint": {"container_kind": "Tabs", "contents": [c1], "active_tab": c1}},
        f"/{c1}": {"ContainerBlueprint": {"container_kind": "Vertical", "contents": [], "display_name": "✗ a→b"}},
        f"/{v1}": {"ViewBlueprint": {"display_name": "all landscapes"}},
        f"/{v2}": {"ViewBlueprint": {"display_name": "point transfer (Stage 0: a camera's offset)"}},
    }
    assert on_screen_views(layout) == ["1" * 32]
    assert activate_tab(layout, "point transfer (Stage 0: a camera's offset)")
    assert on_screen_views(layout) == ["2" * 32]
    assert activate_tab(layout, "a→b", suffix=True)
    assert not activate_tab(layout, "point transfer")  # titles match whole unless suffix=True
    assert not activate_tab(layout, "no such tab")


def test_a_container_with_one_child_given_as_a_string_is_read():
    """The viewer's blueprint gives a container's single child as a string, not a list (a run
    that accepted no pair): its view is on screen, and a tab inside it can be activated."""
    from vs_inspect.record.layout_tabs import activate_tab, on_screen_views

    v1, v2 = "view/" + "1" * 32, "view/" + "2" * 32
    layout = {
        "/container/root": {"ContainerBlueprint": {"container_kind": "Vertical", "contents": [
            "container/one", "container/tabs"]}},
        "/container/one": {"ContainerBlueprint": {"container_kind": "Horizontal", "contents": v1}},
        "/container/tabs": {"ContainerBlueprint": {"container_kind": "Tabs", "contents": v2}},
        f"/{v1}": {"ViewBlueprint": {"display_name": "videos"}},
        f"/{v2}": {"ViewBlueprint": {"display_name": "events"}},
    }
    assert on_screen_views(layout) == ["1" * 32, "2" * 32]
    assert activate_tab(layout, "events")
    assert layout["/container/tabs"]["ContainerBlueprint"]["active_tab"] == v2


def test_a_run_that_synchronized_nothing_opens_with_frames_and_its_reasons(tmp_path):
    """Stage 0 could use no video: the recording has no offset_ms timeline, so the viewer is shot
    as it opens, on the frame timeline, with the offsets table in front; no panel on screen is
    empty (the screenshot tool does not stop at the missing timeline, and the videos show frames)."""
    if rerun_executable() is None:
        pytest.skip("no rerun viewer executable beside this Python or on PATH")
    from vs_inspect.record.rerun_sink import RerunSink
    from vs_inspect.result_types import RunResult
    from vs_inspect.types import VideoInfo

    rrd = tmp_path / "nothing.rrd"
    names = ("a", "b")
    why = "no reconstruction: too few matches between the frames of the videos (static background)"
    with RerunSink(rrd, progress=False) as sink:
        for n in names:
            info = VideoInfo(n, 320, 240, 10, np.arange(10) / 10.0, fps=10.0)
            sink.video(info, None)
            for k in range(10):
                img = np.full((240, 320, 3), 70, np.uint8)
                img[40:80, 30 * k:30 * k + 30] = 255
                sink.video_frame(n, k, img)
        sink.run_summary(RunResult("a", dict.fromkeys(names), dict.fromkeys(names), dict.fromkeys(names, why),
                                   (), "irls", (), (), {"total_s": 1.0},
                                   unresolved_headline=dict.fromkeys(names, why.split(" (")[0])))
    try:
        shots = take_screenshots(rrd, tmp_path / "shots", mode="headless", settle_s=0.6)
    except RuntimeError as exc:
        if "did not come up" in str(exc):
            pytest.skip(f"the rerun viewer cannot render here: {str(exc).splitlines()[0]}")
        raise
    assert [(s.label, s.offset_ms, s.timeline_on_open) for s in shots] == [("opened", None, "frame")]
    panels = {p.name: p for p in shots[0].panels}
    assert {"offsets", "a", "b"} <= set(panels), set(panels)
    assert shots[0].empty_panels == [], {p.name: p.ink for p in shots[0].panels}
    with pytest.raises(ValueError, match="no offset_ms timeline"):
        take_screenshots(rrd, tmp_path / "shots2", {"at_0ms": 0}, mode="headless")


def _small_run(path: Path, sink_class=None):
    """Three static cameras, no frames: a Stage 1 + 2 run recorded to path."""
    from vs_inspect.pipeline import run as run_pipeline
    from vs_inspect.record.rerun_sink import RerunSink
    from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=3.0,
                                          max_offset_s=0.8, points_per_object=10, pairs_per_view_pair=100,
                                          no_match_pairs=0, all_wrong_pair=False, fps_choices=(25.0, 30.0),
                                          noise_px=0.5, wrong_fraction=0.0, pose_error_deg=0.0,
                                          track_life_s=(3.0, 3.0), seed=4))
    with (sink_class or RerunSink)(path, progress=False) as sink:
        result = run_pipeline(scene.bundle, sink=sink, progress=False)
    return scene, result


def _viewer_or_skip(fn):
    try:
        return fn()
    except RuntimeError as exc:
        if "did not come up" in str(exc):
            pytest.skip(f"the rerun viewer cannot render here: {str(exc).splitlines()[0]}")
        raise


def test_a_panel_with_only_a_border_or_a_cursor_is_empty(tmp_path):
    """Panels planted with nothing to show on offset_ms: a video view whose video has no frame
    (only its image border is logged) and a plot of the solve (its data are on the `iteration`
    timeline: on offset_ms it shows axes and the time cursor). The check reports both EMPTY, the
    panels with data stay ok, and the command exits 1."""
    if rerun_executable() is None:
        pytest.skip("no rerun viewer executable beside this Python or on PATH")
    import rerun.blueprint as rrb

    from vs_inspect.io.recording_paths import SYNC_SOLVE, video_path
    from vs_inspect.record.rerun_sink import RerunSink
    from vs_inspect.record.screenshots import main

    class Planted(RerunSink):
        def blueprint(self, names):
            return rrb.Blueprint(rrb.Horizontal(
                rrb.TextDocumentView(origin="guide", name="how to read this recording"),
                rrb.Vertical(rrb.Spatial2DView(origin=video_path(names[0]), name="planted video"),
                             rrb.TimeSeriesView(origin=SYNC_SOLVE, name="planted solve plot")),
                rrb.TimeSeriesView(origin=f"pairs/{self._pairs_logged[0]}/landscape", name="landscape")),
                rrb.TimePanel(state="expanded", timeline="offset_ms", play_state="paused"), auto_views=False)

    rrd = tmp_path / "planted.rrd"
    scene, result = _small_run(rrd, Planted)
    chosen = round(next(p for p in result.pairs if p.decision.accepted).best_offset_s * 1000)
    import contextlib
    import io
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = _viewer_or_skip(lambda: main([str(rrd), "--out", str(tmp_path / "shots"), "--mode", "headless",
                                             "--at", str(chosen)]))
    rows = {line.split(maxsplit=4)[-1]: line.split()[0] for line in out.getvalue().splitlines()
            if line.startswith("  ")}
    assert rows == {"how to read this recording": "ok", "landscape": "ok",
                    "planted video": "EMPTY", "planted solve plot": "EMPTY"}, out.getvalue()
    assert code == 1


def test_recording_without_frames_has_no_video_panel_and_opens_at_the_front_pairs_delta(tmp_path):
    """A run without frames (a cue bundle's) has no video view in its layout; the viewer, opened
    as `vs-inspect view` opens it, puts the cursor at the front pair's chosen Δ, not at the start
    of the range; the tabs are found by the titles they show; the default wrong offset has lines
    on screen; and no panel is empty at the chosen offset, the IRLS tab included."""
    if rerun_executable() is None:
        pytest.skip("no rerun viewer executable beside this Python or on PATH")
    from vs_inspect.io.recorded_series import read_epipolar_sweep
    from vs_inspect.io.recording import read_recording
    from vs_inspect.record.screenshot_offsets import chosen_and_wrong_ms
    from vs_inspect.record.viewer import open_recording

    from vs_inspect.record.viewer import front_offset_ms
    rrd = tmp_path / "noframes.rrd"
    scene, result = _small_run(rrd)
    rec = read_recording(rrd)
    front = front_offset_ms(rec)
    p = next(q for q in result.pairs if q.decision.accepted)
    chosen, wrong = chosen_and_wrong_ms(rec, (p.a, p.b))
    assert chosen == round(p.best_offset_s * 1000)
    sweep = read_epipolar_sweep(rrd, p.a, p.b)
    at = int(np.argmin(np.abs(sweep.offset_ms - wrong)))
    assert sweep.lines[at] >= 3 and wrong != chosen  # lines on screen, missing the points
    i = int(np.argmin(np.abs(sweep.offset_ms - chosen)))
    assert sweep.median_px[at] > 4 * np.nanmin(sweep.median_px[max(0, i - 2):i + 3])

    shots = _viewer_or_skip(lambda: take_screenshots(rrd, tmp_path / "shots", {"front": front},
                                                     mode="headless", settle_s=0.6,
                                                     tabs=("pairs (failed first)", "IRLS solve")))
    # opened as `vs-inspect view` opens it: at the front pair's Δ, not at the start of offset_ms
    assert (shots[0].timeline_on_open, shots[0].time_on_open) == ("offset_ms", front)
    assert front > round(min(q.offsets_s[0] for q in result.pairs) * 1000)
    names = {x.name for x in shots[0].panels}
    assert not names & set(result.offsets_s), names  # no video panel
    assert {"pairs (failed first)", "3D"} <= names
    assert any(n.startswith("IRLS:") for n in names), names
    assert shots[0].empty_panels == [], {x.name: x.ink for x in shots[0].panels}
