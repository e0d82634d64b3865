"""RunConfig: JSON round trip, strict reading, and the command-line options generated from it."""

from __future__ import annotations

import argparse
import dataclasses
import json

import pytest

from vs_inspect.commands import cues as cues_cmd
from vs_inspect.commands import sync as sync_cmd
from vs_inspect.commands._common import run_config
from vs_inspect.cues.config import CameraConfig, CueConfig
from vs_inspect.errors import InputError
from vs_inspect.pipeline import RunConfig
from vs_inspect.pipeline.config import field_doc
from vs_inspect.analysis.record_options import RecordOptions
from vs_inspect.sync.config import (DecisionConfig, LandscapeConfig, PairSelection, SolveConfig,
                                    SyncConfig)

# the flags that the README and the tests use; they keep their names and meanings
SYNC_FLAGS = ("--energy", "--loss", "--solver", "--no-spurious-filter", "--pairs", "--seed",
              "--reference", "--range-s", "--step-s", "--min-overlap-s", "--huber-delta-s")
CUE_FLAGS = ("--calib", "--fps", "--max-side", "--keyframes", "--max-tracks", "--sfm-frames",
             "--sfm-features", "--sfm-max-features", "--camera-motion")
RECORD_FLAGS = ("--rrd", "--no-rrd", "--rrd-minimal", "--rrd-all-offsets", "--rrd-full-frames",
                "--rrd-all-tracks")

CUSTOM = RunConfig(
    cues=CueConfig(max_side=480, max_tracks=700,
                   camera=CameraConfig(static_frames=5, moving_frames=12, features="sift"),
                   camera_motion={"cam1": "static"}),
    sync=SyncConfig(landscape=LandscapeConfig(residual="cosine", range_s=2.5, min_overlap_s=0.5),
                    decision=DecisionConfig(enabled=False),
                    solve=SolveConfig(solver="ls", reference="cam2", huber_delta_s=0.02),
                    pairs=PairSelection("fraction", 0.5, 3)),
    record=RecordOptions.minimal())


def _parser(command):
    top = argparse.ArgumentParser()
    command.register(top.add_subparsers(dest="command"))
    return top


def test_round_trip_through_json():
    assert RunConfig.from_dict(json.loads(json.dumps(CUSTOM.to_dict()))) == CUSTOM
    assert RunConfig.from_dict(RunConfig().to_dict()) == RunConfig()
    assert RunConfig.from_dict({}) == RunConfig()  # missing keys keep their defaults
    partial = RunConfig.from_dict({"sync": {"solve": {"solver": "ls"}}})
    assert partial == dataclasses.replace(RunConfig(), sync=SyncConfig(solve=SolveConfig(solver="ls")))


def test_save_and_load(tmp_path):
    path = CUSTOM.save(tmp_path / "config.json")
    assert path == tmp_path / "config.json"
    assert RunConfig.load(path) == CUSTOM
    assert RunConfig.load(tmp_path) == CUSTOM  # a run folder holding config.json


def test_unknown_key_is_an_error_naming_it():
    with pytest.raises(InputError, match=r"'sync\.solve\.solvr'"):
        RunConfig.from_dict({"sync": {"solve": {"solvr": "ls"}}})
    with pytest.raises(InputError, match=r"'stage3'"):
        RunConfig.from_dict({"stage3": {}})


@pytest.mark.parametrize("data, key", [
    ({"sync": {"landscape": {"min_overlap_s": "1.0"}}}, "sync.landscape.min_overlap_s"),
    ({"cues": {"max_side": True}}, "cues.max_side"),
    ({"cues": {"max_side": 640.5}}, "cues.max_side"),
    ({"sync": {"decision": {"enabled": 1}}}, "sync.decision.enabled"),
    ({"cues": {"camera_motion": {"cam0": 3}}}, "cues.camera_motion.cam0"),
    ({"sync": {"solve": []}}, "sync.solve"),
])
def test_wrong_type_is_an_error_naming_the_key(data, key):
    with pytest.raises(InputError, match=key.replace(".", r"\.")):
        RunConfig.from_dict(data)


def test_bad_value_is_an_input_error():
    with pytest.raises(InputError, match="unknown solver 'newton'"):
        RunConfig.from_dict({"sync": {"solve": {"solver": "newton"}}})
    with pytest.raises(InputError, match="static or moving"):
        RunConfig.from_dict({"cues": {"camera_motion": {"cam0": "flying"}}})


@pytest.mark.parametrize("data,needle", [
    ({"sync": {"landscape": {"step_s": float("nan")}}}, "--step-s must be a finite number"),
    ({"sync": {"landscape": {"min_overlap_s": -1}}}, "--min-overlap-s must be >= 0"),
    ({"sync": {"decision": {"min_track_pairs": -1}}}, "min_track_pairs must be >= 0"),
    ({"sync": {"solve": {"max_iterations": 0}}}, "max_iterations must be positive"),
    ({"sync": {"solve": {"huber_delta_s": float("inf")}}}, "--huber-delta-s must be a finite number"),
    ({"sync": {"pairs": {"fraction": 0.0}}}, r"--pairs fraction must be in \(0,1\]"),
    ({"cues": {"max_side": 0}}, "--max-side must be positive"),
    ({"cues": {"max_tracks": 0}}, "--max-tracks must be positive"),
    ({"cues": {"camera": {"max_side": 0}}}, "max_side must be positive"),
    ({"record": {"jpeg_quality": 101}}, "jpeg_quality must be <= 100"),
    ({"record": {"max_asset_mb": float("nan")}}, "max_asset_mb must be a finite number"),
])
def test_every_number_is_validated_naming_the_option(data, needle):
    with pytest.raises(InputError, match=needle):
        RunConfig.from_dict(data)


def test_defaults_and_presets_pass_validation():
    from vs_inspect.analysis.record_options import RecordOptions
    RunConfig()
    RecordOptions.minimal().with_flags(all_offsets=True, full_frames=True, all_tracks=True)


def test_every_flag_is_there_with_its_docstring_as_help():
    sub = _parser(sync_cmd)._subparsers._group_actions[0].choices["sync"]
    flags = {s: a for a in sub._actions for s in a.option_strings}
    for f in SYNC_FLAGS + CUE_FLAGS + RECORD_FLAGS + ("--config",):
        assert f in flags, f
    assert flags["--energy"].help.startswith(field_doc(LandscapeConfig, "residual"))
    assert flags["--min-overlap-s"].help.startswith(field_doc(LandscapeConfig, "min_overlap_s"))
    assert flags["--max-tracks"].help.startswith(field_doc(CueConfig, "max_tracks"))
    cue_sub = _parser(cues_cmd)._subparsers._group_actions[0].choices["cues"]
    assert {s for a in cue_sub._actions for s in a.option_strings} >= set(CUE_FLAGS)


def test_flags_set_the_fields_they_name():
    args = _parser(sync_cmd).parse_args(
        ["sync", "--out", "o", "--energy", "cosine", "--loss", "mean", "--solver", "ls",
         "--no-spurious-filter", "--pairs", "0.5", "--seed", "3", "--reference", "cam2",
         "--range-s", "2.5", "--step-s", "0.01", "--min-overlap-s", "0.5", "--huber-delta-s", "0.02",
         "--max-side", "480", "--keyframes", "6", "--max-tracks", "700", "--sfm-frames", "5", "12",
         "--sfm-features", "sift", "--sfm-max-features", "1024",
         "--camera-motion", "a=static",
         "--camera-motion", "b=moving", "--rrd-minimal"])
    cfg = run_config(args)
    assert cfg.sync == SyncConfig(
        landscape=LandscapeConfig(residual="cosine", loss="mean", range_s=2.5, step_s=0.01,
                                  min_overlap_s=0.5),
        decision=DecisionConfig(enabled=False),
        solve=SolveConfig(solver="ls", reference="cam2", huber_delta_s=0.02),
        pairs=PairSelection("fraction", 0.5, 3))
    assert cfg.cues == CueConfig(max_side=480, keyframes=6, max_tracks=700,
                                 camera=CameraConfig(static_frames=5, moving_frames=12, features="sift",
                                                     max_features=1024),
                                 camera_motion={"a": "static", "b": "moving"})
    assert cfg.record == RecordOptions.minimal()
    defaults = run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o"]))
    assert defaults == RunConfig()


def test_config_file_then_command_line(tmp_path):
    """--config FILE gives the settings; an option on the command line overrides that one value."""
    path = CUSTOM.save(tmp_path / "config.json")
    p = _parser(sync_cmd)
    assert run_config(p.parse_args(["sync", "--out", "o", "--config", str(path)])) == CUSTOM
    cfg = run_config(p.parse_args(["sync", "--out", "o", "--config", str(path), "--energy", "symmetric",
                                   "--seed", "7", "--camera-motion", "cam0=moving"]))
    assert cfg.sync.landscape == dataclasses.replace(CUSTOM.sync.landscape, residual="symmetric")
    assert cfg.sync.pairs == PairSelection("fraction", 0.5, 7)  # the file's fraction, the flag's seed
    assert cfg.cues.camera_motion == {"cam1": "static", "cam0": "moving"}
    assert (cfg.sync.solve, cfg.sync.decision, cfg.record) == (CUSTOM.sync.solve, CUSTOM.sync.decision,
                                                               CUSTOM.record)


def test_bad_flag_values_are_input_errors():
    p = _parser(sync_cmd)
    with pytest.raises(InputError, match="--camera-motion must be NAME=static or NAME=moving"):
        run_config(p.parse_args(["sync", "--out", "o", "--camera-motion", "cam0"]))
    with pytest.raises(InputError, match="--pairs"):
        run_config(p.parse_args(["sync", "--out", "o", "--pairs", "1.5"]))
    with pytest.raises(InputError, match="--range-s"):
        run_config(p.parse_args(["sync", "--out", "o", "--range-s", "-1"]))


def test_help_shows_no_measurement_of_a_dataset():
    text = _parser(sync_cmd)._subparsers._group_actions[0].choices["sync"].format_help()
    for word in ("blenderbox", "pan160906", "fencing1", "rendered scene", "measured", " min on "):
        assert word not in text, word


def test_engine_and_knn_flags():
    from vs_inspect.engine import EngineConfig
    args = _parser(sync_cmd).parse_args(["sync", "--out", "o", "--engine", "ray", "--ray-address",
                                         "127.0.0.1:6379", "--pairs", "knn:3", "--seed", "2"])
    cfg = run_config(args)
    assert cfg.engine == EngineConfig("ray", "127.0.0.1:6379")
    assert cfg.sync.pairs == PairSelection("knn", 1.0, 2, 3)
    assert RunConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))) == cfg
    assert run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o"])).engine == EngineConfig("local")
    with pytest.raises(InputError, match="knn:K"):
        run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o", "--pairs", "knn:0"]))


def test_any_setting_by_its_path_and_an_unknown_path_named(tmp_path):
    from vs_inspect.pipeline.config import parse_set, with_settings

    cfg = with_settings(RunConfig(), parse_set(["sync.landscape.range_s=5", "cues.heads=no",
                                                "cues.camera.features=sift", "sync.solve.reference=cam2",
                                                'sync.landscape.around={"cam1": [1.5, 0.25]}',
                                                "sync.landscape.step_s=null"]))
    assert cfg.sync.landscape.range_s == 5.0 and cfg.cues.heads is False and cfg.cues.camera.features == "sift"
    assert cfg.sync.solve.reference == "cam2" and cfg.sync.landscape.around == {"cam1": (1.5, 0.25)}
    with pytest.raises(InputError, match=r"unknown setting 'sync.landscape.rang_s' \(known in sync.landscape: .*range_s"):
        with_settings(RunConfig(), parse_set(["sync.landscape.rang_s=5"]))
    with pytest.raises(InputError, match="unknown setting 'nothing'"):
        with_settings(RunConfig(), {"nothing": 1})
    with pytest.raises(InputError, match="must be a number"):
        with_settings(RunConfig(), parse_set(["sync.landscape.range_s=soon"]))
    with pytest.raises(InputError, match="PATH=VALUE"):
        parse_set(["sync.landscape.range_s"])


def test_presets_on_the_command_line(tmp_path):
    from vs_inspect.pipeline.config import PRESETS

    fast = run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o", "--preset", "fast", "--keyframes", "6"]))
    assert fast.cues.max_tracks == 800 and fast.cues.camera.features == "sift" and fast.cues.heads is False
    assert fast.cues.keyframes == 6  # the options given apply on top of the preset
    paper = run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o", "--preset", "paper"]))
    assert paper.sync.landscape.loss == "mean" and not paper.sync.sightings.enabled
    assert run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o", "--preset", "estimated"])) == RunConfig()
    calibrated = ["sync", "--out", "o", "--preset", "calibrated"]
    with pytest.raises(InputError, match="--preset calibrated: give the rig's calibration with --calib"):
        run_config(_parser(sync_cmd).parse_args(calibrated))
    assert run_config(_parser(sync_cmd).parse_args(calibrated + ["--calib", "c.toml"])) == RunConfig()
    RunConfig().save(tmp_path)
    with pytest.raises(InputError, match="give one of them"):
        run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o", "--preset", "fast", "--config",
                                                 str(tmp_path / "config.json")]))
    assert set(PRESETS) == {"calibrated", "estimated", "fast", "paper"}
    # --set wins over everything
    late = run_config(_parser(sync_cmd).parse_args(["sync", "--out", "o", "--preset", "fast", "--keyframes", "6",
                                                    "--set", "cues.keyframes=9"]))
    assert late.cues.keyframes == 9
