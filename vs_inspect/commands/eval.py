"""vs-inspect eval: the paper's metrics of a result against true offsets."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import InputError
from ..eval.metrics import evaluate_offsets
from ..io.bundle import read_gt
from ..io.result import read_run_result


def register(sub) -> None:
    p = sub.add_parser("eval", help="score a result.json against true offsets",
                       description="Pairwise A@100 and A@500 (%) and per-video δ_mean / δ_med (ms) "
                                   "relative to the result's reference video.")
    p.add_argument("result", type=Path, help="result.json or the run folder holding it")
    p.add_argument("--gt", type=Path, required=True, help="gt.json with {'offsets_s': {...}}")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    res = read_run_result(args.result)
    gt = read_gt(args.gt)
    unknown = sorted(set(res.offsets_s) ^ set(gt))
    if unknown:
        raise InputError(f"result and ground truth name different videos: {unknown}")
    if res.reference not in gt:
        raise InputError(f"reference {res.reference!r} has no true offset")
    m = evaluate_offsets(res.offsets_s, gt, res.reference)
    f = lambda x: "nan" if not math.isfinite(x) else f"{x:.1f}"  # noqa: E731
    print(f"{'A@100':>8}{'A@500':>8}{'δ_mean_ms':>11}{'δ_med_ms':>10}{'δ_max_ms':>10}{'unresolved':>12}")
    print(f"{m.a100:>8.1f}{m.a500:>8.1f}{f(m.delta_mean_ms):>11}{f(m.delta_med_ms):>10}"
          f"{f(m.delta_max_ms):>10}{m.num_unresolved:>12}")
    for v, e in m.per_video_ms.items():
        print(f"  {v:<16}{'unresolved' if e is None else f'{e:.1f} ms'}")
    return 0
