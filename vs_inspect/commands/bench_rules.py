"""vs-inspect bench-rules: what each of Stage 0's acceptance rules and camera paths is worth."""

from __future__ import annotations

import argparse
import datetime
from pathlib import Path

from .bench import _default_data


def register(sub) -> None:
    p = sub.add_parser("bench-rules", help="each acceptance rule left out in turn, offsets counted per set",
                       description="Runs the whole pipeline on the measured sets with every acceptance rule "
                                   "and camera path, then with each one left out, and prints per set the "
                                   "offsets within 1 frame, over 2 frames and null; then drops, in order, "
                                   "each rule whose absence makes no set worse. Each scene's expensive steps "
                                   "are kept in --scratch, so the variants replay decisions only and a "
                                   "stopped run resumes.")
    p.add_argument("--sets", nargs="+", default=["clips", "caliscope", "demo", "arcs:seeds-10-21"],
                   help="clips, caliscope, demo, arcs:SET (default: all four, arcs:seeds-10-21)")
    p.add_argument("--scratch", type=Path, required=True, help="folder for the inputs made and the kept steps")
    p.add_argument("--rules", nargs="+", help="only these rules (default: all, in their order)")
    p.add_argument("--markdown", type=Path, help="also write the tables here")
    p.add_argument("--data", type=Path, default=None, help="real data (default: $VS_INSPECT_DATA or ../shared/data)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..bench.rules import run as ablate
    from ..bench.runner import machine
    from ..io.atomic import write_text_atomic

    args.scratch.mkdir(parents=True, exist_ok=True)
    tables = ablate(args.sets, args.data or _default_data(), args.scratch, args.rules, lambda m: print(m, flush=True))
    m = machine()
    text = (f"Command: `vs-inspect bench-rules --sets {' '.join(args.sets)}`, {datetime.date.today()}, commit "
            f"{m.get('git_commit', '?')}, {m.get('cpu', m['processor'])}, {m['cpu_count']} cores.\n\n{tables}")
    print(text)
    if args.markdown:
        write_text_atomic(text, args.markdown)
    return 0
