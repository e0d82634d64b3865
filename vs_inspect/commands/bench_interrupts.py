"""vs-inspect bench-interrupts: Ctrl-C and SIGTERM at a sweep of moments of every long command."""

from __future__ import annotations

import argparse
import platform
import subprocess
import time
from pathlib import Path

from ._common import positive_float, positive_int


def register(sub) -> None:
    p = sub.add_parser("bench-interrupts", help="interrupt every long command at a sweep of moments",
                       description="Makes small synthetic inputs in --workdir, then runs each long "
                                   "command (sync from videos during Stage 0 and during Stage 1, sync "
                                   "of a bundle, report during 3D rendering and during PNG writing, "
                                   "export --mosaic, demo) once to time it, and again for each signal "
                                   "(SIGINT, SIGTERM) and each moment of a sweep over that time: each "
                                   "must exit 130 or 143 with exactly one line on stderr, no traceback, "
                                   "no crash, and leave its outputs exactly as they were before (or "
                                   "complete, when the signal came after its work was done). Prints a "
                                   "table: command, signal, runs, ok, missed (finished before the "
                                   "signal), failures, and the seconds from the signal to the end of the process (median, max).")
    p.add_argument("--workdir", type=Path, required=True, help="folder for the inputs and the runs (inputs are reused)")
    p.add_argument("--moments", type=positive_int, default=10, help="moments per command and signal")
    p.add_argument("--repeats", type=positive_int, default=3, help="times the whole sweep is run")
    p.add_argument("--only", nargs="+", default=None, metavar="WORD",
                   help="only the commands whose name contains one of these words (e.g. report demo)")
    p.add_argument("--grace-s", type=positive_float, default=10.0,
                   help="VS_INSPECT_STOP_GRACE_S of the interrupted commands")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..bench.interrupts import run_sweep, table

    t0 = time.perf_counter()
    outcomes = run_sweep(args.workdir, args.moments, args.repeats, args.only, grace_s=args.grace_s,
                         report=lambda s: print(s, flush=True))
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=Path(__file__).parent,
                                capture_output=True, text=True, timeout=10).stdout.strip() or "?"
    except (OSError, subprocess.SubprocessError):
        commit = "?"
    print(f"\nbench-interrupts --moments {args.moments} --repeats {args.repeats}: "
          f"{time.strftime('%Y-%m-%d', time.gmtime())}, commit {commit}, "
          f"{platform.machine()}, {len(outcomes)} runs in {time.perf_counter() - t0:.0f} s")
    print(table(outcomes))
    failed = [o for o in outcomes if not o.ok]
    return 0 if not failed else 2
