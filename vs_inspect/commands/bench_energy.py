"""vs-inspect bench-energy: speed of the Stage 1 landscape against a plain numpy reference."""

from __future__ import annotations

import argparse

from ..bench.energy import format_rows, run_energy_bench


def register(sub) -> None:
    p = sub.add_parser("bench-energy", help="time the energy landscape (5,000 track pairs x 300 frames x 201 offsets)",
                       description="Times the compiled landscape kernel and a straightforward numpy "
                                   "reference in the same process, for a static pair and a pair with a "
                                   "moving camera, and prints a table with the speed-up.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--repeats", type=int, default=3, help="timed repeats of the kernel (median reported)")
    p.add_argument("--reference-offsets", type=int, default=201,
                   help="offsets the reference actually evaluates (its time is scaled to 201)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    print(format_rows(run_energy_bench(args.repeats, args.reference_offsets)))
    return 0
