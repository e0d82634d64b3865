"""The core path through the CLI and the bundle format alone: synth-cues -> sync -> eval."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vs_inspect.cli import main
from vs_inspect.eval.metrics import evaluate_offsets


def test_accuracy_scene_smaller_size(tmp_path):
    """Like the judged scene (2 moving, 1 variable rate, 0.8 px, 25 % wrong, 0.5°, one all-wrong
    pair) with 6 cameras and 7 s instead of 7 and 8 s. With fewer redundant pairs the moving
    cameras' pose errors average out less, so the bounds are twice the judged ones (median
    <= 10 ms, worst <= 2/3 of the slowest frame interval); the judged size is measured by the
    benchmarks (BENCHMARKS.md)."""
    bundle = tmp_path / "bundle"
    assert main(["synth-cues", "--out", str(bundle), "--cameras", "6", "--moving", "2",
                 "--variable-rate", "1", "--seconds", "7", "--seed", "4"]) == 0
    assert main(["sync", "--bundle", str(bundle), "--out", str(tmp_path / "run"), "--no-progress"]) == 0
    res = json.loads((tmp_path / "run" / "result.json").read_text())
    gt = json.loads((bundle / "gt.json").read_text())["offsets_s"]
    meta = json.loads((bundle / "bundle.json").read_text())
    m = evaluate_offsets(res["offsets_s"], gt, res["reference"])
    assert m.num_unresolved == 0
    assert m.delta_med_ms <= 10.0
    slowest = max(1.0 / v["fps"] if "fps" in v else 0.0 for v in meta["videos"])
    assert m.delta_max_ms <= 1000 * slowest * 2 / 3
    rejected = [p for p in res["pairs"] if not p["accepted"]]
    assert rejected and all(p["reason"] for p in rejected)
    assert all(isinstance(p["offset_s"], (float, type(None))) for p in res["pairs"])


def test_all_wrong_pair_is_rejected_with_a_reason():
    from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
    from vs_inspect.pipeline import sync_bundle
    from vs_inspect.sync import SyncConfig
    scene = make_cue_scene(CueSceneConfig(cameras=4, moving=1, seconds=5.0, no_match_pairs=0, seed=5))
    res = sync_bundle(scene.bundle, SyncConfig(), progress=False)
    bad = [p for p in res.pairs if (p.a, p.b) == scene.all_wrong_pair][0]
    assert not bad.decision.accepted and bad.decision.reason
    assert all(v is not None for v in res.offsets_s.values())


def test_same_input_same_offsets(tmp_path):
    bundle = tmp_path / "b"
    main(["synth-cues", "--out", str(bundle), "--cameras", "3", "--seconds", "4", "--seed", "9"])
    main(["sync", "--bundle", str(bundle), "--out", str(tmp_path / "r1"), "--no-progress"])
    main(["sync", "--bundle", str(bundle), "--out", str(tmp_path / "r2"), "--no-progress"])
    r1 = json.loads((tmp_path / "r1" / "result.json").read_text())
    r2 = json.loads((tmp_path / "r2" / "result.json").read_text())
    assert r1["offsets_s"] == r2["offsets_s"]


def test_unknown_reference_and_bad_options_exit_2(tmp_path, capsys):
    bundle = tmp_path / "b"
    main(["synth-cues", "--out", str(bundle), "--cameras", "2", "--seconds", "3", "--no-all-wrong-pair",
          "--no-match-pairs", "0"])
    assert main(["sync", "--bundle", str(bundle), "--out", str(tmp_path / "o"), "--reference", "zz"]) == 2
    assert "zz" in capsys.readouterr().err
    assert main(["sync", "--bundle", str(bundle), "--out", str(tmp_path / "o"), "--pairs", "7"]) == 2
    assert main(["sync", "--out", str(tmp_path / "o")]) == 2


def test_console_script_help_runs():
    exe = Path(sys.executable).with_name("vs-inspect")
    if not exe.exists():
        pytest.skip("package not installed into this interpreter (run through make test)")
    out = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=60,
                         env={**os.environ})
    assert out.returncode == 0 and "sync" in out.stdout and "synth-cues" in out.stdout
