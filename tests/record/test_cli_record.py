"""`vs-inspect sync --bundle` writes recordings/<out name>-<hash>.rrd by default, --rrd PATH elsewhere,
nothing with --no-rrd; the recording's result equals result.json."""

from __future__ import annotations

import json
import re
from pathlib import Path

from vs_inspect.cli import main
from vs_inspect.commands._record import default_rrd_path
from vs_inspect.io.bundle import write_bundle
from vs_inspect.io.recording import read_recording
from vs_inspect.io.result import run_result_to_dict
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene


def test_sync_records_by_default_and_not_with_no_rrd(tmp_path, monkeypatch, capsys):
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=4.0,
                                          points_per_object=10, pairs_per_view_pair=80,
                                          no_match_pairs=0, all_wrong_pair=False, seed=2))
    bdir = write_bundle(scene.bundle, tmp_path / "bundle")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("VS_INSPECT_RECORDINGS", raising=False)  # the default: ./recordings
    assert main(["sync", "--bundle", str(bdir), "--out", "out/run7", "--no-progress",
                 "--rrd-minimal"]) == 0
    rrd = tmp_path / default_rrd_path(Path("out/run7"))  # recordings/run7-<hash of the abs. path>.rrd
    assert rrd.parent == tmp_path / "recordings" and re.fullmatch(r"run7-[0-9a-f]{8}\.rrd", rrd.name)
    assert rrd.is_file()
    assert f"recording: recordings/{rrd.name}" in capsys.readouterr().out
    rec = read_recording(rrd)
    on_disk = json.loads((tmp_path / "out" / "run7" / "result.json").read_text())
    assert run_result_to_dict(rec.result) == on_disk
    assert rec.config == on_disk["config"]
    assert rec.meta["options"]["frames"] is False  # --rrd-minimal

    assert main(["sync", "--bundle", str(bdir), "--out", "out/run8", "--no-progress", "--no-rrd"]) == 0
    assert sorted(p.name for p in (tmp_path / "recordings").iterdir()) == [rrd.name]


def test_recordings_folder_from_environment(tmp_path, monkeypatch):
    import argparse

    from vs_inspect.commands._record import rrd_path
    args = argparse.Namespace(no_rrd=False, rrd=None)
    monkeypatch.setenv("VS_INSPECT_RECORDINGS", str(tmp_path / "recs"))
    got = rrd_path(args, tmp_path / "out" / "run3")
    assert got.parent == tmp_path / "recs" and re.fullmatch(r"run3-[0-9a-f]{8}\.rrd", got.name)
    # a/out and b/out get different default recordings
    assert rrd_path(args, tmp_path / "a" / "out") != rrd_path(args, tmp_path / "b" / "out")
    assert rrd_path(argparse.Namespace(no_rrd=False, rrd="x/y.rrd"), tmp_path) == Path("x/y.rrd")
    assert rrd_path(argparse.Namespace(no_rrd=True, rrd="x/y.rrd"), tmp_path) is None
