"""vs-inspect bench: every sub-benchmark's options, sync's options passed to the runs, and the
errors of a bad option before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from vs_inspect.bench.scenes import DEFAULT_SET
from vs_inspect.bench.videos import CLIP_SCENES
from vs_inspect.cli import build_parser, main
from vs_inspect.commands.bench import config_of


def _args(*argv):
    return build_parser().parse_args(["bench", *argv])


def test_accuracy_options():
    a = _args("accuracy", "--quick", "--only", "cue/easy,caliscope", "--json", "rows.json")
    assert (a.quick, a.only, a.json, a.out, a.from_json) == (True, "cue/easy,caliscope", Path("rows.json"), None, None)
    assert _args("accuracy", "--from-json", "a.json", "b.json").from_json == [Path("a.json"), Path("b.json")]


def test_stage0_options_of_each_dataset():
    c = _args("stage0", "caliscope", "--trials", "2", "--cameras", "board", "--seed", "1")
    assert (c.dataset, c.trials, c.max_cut, c.seed, c.cameras, c.data, c.workdir) == \
        ("caliscope", 2, 12, 1, "board", None, None)
    assert _args("stage0", "caliscope").cameras == "calibration"
    v = _args("stage0", "clips", "--scenes", "blenderbox")
    assert v.scenes == ["blenderbox"] and _args("stage0", "clips").scenes == list(CLIP_SCENES)
    r = _args("stage0", "rendered", "--scenes", "demo", "a60_c4m1_s12", "--cameras", "calibration")
    assert (r.scenes, r.cameras, r.set) == (["demo", "a60_c4m1_s12"], "calibration", DEFAULT_SET)
    assert _args("stage0", "rendered", "--set", "mixed-rates").set == "mixed-rates"
    s = _args("stage0", "speed", "--seconds", "3")
    assert (s.seconds, s.cameras, s.sync_args) == (3, "calibration", ())
    for bad in (["stage0"], ["stage0", "rendered", "--set", "nonsense"], ["stage0", "rendered", "--scenes", "a0_c4m1_s1"],
                ["stage0", "rendered", "--data", "x"], ["stage0", "speed", "--seconds", "0"],
                ["stage0", "clips", "--cameras", "calibration"]):
        with pytest.raises(SystemExit):
            _args(*bad)


def test_sync_args_are_syncs_own_options():
    a = _args("stage0", "clips", "--sync-args", "--max-side 480 --range-s 2")
    assert a.sync_args == ("--max-side", "480", "--range-s", "2")
    cfg = config_of(a.sync_args)
    assert cfg.cues.max_side == 480 and cfg.sync.landscape.range_s == 2.0
    assert config_of(()) == config_of(("--max-side", str(config_of(()).cues.max_side)))  # the defaults


@pytest.mark.parametrize("text, says", [("--nonsense 3", "unrecognized arguments: --nonsense"),
                                        ("--calib c.json", "--calib and --fps come from the benchmark's data"),
                                        ("--range-s x", "--range-s")])
def test_a_bad_sync_option_fails_before_any_work(text, says, capsys):
    assert main(["bench", "stage0", "clips", "--sync-args", text]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "argument --sync-args" in err and says in err, err


def test_the_other_benchmarks_options():
    t = _args("timing", "--cameras", "calibration", "--width", "320", "--sync-args", "--max-side 240")
    assert (t.cameras, t.width, t.height, t.seconds, t.sync_args) == (["calibration"], 320, 720, 10.0,
                                                                     ("--max-side", "240"))
    assert (_args("energy").repeats, _args("energy", "--reference-offsets", "11").reference_offsets) == (3, 11)
    s = _args("scale", "--cameras", "8", "16", "--pairs", "all", "knn:4", "--engines", "local")
    assert (s.cameras, s.pairs, s.engines, s.ray_cpus) == ([8, 16], ["all", "knn:4"], ["local"], None)
    d = _args("drone", "/data/drone", "--workers", "1")
    assert (d.path, d.workers) == (Path("/data/drone"), 1)
    f = _args("drift", "--seeds", "2", "--drift-ppm", "500")
    assert (f.seeds, f.drift_ppm, f.difficulty, f.seconds) == (2, 500.0, "default", None)
    rec = _args("recording", "demo", "caliscope", "--out", "/tmp/x")
    assert (rec.cases, rec.out) == (["demo", "caliscope"], Path("/tmp/x")) and _args("recording").cases == "all"
    i = _args("interrupts", "--workdir", "/tmp/w", "--only", "report")
    assert (i.workdir, i.moments, i.repeats, i.only, i.grace_s) == (Path("/tmp/w"), 10, 3, ["report"], 10.0)
    for bad in (["scale", "--pairs", "knn:x"], ["drone"], ["interrupts"], ["recording", "nonsense"],
                ["drift", "--difficulty", "x"], ["nonsense"], []):
        with pytest.raises(SystemExit):
            _args(*bad)
