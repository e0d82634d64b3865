"""--around NAME=OFFSET±WINDOW: a video's search limited to a window of its offset, on a scene whose
deepest minimum is a wrong one (track pairs that fit Δ_ab + 1 s), recorded in result.json and
in the recording; bad values refused with a clear message."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.io.bundle import write_bundle
from vs_inspect.io.recording import read_recording
from vs_inspect.io.recording_paths import pair_key
from vs_inspect.pipeline import RunConfig, run
from vs_inspect.sync.config import LandscapeConfig, SyncConfig, parse_around
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.types import TrackPairs, Tracks

FPS = 30.0
SHIFT_FRAMES = 75  # the wrong minimum lies this many frames (2.5 s) after the true Δ_ab
WINDOW_S = 0.5  # the half width of the window given (the wrong minimum lies 2 s beyond it)
WRONG_TOL_S = 0.1  # the wrong minimum's copies lose their last frames: it is not on the frame exactly
RERUN = Path(sys.executable).parent / "rerun"


@pytest.fixture(scope="module")
def wrong_deeper(tmp_path_factory):
    """(bundle folder, a, b, true Δ_ab): two static cameras; 40 % of the track pairs join the
    same points, 60 % join a's tracks with b's tracks shifted 75 frames in time, which fit
    Δ_ab + 2.5 s as the right ones fit Δ_ab: the deepest minimum is the wrong one."""
    sc = make_cue_scene(CueSceneConfig(cameras=2, moving=0, variable_rate=0, seconds=6.0, pairs_per_view_pair=200,
                                       max_offset_s=0.5, no_match_pairs=0, all_wrong_pair=False,
                                       wrong_fraction=0.0, fps_choices=(FPS,), seed=3))
    (a, b), tp = next(iter(sc.bundle.pairs.items()))
    xy = sc.bundle.tracks[b].xy
    late = np.full_like(xy, np.nan)
    late[:, :-SHIFT_FRAMES] = xy[:, SHIFT_FRAMES:]
    index = tp.index.copy()
    shifted = np.random.default_rng(0).random(len(index)) < 0.6
    index[shifted, 1] += len(xy)
    bundle = dataclasses.replace(sc.bundle, tracks={**sc.bundle.tracks, b: Tracks(np.concatenate([xy, late]))},
                                 pairs={(a, b): TrackPairs(a, b, index)})
    truth = sc.bundle.gt_offsets_s[b] - sc.bundle.gt_offsets_s[a]
    folder = write_bundle(bundle, tmp_path_factory.mktemp("around") / "bundle")
    return folder, a, b, truth


def _result(out: Path) -> dict:
    return json.loads((out / "result.json").read_text())


def test_without_a_window_the_wrong_minimum_is_deepest(wrong_deeper):
    folder, a, b, truth = wrong_deeper
    r = run(folder, RunConfig(), progress=False)
    land = next(p for p in r.pairs if {p.a, p.b} == {a, b})
    deepest = float(land.offsets_s[int(np.nanargmin(land.energy))])
    assert abs(deepest - (truth + SHIFT_FRAMES / FPS)) <= WRONG_TOL_S
    assert land.window_s is None
    # without a window, b's offset is not the true one (wrong or refused as ambiguous)
    assert r.offsets_s[b] is None or abs(r.offsets_s[b] - truth) > 0.5


def test_around_picks_the_true_minimum_and_records_its_window(wrong_deeper, tmp_path):
    folder, a, b, truth = wrong_deeper
    out, rrd = tmp_path / "run", tmp_path / "run.rrd"
    assert main(["sync", "--bundle", str(folder), "--out", str(out), "--no-progress", "--rrd", str(rrd),
                 "--rrd-minimal", "--around", f"{b}={truth:.3f}±{WINDOW_S}"]) == 0
    res = _result(out)
    assert res["offsets_s"][b] == pytest.approx(truth, abs=1.0 / FPS)
    pair = next(p for p in res["pairs"] if {p["a"], p["b"]} == {a, b})
    sign = 1.0 if pair["a"] == a else -1.0  # Δ_ab of the pair as written
    lo, hi = sorted((sign * (round(truth, 3) - WINDOW_S), sign * (round(truth, 3) + WINDOW_S)))
    assert pair["window_s"] == pytest.approx([lo, hi], abs=1e-9)
    # the landscape spans the whole range (its median and rivals are read there); the minimum
    # is taken within the window
    offsets = np.asarray(pair["landscape"]["offsets_s"])
    assert offsets.min() < lo and offsets.max() > hi
    assert lo <= pair["offset_s"] <= hi
    assert res["config"]["sync"]["landscape"]["around"] == {b: [round(truth, 3), WINDOW_S]}
    # the recording is valid for rerun and shows the window on the pair's landscape panel
    env = dict(os.environ, XDG_CONFIG_HOME=str(tmp_path / "xdg-config"), XDG_DATA_HOME=str(tmp_path / "xdg-data"))
    verify = subprocess.run([str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, env=env,
                            timeout=120)
    assert verify.returncode == 0, verify.stderr
    rec = read_recording(rrd)
    bar = rec.landscapes[pair_key(pair["a"], pair["b"])]["window"]
    assert list(bar.offset_ms) == [round(lo * 1000), round(hi * 1000)]
    assert rec.result.pairs[0].window_s == pytest.approx((lo, hi), abs=1e-3)


def test_a_window_around_the_wrong_minimum_finds_that_one(wrong_deeper):
    """The window decides which minimum is searched: around the wrong one, the wrong one comes out
    (so the true one above is the window's doing, not chance)."""
    folder, a, b, truth = wrong_deeper
    wrong = truth + SHIFT_FRAMES / FPS
    cfg = RunConfig(sync=SyncConfig(landscape=LandscapeConfig(around=parse_around([f"{b}={wrong}:{WINDOW_S}"]))))
    r = run(folder, cfg, progress=False)
    assert r.offsets_s[b] == pytest.approx(wrong, abs=WRONG_TOL_S)


@pytest.mark.parametrize("value, message", [
    ("nocam=0.5±0.2", "no video is named 'nocam'"),
    ("{b}=0.5", "NAME=OFFSET±WINDOW"),
    ("{b}=abc±1", "NAME=OFFSET±WINDOW"),
    ("{b}=0.5±-1", ">= 0"),
    ("{b}=9±0.5", "outside --range-s"),
    ("{a}=2±0.5", "is the reference"),
])
def test_bad_windows_are_refused_with_a_clear_message(wrong_deeper, tmp_path, capsys, value, message):
    folder, a, b, _ = wrong_deeper
    out = tmp_path / "o"
    assert main(["sync", "--bundle", str(folder), "--out", str(out), "--no-progress", "--no-rrd", "--range-s", "3",
                 "--around", value.format(a=a, b=b)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()  # no partial output


def test_the_three_spellings_are_one_window():
    want = {"cam1": (1.5, 0.25)}
    for text in ("cam1=1.5±0.25", "cam1=1.5+-0.25", "cam1=1.5:0.25", " cam1 = 1.5 ± 0.25 "):
        assert parse_around([text]) == want
    assert parse_around(["cam1=-1e-1±2"]) == {"cam1": (-0.1, 2.0)}
    # a window's Δ bounds for each pair: the reference at 0, two windows by their difference
    grid = LandscapeConfig(around={"c1": (1.5, 0.25), "c2": (-1.0, 0.5)}).offset_grid("c0")
    assert grid.pair_window("c0", "c1") == (1.25, 1.75)
    assert grid.pair_window("c1", "c2") == (-3.25, -1.75)  # c2 − c1 within -1.5 − 1.75 .. -0.5 − 1.25
    assert grid.pair_window("c1", "c3") is None


def test_windows_round_trip_through_config_json(tmp_path):
    cfg = RunConfig(sync=SyncConfig(landscape=LandscapeConfig(around={"cam1": (1.5, 0.25)})))
    back = RunConfig.load(cfg.save(tmp_path / "config.json"))
    assert back.sync.landscape.around == {"cam1": (1.5, 0.25)}
    (tmp_path / "bad.json").write_text(json.dumps({"sync": {"landscape": {"around": {"cam1": [1.5]}}}}))
    with pytest.raises(Exception, match=r"around.cam1.*list of 2 values"):
        RunConfig.load(tmp_path / "bad.json")
