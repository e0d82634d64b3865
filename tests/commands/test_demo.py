"""`vs-inspect demo` records both of its runs: the scene's true cues and the rendered videos
through the whole pipeline (whose failures are the ones to debug), each to its own .rrd."""

from __future__ import annotations

import json

from vs_inspect.cli import main
from vs_inspect.commands import demo
from vs_inspect.io.recording import read_recording
from vs_inspect.io.result import run_result_to_dict
from vs_inspect.synth.world import SceneConfig

TINY = SceneConfig(cameras=3, moving=0, seconds=2.0, width=160, height=120, fps=24.0,
                   variable_rate=0, max_offset_s=0.4, exposure=False, points_per_object=30, seed=5)


def test_demo_records_the_video_run(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(demo, "DEMO_SCENE", TINY)
    rrd = tmp_path / "recs" / "demo.rrd"
    assert main(["demo", "--out", str(tmp_path / "out"), "--no-progress", "--rrd", str(rrd)]) == 0
    out = capsys.readouterr().out
    videos_rrd = tmp_path / "recs" / "demo-videos.rrd"
    assert sorted(p.name for p in rrd.parent.iterdir()) == ["demo-videos.rrd", "demo.rrd"]
    assert f"recording: {videos_rrd}" in out and f"recording: {rrd}" in out
    rec = read_recording(videos_rrd)
    on_disk = json.loads((tmp_path / "out" / "videos" / "result.json").read_text())
    assert run_result_to_dict(rec.result) == on_disk  # the video run, whatever its outcome
    assert {v.name for v in rec.videos} == set(on_disk["offsets_s"])
    assert rec.meta["options"]["frames"] is True

    # --no-rrd: neither run is recorded
    assert main(["demo", "--out", str(tmp_path / "out2"), "--no-progress", "--no-rrd",
                 "--rrd", str(tmp_path / "none" / "x.rrd")]) == 0
    assert not (tmp_path / "none").exists()
