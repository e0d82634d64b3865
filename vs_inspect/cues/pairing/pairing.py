"""Stage 0's joint vote on one set of cameras: which cross-view track pairs Stage 1 gets.

For every pair of cameras, geometric_pairs votes for the offsets at which track pairs stay on
their epipolar lines. Here those votes become decisions: the offsets of all cameras chosen
together (or the peaks that close every triangle), which cameras are sure of theirs (the
three-view checks of cues/pairing/transfer.py agree), the supporters of the trusted offsets added
to the descriptor pairs. The pairing's decisions come back as notes in words (the Stage 0
controller reports them). No I/O.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from tqdm import tqdm

from ...cue_stats import JointVoteRecord, PairVoteSummary
from ...geometry.offsets import OffsetGrid
from ...memo import NO_MEMO, Memo
from ...progress import stage
from ..config import CueConfig
from ..rules import ALL
from ..records import Note, say
from .joint_checks import _check_in_three_views, _confirm_by_transfer
from .kept_pairs import (_JointChecks, _add_joint_pairs, _add_transfer_pairs, _consistent_descriptor_pairs,
                         _merge_pairs)

# The vote's decisions are logged at INFO (`-v`): the recording and result.json hold them in full,
# and the console ends with one plain reason per unresolved video.
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class GeometricPairing:
    """What add_geometric_pairs made of one set of cameras."""

    pairs: dict  # (a, b) -> TrackPairs: the descriptor pairs kept plus the geometric ones
    voted: dict  # (a, b) -> the Δ_ab (s) whose supporters were added
    peaks_s: dict  # (a, b) -> tuple of the pair's vote peaks Δ_ab (s), as the vote found them
    status: str  # how the peaks were chosen: "joint", or consistent_peaks' status
    votes: dict  # (a, b) -> PairVoteSummary of what its vote found and kept
    transfer_new: dict  # (a, b) -> track pairs point transfer added
    joint: JointVoteRecord | None  # the joint vote, None when the triangles decided
    found: dict = field(default_factory=dict)  # (a, b) -> GeometricPairStats: the pair's vote
    chosen_s: dict = field(default_factory=dict)  # (a, b) -> the Δ_ab whose supporters were kept, or None
    transfer: dict = field(default_factory=dict)  # camera -> transfer.TransferCheck of an unsure camera
    three_view: dict = field(default_factory=dict)  # camera -> transfer.ThreeViewCheck of a sure camera
    notes: tuple[Note, ...] = ()  # the decisions in words, in order


def add_geometric_pairs(pairs: dict, cameras: dict, tracks: dict, vids: dict, cfg: CueConfig,
                        progress: bool, estimated: bool,
                        grid: OffsetGrid = OffsetGrid(), rules: frozenset[str] = ALL,
                        memo: Memo = NO_MEMO) -> GeometricPairing:
    """Descriptor pairs plus epipolar-consistency pairs for every pair of known cameras (a moving
    one with its per-frame poses), the Δ_ab whose supporters were added and every pair's vote peaks.
    estimated: Stage 0 estimated the cameras (no calibration given); only then are sure cameras
    checked in three views. grid: the limits of every vote's offsets (overlap,
    range), the point transfer's included; its --around windows hold the peaks and offsets chosen.

    With three or more such cameras, the vote peaks whose offsets close every triangle
    (Δ_ab + Δ_bc ≈ Δ_ac) are chosen and only their supporters kept. When no choice closes the
    triangles, the peaks of at least one pair are all wrong and Stage 1 could not tell (the
    pairs were picked to agree with them), so no geometric pair is added; nor with three cameras,
    whose one triangle's closure is too weak a check (consistent_peaks: "one triangle"). With two static
    cameras (no triangle) every kept peak's supporters are added, marked TrackPairs.unchecked (Stage 1
    accepts the pair only if its descriptor pairs alone give the same minimum); with a moving
    camera, none (GeometricPairConfig.unchecked_moving).
    """
    from .joint import joint_offsets

    found = _vote_on_every_pair(pairs, cameras, tracks, vids, progress, grid, memo)
    peaks_s = {k: tuple(gs.peaks_s) for k, (_, gs) in found.items()}
    votes = {k: gs for k, (_, gs) in found.items()}  # each pair's vote evidence
    notes: list[Note] = []
    coarsest = max((vids[n].info.frame_interval_s for k in found for n in k), default=0.0)
    # each of a triangle's three peaks is located to about ±1 frame (its support window), so
    # right peaks close within about 3 frames, while wrong ones miss by far more
    with stage("geometric pairs: every camera's offset chosen at once", progress and cfg.geometric.joint):
        joint = joint_offsets(votes, 3.0 * coarsest) if cfg.geometric.joint else None
    third = "moving_pair_third" in rules
    sure, three_view, dissent, dissent_short = _sure_cameras(
        found, votes, joint, cameras, tracks, vids, cfg, notes, coarsest, estimated, progress, grid, third, rules,
        memo)
    refused = bool(dissent) or any(not chk.passed for chk in three_view.values())
    # a camera refused (by its pairs or in three views) keeps the joint path (no geometric pair
    # for it), instead of the triangle fallback below choosing among the same cameras' vote peaks
    if sum(sure.values()) >= 2 or refused or ("triangle_fallback" not in rules and joint is not None):
        checks, traj = {}, None
        if "transfer" in rules and cfg.geometric.transfer and not all(sure.values()) and sum(sure.values()) >= 2:
            # not of a camera its own pairs contradict: point transfer projects into the same
            # camera, whose biased geometry it can then confirm at a wrong offset
            with stage("geometric pairs: unsure cameras checked by point transfer", progress):
                checks, traj = _confirm_by_transfer(found, joint, sure, cameras, tracks, vids, cfg, notes,
                                                    frozenset(dissent), grid, third, memo)
        sure = {n: ok or (n in checks and checks[n].confirmed) for n, ok in sure.items()}
        said = _JointChecks({c: chk.summary(traj.num_trajectories) for c, chk in checks.items()},
                            {c: chk.summary() for c, chk in three_view.items()}, dissent, dissent_short)
        out, used, summaries, record, chosen = _add_joint_pairs(pairs, found, joint, sure, cameras, tracks, vids,
                                                                cfg, notes, said, rules)
        out, transfer_new = _add_transfer_pairs(out, checks, traj, list(vids), notes)
        return GeometricPairing(out, used, peaks_s, "joint", summaries, transfer_new, record, votes, chosen,
                                checks, three_view, tuple(notes))
    if joint is not None:
        # sure of fewer than two cameras, the joint vote has chosen nothing: the triangle rule
        # decides (and refuses when the triangles do not close)
        say(notes, "joint vote sure of fewer than two cameras (margins "
            + ", ".join(f"{n} {m:.1f}" for n, m in joint.margin.items())
            + "): geometric peaks chosen by triangle closure")
    return _triangle_pairing(pairs, found, joint, cameras, tracks, vids, cfg, notes, coarsest, peaks_s, votes,
                             rules)


def _vote_on_every_pair(pairs: dict, cameras: dict, tracks: dict, vids: dict, progress: bool,
                        grid: OffsetGrid, memo: Memo) -> dict:
    """{(a, b): (TrackPairs, GeometricPairStats)}: geometric_pairs' vote on every pair of cameras
    in pairs."""
    from .votes import VOTE, geometric_pairs

    # every pair of cameras: a moving one with its per-frame poses (two moving ones: the
    # geometry per frame of b and per offset)
    todo = list(pairs)
    found = {}
    for a, b in tqdm(todo, desc="geometric pairs", unit="pair", disable=not progress, leave=False):
        found[(a, b)] = memo.call("votes", geometric_pairs, a, b, vids[a].info, vids[b].info, cameras[a],
                                  cameras[b], tracks[a].xy, tracks[b].xy, VOTE, grid)
    return found


def _sure_cameras(found: dict, votes: dict, joint, cameras: dict, tracks: dict, vids: dict, cfg: CueConfig,
                  notes: list[Note], coarsest: float, estimated: bool, progress: bool, grid: OffsetGrid,
                  third: bool, rules: frozenset[str], memo: Memo) -> tuple[dict, dict, dict, dict]:
    """(sure, three_view, dissent, dissent_short): whether the joint vote is sure of each camera
    ({camera: bool}: its margin is wide enough), then unsure of those that fail a check, in turn:
    the three-view check of estimated cameras (three_view: {camera: transfer.ThreeViewCheck}), a
    rival offset in three views. dissent: {camera: why it was made unsure}, dissent_short: the
    same in a few words. Each decision is said in notes."""
    sure = {} if joint is None else {n: m >= cfg.geometric.joint_min_margin or "margin" not in rules
                                     for n, m in joint.margin.items()}
    three_view = {}
    # the check is of cameras Stage 0 estimated: a calibration's are given (and a right calibrated
    # camera can follow as few trajectories as a wrong estimated one)
    if "three_view" in rules and cfg.geometric.three_view_min_supporters > 0 and estimated and sum(sure.values()) >= 3:
        with stage("geometric pairs: each sure camera checked against the others' 3D points", progress):
            three_view = _check_in_three_views(found, joint, sure, cameras, tracks, vids, cfg, notes, grid, third,
                                               memo)
        sure = {n: ok and (n not in three_view or three_view[n].passed) for n, ok in sure.items()}
    dissent, dissent_short = {}, {}  # camera -> why it was made unsure; the same in a few words
    # three_view is only filled for estimated cameras (a calibration's are given)
    if "rival_offset" in rules and three_view and cfg.geometric.three_view_rival_frames > 0:
        from .rules import rival_offsets

        best = {n: (chk.best_offset_s, chk.best_supporters, chk.supporters) for n, chk in three_view.items()
                if chk.best_offset_s is not None}
        rivals = rival_offsets(votes, joint, sure, best, cfg.geometric.three_view_rival_frames * coarsest,
                               cfg.geometric.three_view_rival_vote_share)
        _not_sure(rivals, sure, dissent, notes, dissent_short,
                  {n: f"two offsets {abs(best[n][0] - joint.offsets_s[n]):.2f} s apart, as a repeated motion gives"
                   for n in rivals})
    return sure, three_view, dissent, dissent_short


def _triangle_pairing(pairs: dict, found: dict, joint, cameras: dict, tracks: dict, vids: dict, cfg: CueConfig,
                      notes: list[Note], coarsest: float, peaks_s: dict, votes: dict,
                      rules: frozenset[str]) -> GeometricPairing:
    """The GeometricPairing when the joint vote decided nothing (the triangle rule): each pair gets
    the supporters of its vote peak that closes every triangle (consistent_peaks); when the peaks
    do not close the triangles, or three cameras give only one, no pair gets any and the descriptor
    pairs are kept only where consistent at the joint vote's offsets (when there is a joint vote);
    with no triangle, a pair gets every kept peak's supporters, marked unchecked, unless one of its
    cameras moves."""
    from .joint import consistent_peaks

    chosen, status = consistent_peaks({k: (gs.peaks_s, gs.peak_votes) for k, (_, gs) in found.items()},
                                      3.0 * coarsest)
    # the descriptor pairs are unchecked too then: alone they can put a camera a wrong offset that
    # Stage 1 accepts; kept only where consistent at the joint vote's offsets, unsure as they are,
    # so that a wrong offset leaves too few of them
    unchecked = status in ("inconsistent", "one triangle")
    filter_desc = unchecked and joint is not None and cfg.geometric.joint_filter_descriptor \
        and "descriptor_filter" in rules
    unchecked_why = unchecked_short = None
    if unchecked:
        unchecked_short = ("vote peaks do not close the triangles" if status == "inconsistent" else
                           "three cameras, one triangle: too weak a check of the vote peaks")
        unchecked_why = ("the vote peaks of the camera pairs do not close the triangles (Δ_ab + Δ_bc ≠ Δ_ac), "
                         "so some peaks are wrong" if status == "inconsistent" else
                         "three cameras give one triangle, and its closure (Δ_ab + Δ_bc ≈ Δ_ac) is a single "
                         "check on 27 choices of vote peaks, some of which close by chance")
        msg = (f"geometric track pairs not used: {unchecked_why}"
               + ("; descriptor pairs kept only where consistent at the joint vote's offsets" if filter_desc else ""))
        say(notes, msg)
        log.info(msg)
    out, summaries, chosen_s = dict(pairs), {}, {}
    for (a, b), (gp, gs) in found.items():
        pick = chosen.get((a, b)) if chosen is not None else None  # index of the chosen peak
        index, withheld, withheld_short = gp.index, None, None
        if pick is not None:
            index = index[gs.pair_peak == pick]
        elif unchecked:
            index, withheld, withheld_short = index[:0], unchecked_why, unchecked_short
        elif len(index) and (cameras[a].is_moving or cameras[b].is_moving) and not cfg.geometric.unchecked_moving \
                and "lone_moving_pair" in rules:
            withheld = (f"no triangle checks its vote peaks ({', '.join(f'{p:+.3f}' for p in gs.peaks_s)} s), "
                        f"and a moving camera's per-frame geometry lets wrong tracks fit a wrong offset")
            withheld_short = "a moving camera's vote peaks, no triangle to check them"
            msg = f"geometric track pairs not used for {a}__{b}: {withheld}"
            say(notes, msg, pair=f"{a}__{b}")
            log.info(msg)
            index = index[:0]
        chosen_s[(a, b)] = gs.peaks_s[pick] if pick is not None else None
        desc = pairs[(a, b)]
        n_desc = len(desc.index)
        if filter_desc:
            desc = _consistent_descriptor_pairs(desc, joint.offsets_s[b] - joint.offsets_s[a], cameras,
                                                tracks, vids, cfg)
        # supporters of a peak no triangle chose: Stage 1 must find the pair's minimum without them too
        # with no geometric pair, every row was kept at the joint vote's Δ
        kept_at = joint.offsets_s[b] - joint.offsets_s[a] if filter_desc and not len(index) else None
        out[(a, b)], n_new = _merge_pairs(desc, index, unchecked=pick is None, chosen_at_offset_s=kept_at)
        summaries[(a, b)] = PairVoteSummary(
            gs.candidates, gs.informative, int(len(index)), n_new, tuple(round(p, 4) for p in gs.peaks_s),
            tuple(gs.peak_votes), geometric_chosen_peak_s=round(gs.peaks_s[pick], 4) if pick is not None else None,
            geometric_withheld=withheld, geometric_withheld_short=withheld_short,
            geometric_unchecked=int(n_new) if pick is None and n_new else None,
            descriptor_pairs_kept=int(len(desc.index)) if filter_desc else None,
            descriptor_pairs_before=int(n_desc) if filter_desc else None)
        which = (f"peak {gs.peaks_s[pick]:+.3f} s chosen: the peaks of all static pairs close every triangle"
                 if pick is not None else
                 f"vote peaks at {', '.join(f'{p:+.3f}' for p in gs.peaks_s)} s")
        say(notes, f"{a}__{b}: {len(index)} track pairs from epipolar consistency ({which})")
        log.info("%s__%s: %d geometric track pairs (%d new), %s", a, b, len(index), n_new, which)
    used = {k: found[k][1].peaks_s[i] for k, i in (chosen or {}).items() if i is not None}
    return GeometricPairing(out, used, peaks_s, status, summaries, {}, None, votes, chosen_s, {}, {}, tuple(notes))


def _not_sure(refused: dict[str, str], sure: dict[str, bool], dissent: dict[str, str], notes: list[Note],
              dissent_short: dict[str, str], short: dict[str, str]) -> None:
    """Marks each camera of refused ({camera: why}) not sure, keeps why in dissent (and short's
    few words in dissent_short), and says so."""
    for n, why in refused.items():
        sure[n] = False
        dissent[n] = why
        dissent_short[n] = short[n]
        msg = f"joint vote not sure of {n}: {why}"
        say(notes, msg)
        log.info(msg)
