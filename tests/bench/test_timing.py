"""bench-timing on a tiny rendered scene: a real render, real `sync` processes, the table."""

from __future__ import annotations

import json
import math

from vs_inspect.bench.timing import COLUMNS, STAGES, TimingRow, format_table
from vs_inspect.cli import main


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def test_tiny_scene_table_and_offsets(tmp_path, capsys):
    code = main(["bench-timing", "--width", "160", "--height", "120", "--seconds", "2",
                 "--workdir", str(tmp_path), "--timeout-s", "900"])
    assert code == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("|")]
    assert _cells(lines[0]) == list(COLUMNS)
    rows = [dict(zip(COLUMNS, _cells(ln))) for ln in lines[2:]]
    assert [r["cameras"] for r in rows] == ["estimated", "calibration"]
    for r in rows:
        assert r["scene"] == "4x2s 160x120 30fps"
        assert float(r["wall_s"]) > 0 and float(r["cpu_s"]) > 0 and float(r["rss_mb"]) > 50
        assert float(r["decode"]) >= 0 and float(r["stage1"]) >= 0
        assert r["target"].split()[0] in ("met", "MISSED")
    for mode in ("estimated", "calibration"):
        offsets = json.loads((tmp_path / f"run_{mode}" / "result.json").read_text())["offsets_s"]
        assert offsets and all(v is not None and math.isfinite(v) for v in offsets.values()), (mode, offsets)


def test_target_needs_every_video_and_the_time():
    def row(wall, resolved):
        return TimingRow("s", "estimated", {c: 1.0 for c, _ in STAGES}, 10.0, wall, 5.0, 300.0,
                         resolved, 4, 1.0, 2.0)
    assert row(179.0, 4).met and not row(181.0, 4).met and not row(10.0, 3).met
    table = format_table([row(179.0, 4), row(181.0, 3)]).splitlines()
    assert _cells(table[2])[-1].startswith("met") and _cells(table[3])[-1].startswith("MISSED")
    assert _cells(table[2])[COLUMNS.index("other")] == f"{179.0 - len(STAGES):.1f}"
