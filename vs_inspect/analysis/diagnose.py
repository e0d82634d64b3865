"""Reading a run's result for what went wrong: each failed pair's cause, loops of three pairs,
the videos and pairs to blame, and when the cause is global instead.

Works on the RunResult alone (from result.json, or from a recording's meta/result_json), so the
same diagnosis comes from a run folder or from an .rrd someone sent.

How blame is assigned (each step explains failures, later steps see only what is unexplained):
  1. a video none of whose pairs has cross-view track pairs while the other pairs do is blind;
  2. loops of three pairs with a minimum: Δ_ab + Δ_bc − Δ_ac should be 0; a loop that misses by
     more than its tolerance is blamed on the pair in the largest share of bad loops;
  3. a video is a suspect when most of its (still unexplained) pairs fail, at least
     MIN_FAILING_PAIRS of them, while the pairs without it mostly do not; a failing pair that
     its loops already blame counts half (it has its own explanation);
  4. when most pairs fail and steps 1-3 explain few of them, the cause is global (too few track
     pairs, flat landscapes, ...): no video is blamed for what all of them share.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..eval.metrics import offset_errors_ms
from ..result_types import RunResult, SyncResult
from ..types import VideoInfo

if TYPE_CHECKING:
    from ..io.recording import RecordedVideo

DEFAULT_FRAME_MS = 40.0  # frame interval assumed for a video the caller gives no clock of
LOOP_TOLERANCE_FRAMES = 2.0  # a loop may miss by this many frames of its slowest video
MIN_FAILING_PAIRS = 2.0  # a suspect video has at least this many failing pairs (loop-blamed: 0.5)
SUSPECT_SHARE = 0.6  # ... and at least this share of its pairs fail

# cause categories of a failing pair (PairCheck.cause)
CAUSE_NO_PAIRS = "no cross-view pairs"
CAUSE_FLAT = "flat landscape"
CAUSE_GEOMETRY = "inconsistent geometry (pose or calibration)"
CAUSE_LOOPS = "inconsistent offsets around loops"
CAUSE_EDGE = "minimum at the edge of the search range"
CAUSE_AMBIGUOUS = "ambiguous landscape"
CAUSE_SUPPORT = "little overlap at the minimum"
CAUSE_WIDE = "too wide a minimum"
CAUSE_SOLUTION = "disagrees with the solution"

CAUSE_MEANING = {
    CAUSE_NO_PAIRS: "too few cross-view track pairs: the views share too little matched motion "
                    "(little overlap of the views, untextured or small moving objects, or the "
                    "matcher found few matches)",
    CAUSE_FLAT: "no offset fits clearly better than the others: wrong matches or no shared motion",
    CAUSE_GEOMETRY: "the epipolar lines miss the matched points even at the best offset: a wrong "
                    "camera pose or calibration (or wrong matches)",
    CAUSE_LOOPS: "the pair offsets do not add up around loops of three videos: a wrong pose or "
                 "calibration, or wrong matches on one pair",
    CAUSE_EDGE: "the true offset may lie outside the search range (--range-s or --around), or the matches are "
                "wrong",
    CAUSE_AMBIGUOUS: "two offsets fit alike: repetitive motion or wrong matches",
    CAUSE_SUPPORT: "the best offset rests on little overlap of the two videos' tracks: a chance dip",
    CAUSE_WIDE: "the best minimum is wider than a frame: too few track pairs or too shallow a dip to "
                "time the pair (with estimated cameras, their error can also flatten it)",
    CAUSE_SOLUTION: "the pair's own offset disagrees with the one the other pairs imply",
}


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
    cause: str | None = None  # CAUSE_* of a bad pair (None for a good one)
    num_track_pairs: int = 0
    loops: int = 0  # loops of three pairs (all with a minimum) through this pair
    loops_bad: int = 0  # of those, how many miss by more than their tolerance
    worst_loop_ms: float | None = None  # largest |Δ_ab + Δ_bc − Δ_ac| over its loops, ms
    error_ms: float | None = None  # |Δ_ab − true Δ_ab| in ms when the truth is given

    @property
    def key(self) -> str:
        return f"{self.a}__{self.b}"

    @property
    def ok(self) -> bool:
        """Accepted, within tolerance of the solution, and every loop through it closes."""
        return not self.bad and self.loops_bad == 0


@dataclass(frozen=True)
class Loop:
    videos: tuple[str, str, str]  # a, b, c in name order
    residual_ms: float  # Δ_ab + Δ_bc − Δ_ac, ms
    tolerance_ms: float

    @property
    def bad(self) -> bool:
        return abs(self.residual_ms) > self.tolerance_ms

    def pairs(self) -> tuple[frozenset, frozenset, frozenset]:
        a, b, c = self.videos
        return frozenset((a, b)), frozenset((b, c)), frozenset((a, c))


@dataclass(frozen=True)
class Suspect:
    kind: str  # "video", "pair", or "global" (the cause is shared by most pairs)
    name: str  # video name, "a__b", or "all"
    message: str
    cause: str | None = None  # CAUSE_* behind it


@dataclass(frozen=True)
class Diagnosis:
    checks: list[PairCheck]  # every pair, most disagreeing first
    loops: list[Loop]
    suspects: list[Suspect]
    global_cause: str | None  # CAUSE_* when most pairs fail for one shared reason
    cautious: list[PairCheck] = field(default_factory=list)  # rejected, yet its loops close
    unexplained: list[PairCheck] = field(default_factory=list)  # failing, blamed on nothing
    consequences: dict[str, str] = field(default_factory=dict)  # unresolved video -> why (not a suspect)


def _frame_ms(videos: dict[str, RecordedVideo | VideoInfo], name: str) -> float:
    v = videos.get(name)
    dt = v.frame_length_s if v is not None else math.inf
    return 1000.0 * dt if math.isfinite(dt) else DEFAULT_FRAME_MS


def _cause_of_reason(reason: str) -> str | None:
    r = reason.lower()
    if "track pairs" in r and ("no cross-view" in r or "too few" in r or "only" in r):
        return CAUSE_NO_PAIRS
    if "flat" in r:
        return CAUSE_FLAT
    if "epipolar inliers" in r:
        return CAUSE_GEOMETRY
    if "edge" in r:
        return CAUSE_EDGE
    if "ambiguous" in r:
        return CAUSE_AMBIGUOUS
    if "supported by" in r or "overlap" in r:
        return CAUSE_SUPPORT
    if "too wide" in r:
        return CAUSE_WIDE
    return None


def loop_closures(result: RunResult | SyncResult, videos: Iterable[RecordedVideo | VideoInfo] = ()) -> list[Loop]:
    """Every triangle of three pairs with a chosen offset (Δ_ba = −Δ_ab), names sorted, with its
    tolerance: LOOP_TOLERANCE_FRAMES frames of its slowest video, or 3σ of the three pairs'
    uncertainties when larger. The recording's loop table and inspect both read these."""
    return _loops(result, {v.name: v for v in videos})


def _loops(result: RunResult | SyncResult, by_name: dict) -> list[Loop]:
    delta: dict[tuple[str, str], float] = {}
    sigma: dict[frozenset, float] = {}
    for p in result.pairs:
        if math.isfinite(p.best_offset_s):
            delta[(p.a, p.b)] = p.best_offset_s
            delta[(p.b, p.a)] = -p.best_offset_s
            sigma[frozenset((p.a, p.b))] = p.uncertainty_s
    names = sorted({n for k in delta for n in k})
    out = []
    for a, b, c in itertools.combinations(names, 3):
        if (a, b) in delta and (b, c) in delta and (a, c) in delta:
            r = 1000.0 * (delta[(a, b)] + delta[(b, c)] - delta[(a, c)])
            tol = LOOP_TOLERANCE_FRAMES * max(_frame_ms(by_name, v) for v in (a, b, c))
            sig = [sigma[frozenset(x)] for x in ((a, b), (b, c), (a, c))]
            if all(math.isfinite(s) for s in sig):
                tol = max(tol, 3000.0 * math.sqrt(sum(s * s for s in sig)))
            out.append(Loop((a, b, c), r, tol))
    return out


def check_pairs(result: RunResult, videos: Iterable[RecordedVideo | VideoInfo] | None = None,
                gt: dict[str, float] | None = None) -> list[PairCheck]:
    """Every evaluated pair against the final offsets and its loops, most disagreeing first
    (rejected pairs with a landscape minimum are compared too: a rejected pair that agrees is a
    cautious rejection). videos: the videos' clocks (a pair's tolerance is two frames of its
    slower video). gt: true offsets, for each pair's error."""
    return _checks(result, videos, gt)[0]


def _checks(result: RunResult, videos, gt) -> tuple[list[PairCheck], list[Loop]]:
    by_name = {v.name: v for v in (videos or ())}
    loops = _loops(result, by_name)
    through: dict[frozenset, list[Loop]] = {}
    for lp in loops:
        for k in lp.pairs():
            through.setdefault(k, []).append(lp)
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
        inconsistent = dis is not None and dis > tol
        bad = (not p.decision.accepted) or inconsistent
        lps = through.get(frozenset((a, b)), [])
        nbad = sum(lp.bad for lp in lps)
        worst = max((abs(lp.residual_ms) for lp in lps), default=None)
        cause = None
        if bad:
            cause = _cause_of_reason(p.decision.reason) if not p.decision.accepted else None
            if cause is None:
                cause = CAUSE_LOOPS if lps and nbad == len(lps) else CAUSE_SOLUTION
        err = None
        if gt and a in gt and b in gt and d is not None:
            err = offset_errors_ms({a: 0.0, b: d}, gt, a)[b]  # the pair's Δ as b's offset from a
        out.append(PairCheck(a, b, bool(p.decision.accepted), p.decision.reason, d, sol, dis, tol,
                             bad, cause, int(p.num_track_pairs), len(lps), nbad, worst, err))
    out.sort(key=lambda c: (-(c.disagreement_ms if c.disagreement_ms is not None else -1.0), c.a, c.b))
    return out, loops


def _loop_blamed(checks: list[PairCheck], loops: list[Loop], skip: set[str]) -> set[frozenset]:
    """Pairs blamed by the loops: for every bad loop, the pair(s) with the largest share of bad
    loops, when that share is all of its loops (a pair with a closing loop is never blamed); pairs
    of a video in skip (already blamed itself) are not."""
    through: dict[frozenset, list[bool]] = {}  # pair -> badness of each loop through it
    for lp in loops:
        for k in lp.pairs():
            through.setdefault(k, []).append(lp.bad)
    share = {k: sum(bad) / len(bad) for k, bad in through.items()}
    blamed: set[frozenset] = set()
    for lp in loops:
        if not lp.bad:
            continue
        top = max(share[k] for k in lp.pairs())
        if top == 1.0:
            blamed |= {k for k in lp.pairs() if share[k] == top and not k & skip}
    return blamed


def diagnose(result: RunResult, videos: Iterable[RecordedVideo | VideoInfo] | None = None,
             gt: dict[str, float] | None = None) -> Diagnosis:
    """The whole diagnosis: checks, loops, suspects (or one global cause) and the rest."""
    checks, loops = _checks(result, videos, gt)
    names = list(result.offsets_s)
    per: dict[str, list[PairCheck]] = {v: [] for v in names}
    for c in checks:
        per.setdefault(c.a, []).append(c)
        per.setdefault(c.b, []).append(c)
    bad = [c for c in checks if c.bad]
    # 1. blind videos, 2. + 3. loops, then videos whose unexplained pairs mostly fail
    suspects, accused = _blind_videos(result, checks, per)
    failing, accused, blamed = _failing_videos(checks, loops, per, names, accused)
    suspects += failing
    # 4. pairs: loop-blamed, or failing between videos that are fine elsewhere
    pair_suspects, cautious, unexplained = _pair_suspects(checks, per, accused, blamed)
    global_cause = None
    overall = _global_suspect(result, checks, bad, names, accused, pair_suspects)
    if overall is not None:
        global_cause = overall.cause
        suspects = [overall]
        pair_suspects, cautious, unexplained = [], [], []
        accused = set()
    suspects += pair_suspects
    unsynced, consequences = _unsynchronized(result, names, per, accused)
    suspects += unsynced
    return Diagnosis(checks, loops, suspects, global_cause, cautious, unexplained, consequences)


def _blind_videos(result: RunResult, checks: list[PairCheck], per: dict[str, list[PairCheck]]
                  ) -> tuple[list[Suspect], set[str]]:
    """(suspects, their videos) of the videos with no cross-view pairs in any of their pairs,
    while the others have some."""
    suspects: list[Suspect] = []
    accused: set[str] = set()
    for v, cs in per.items():
        if len(cs) < 2 or not all(c.bad and c.cause == CAUSE_NO_PAIRS for c in cs):
            continue
        others = [c for c in checks if v not in (c.a, c.b)]
        if others and sum(c.cause == CAUSE_NO_PAIRS for c in others) / len(others) < 0.5:
            accused.add(v)
            lo, hi = min(c.num_track_pairs for c in cs), max(c.num_track_pairs for c in cs)
            why = (result.cues.geometric_refusal(v) if result.cues is not None else None) or \
                "it does not see the shared motion, or its tracks or matches failed"
            suspects.append(Suspect("video", v, (
                f"{v}: {CAUSE_NO_PAIRS}: none of its {len(cs)} pairs has enough cross-view track "
                f"pairs ({f'{lo}-{hi}' if lo != hi else lo} track pairs) while most other pairs do: "
                f"{why}"), CAUSE_NO_PAIRS))
    return suspects, accused


def _failing_videos(checks: list[PairCheck], loops: list[Loop], per: dict[str, list[PairCheck]],
                    names: list[str], accused: set[str]) -> tuple[list[Suspect], set[str], set[frozenset]]:
    """(suspects, all accused videos, loop-blamed pairs): videos whose pairs not explained by
    the accused or by loops mostly fail, the worst first, each accusation changing the rest."""
    accused = set(accused)
    suspects: list[Suspect] = []
    blamed = _loop_blamed(checks, loops, accused)
    while True:
        best = _worst_video(checks, per, names, accused, blamed)
        if best is None:
            break
        v, fail, others_bad = best
        accused.add(v)
        blamed = _loop_blamed(checks, loops, accused)
        causes = Counter(c.cause for c in fail)
        main, _ = causes.most_common(1)[0]
        all_cs = per[v]
        n_bad_all = sum(c.bad for c in all_cs)
        rej = sum(not c.accepted for c in all_cs)
        inc = n_bad_all - rej
        what = ", ".join(f"{n} {k}" for k, n in Counter(c.cause for c in all_cs if c.bad).most_common())
        suspects.append(Suspect("video", v, (
            f"{v}: {n_bad_all} of {len(all_cs)} pairs fail ({rej} rejected, {inc} inconsistent with "
            f"the solution; {what}) while only {others_bad:.0%} of the other pairs do: "
            + _video_blame(main)), main))
    return suspects, accused, blamed


def _worst_video(checks: list[PairCheck], per: dict[str, list[PairCheck]], names: list[str], accused: set[str],
                 blamed: set[frozenset]) -> tuple[str, list[PairCheck], float] | None:
    """(video, its failing pairs, the share of the other pairs failing) of the video not yet
    accused whose pairs fail most (MIN_FAILING_PAIRS, SUSPECT_SHARE, more than the others);
    None when there is none such."""
    best = None
    for v, cs in per.items():
        if v in accused or len(cs) < 2:
            continue
        mine = [c for c in cs if not ({c.a, c.b} - {v}) & accused]
        fail = [c for c in mine if c.bad]
        if not mine:
            continue
        score = sum(0.5 if frozenset((c.a, c.b)) in blamed else 1.0 for c in fail)
        others = [c for c in checks if v not in (c.a, c.b) and not {c.a, c.b} & accused]
        others_bad = sum(c.bad for c in others) / len(others) if others else 0.0
        share = len(fail) / len(mine)
        if score >= MIN_FAILING_PAIRS and share >= SUSPECT_SHARE and others_bad < share:
            homogeneous = Counter(c.cause for c in fail).most_common(1)[0][1]
            key = (score, share, homogeneous, -names.index(v) if v in names else 0)
            if best is None or key > best[0]:
                best = (key, v, fail, others_bad)
    return None if best is None else best[1:]


def _pair_suspects(checks: list[PairCheck], per: dict[str, list[PairCheck]], accused: set[str],
                   blamed: set[frozenset]) -> tuple[list[Suspect], list[PairCheck], list[PairCheck]]:
    """(suspect pairs, cautious pairs, unexplained pairs) among the failing pairs of videos not
    accused."""
    cautious, unexplained = [], []
    pair_suspects = []
    for c in checks:
        if not c.bad or {c.a, c.b} & accused:
            continue
        k = frozenset((c.a, c.b))
        if k in blamed:
            pair_suspects.append(Suspect("pair", c.key, _pair_message(c, loop=True), CAUSE_LOOPS))
            continue
        if (not c.accepted and c.loops and c.loops_bad < c.loops
                and c.cause not in (CAUSE_NO_PAIRS, CAUSE_FLAT, CAUSE_AMBIGUOUS)):
            # a clear minimum that closes a loop: the offset is right, the decision cautious (a
            # flat or ambiguous landscape whose weak minimum lands right by chance still failed)
            cautious.append(c)
            continue
        fine = [v for v in (c.a, c.b)
                if sum(not x.bad for x in per[v] if x is not c) >= max(1, 0.5 * (len(per[v]) - 1))]
        if len(fine) == 2:
            pair_suspects.append(Suspect("pair", c.key, _pair_message(c, loop=False), c.cause))
        else:
            unexplained.append(c)
    return pair_suspects, cautious, unexplained


def _global_suspect(result: RunResult, checks: list[PairCheck], bad: list[PairCheck], names: list[str],
                    accused: set[str], pair_suspects: list[Suspect]) -> Suspect | None:
    """The global verdict, when most pairs fail and what the suspects explain is little of it
    (None: the suspects stand)."""
    explained = [c for c in bad if {c.a, c.b} & accused or any(s.name == c.key for s in pair_suspects)]
    if not (bad and len(bad) > 0.5 * len(checks) and (len(explained) < 0.5 * len(bad)
                                                      or len(accused) > len(names) / 2)):
        return None
    causes = Counter(c.cause for c in bad)
    global_cause = causes.most_common(1)[0][0]
    spread = ", ".join(f"{n} {k}" for k, n in causes.most_common())
    extra, stage0 = "", ""
    if global_cause == CAUSE_NO_PAIRS:
        counts = [c.num_track_pairs for c in bad if c.cause == CAUSE_NO_PAIRS]
        extra = f" ({min(counts)}-{max(counts)} track pairs per pair)"
        if refused := (result.cues.refused_in_three_views() if result.cues is not None else []):
            stage0 = (f"; Stage 0 refused {', '.join(refused)} in three views (their tracks do not "
                      f"follow the points the other cameras triangulate at the joint vote's offsets), "
                      f"which points to wrong estimated cameras: a calibration (--calib) or other "
                      f"camera features (--sfm-features) may help")
        stage0 += _tracks_found(result.cues)
    msg = (f"most pairs fail ({len(bad)} of {len(checks)}: {spread}): the cause is global: "
           f"{global_cause}{extra}: {CAUSE_MEANING[global_cause]}; no single video or pair "
           f"is to blame{stage0}")
    return Suspect("global", "all", msg, global_cause)


def _unsynchronized(result: RunResult, names: list[str], per: dict[str, list[PairCheck]], accused: set[str]
                    ) -> tuple[list[Suspect], dict[str, str]]:
    """(suspects, consequences) of the videos left without an offset and not accused: a suspect
    when none of its pairs was evaluated, else a consequence of the others' failures."""
    suspects: list[Suspect] = []
    consequences: dict[str, str] = {}
    for v in names:
        if result.offsets_s.get(v, 0.0) is not None or v in accused:
            continue
        why = result.unresolved.get(v, "no accepted pair connects it")
        if not per.get(v):  # nothing was evaluated for it: its own problem
            suspects.append(Suspect("video", v, f"{v}: not synchronized ({why})"))
        else:
            consequences[v] = why
    return suspects, consequences


def _tracks_found(cues) -> str:
    """What Stage 0 had to pair, per video: its tracks and how much of its frames moved, and
    which cameras moved (their moving regions are what one homography per frame pair leaves
    unexplained: slow objects are missed and parallax is marked)."""
    if cues is None or not cues.videos:
        return ""
    per = ", ".join(f"{n} {v.tracks} ({100 * v.moving_fraction:.1f} %)" for n, v in cues.videos.items())
    moved = [n for n, v in cues.videos.items() if v.camera_motion == "moving"]
    out = f"; Stage 0's tracks per video (share of the frames in moving regions): {per}"
    if moved:
        out += (f"; {', '.join(moved)} moved: their moving regions are what one homography per frame "
                f"pair leaves unexplained, which misses slow objects and marks parallax "
                f"(--camera-motion NAME=static for a camera that did not move)")
    return out


def _video_blame(cause: str | None) -> str:
    if cause == CAUSE_NO_PAIRS:
        return "it shares too little matched motion with the others (its tracks or matches)"
    if cause in (CAUSE_GEOMETRY, CAUSE_LOOPS, CAUSE_SOLUTION):
        return "its camera pose or calibration is likely wrong"
    if cause == CAUSE_FLAT:
        return ("no offset fits any of its pairs: its camera pose or calibration is likely wrong "
                "(or its tracks)")
    if cause == CAUSE_EDGE:
        return "its true offset likely lies outside the search range (--range-s or --around)"
    return f"{cause}: {CAUSE_MEANING.get(cause, '')}"


def _pair_message(c: PairCheck, loop: bool) -> str:
    key = c.key
    if c.cause == CAUSE_NO_PAIRS and not loop:
        return f"{key}: {CAUSE_NO_PAIRS}: the views share no matched motion ({c.reason})"
    if c.accepted and c.disagreement_ms is not None and c.disagreement_ms > c.tolerance_ms:
        head = (f"{key}: accepted at Δ={c.offset_s:+.4f} s but the solution says {c.solution_s:+.4f} s "
                f"({c.disagreement_ms:.0f} ms apart, tolerance {c.tolerance_ms:.0f} ms)")
        tail = "this pair's matches are likely wrong (down-weighted by the solve)"
    elif c.accepted:
        head, tail = f"{key}: accepted at Δ={c.offset_s:+.4f} s", "this pair's matches are likely wrong"
    else:
        extra = (f"; its minimum {c.offset_s:+.4f} s is {c.disagreement_ms:.0f} ms from the solution"
                 if c.disagreement_ms is not None else "")
        head = f"{key}: rejected ({c.reason}){extra}"
        tail = f"{c.cause}: {CAUSE_MEANING.get(c.cause, 'its cross-view matches are likely wrong')}"
    if loop:
        return (f"{head}; it breaks {c.loops_bad} of {c.loops} loops of three pairs (worst by "
                f"{c.worst_loop_ms:.0f} ms) while the other pairs close theirs: {CAUSE_LOOPS}: "
                + ("this pair's matches are likely wrong" if not c.accepted else tail))
    return f"{head} while {c.a} and {c.b} agree elsewhere: {tail}"


def find_suspects(result: RunResult,
                  videos: Iterable[RecordedVideo | VideoInfo] | None = None) -> list[Suspect]:
    """The videos and pairs to blame (or one "global" suspect when most pairs fail for a shared
    reason); see diagnose()."""
    return diagnose(result, videos).suspects
