"""vs-inspect bench: accuracy and speed of vs_inspect, its ablations and two classical peers."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import time

from ..bench.runner import (full_plan, machine, quick_plan, rows_from_json, rows_to_json, timed_run,
                            to_text, write_outputs)
from ..errors import InputError
from ..io.atomic import write_json_atomic


def _default_data() -> Path:
    here = Path(__file__).resolve().parents[2]
    return Path(os.environ.get("VS_INSPECT_DATA", here.parent / "shared" / "data"))


def register(sub) -> None:
    p = sub.add_parser(
        "bench", help="benchmark vs_inspect, its ablations and two classical peers (writes BENCHMARKS.md)",
        description="Runs vs_inspect (with the paper's ablations: residual, solver, spurious-pair "
                    "filter, pairs used, true vs estimated cameras) and two classical peers "
                    "(motion-signal cross-correlation, RANSAC-inlier criterion) on the same data: "
                    "cue-level synthetic scenes, the caliscope session with cut leading frames and "
                    "the VisualSync clips, and prints the tables. --quick runs a small subset "
                    "(a few minutes at most); the full run writes BENCHMARKS.md.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--quick", action="store_true", help="small subset (1 synthetic scene, 1 caliscope cut)")
    p.add_argument("--out", type=Path, default=None,
                   help="markdown file to write (default: BENCHMARKS.md for the full run, none for --quick)")
    p.add_argument("--json", type=Path, default=None, help="also write every row as JSON here")
    p.add_argument("--data", type=Path, default=None,
                   help="folder with the real data (default: $VS_INSPECT_DATA or ../shared/data)")
    p.add_argument("--only", default=None, metavar="PREFIX",
                   help="run only the datasets whose name starts with PREFIX (comma-separated list; e.g. cue/easy, caliscope, clips)")
    p.add_argument("--skip", default=None, metavar="PREFIX",
                   help="leave out the datasets whose name starts with PREFIX")
    p.add_argument("--from-json", type=Path, nargs="+", default=None, metavar="JSON",
                   help="do not run: write the tables of previous runs' --json files (rows concatenated)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.from_json is not None:
        rows, skipped, walls, cmds, info, commits = [], [], [], [], None, {}
        for f in args.from_json:  # a dataset in a later file replaces its rows from earlier files
            if not f.is_file():
                raise InputError(f"{f} not found")
            d = json.loads(f.read_text())
            r, s = rows_from_json(d)
            again = {x.dataset for x in r} | {x.name for x in s}
            rows = [x for x in rows if x.dataset not in again] + r
            skipped = [x for x in skipped if x.name not in again] + s
            walls.append(d.get("wall_s") or float("nan"))
            cmds.append(d.get("command", "vs-inspect bench"))
            info = info or d.get("machine")
            commits[f.name] = (d.get("machine") or {}).get("git_commit")
        if info is not None and len(set(commits.values())) > 1:  # rows of different code: say which is which
            info = {**info, "git_commit": ", ".join(f"{c} ({n})" for n, c in commits.items())}
        print(to_text(rows, skipped))
        cmd = "; ".join(f"{c} --json {f.name}" for c, f in zip(cmds, args.from_json))
        write_outputs(rows, skipped, max(walls), cmd, args.out, None, info)
        return 0
    plan = quick_plan() if args.quick else full_plan()
    if args.only:
        plan = [d for d in plan if d.name.startswith(tuple(args.only.split(",")))]
    if args.skip:
        plan = [d for d in plan if not d.name.startswith(tuple(args.skip.split(",")))]
    out = args.out if args.out is not None else (None if args.quick else Path("BENCHMARKS.md"))
    cmd = "vs-inspect bench" + (" --quick" if args.quick else "") + (f" --only {args.only}" if args.only else "") \
        + (f" --skip {args.skip}" if args.skip else "")
    info = machine()
    t0 = time.perf_counter()

    def save_partial(rows, skipped):  # a long run keeps what it has measured so far
        if args.json is not None:
            write_json_atomic(rows_to_json(rows, skipped, time.perf_counter() - t0, cmd + " (partial)", info,
                                           [d.name for d in plan]), args.json)

    rows, skipped, wall = timed_run(plan, args.data or _default_data(), not args.no_progress, save_partial)
    print(to_text(rows, skipped))
    for s in skipped:
        print(f"{s.name}: {s.why}")
    write_outputs(rows, skipped, wall, cmd, out, args.json, info)
    print(f"{len(rows)} runs on {len({r.dataset for r in rows})} datasets in {wall:.0f} s"
          + (f"; wrote {out}" if out else ""))
    return 0
