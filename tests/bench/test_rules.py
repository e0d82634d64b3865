"""bench rules: offsets counted per set, each rule left out alone, and the backward elimination
that drops a rule only when no set gets worse without it (from measured results kept on disk)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vs_inspect.bench.rules import Count, Scene, ablate, count, markdown, run
from vs_inspect.errors import InputError


def test_count_sorts_errors_into_within_a_frame_over_two_and_null():
    c = count([0.2, -1.0, 1.5, -2.5, None, 3.0])
    assert (c.offsets, c.within_1, c.over_2, c.nulls) == (6, 2, 2, 1)
    assert c.text() == "2 / 2 / 1"
    assert Count(3, 2, 0, 1).worse_than(Count(3, 3, 0, 0))  # one fewer within a frame
    assert Count(3, 3, 1, 0).worse_than(Count(3, 3, 0, 0))  # one more wrong offset
    assert not Count(3, 3, 0, 0).worse_than(Count(3, 2, 0, 1))


def _scene(set_name: str, name: str) -> Scene:
    return Scene(set_name, name, (Path(f"{name}/cam0.mp4"), Path(f"{name}/cam1.mp4")), None,
                 {"cam0": 0.0, "cam1": 0.5}, {"cam0": 30.0, "cam1": 30.0})


def test_elimination_keeps_a_rule_only_where_leaving_it_out_costs_a_set(tmp_path):
    """Measured results (as a stopped run leaves them): leaving out `guard` gives a wrong offset on
    set B, `idle` changes nothing, `costly` loses an offset on set A only once `idle` is gone too."""
    scenes = [_scene("A", "a1"), _scene("B", "b1")]
    measured = {
        "a1|": {"cam1": 0.1}, "b1|": {"cam1": None},
        "a1|guard": {"cam1": 0.1}, "b1|guard": {"cam1": 40.0},
        "a1|idle": {"cam1": 0.1}, "b1|idle": {"cam1": None},
        "a1|costly": {"cam1": 0.1}, "b1|costly": {"cam1": None},
        "a1|guard,idle": {"cam1": 0.1}, "b1|guard,idle": {"cam1": 40.0},
        "a1|costly,idle": {"cam1": None}, "b1|costly,idle": {"cam1": None},
    }
    (tmp_path / "results.json").write_text(json.dumps({k: {"errors": v, "seconds": 0.0} for k, v in measured.items()}))
    full, alone, steps = ablate(scenes, tmp_path, ["guard", "idle", "costly"], progress=lambda *_: None)
    assert full.counts == {"A": Count(1, 1, 0, 0), "B": Count(1, 0, 0, 1)}
    assert [v.counts["B"].over_2 for v in alone] == [1, 0, 0]
    assert [(r, ok) for r, _, ok in steps] == [("guard", False), ("idle", True), ("costly", False)]
    text = markdown(full, alone, steps, {"guard": "refuses a wrong offset"})
    assert "| `guard` | refuses a wrong offset | 1 / 0 / 0 | 0 / 1 / 0 **worse** |" in text
    assert "| `idle` | 1 / 0 / 0 | 0 / 0 / 1 | dropped |" in text


def test_an_unknown_set_is_refused_naming_the_known_ones(tmp_path):
    with pytest.raises(InputError, match="unknown set 'nope': use clips, caliscope, demo, small or arcs:SET"):
        run(["nope"], tmp_path, tmp_path)
