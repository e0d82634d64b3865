"""vs-inspect bench-recording: size and write time of recordings (.rrd), one line per case."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from ..bench.recording import CASES
from .bench import _default_data


def register(sub) -> None:
    p = sub.add_parser("bench-recording", help="size and write time of recordings (.rrd), one line per case",
                       description="Writes recordings of the demo scene (default options, --rrd-minimal, "
                                   "--rrd-all-offsets --rrd-all-tracks), of the size budget (4 videos x 10 s x "
                                   "30 fps 720p, every frame and mask sent) and of the caliscope session, "
                                   "checks each with `rerun rrd verify` and prints its size, the time spent "
                                   "recording and the run's time.")
    p.add_argument("cases", nargs="*", choices=CASES + ("all",), default="all", metavar="CASE",
                   help=f"cases to run: {', '.join(CASES)} or all (default: all)")
    p.add_argument("--out", type=Path, default=None, help="folder for the .rrd files (default: a temporary one, kept)")
    p.add_argument("--data", type=Path, default=None,
                   help="folder with the real data (default: $VS_INSPECT_DATA or ../shared/data)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..bench.recording import run_recording_bench

    cases = CASES if "all" in args.cases else tuple(args.cases)
    out = args.out or Path(tempfile.mkdtemp(prefix="vs-inspect-bench-rrd-"))
    out.mkdir(parents=True, exist_ok=True)
    run_recording_bench(cases, out, args.data or _default_data(), lambda s: print(s, flush=True))
    print(f"recordings in {out}")
    return 0
