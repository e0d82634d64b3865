"""Shared CLI helpers: sync options from the config dataclasses, and the offsets table."""

from __future__ import annotations

import argparse
import math

from ..geometry.epipolar import RESIDUALS
from ..sync.config import (DecisionConfig, LandscapeConfig, PairSelection, SolveConfig,
                           SyncConfig)


def _doc(cls, name: str) -> str:
    """The docstring under a dataclass field (see sync/config.py)."""
    import ast
    import inspect
    tree = ast.parse(inspect.getsource(cls))
    body = tree.body[0].body
    for i, node in enumerate(body):
        if isinstance(node, ast.AnnAssign) and getattr(node.target, "id", None) == name:
            nxt = body[i + 1] if i + 1 < len(body) else None
            if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant):
                return str(nxt.value.value)
    return ""


def add_sync_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("synchronization (Stage 1 and 2)")
    g.add_argument("--energy", choices=RESIDUALS, default="sampson", help=_doc(LandscapeConfig, "residual"))
    g.add_argument("--loss", choices=("truncated", "mean"), default="truncated", help=_doc(LandscapeConfig, "loss"))
    g.add_argument("--solver", choices=("irls", "ls"), default="irls", help=_doc(SolveConfig, "solver"))
    g.add_argument("--no-spurious-filter", action="store_true", help=_doc(DecisionConfig, "enabled"))
    g.add_argument("--pairs", default="all", metavar="{all,FRACTION,rst}",
                   help="pairs of videos to evaluate: " + _doc(PairSelection, "mode"))
    g.add_argument("--seed", type=int, default=0, help="seed of random pair selection")
    g.add_argument("--reference", default=None, metavar="NAME", help=_doc(SolveConfig, "reference"))
    g.add_argument("--range-s", type=float, default=None, help=_doc(LandscapeConfig, "range_s"))
    g.add_argument("--step-s", type=float, default=None, help=_doc(LandscapeConfig, "step_s"))
    g.add_argument("--min-overlap-s", type=float, default=1.0, help=_doc(LandscapeConfig, "min_overlap_s"))
    g.add_argument("--huber-delta-s", type=float, default=None, help=_doc(SolveConfig, "huber_delta_s"))


def sync_config_from_args(args: argparse.Namespace) -> SyncConfig:
    return SyncConfig(
        landscape=LandscapeConfig(residual=args.energy, loss=args.loss, range_s=args.range_s,
                                  step_s=args.step_s, min_overlap_s=args.min_overlap_s),
        decision=DecisionConfig(enabled=not args.no_spurious_filter),
        solve=SolveConfig(solver=args.solver, reference=args.reference,
                          huber_delta_s=args.huber_delta_s),
        pairs=PairSelection.parse(args.pairs, args.seed),
    )


def fmt_s(x) -> str:
    return "null" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:+.4f}"


def offsets_table(offsets: dict, uncertainty: dict, truth: dict | None, reference: str,
                  unresolved: dict) -> str:
    """A short plain-text table of offsets, with the truth and error when known."""
    lines = []
    head = f"{'video':<16}{'offset_s':>11}{'± s':>9}"
    if truth:
        head += f"{'true_s':>11}{'error_ms':>10}"
    lines.append(head)
    ref_est = offsets.get(reference)
    for v, off in offsets.items():
        u = uncertainty.get(v)
        row = f"{v:<16}{fmt_s(off):>11}{('%.4f' % u) if u is not None else '-':>9}"
        if truth and v in truth:
            tv = truth[v] - truth.get(reference, 0.0)
            row += f"{tv:>+11.4f}"
            row += f"{1000 * abs(off - ref_est - tv):>10.1f}" if off is not None and ref_est is not None else f"{'-':>10}"
        if off is None:
            row += f"   ({unresolved.get(v, 'unresolved')})"
        lines.append(row)
    return "\n".join(lines)
