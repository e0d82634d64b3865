import math

import pytest

from vs_inspect.cli import main
from vs_inspect.eval.metrics import evaluate_offsets, pair_auc, time_errors


def test_pair_auc_exact_values():
    import numpy as np
    assert pair_auc(np.array([0.0, 50.0, 100.0, 300.0]), 100.0) == pytest.approx(100 * (1 + 0.5) / 4)
    assert pair_auc(np.array([math.inf]), 500.0) == 0.0


def test_evaluate_offsets_exact():
    true = {"a": 0.0, "b": 1.0, "c": -0.5}
    est = {"a": 0.0, "b": 1.010, "c": -0.530}
    m = evaluate_offsets(est, true, "a")
    assert m.per_video_ms == {"b": pytest.approx(10.0), "c": pytest.approx(30.0)}
    assert m.delta_mean_ms == pytest.approx(20.0) and m.delta_med_ms == pytest.approx(20.0)
    # pair errors: ab 10, ac 30, bc 40 ms -> A@100 = mean(0.9, 0.7, 0.6)
    assert m.a100 == pytest.approx(100 * (0.9 + 0.7 + 0.6) / 3)
    assert m.a500 == pytest.approx(100 * (0.98 + 0.94 + 0.92) / 3)


def test_unresolved_video_counts_as_wrong():
    m = evaluate_offsets({"a": 0.0, "b": 1.0, "c": None}, {"a": 0.0, "b": 1.0, "c": 2.0}, "a")
    assert m.num_unresolved == 1 and m.per_video_ms["c"] is None
    assert m.a100 == pytest.approx(100 / 3)  # only a-b is right


def test_eval_cli(tmp_path, capsys):
    import json
    (tmp_path / "result.json").write_text(json.dumps(
        {"reference": "a", "offsets_s": {"a": 0.0, "b": 1.02}}))
    (tmp_path / "gt.json").write_text(json.dumps({"offsets_s": {"a": 0.0, "b": 1.0}}))
    assert main(["eval", str(tmp_path / "result.json"), "--gt", str(tmp_path / "gt.json")]) == 0
    out = capsys.readouterr().out
    assert "80.0" in out and "20.0" in out  # A@100 = 80 %, δ = 20 ms
    (tmp_path / "gt2.json").write_text(json.dumps({"offsets_s": {"a": 0.0, "zz": 1.0}}))
    assert main(["eval", str(tmp_path), "--gt", str(tmp_path / "gt2.json")]) == 2


def test_time_errors_offset_drift_and_over_the_span():
    """Relative to the reference (its own offset taken out); the error grows with local time by
    the rate error, so over a 0..100 s span it is worst at an end."""
    true = {"r": 1.0, "v": 3.0, "w": 0.0}
    est = {"r": 2.0, "v": 4.01, "w": None}
    te = time_errors(est, true, "r", {"r": 30.0, "v": 25.0}, {"r": 0.0, "v": -150.0}, {"r": 0.0, "v": 50.0},
                     {"r": (0.0, 100.0), "v": (0.0, 100.0)})
    v = te["v"]
    assert v.offset_err_s == pytest.approx(0.01) and v.offset_err_frames == pytest.approx(0.25)
    assert v.drift_err_ppm == pytest.approx(-200.0)
    assert v.end_err_s == pytest.approx(0.01 - 200e-6 * 100.0)  # -0.01 s at the last frame
    assert v.worst_err_s == pytest.approx(0.01) and v.worst_err_frames == pytest.approx(0.25)
    assert te["w"] is None and te["r"].offset_err_s == 0.0 and te["r"].worst_err_s == 0.0
    # without a span or fps: those errors are unknown; a truth without drift gives no drift error,
    # and its time map is the constant one
    bare = time_errors(est, true, "r", est_drift_ppm={"v": -150.0}, span_s={"v": (0.0, 10.0)})["v"]
    assert bare.offset_err_frames is None and bare.drift_err_ppm is None and bare.worst_err_frames is None
    assert bare.end_err_s == pytest.approx(0.01 - 150e-6 * 10.0)
