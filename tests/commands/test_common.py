"""commands/_common.py: the offsets table every command prints."""

from __future__ import annotations

from vs_inspect.commands._common import offsets_table


def test_the_offsets_table_stays_aligned_with_long_names_and_gives_each_null_its_reason():
    long = "sequence69_n05_cam01_4098_4262_0"  # 32 characters, as the VisualSync clips are named
    table = offsets_table({"cam0": 0.0, long: 0.25, "c": None}, {"cam0": 0.0, long: 0.01, "c": None},
                          {"cam0": 0.0, long: 0.3, "c": 1.0}, "cam0", {"c": "no camera"})
    lines = table.splitlines()
    # every column of numbers ends where its header ends
    ends = [lines[0].index(h) + len(h) for h in ("offset_s", "true_s")]
    assert lines[2].index("+0.2500") + len("+0.2500") == ends[0]
    assert lines[2].index("+0.3000") + len("+0.3000") == ends[1]
    assert lines[1].index("+0.0000") + len("+0.0000") == ends[0]
    assert lines[3].endswith("(no camera)") and "null" in lines[3]
