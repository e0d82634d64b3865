"""The recording's reader: a recording written by RerunSink reads back as the run's RunResult,
typed videos, decisions, landscapes, solve iterations and the embedded cue bundle; missing,
damaged and foreign files give InputError."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vs_inspect.errors import InputError
from vs_inspect.io import recording_paths as P
from vs_inspect.io.recorded_frames import read_rrd_frames
from vs_inspect.io.recording import RecordedVideo, read_recorded_bundle, read_recording
from vs_inspect.io.result import run_result_to_dict
from vs_inspect.analysis.record_options import RecordOptions
from vs_inspect.record.rerun_sink import RerunSink
from vs_inspect.sync.config import SyncConfig
from vs_inspect.pipeline.stage12 import sync_bundle
from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
from vs_inspect.result_types import RunResult


def test_recorded_video_frame_interval():
    assert RecordedVideo("v", "v", 10, 10, 100, 25.0, 3.96).frame_interval_s == pytest.approx(0.04)
    assert RecordedVideo("v", "v", 10, 10, 5, None, 2.0).frame_interval_s == pytest.approx(0.5)
    assert math.isinf(RecordedVideo("v", "v", 10, 10, 1, None, 0.0).frame_interval_s)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("recording")
    scene = make_cue_scene(CueSceneConfig(cameras=3, moving=0, variable_rate=1, seconds=3.0,
                                          points_per_object=8, pairs_per_view_pair=60,
                                          no_match_pairs=0, all_wrong_pair=False, seed=4))
    b = scene.bundle
    path = tmp / "run.rrd"
    with RerunSink(path, options=RecordOptions.minimal(), progress=False) as sink:
        r = sync_bundle(b, SyncConfig(), sink=sink, progress=False)
        run = RunResult(r.reference, r.offsets_s, r.uncertainty_s, r.unresolved_reason, r.pairs, r.solver,
                        r.solve_pairs, r.iterations, r.timings_s, config={"k": 1},
                        gt_offsets_s=b.gt_offsets_s)
        sink.run_summary(run)
    return path, b, run, tmp


def test_read_back_the_run(recorded):
    path, b, run, _ = recorded
    rec = read_recording(path)
    assert run_result_to_dict(rec.result) == json.loads(json.dumps(run_result_to_dict(run)))
    assert rec.config == {"k": 1}
    assert rec.meta["format"] == P.RECORDING_FORMAT and rec.meta["version"] == P.RECORDING_VERSION
    assert rec.gt_offsets_s == b.gt_offsets_s
    assert [v.name for v in rec.videos] == b.names
    for v, info in zip(rec.videos, b.videos):
        assert (v.entity, v.width, v.height, v.num_frames, v.fps) == \
            (P.entity_name(info.name), info.width, info.height, info.num_frames, info.fps)
        assert v.duration_s == info.duration_s
    assert set(rec.decisions) == {P.pair_key(p.a, p.b) for p in run.pairs}
    for p in run.pairs:
        key = P.pair_key(p.a, p.b)
        assert ("ACCEPTED" if p.decision.accepted else "REJECTED") in rec.decisions[key]
        ok = np.isfinite(p.energy)
        if ok.any():
            e = rec.landscapes[key]["energy"]
            np.testing.assert_array_equal(e.offset_ms, np.round(p.offsets_s[ok] * 1000).astype(int))
            np.testing.assert_array_equal(e.value, p.energy[ok])
    for i, (a, b_) in enumerate(run.solve_pairs):
        np.testing.assert_allclose(rec.solve["weight"][P.pair_key(a, b_)], [it.weight[i] for it in run.iterations])
    assert rec.bundle_zip is None  # only when asked


def test_metadata_only_and_embedded_bundle(recorded):
    path, b, _, _ = recorded
    rec = read_recording(path, with_structure=False, bundle=True)
    assert rec.landscapes == {} and rec.solve == {} and rec.decisions == {}
    assert rec.result is not None
    back = read_recorded_bundle(rec)
    assert back.names == b.names
    for n in b.names:
        np.testing.assert_array_equal(back.tracks[n].xy, b.tracks[n].xy)
    frames = read_rrd_frames(path, [(v.name, v.width, v.height) for v in b.videos])
    assert frames.names() == []  # a minimal recording carries no frames
    assert frames.read(b.names[0], 0) is None


def test_no_result_and_bad_files(recorded, tmp_path, capsys):
    """InputError from the reader, and `vs-inspect inspect` turns it into one line (exit 2)."""
    import rerun as rr

    from vs_inspect.cli import main
    path, b, _, _ = recorded
    early = tmp_path / "early.rrd"
    with RerunSink(early, options=RecordOptions.minimal(), progress=False) as sink:
        sink.bundle(b)
    rec = read_recording(early)
    assert rec.result is None and rec.meta["has_result"] is False
    assert main(["inspect", str(early)]) == 2
    assert "the recording has no result" in capsys.readouterr().err
    trunc = tmp_path / "trunc.rrd"
    trunc.write_bytes(path.read_bytes()[:20_000])
    garbage = tmp_path / "garbage.rrd"
    garbage.write_text("not a recording")
    foreign = tmp_path / "foreign.rrd"
    other = rr.RecordingStream("someone_else")
    other.save(str(foreign))
    other.log("points", rr.Points2D([[1, 2]]), static=True)
    other.flush()
    other.disconnect()
    for f, what in ((tmp_path / "missing.rrd", "no such recording"), (trunc, "not a readable"),
                    (garbage, "not a readable"), (foreign, "not a vs_inspect recording")):
        with pytest.raises(InputError, match=what):
            read_recording(f)
        assert main(["inspect", str(f)]) == 2
        err = capsys.readouterr().err
        assert what in err and "Traceback" not in err
