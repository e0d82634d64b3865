"""Reading a run's result for what went wrong: pair disagreements and named suspects.

Works on the RunResult alone (from result.json, or from a recording's meta/result_json), so the
same diagnosis comes from a run folder or from an .rrd someone sent.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..types import RunResult, VideoInfo

if TYPE_CHECKING:
    from ..io.recording import RecordedVideo

DEFAULT_FRAME_MS = 40.0  # frame interval assumed for a video the caller gives no clock of

@dataclass(frozen=True)
class PairCheck:
    a: str
    b: str
    accepted: bool
    reason: str
    offset_s: float | None  # the pair's own Δ_ab (landscape minimum)
    solution_s: float | None  # s_b − s_a from the final offsets
    disagreement_ms: float | None  # |Δ_ab − (s_b − s_a)|, ms
    tolerance_ms: float  # beyond this the pair counts as inconsistent
    bad: bool  # rejected, or inconsistent with the solution


@dataclass(frozen=True)
class Suspect:
    kind: str  # "video" or "pair"
    name: str  # video name or "a__b"
    message: str


def _frame_ms(videos: dict[str, RecordedVideo | VideoInfo], name: str) -> float:
    v = videos.get(name)
    dt = v.frame_interval_s if v is not None else math.inf
    return 1000.0 * dt if math.isfinite(dt) else DEFAULT_FRAME_MS


def check_pairs(result: RunResult,
                videos: Iterable[RecordedVideo | VideoInfo] | None = None) -> list[PairCheck]:
    """Every evaluated pair against the final offsets, most disagreeing first (rejected pairs with
    a landscape minimum are compared too: a rejected pair that agrees is a cautious rejection).
    videos: the videos' clocks (a pair's tolerance is two frames of its slower video)."""
    by_name = {v.name: v for v in (videos or ())}
    offs = result.offsets_s
    out = []
    for p in result.pairs:
        a, b = p.a, p.b
        sa, sb = offs.get(a), offs.get(b)
        sol = (sb - sa) if sa is not None and sb is not None else None
        d = p.best_offset_s if math.isfinite(p.best_offset_s) else None
        dis = abs(d - sol) * 1000.0 if d is not None and sol is not None else None
        unc = p.uncertainty_s
        tol = max(2.0 * max(_frame_ms(by_name, a), _frame_ms(by_name, b)),
                  3000.0 * unc if math.isfinite(unc) else 0.0)
        bad = (not p.decision.accepted) or (dis is not None and dis > tol)
        out.append(PairCheck(a, b, bool(p.decision.accepted), p.decision.reason, d, sol, dis, tol, bad))
    out.sort(key=lambda c: (-(c.disagreement_ms if c.disagreement_ms is not None else -1.0), c.a, c.b))
    return out


def find_suspects(result: RunResult,
                  videos: Iterable[RecordedVideo | VideoInfo] | None = None) -> list[Suspect]:
    """Name the videos whose pairs mostly fail (a wrong camera pose, bad tracks, no shared motion)
    and the single pairs that fail between videos that are fine elsewhere (wrong matches)."""
    checks = check_pairs(result, videos)
    names = list(result.offsets_s)
    per: dict[str, list[PairCheck]] = {v: [] for v in names}
    for c in checks:
        per.setdefault(c.a, []).append(c)
        per.setdefault(c.b, []).append(c)
    out: list[Suspect] = []
    bad_video = set()
    for v, cs in per.items():
        n_bad = sum(c.bad for c in cs)
        if len(cs) >= 2 and n_bad / len(cs) >= 0.6:
            # only a suspect if its partners are mostly fine in pairs without v
            others = [c for c in checks if v not in (c.a, c.b)]
            others_bad = sum(c.bad for c in others) / len(others) if others else 0.0
            if others_bad < n_bad / len(cs):
                bad_video.add(v)
                rej = sum(not c.accepted for c in cs)
                inc = n_bad - rej
                out.append(Suspect("video", v, (
                    f"{v}: {n_bad} of {len(cs)} pairs fail ({rej} rejected, {inc} inconsistent with the "
                    f"solution) while only {others_bad:.0%} of the other pairs do: its camera pose, "
                    f"calibration or tracks are likely wrong")))
        if result.offsets_s.get(v, 0.0) is None and v not in bad_video:
            why = result.unresolved.get(v, "no accepted pair connects it")
            out.append(Suspect("video", v, f"{v}: not synchronized ({why})"))
    for c in checks:
        if not c.bad or c.a in bad_video or c.b in bad_video:
            continue
        fine = [v for v in (c.a, c.b)
                if sum(not x.bad for x in per[v] if x is not c) >= max(1, 0.5 * (len(per[v]) - 1))]
        if len(fine) < 2:
            continue
        key = f"{c.a}__{c.b}"
        if "no cross-view track pairs" in c.reason:
            msg = f"{key}: no cross-view track pairs: the views share no matched motion"
        elif c.accepted:
            msg = (f"{key}: accepted at Δ={c.offset_s:+.4f} s but the solution says {c.solution_s:+.4f} s "
                   f"({c.disagreement_ms:.0f} ms apart, tolerance {c.tolerance_ms:.0f} ms) while {c.a} and "
                   f"{c.b} agree elsewhere: this pair's matches are likely wrong (down-weighted by the solve)")
        else:
            extra = (f"; its minimum {c.offset_s:+.4f} s is {c.disagreement_ms:.0f} ms from the solution"
                     if c.disagreement_ms is not None else "")
            why = c.reason.lower()
            if "edge" in why:
                cause = "the true offset may lie outside its search range, or its matches are wrong"
            elif "ambiguous" in why:
                cause = "repetitive motion or wrong matches make two offsets look alike"
            else:
                cause = "this pair's cross-view matches are likely wrong"
            msg = f"{key}: rejected ({c.reason}){extra} while {c.a} and {c.b} agree elsewhere: {cause}"
        out.append(Suspect("pair", key, msg))
    return out
