"""`vs-inspect bench accuracy --quick` (run through the CLI as CI does): its tables come out, every method
runs on the same data, and its numbers equal the same rows of the full plan (fixed seeds)."""

import json
import math

import pytest

from vs_inspect.bench.runner import full_plan, quick_plan, rows_from_json, run_plan
from vs_inspect.cli import main


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    import io
    from contextlib import redirect_stdout
    buf = io.StringIO()
    with redirect_stdout(buf):
        rc = main(["bench", "accuracy", "--quick", "--no-progress", "--json", str(out / "q.json"),
                   "--out", str(out / "q.md")])
    return rc, buf.getvalue(), json.loads((out / "q.json").read_text()), (out / "q.md").read_text()


def test_quick_prints_every_table_with_vs_inspect_and_both_peers(quick):
    rc, text, data, md = quick
    assert rc == 0
    for title in ("vs_inspect and the two peers", "Key components", "Input settings", "Ranking checks"):
        assert title in text and title in md
    rows, skipped = rows_from_json(data)
    ran = {r.dataset for r in rows}
    assert "cue/default/s0" in ran
    for ds in ran:  # every method on the same data in the same run
        assert {r.method for r in rows if r.dataset == ds} == {"vs_inspect", "motion-xcorr", "ransac-inlier"}
    assert ran | {s.name for s in skipped} == {d.name for d in quick_plan()}
    base = [r for r in rows if r.dataset == "cue/default/s0" and r.method == "vs_inspect" and r.variant == "default"][0]
    assert 0 <= base.a100 <= 100 and base.videos == 5 and math.isfinite(base.stage1_s)
    assert f"{base.a100:.1f}" in md  # the table shows the measured number
    variants = {r.variant for r in rows if r.dataset == "cue/default/s0"}
    assert {"solver=ls", "filter=off", "stage1-only", "pairs=rst/seed=0", "pairs=0.5/seed=4"} <= variants


def test_quick_plan_is_a_subset_of_the_full_plan():
    full = {d.name: d.opts for d in full_plan()}
    for d in quick_plan():
        f = full[d.name]
        assert set(d.opts.residuals) <= set(f.residuals) and set(d.opts.pair_seeds) <= set(f.pair_seeds)
        assert (not d.opts.true_cameras or f.true_cameras) and (not d.opts.peers or f.peers)


def test_quick_numbers_equal_the_full_run_rows(quick, shared_data):
    """Same seeds => identical numbers: the full plan's caliscope/cut0 gives the quick rows again."""
    _, _, data, _ = quick
    rows, _ = rows_from_json(data)
    mine = {r.key: r for r in rows if r.dataset == "caliscope/cut0"}
    assert mine, "the quick run has no caliscope rows although the data is present"
    plan = [d for d in full_plan() if d.name == "caliscope/cut0"]
    full_rows, _ = run_plan(plan, shared_data, progress=False)
    full = {r.key: r for r in full_rows}
    for key, r in mine.items():
        assert key in full
        got, want = r.accuracy(), full[key].accuracy()
        assert all((a == b) or (isinstance(a, float) and math.isnan(a) and math.isnan(b))
                   for a, b in zip(got, want)), (key, got, want)


def test_tables_from_runs_of_different_commits_say_which_rows_came_from_which(quick, tmp_path):
    """--from-json of two runs made at different commits (the clips rerun after a change): the
    Machine line names each file's commit, not the first one's alone; one commit stays as it was."""
    _, _, data, _ = quick
    for name, commit in (("full.json", "aaaaaaa"), ("clips.json", "bbbbbbb"), ("same.json", "aaaaaaa")):
        (tmp_path / name).write_text(json.dumps({**data, "machine": {**data["machine"], "git_commit": commit}}))
    import io
    from contextlib import redirect_stdout
    with redirect_stdout(io.StringIO()):
        assert main(["bench", "accuracy", "--from-json", str(tmp_path / "full.json"), str(tmp_path / "clips.json"),
                     "--out", str(tmp_path / "two.md")]) == 0
        assert main(["bench", "accuracy", "--from-json", str(tmp_path / "full.json"), str(tmp_path / "same.json"),
                     "--out", str(tmp_path / "one.md")]) == 0
    assert "git_commit aaaaaaa (full.json), bbbbbbb (clips.json)," in (tmp_path / "two.md").read_text()
    assert "git_commit aaaaaaa," in (tmp_path / "one.md").read_text()
