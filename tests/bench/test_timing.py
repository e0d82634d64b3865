"""bench timing on a tiny rendered scene: a real render, real `sync` processes, the table."""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

from vs_inspect.bench.timing import COLUMNS, PER_VIDEO, STAGES, TimingRow, format_table
from vs_inspect.cli import main


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


@pytest.mark.timeout(1200)  # a render and a sync process: minutes on a loaded 2-core machine
def test_tiny_scene_table_and_offsets(tmp_path, capsys):
    # with the calibration: the table and its bookkeeping are the point, not camera estimation
    # on small images (its rows are the same code path). 320x240 and 4 s with offsets in ±0.4 s:
    # at 3 s one view shares under 1 s of enough motion for Stage 0's votes (--min-overlap-s)
    code = main(["bench", "timing", "--width", "320", "--height", "240", "--seconds", "4",
                 "--max-offset-s", "0.4", "--cameras", "calibration", "--workdir", str(tmp_path),
                 "--timeout-s", "1000"])
    assert code == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("|")]
    assert _cells(lines[0]) == list(COLUMNS)
    rows = [dict(zip(COLUMNS, _cells(ln))) for ln in lines[2:]]
    assert [r["cameras"] for r in rows] == ["calibration"]
    for r in rows:
        assert r["scene"] == "4x4s 320x240 30fps"
        assert float(r["wall_s"]) > 0 and float(r["cpu_s"]) > 0 and float(r["rss_mb"]) > 50
        assert float(r["decode"]) >= 0 and float(r["stage1"]) >= 0
        # the videos' own steps run two at a time: counted by their wall time together, not their sum
        assert float(r["other"]) >= 0, r
        assert r["target"].split()[0].rstrip(":") in ("met", "MISSED"), r["target"]
    offsets = json.loads((tmp_path / "run_calibration" / "result.json").read_text())["offsets_s"]
    assert len(offsets) == 4 and all(v is not None and math.isfinite(v) for v in offsets.values()), offsets
    assert rows[0]["resolved"] == "4/4" and 0 <= float(rows[0]["max_ms"]) < 100  # measured: 26 ms


def test_target_needs_every_video_and_the_time():
    def row(wall, resolved):
        return TimingRow("s", "estimated", {c: 1.0 for c, _ in STAGES}, 10.0, wall, 5.0, 300.0,
                         resolved, 4, 1.0, 2.0)
    assert row(179.0, 4).met and not row(181.0, 4).met and not row(10.0, 3).met
    table = format_table([row(179.0, 4), row(181.0, 3)]).splitlines()
    assert _cells(table[2])[-1].startswith("met") and _cells(table[3])[-1].startswith("MISSED")
    assert _cells(table[3])[-1] == "MISSED (<180 s)"
    # in time but a video unresolved: the row says which half of the target failed
    assert _cells(format_table([row(10.0, 3)]).splitlines()[2])[-1] == "MISSED: in time (<180 s), 3/4 resolved"
    assert _cells(table[2])[COLUMNS.index("other")] == f"{179.0 - len(STAGES):.1f}"
    # the videos' own steps (1 s each here) took 2 s together
    overlapped = dataclasses.replace(row(179.0, 4), videos_s=2.0)
    assert _cells(format_table([overlapped]).splitlines()[2])[COLUMNS.index("other")] == \
        f"{179.0 - (len(STAGES) - len(PER_VIDEO) + 2.0):.1f}"
    # where an estimated run's cameras came from is part of its time
    moving = TimingRow("s", "estimated", {}, 10.0, 300.0, 5.0, 300.0, 0, 4, math.nan, math.nan,
                       camera_source="estimated from moving points (two-view geometry)")
    assert _cells(format_table([moving]).splitlines()[2])[1] == \
        "estimated (estimated from moving points (two-view geometry))"
    plain = dataclasses.replace(moving, camera_source="estimated")
    assert _cells(format_table([plain]).splitlines()[2])[1] == "estimated"
