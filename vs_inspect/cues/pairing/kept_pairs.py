"""Which track pairs Stage 1 gets once the joint vote has decided: the supporters of each trusted
joint offset and those point transfer found, beside the descriptor pairs consistent there. No I/O.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np

from ...cue_stats import JointVoteRecord, PairVoteSummary
from ...types import TrackPairs
from ..config import CueConfig
from ..records import Note, say
from ..rules import ALL
from .joint_checks import _transfer_source

log = logging.getLogger(__name__)


def _add_transfer_pairs(pairs: dict, checks: dict, traj, order: list[str], notes: list[Note]) -> tuple[dict, dict]:
    """(pairs plus, for every camera that point transfer confirmed, its tracks that follow a
    trajectory (of traj, transfer.Trajectories) paired with both tracks the trajectory was
    triangulated from, {(a, b): track pairs added}); order: the videos' order (a pair's key
    names the earlier one first)."""
    out, added = dict(pairs), {}
    for c, chk in checks.items():
        if not chk.confirmed:
            continue
        new: dict[tuple[str, str], list] = {}
        for t, j in chk.landscape.matches.tolist():
            pair_no, ta, tb, _ = traj.source[t].tolist()
            a, b = traj.pairs[pair_no]
            for other, track in ((a, ta), (b, tb)):
                key = (other, c) if order.index(other) < order.index(c) else (c, other)
                new.setdefault(key, []).append((track, j) if key[0] == other else (j, track))
        for key, rows in new.items():
            if key not in out:
                continue
            # no chosen_at_offset_s: the new rows follow trajectories at the transfer's offset
            out[key], n_new = _merge_pairs(out[key], np.unique(np.array(rows, np.int64), axis=0))
            added[key] = int(n_new)
            say(notes, f"{key[0]}__{key[1]}: {n_new} track pairs from point transfer",
                pair=f"{key[0]}__{key[1]}", transfer_new=int(n_new))
    return out, added


def _consistent_descriptor_pairs(desc: TrackPairs, delta_s: float, cameras: dict, tracks: dict,
                                 vids: dict, cfg: CueConfig) -> TrackPairs:
    """The descriptor pairs of (desc.a, desc.b) that are epipolar-consistent at Δ = delta_s
    (geometric_pairs.consistent_at with the geometric pairs' tolerances)."""
    from .votes import VOTE, consistent_at

    if not len(desc.index):
        return desc
    a, b, g = desc.a, desc.b, VOTE
    tau = max(2.0, g.tau_diag * float(np.hypot(vids[b].info.width, vids[b].info.height)))
    ok = consistent_at(vids[a].info, vids[b].info, cameras[a], cameras[b], tracks[a].xy,
                       tracks[b].xy, desc.index, delta_s, tau, g.min_inlier_share, g.min_frames)
    return TrackPairs(a, b, desc.index[ok], None if desc.weight is None else desc.weight[ok])


def _merge_pairs(tp: TrackPairs, index: np.ndarray, unchecked: bool = False,
                 chosen_at_offset_s: float | None = None) -> tuple[TrackPairs, int]:
    """Descriptor pairs tp plus the geometric pairs index (P,2) not already in it: (pairs, new).
    unchecked: the new rows are marked TrackPairs.unchecked (no triangle checked their vote peak);
    chosen_at_offset_s: the Δ_ab at which every row of both was kept (TrackPairs), if one was."""
    w_desc = tp.weight if tp.weight is not None else np.ones(len(tp.index))
    have = {tuple(x) for x in tp.index.tolist()}
    new = np.array([x for x in index.tolist() if tuple(x) not in have], np.int64).reshape(-1, 2)
    mark = None
    if unchecked and len(new):
        mark = np.concatenate([np.zeros(len(tp.index), bool), np.ones(len(new), bool)])
    return TrackPairs(tp.a, tp.b, np.concatenate([tp.index, new]),
                      np.concatenate([w_desc, np.ones(len(new))]), mark, chosen_at_offset_s), len(new)


@dataclass(frozen=True)
class _JointChecks:
    """What the checks after the joint vote said of its cameras, kept in result.json."""

    transfer: dict = dataclasses.field(default_factory=dict)  # camera -> TransferSummary
    three_view: dict = dataclasses.field(default_factory=dict)  # camera -> ThreeViewSummary
    dissent: dict = dataclasses.field(default_factory=dict)  # camera -> why a check after the vote contradicts it
    dissent_short: dict = dataclasses.field(default_factory=dict)  # camera -> that in a few words (a null's headline)


def _add_joint_pairs(pairs: dict, found: dict, joint, sure: dict[str, bool], cameras: dict,
                     tracks: dict, vids: dict, cfg: CueConfig, notes: list[Note],
                     said: _JointChecks = _JointChecks(), rules: frozenset[str] = ALL
                     ) -> tuple[dict, dict, dict, JointVoteRecord, dict]:
    """(pairs, {(a, b): the joint Δ_ab whose supporters were added}, {(a, b): PairVoteSummary},
    the JointVoteRecord, {(a, b): that Δ_ab or None for every pair}): the supporters of the jointly chosen offsets
    (geometric_pairs.joint_offsets) for every pair whose Δ is trusted (_transfer_source: both
    cameras' offsets won by at least joint_min_margin, or point transfer confirmed them, and a
    third camera sure too when both move; sure: camera -> whether it is, said: what the checks after
    the vote said, for result.json); nothing for the others. A descriptor pair is kept only if it
    is epipolar-consistent at the joint Δ (with joint_filter_descriptor): the descriptor pairs are
    mostly wrong on small moving objects (BENCHMARKS.md), and the joint Δ is the best evidence
    there is of the moment they share."""
    from .votes import supporters, votes_at

    # the pairs whose joint Δ is trusted, and that Δ: the one decision everything below reads
    used = {(a, b): joint.offsets_s[b] - joint.offsets_s[a] for a, b in found
            if _transfer_source(a, b, sure, cameras, "moving_pair_third" in rules)}
    record = JointVoteRecord(joint.origin, {n: round(o, 4) for n, o in joint.offsets_s.items()},
                             round(joint.score, 2), {n: round(m, 2) for n, m in joint.margin.items()},
                             tuple(sorted(n for n, ok in sure.items() if ok)), tuple(sorted({n for k in used for n in k})),
                             # an empty check is left out; its summaries stay typed (asdict would not)
                             **{f.name: dict(getattr(said, f.name)) for f in dataclasses.fields(said)
                                if getattr(said, f.name)})
    three_view, dissent, transfer = said.three_view, said.dissent, said.transfer
    failed = sorted(n for n, chk in three_view.items() if not chk.passed and not sure[n])
    if failed:
        seen = ", ".join(f"{n} {three_view[n].supporters}" for n in failed)
        msg = (f"geometric track pairs not used for {', '.join(failed)}: the joint vote was sure of "
               f"their offsets, but the points the other sure cameras triangulate are not seen there "
               f"(supporters {seen}; a camera needs {cfg.geometric.three_view_min_supporters}, and "
               f"{cfg.geometric.three_view_min_share_of_best:.2g} of those at its best offset)")
        say(notes, msg)
        log.info(msg)
    weak = sorted(n for n, ok in sure.items() if not ok and n not in failed and n not in dissent)
    if weak:
        msg = (f"geometric track pairs not used for {', '.join(weak)}: the joint vote prefers their "
               f"offsets by less than {cfg.geometric.joint_min_margin:g} (margins "
               f"{', '.join(f'{n} {joint.margin[n]:.1f}' for n in weak)})"
               + ("; point transfer did not confirm them" if transfer else ""))
        say(notes, msg)
        log.info(msg)
    # two moving cameras' Δ only when a third camera is sure too: their per-frame geometry lets
    # wrong tracks fit one wrong offset
    unconfirmed = {(a, b) for (a, b) in found if sure.get(a) and sure.get(b) and (a, b) not in used}
    if unconfirmed:
        names = ", ".join(sorted(f"{a}__{b}" for a, b in unconfirmed))
        msg = (f"geometric track pairs not used for {names}: both cameras move and the joint vote is "
               f"sure of {sum(sure.values())} camera(s) only, so no third camera confirms their Δ")
        say(notes, msg)
        log.info(msg)
    out, summaries, chosen = dict(pairs), {}, {}
    for (a, b), (_, gs) in found.items():
        delta = joint.offsets_s[b] - joint.offsets_s[a]
        both = (a, b) in used
        index = supporters(gs, delta) if both else np.zeros((0, 2), np.int64)
        chosen[(a, b)] = delta if both else None
        desc = pairs[(a, b)]
        n_desc = len(desc.index)
        # an unsure camera's descriptor pairs are filtered too: at a wrong joint Δ few survive
        # (the pair is then refused for too few pairs) instead of a wrong minimum being accepted
        if cfg.geometric.joint_filter_descriptor and "descriptor_filter" in rules:
            desc = _consistent_descriptor_pairs(desc, delta, cameras, tracks, vids, cfg)
        every = (cfg.geometric.joint_filter_descriptor and "descriptor_filter" in rules) or not n_desc  # every row kept at delta
        out[(a, b)], n_new = _merge_pairs(desc, index, chosen_at_offset_s=delta if every else None)
        votes = votes_at(gs, delta)
        summaries[(a, b)] = PairVoteSummary(
            gs.candidates, gs.informative, int(len(index)), int(n_new), tuple(round(p, 4) for p in gs.peaks_s),
            tuple(gs.peak_votes), geometric_joint_delta_s=round(delta, 4), geometric_joint_votes=votes,
            geometric_joint_margin=(round(joint.margin[a], 2), round(joint.margin[b], 2)),
            descriptor_pairs_kept=int(len(desc.index)), descriptor_pairs_before=int(n_desc))
        say(notes, f"{a}__{b}: {len(index)} track pairs from epipolar consistency "
                   f"(joint vote over all camera pairs: Δ {delta:+.3f} s)",
            pair=f"{a}__{b}", votes=votes, informative=gs.informative,
            geometric_pairs=int(len(index)), descriptor_pairs_kept=int(len(desc.index)),
            descriptor_pairs_before=int(n_desc), margin_a=round(joint.margin[a], 2),
            margin_b=round(joint.margin[b], 2))
        log.info("%s__%s: %d geometric track pairs (%d new) at the joint Δ %+.3f s", a, b,
                 len(index), n_new, delta)
    return out, used, summaries, record, chosen
