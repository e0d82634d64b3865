"""vs-inspect inspect: what a recording says about its run, read from the .rrd alone."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..errors import InputError
from ..types import PairLandscape, RunResult
from ._common import offsets_table


def register(sub) -> None:
    p = sub.add_parser("inspect", help="summarize a recording (.rrd): offsets, decisions, suspects",
                       description="Reads a vs_inspect recording alone (nothing is recomputed) and "
                                   "prints the videos and their offsets, each pair's decision with its "
                                   "reason, the pairs that most disagree with the final solution and "
                                   "the videos or pairs that look broken.")
    p.add_argument("rrd", type=Path, help="a .rrd written by vs-inspect sync/demo")
    p.add_argument("--pair", nargs=2, metavar=("A", "B"), help="also print this pair's landscape minima")
    p.add_argument("--top", type=int, default=5, help="how many disagreeing pairs to list")
    p.set_defaults(func=run)


def _pair_entry(result: RunResult, a: str, b: str) -> tuple[PairLandscape | None, float]:
    for p in result.pairs:
        if (p.a, p.b) == (a, b):
            return p, 1.0
        if (p.a, p.b) == (b, a):
            return p, -1.0
    return None, 1.0


def _opt(x: float) -> float | None:
    return x if math.isfinite(x) else None


def run(args: argparse.Namespace) -> int:
    from ..analysis.diagnose import check_pairs, find_suspects
    from ..io.recording import pair_key, read_recording

    rec = read_recording(args.rrd)
    res = rec.result
    size_mb = args.rrd.stat().st_size / 1e6
    print(f"recording {args.rrd} ({size_mb:.1f} MB, vs_inspect {rec.meta.get('vs_inspect_version')}, "
          f"rerun {rec.meta.get('rerun_version')})")
    if res is None:
        raise InputError(f"{args.rrd}: the recording has no result (the run stopped before Stage 2)")
    truth = res.gt_offsets_s or rec.gt_offsets_s
    print(f"\nvideos ({len(res.offsets_s)}), reference {res.reference}:")
    for v in rec.videos:
        rate = f"{v.fps:g} fps" if v.fps else "variable rate"
        print(f"  {v.name}: {v.width}x{v.height}, {v.num_frames} frames, {v.duration_s:.2f} s, {rate}")
    print(offsets_table(res.offsets_s, res.uncertainty_s, truth, res.reference, res.unresolved))

    pairs = res.pairs
    acc = sum(p.decision.accepted for p in pairs)
    print(f"\npairs: {len(pairs)} evaluated, {acc} accepted, {len(pairs) - acc} rejected")
    for p in pairs:
        off = f"{p.best_offset_s:+.4f} s" if _opt(p.best_offset_s) is not None else "none"
        print(f"  {p.a + '__' + p.b:<24} {'accepted' if p.decision.accepted else 'REJECTED':<9} "
              f"Δ={off:<12} {p.decision.reason}")

    checks = [c for c in check_pairs(res, rec.videos) if c.disagreement_ms is not None]
    print("\nmost disagreeing with the final solution (|Δ_ab − (s_b − s_a)|, largest first):")
    if not checks:
        print("  (no pair with both videos synchronized)")
    for c in checks[: args.top]:
        flag = "INCONSISTENT" if c.disagreement_ms > c.tolerance_ms else "ok"
        print(f"  {c.a + '__' + c.b:<24} {c.disagreement_ms:9.1f} ms  (Δ={c.offset_s:+.4f}, solution "
              f"{c.solution_s:+.4f}, tolerance {c.tolerance_ms:.0f} ms) {flag}"
              f"{'' if c.accepted else ', rejected: ' + c.reason}")

    suspects = find_suspects(res, rec.videos)
    print("\nsuspects:")
    if not suspects:
        print("  none: every pair agrees with the solution within its tolerance")
    for s in suspects:
        print(f"  - {s.message}")

    if args.pair:
        a, b = args.pair
        p, sign = _pair_entry(res, a, b)
        if p is None:
            known = ", ".join(f"{q.a} {q.b}" for q in pairs)
            raise InputError(f"pair {a} {b} was not evaluated in this run; evaluated: {known}")
        print(f"\npair {p.a} → {p.b}" + (f" (evaluated in this order; Δ for {a} → {b} is the "
                                         "negative)" if sign < 0 else "") + ":")
        print(f"  {'accepted' if p.decision.accepted else 'REJECTED'}: {p.decision.reason}")
        print(f"  chosen Δ = {p.best_offset_s:+.4f} s" if _opt(p.best_offset_s) is not None else "  no minimum")
        print("  landscape minima (best first):")
        for i in p.minima_idx:
            o, e = float(p.offsets_s[i]), _opt(float(p.energy[i]))
            print(f"    Δ = {o:+.4f} s   E = {e:.6g}" if e is not None else f"    Δ = {o:+.4f} s")
        series = rec.landscapes.get(pair_key(p.a, p.b), {})
        if "energy" in series:
            e = series["energy"]
            print(f"  logged landscape: {len(e.offset_ms)} offsets from {e.offset_ms.min():+d} to "
                  f"{e.offset_ms.max():+d} ms on the offset_ms timeline")
    return 0
