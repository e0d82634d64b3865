"""vs-inspect inspect: what a recording says about its run, read from the .rrd alone."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import InputError
from ..result_types import PairLandscape, RunResult
from ._common import add_gt_option, load_gt, offsets_table, sign_in_words

if TYPE_CHECKING:  # loaded when the command runs (the CLI starts without them)
    from ..analysis.diagnose import Diagnosis, PairCheck
    from ..io.recording import Recording


def register(sub) -> None:
    p = sub.add_parser("inspect", help="summarize a recording (.rrd): offsets, decisions, suspects",
                       description="Reads a vs_inspect recording alone (nothing is recomputed) and "
                                   "prints the videos and their offsets, each pair's decision with its "
                                   "reason, the pairs that most disagree with the final solution, the "
                                   "loops of three pairs, the cause of each failing pair (no "
                                   "cross-view pairs, flat landscape, inconsistent geometry or "
                                   "loops: pose or calibration, edge of the search range) and the "
                                   "videos or pairs to blame, or the one global cause when most "
                                   "pairs fail.")
    p.add_argument("rrd", type=Path, help="a .rrd written by vs-inspect sync/demo")
    p.add_argument("--pair", nargs=2, metavar=("A", "B"), help="also print this pair's landscape minima")
    p.add_argument("--top", type=int, default=5, help="how many disagreeing pairs and loops to list")
    add_gt_option(p)
    p.set_defaults(func=run)


def _pair_entry(result: RunResult, a: str, b: str) -> tuple[PairLandscape | None, float]:
    for p in result.pairs:
        if (p.a, p.b) == (a, b):
            return p, 1.0
        if (p.a, p.b) == (b, a):
            return p, -1.0
    return None, 1.0


def _not_a_run_folder(path: Path) -> None:
    """InputError pointing to `report` (and to the run's recording) for a run folder or a
    result.json: inspect reads recordings."""
    folder = path if path.is_dir() else path.parent if path.name == "result.json" or path.suffix == ".json" else None
    if folder is None or not path.exists():
        return
    raise InputError(f"{path} is {'a run folder' if path.is_dir() else 'a run' + chr(39) + 's ' + path.name}, "
                     f"not a recording: `vs-inspect report {folder}` draws its figures and index.html; "
                     "`inspect` reads the run's .rrd (sync printed where it wrote it: recordings/<name of --out>-<hash>.rrd "
                     "by default)")


def _opt(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _people_lines(people) -> str:
    """What the people in view gave Stage 0 (cue_stats.PeopleRecord), a few lines."""
    lines = [f"\npeople as correspondences ({'their cameras used' if people.kept else 'not used'}): {people.why}",
             "  people followed: " + ", ".join(f"{v} {n}" for v, n in people.people.items())]
    for key, p in people.pairs.items():
        shift = "refused" if p.offset_s is None else f"Δ {p.offset_s:+.4f} s" + (
            f" ± {p.offset_std_s:.4f}" if p.offset_std_s is not None else "")
        lines.append(f"  {key:<24} {shift}, {p.people_associated} people paired: {p.reason}")
    for v, why in people.refused.items():
        lines.append(f"  {v}: no camera: {why}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from ..analysis.diagnose import diagnose
    from ..io.recording import read_recording

    _not_a_run_folder(args.rrd)
    rec = read_recording(args.rrd)
    res = rec.result
    if args.pair and res is not None:  # a pair the run did not evaluate fails before the report
        a, b = args.pair
        if _pair_entry(res, a, b)[0] is None:
            known = ", ".join(f"{q.a} {q.b}" for q in res.pairs)
            raise InputError(f"--pair {a} {b}: this run evaluated no such pair; its pairs: {known or 'none'}")
    size_mb = args.rrd.stat().st_size / 1e6
    print(f"recording {args.rrd} ({size_mb:.1f} MB, vs_inspect {rec.meta.get('vs_inspect_version')}, "
          f"rerun {rec.meta.get('rerun_version')})")
    if res is None:
        raise InputError(f"{args.rrd}: the recording has no result (the run stopped before Stage 2)")
    gt = load_gt(args.gt, list(res.offsets_s), res.reference)
    truth = gt or res.gt_offsets_s or rec.gt_offsets_s
    frame_s = {v.name: v.frame_interval_s for v in rec.videos}
    _print_videos(rec, res, truth, frame_s)

    diag = diagnose(res, rec.videos, truth)
    pairs = res.pairs
    _print_pairs(pairs, diag, truth)
    _print_disagreeing(diag, args.top)
    _print_loops(diag, args.top)
    failing = _print_causes(diag)
    _print_suspects(diag, failing)

    if args.pair:
        a, b = args.pair
        _print_pair_minima(rec, res, pairs, a, b)
    return 0


def _print_videos(rec: Recording, res: RunResult, truth: dict[str, float] | None,
                  frame_s: dict[str, float]) -> None:
    """Prints the recording's videos, their offsets (with the truth when known) and what the
    people in view gave Stage 0."""
    print(f"\nvideos ({len(res.offsets_s)}), reference {res.reference}:")
    for v in rec.videos:
        rate = f"{v.fps:g} fps" if v.fps else "variable rate"
        print(f"  {v.name}: {v.width}x{v.height}, {v.num_frames} frames, {v.duration_s:.2f} s, {rate}")
    print(offsets_table(res.offsets_s, res.uncertainty_s, truth, res.reference, res.headlines(),
                        frame_s if truth else None))
    if sign_in_words(res.offsets_s, res.reference):
        print(sign_in_words(res.offsets_s, res.reference))

    if res.cues is not None and res.cues.people is not None:
        print(_people_lines(res.cues.people))


def _print_pairs(pairs: tuple[PairLandscape, ...], diag: Diagnosis, truth: dict[str, float] | None) -> None:
    """Prints every pair evaluated: its decision, Δ, track pairs, error (with the truth) and cause."""
    by_key = {c.key: c for c in diag.checks}
    acc = sum(p.decision.accepted for p in pairs)
    print(f"\npairs: {len(pairs)} evaluated, {acc} accepted, {len(pairs) - acc} rejected"
          + ("; error = |Δ − true Δ|" if truth else ""))
    for p in pairs:
        c = by_key[f"{p.a}__{p.b}"]
        off = f"{p.best_offset_s:+.4f} s" if _opt(p.best_offset_s) is not None else "none"
        err = f"error {c.error_ms:.1f} ms  " if c.error_ms is not None else ""
        cause = f" [{c.cause}]" if c.bad and c.cause else ""
        print(f"  {p.a + '__' + p.b:<24} {'accepted' if p.decision.accepted else 'REJECTED':<9} "
              f"Δ={off:<12} {p.num_track_pairs:>5} track pairs  {err}{p.decision.reason}{cause}")


def _print_disagreeing(diag: Diagnosis, top: int) -> None:
    """Prints the top pairs that most disagree with the final solution, each flagged."""
    checks = [c for c in diag.checks if c.disagreement_ms is not None]
    print("\nmost disagreeing with the final solution (|Δ_ab − (s_b − s_a)|, largest first; ok = "
          "within tolerance and every loop through it closes):")
    if not checks:
        print("  (no pair with both videos synchronized)")
    for c in checks[:top]:
        if c.disagreement_ms > c.tolerance_ms:
            flag = "INCONSISTENT"
        elif c.loops_bad:
            flag = f"LOOP OFF ({c.loops_bad} of {c.loops} loops miss, worst by {c.worst_loop_ms:.0f} ms)"
        else:
            flag = "ok"
        print(f"  {c.a + '__' + c.b:<24} {c.disagreement_ms:9.1f} ms  (Δ={c.offset_s:+.4f}, solution "
              f"{c.solution_s:+.4f}, tolerance {c.tolerance_ms:.0f} ms) {flag}"
              f"{'' if c.accepted else ', rejected: ' + c.reason}")


def _print_loops(diag: Diagnosis, top: int) -> None:
    """Prints how many loops of three pairs miss, and the top ones by residual."""
    print(f"\nloops of three pairs (Δ_ab + Δ_bc − Δ_ac should be 0): {len(diag.loops)}, "
          f"{sum(lp.bad for lp in diag.loops)} miss")
    for lp in sorted(diag.loops, key=lambda lp: -abs(lp.residual_ms))[:top]:
        a, b, c = lp.videos
        print(f"  {a} → {b} → {c}: {lp.residual_ms:+9.1f} ms (tolerance {lp.tolerance_ms:.1f} ms) "
              f"{'MISSES' if lp.bad else 'closes'}")


def _print_causes(diag: Diagnosis) -> list[PairCheck]:
    """Prints the failing pairs grouped by cause, with what each cause means; returns them."""
    from ..analysis.diagnose import CAUSE_MEANING

    print("\ncauses of the failing pairs:")
    failing = [c for c in diag.checks if c.bad]
    if not diag.checks:
        print("  none evaluated: Stage 0 left no pair to search (each video's reason is above)")
    elif not failing:
        print("  none: every pair is accepted and agrees with the solution")
    causes: dict[str, list[str]] = {}
    for c in failing:
        causes.setdefault(c.cause or "?", []).append(c.key)
    for cause, keys in sorted(causes.items(), key=lambda kv: -len(kv[1])):
        print(f"  {cause} ({len(keys)}): {', '.join(keys)}\n      {CAUSE_MEANING.get(cause, '')}")
    return failing


def _print_suspects(diag: Diagnosis, failing: list[PairCheck]) -> None:
    """Prints the videos and pairs to blame, the cautious rejections, the loops no suspect
    explains and the videos left unsynchronized as a consequence."""
    from ..analysis.diagnose import CAUSE_LOOPS

    print("\nsuspects:")
    if not diag.suspects:
        print("  none: no video or pair is to blame" if failing or not diag.checks else
              "  none: every pair agrees with the solution within its tolerance")
    for s in diag.suspects:
        print(f"  - {s.message}")
    for c in diag.cautious:
        print(f"  (not a suspect) {c.key}: rejected, but its minimum Δ={c.offset_s:+.4f} s closes "
              f"{c.loops - c.loops_bad} of {c.loops} loops: a cautious rejection ({c.reason})")
    for c in diag.unexplained:
        print(f"  (unexplained) {c.key}: {c.cause}: {c.reason}")
    blamed = {s.name for s in diag.suspects}
    for lp in diag.loops:
        keys = [f"{x}__{y}" for x, y in ((lp.videos[0], lp.videos[1]), (lp.videos[1], lp.videos[2]),
                                         (lp.videos[0], lp.videos[2]))]
        if lp.bad and not (set(lp.videos) | set(keys)) & blamed:
            print(f"  (loop) {' → '.join(lp.videos)} misses by {lp.residual_ms:+.1f} ms (tolerance "
                  f"{lp.tolerance_ms:.1f} ms): one of its pairs is off by about that much "
                  f"({CAUSE_LOOPS}: pose or calibration, or matches); "
                  + ("a single loop cannot tell which" if len(diag.loops) == 1 else
                     "no pair misses all of its loops"))
    for v, why in diag.consequences.items():
        print(f"  (consequence, not a suspect) {v}: not synchronized: {why}")


def _print_pair_minima(rec: Recording, res: RunResult, pairs: tuple[PairLandscape, ...], a: str, b: str) -> None:
    """Prints pair (a, b)'s decision, chosen Δ and landscape minima (in the order it was
    evaluated); InputError when the run did not evaluate it."""
    from ..io.recording_paths import pair_key

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
