"""vs-inspect bench stage0: one table row per set of videos from its run, and the summary."""

from __future__ import annotations

import dataclasses
import re

import pytest

from vs_inspect.bench.stage0 import HEAD, bench_sets, row, summary_line
from vs_inspect.bench.videos import Summary, caliscope_sets
from vs_inspect.cli import main
from vs_inspect.pipeline.config import RunConfig



def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


@pytest.mark.timeout(900)
def test_rendered_scene_with_its_calibration_judges_the_track_pairs(small, tmp_path):
    lines = []
    runs = bench_sets([small], RunConfig(), tmp_path, lines.append)
    assert lines[0] == HEAD and lines[2] == ""
    cells = _cells(lines[1])
    assert cells[0] == "small" and cells[1] == runs[0].result.reference
    assert "null" not in cells[2] and cells[3] == "calibration 4/4"
    m = re.fullmatch(r"(\d+), precision ([\d.]+), recall ([\d.]+)", cells[4])
    assert m and int(m.group(1)) == runs[0].result.cues.track_pairs > 0
    assert 0.5 < float(m.group(2)) <= 1 and 0 < float(m.group(3)) <= 1  # measured: 0.85 and 0.18
    assert float(cells[5]) > 0 and float(cells[6]) > 0
    assert lines[3].startswith("1 sets, 3 offsets: 3 resolved (") and "**0 over 2 frames**), 0 null" in lines[3]
    assert (tmp_path / "small" / "result.json").is_file()
    # without the true cameras given to the run, the row only counts the pairs
    unjudged = dataclasses.replace(runs[0], videos=dataclasses.replace(small, true_cameras=None))
    assert _cells(row(unjudged))[4] == cells[4].split(",")[0]


def test_a_null_says_why_and_an_offset_over_two_frames_is_marked():
    s = Summary(4, 3, 1, 1, 1, 1.5, 36.6, 50.0, 1200.0)
    assert summary_line(s, 2) == ("2 sets, 4 offsets: 3 resolved (1 within 1 frame, 1 at 1-2 frames, "
                                  "**1 over 2 frames**), 1 null; |error| median 1.50 frames (50.00 ms), "
                                  "max 36.60 frames (1200.00 ms)")


@pytest.mark.timeout(900)
def test_caliscope_cuts_through_the_command(shared_data, tmp_path, capsys):
    """One random cut of the real webcams with their calibration, through `bench stage0` (at
    320 px, so that it takes seconds; measured: every offset within 0.5 frame)."""
    first = next(caliscope_sets(shared_data, tmp_path / "cuts", 1, max_cut=12, seed=0))
    assert first.name == "caliscope/t0 cuts 11-8-6-3"  # the seeded cuts of trial 0
    assert first.calibration.name == "camera_array.toml" and len(first.videos) == 4
    assert main(["bench", "stage0", "caliscope", "--trials", "1", "--data", str(shared_data),
                 "--workdir", str(tmp_path / "w"), "--sync-args", "--max-side 320"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] + "\n" + out[1] == HEAD
    cells = _cells(out[2])
    assert cells[0] == first.name and cells[3] == "calibration 4/4"
    assert out[4].startswith("1 sets, 3 offsets: 3 resolved") and "**0 over 2 frames**" in out[4]
    assert (tmp_path / "w" / "runs" / "caliscope_t0_cuts_11-8-6-3" / "cues" / "bundle.json").is_file()


@pytest.mark.timeout(900)
def test_the_speed_set_prints_every_steps_seconds(shared_data, tmp_path, capsys):
    """caliscope blended to 30 fps, 1 s per video (too short to synchronize: the path, not the
    offsets), through `bench stage0 speed`: the row, then the run's seconds per step."""
    assert main(["bench", "stage0", "speed", "--seconds", "1", "--data", str(shared_data),
                 "--workdir", str(tmp_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert _cells(out[2])[0] == "speed/1s 720p 30fps" and out[4].startswith("1 sets, 3 offsets: ")
    steps = dict(line.split() for line in out[6:] if line and not line.startswith("run folders"))
    assert {"stage0_decode_s", "stage0_with_io_s", "stage1_s", "total_s"} <= set(steps)
    assert float(steps["total_s"]) >= float(steps["stage0_with_io_s"]) > 0
    assert len(list((tmp_path / "speed_1s").glob("cam_*.mp4"))) == 4
