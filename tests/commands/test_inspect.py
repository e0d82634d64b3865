"""`vs-inspect inspect` on what is not a recording, and on a pair the run did not evaluate: one
line that says what to do, before any report is printed."""

from __future__ import annotations

import pytest

from vs_inspect.cli import main
from vs_inspect.io.result import write_run_result
from vs_inspect.pipeline import run as run_pipeline
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from vs_inspect.record.rerun_sink import RerunSink
    root = tmp_path_factory.mktemp("inspect")
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=0, seconds=3.0, pairs_per_view_pair=60,
                                          max_offset_s=0.8, seed=2))
    with RerunSink(root / "run.rrd", progress=False) as sink:
        result = run_pipeline(scene.bundle, sink=sink, progress=False)
    write_run_result(result, root / "out" / "result.json")
    return root


def test_a_run_folder_or_its_result_json_points_to_report(run, capsys):
    for given in (run / "out" / "result.json", run / "out"):
        assert main(["inspect", str(given)]) == 2
        cap = capsys.readouterr()
        err = cap.err.strip().splitlines()
        assert len(err) == 1 and not cap.out, err
        assert f"vs-inspect report {run / 'out'}" in err[0] and "not a recording" in err[0]


def test_an_unknown_pair_fails_before_the_report(run, capsys):
    assert main(["inspect", str(run / "run.rrd"), "--pair", "cam0", "nocam"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""  # nothing of the report before the error
    assert "--pair cam0 nocam" in cap.err and "cam0 cam1" in cap.err  # the known pairs named
    assert main(["inspect", str(run / "run.rrd"), "--pair", "cam1", "cam0"]) == 0  # either order
    assert "landscape minima" in capsys.readouterr().out
