"""vs-inspect bench-drone: pose-free sync with clock drift on the drone dataset vs its ground truth."""

from __future__ import annotations

import argparse
import pickle
from pathlib import Path

from ..bench.drone import format_table, load_drone_bundle, run_drone_bench
from ..engine import TaskFailed
from ..errors import InputError
from ..io.atomic import atomic_path


def register(sub) -> None:
    p = sub.add_parser("bench-drone", help="pose-free sync with drift on the drone dataset (offset and ppm errors)",
                       description="Estimates every camera pair's time shift, clock rate and fundamental "
                                   "matrix from the drone detections alone, runs the energy with that F and "
                                   "solves per-camera offset and drift (camera 0 fixed) -- the path of "
                                   "`sync --drift` -- and prints the errors against the README's "
                                   "ground truth, with the constant-offset model as the ablation.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("path", type=Path, help="a bundle written by import-drone, or the dataset folder")
    p.add_argument("--workers", type=int, default=2,
                   help="CPUs of an embedded Ray running the pairs in parallel (`sync --engine ray --ray-cpus N`); "
                        "1: in this process")
    p.add_argument("--no-truth-fit", action="store_true",
                   help="skip refitting F at the README's time map (the untimed per-pair comparison)")
    p.add_argument("--estimates", type=Path, default=None, metavar="FILE",
                   help="reuse the pairs' track estimates saved in FILE by an earlier run (pickle; "
                        "written there when missing): the wall time then leaves them out")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.workers < 1:
        raise InputError(f"--workers must be at least 1, got {args.workers}")
    bundle, drift = load_drone_bundle(args.path)
    est = None
    if args.estimates is not None and args.estimates.is_file():
        with open(args.estimates, "rb") as fh:  # a file this command wrote (trusted, like a cache)
            est = pickle.load(fh)
        print(f"track estimates of {len(est)} pairs from {args.estimates} (not timed)")
    res = run_drone_bench(bundle, drift, workers=args.workers, truth_fit=not args.no_truth_fit, estimates=est)
    if args.estimates is not None and est is None:
        with atomic_path(args.estimates) as tmp:
            # a pair whose task died is left out: a later run estimates it again
            tmp.write_bytes(pickle.dumps({k: p for k, p in res.pairs.items() if not isinstance(p, TaskFailed)}))
    print(format_table(res, bundle))
    return 0
