"""Benchmark tables: each setting averaged over the same datasets."""

from __future__ import annotations

import dataclasses

from vs_inspect.bench.runner import aggregate, failed_variants, ranking_checks, tables
from vs_inspect.bench.suite import Row


def _row(dataset: str, variant: str, a100: float, unresolved: int = 0, error: str = "",
         method: str = "vs_inspect") -> Row:
    nan = float("nan")
    return Row(dataset, "clips", method, variant, a100, a100, 10.0 if not error else nan,
               10.0 if not error else nan, 0.3 if not error else nan, unresolved, 3, error=error)


def _clips_rows() -> list[Row]:
    """One scene Stage 0 read (default and its variants at 60 %), one it could not (only a failed
    default: nothing was left to vary)."""
    good = [_row("clips/a", v, 60.0) for v in ("default", "solver=ls", "filter=off", "residual=cosine",
                                                "pairs=rst/seed=0", "pairs=rst/seed=1")]
    good.append(_row("clips/a", "residual=symmetric", 0.0, unresolved=3, error="ValueError: planted"))
    bad = _row("clips/b", "default", 0.0, unresolved=3, error="NoUsableVideos: no video could be used")
    return good + [bad]


def test_a_dataset_whose_default_failed_fails_in_every_variant_of_its_group():
    rows = _clips_rows()
    extra = failed_variants(rows)
    assert sorted(r.variant for r in extra) == ["filter=off", "pairs=rst/seed=0", "pairs=rst/seed=1",
                                                "residual=cosine", "residual=symmetric", "solver=ls"]
    assert all(r.dataset == "clips/b" and r.error.startswith("NoUsableVideos") and r.unresolved == 3
               for r in extra)
    # a variant that failed on its own is not given a second row
    assert not [r for r in extra if r.dataset == "clips/a"]
    agg = aggregate(rows)
    for family in ("default", "solver=ls", "filter=off", "residual=cosine"):
        assert sorted(r.dataset for r in agg[("clips", "vs_inspect", family)]) == ["clips/a", "clips/b"]
    assert len(agg[("clips", "vs_inspect", "pairs=rst")]) == 4  # one per pair seed and dataset


def test_ranking_checks_compare_settings_over_the_same_datasets():
    rows = _clips_rows()
    lines = "\n".join(ranking_checks(rows))
    # LS and the filter off equal the default on the one scene they ran on, and all three fail on
    # the other: equal means (before, LS and filter off were averaged over clips/a alone: 60 %)
    assert "solver LS 30.0 % / 10.0 ms vs IRLS 30.0 % / 10.0 ms" in lines
    assert "spurious-pair filter off 30.0 % / 10.0 ms / 3 unresolved vs on 30.0 % / 10.0 ms / 3 unresolved" in lines
    key = dict(tables(rows, []))["Key components (the paper's Table 3 on this data)"]
    ls_line = next(line for line in key.splitlines() if "Sampson, LS" in line)
    assert "| 6/6 |" not in ls_line and "| 3/6 | 1 | 2 |" in ls_line  # unresolved, failed, runs


def test_other_groups_and_methods_are_left_alone():
    rows = _clips_rows()
    rows.append(dataclasses.replace(_row("cue/x", "default", 0.0, unresolved=3, error="boom"), group="cue/default"))
    rows.append(_row("clips/b", "default", 0.0, unresolved=3, error="NoUsableVideos", method="ransac-inlier"))
    extra = failed_variants(rows)
    assert {r.dataset for r in extra} == {"clips/b"}  # cue/default ran no variant; a peer has none
    assert {r.method for r in extra} == {"vs_inspect"}
