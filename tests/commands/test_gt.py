"""--gt FILE on sync, inspect and report: every video's error against the truth, in ms and in
frames, from a bundle that carries no truth of its own (sync also keeps it with the result and
draws it in the recording)."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import pytest

from vs_inspect.cli import main
from vs_inspect.eval.metrics import offset_errors_ms
from vs_inspect.io.bundle import write_bundle
from vs_inspect.io.result import read_run_result
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene

SCENE = CueSceneConfig(cameras=3, moving=0, variable_rate=0, seconds=4.0, points_per_object=12,
                       pairs_per_view_pair=120, no_match_pairs=0, all_wrong_pair=False,
                       fps_choices=(25.0, 30.0), seed=7)


@pytest.fixture(scope="module")
def synced(tmp_path_factory):
    """A truth-free bundle, its gt.json apart, and `sync --gt` on it (with a recording)."""
    root = tmp_path_factory.mktemp("gt")
    scene = make_cue_scene(SCENE)
    truth = dict(scene.bundle.gt_offsets_s)
    write_bundle(replace(scene.bundle, gt_offsets_s=None), root / "bundle")
    (root / "gt.json").write_text(json.dumps({"offsets_s": truth}))
    return root, truth, scene.bundle


def _rows(text: str, names) -> dict[str, list[str]]:
    return {ln.split()[0]: ln.split() for ln in text.splitlines() if ln.split() and ln.split()[0] in names
            and re.match(r"^\S+\s+[+-]\d", ln)}


def test_sync_gt_prints_errors_in_ms_and_frames(synced, capsys):
    root, truth, bundle = synced
    assert main(["sync", "--bundle", str(root / "bundle"), "--out", str(root / "out"),
                 "--rrd", str(root / "run.rrd"), "--gt", str(root / "gt.json"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "error_ms" in out and "frames" in out
    result = read_run_result(root / "out")
    # the bundle had no truth: --gt's is kept with the result and drawn in the recording
    assert result.gt_offsets_s == pytest.approx(truth)
    from vs_inspect.io.recording import read_recording
    rec = read_recording(root / "run.rrd")
    assert rec.gt_offsets_s == pytest.approx(truth)
    assert any("truth" in series for series in rec.landscapes.values())
    errs = offset_errors_ms(result.offsets_s, truth, result.reference)
    rows = _rows(out, truth)
    assert set(rows) == set(truth)
    for v, row in rows.items():
        fps = bundle.video(v).fps
        assert float(row[4]) == pytest.approx(errs[v], abs=0.05)
        assert float(row[5]) == pytest.approx(errs[v] * fps / 1000.0, abs=0.005)


def test_sync_gt_bad_file_fails_before_any_work(synced, tmp_path, capsys):
    root, truth, _ = synced
    bad = tmp_path / "gt.json"
    bad.write_text(json.dumps({"offsets_s": {**truth, "camX": 1.0}}))
    assert main(["sync", "--bundle", str(root / "bundle"), "--out", str(tmp_path / "o"), "--no-rrd",
                 "--gt", str(bad), "--no-progress"]) == 2
    assert "camX" in capsys.readouterr().err
    assert main(["sync", "--bundle", str(root / "bundle"), "--out", str(tmp_path / "p"), "--no-rrd",
                 "--gt", str(tmp_path / "missing.json")]) == 2
    assert "missing.json" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()


def test_inspect_and_report_gt(synced, tmp_path, capsys):
    root, truth, bundle = synced
    if not (root / "run.rrd").is_file():
        pytest.skip("needs test_sync_gt_prints_errors_in_ms_and_frames' recording")
    assert main(["inspect", str(root / "run.rrd"), "--gt", str(root / "gt.json")]) == 0
    out = capsys.readouterr().out
    result = read_run_result(root / "out")
    errs = offset_errors_ms(result.offsets_s, truth, result.reference)
    rows = _rows(out, truth)
    assert set(rows) == set(truth)
    for v, row in rows.items():
        assert float(row[4]) == pytest.approx(errs[v], abs=0.05)
    assert re.search(r"track pairs  error \d+\.\d ms", out)  # each pair's error too

    assert main(["report", str(root / "out"), "--out", str(tmp_path / "rep"), "--gt",
                 str(root / "gt.json")]) == 0
    out = capsys.readouterr().out
    assert "errors against the truth" in out
    for v, e in errs.items():
        f = e * bundle.video(v).fps / 1000.0
        assert re.search(rf"{v}\s+{e:.1f} ms\s+{f:.2f} frames", out), v
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "error [ms]" in html and "error [frames]" in html
