"""The checks of the joint vote's cameras by the 3D points of the others: a sure camera must see
the points the other sure cameras triangulate at their joint offsets (three views), an unsure one
can be confirmed when they land on its tracks at its joint offset (point transfer,
cues/pairing/transfer.py). No I/O.
"""

from __future__ import annotations

import logging

import numpy as np

from ...geometry.offsets import OffsetGrid
from ...memo import NO_MEMO, Memo
from ...types import TrackPairs, VideoInfo
from ..config import CueConfig
from ..records import Note, say

log = logging.getLogger(__name__)


def _transfer_source(a: str, b: str, sure: dict[str, bool], cameras: dict, third: bool = True) -> bool:
    """Whether pair (a, b)'s joint Δ may be triangulated for point transfer: both cameras sure,
    and when both move, a third camera sure too (their per-frame geometry lets wrong tracks fit
    one wrong offset)."""
    if not (sure.get(a) and sure.get(b)):
        return False
    return not (third and cameras[a].is_moving and cameras[b].is_moving) or sum(sure.values()) >= 3


def _sure_pairs(found: dict, joint, sure: dict[str, bool], cameras: dict, third: bool = True) -> dict:
    """The supporters of the joint Δ of every pair that point transfer may triangulate
    (_transfer_source)."""
    from .votes import supporters

    out = {}
    for (a, b), (_, gs) in found.items():
        if not _transfer_source(a, b, sure, cameras, third):
            continue
        index = supporters(gs, joint.offsets_s[b] - joint.offsets_s[a])
        out[(a, b)] = TrackPairs(a, b, index, np.ones(len(index)))
    return out


def _transfer_radius_px(info: VideoInfo, g) -> float:
    """How near a projected point a track of the camera must be (GeometricPairConfig.transfer_radius_diag)."""
    return max(3.0, g.transfer_radius_diag * float(np.hypot(info.width, info.height)))


def _check_in_three_views(found: dict, joint, sure: dict[str, bool], cameras: dict, tracks: dict,
                          vids: dict, cfg: CueConfig, notes: list[Note], grid: OffsetGrid = OffsetGrid(),
                          third: bool = True, memo: Memo = NO_MEMO) -> dict:
    """{camera: transfer.ThreeViewCheck} for every sure camera: the other sure cameras' track
    pairs triangulated at their joint offsets and projected into it at its own. Wrong cameras can
    make the joint vote sure of wrong offsets, consistent in every triangle, since a line through
    a wrong epipole still meets some track; a point in a third view rarely does."""
    from .transfer import check_in_three_views, triangulate_pairs

    g = cfg.geometric
    infos = {n: v.info for n, v in vids.items()}
    xy = {n: t.xy for n, t in tracks.items()}
    checks = {}
    for c in sorted(n for n, ok in sure.items() if ok):
        others = {n: ok and n != c for n, ok in sure.items()}
        traj = memo.call("triangulated", triangulate_pairs, infos, cameras, xy,
                         _sure_pairs(found, joint, others, cameras, third),
                         {n: joint.offsets_s[n] for n, ok in others.items() if ok})
        chk = memo.call("three_view", check_in_three_views, c, joint.offsets_s[c], traj, infos[c], cameras[c], xy[c],
                        _transfer_radius_px(infos[c], g), g.transfer_min_hits,
                        g.three_view_min_supporters, g.three_view_min_share_of_best, grid, joint.origin)
        checks[c] = chk
        msg = f"{c}: {chk.reason}"
        say(notes, msg, camera=c, passed=int(chk.passed), supporters=chk.supporters,
            best_supporters=chk.best_supporters, trajectories=chk.trajectories)
        log.info(msg)
    return checks


def _confirm_by_transfer(found: dict, joint, sure: dict[str, bool], cameras: dict, tracks: dict,
                         vids: dict, cfg: CueConfig, notes: list[Note], skip: frozenset[str] = frozenset(),
                         grid: OffsetGrid = OffsetGrid(), third: bool = True, memo: Memo = NO_MEMO):
    """({camera: transfer.TransferCheck}, the transfer.Trajectories projected): a check of every
    camera the joint vote is unsure of (but those of skip), the sure cameras' track pairs
    triangulated at their joint offsets and projected into it over its candidate offsets
    (cues/pairing/transfer.py)."""
    from .transfer import candidate_offsets, confirm_offset, transfer_landscape, triangulate_pairs

    g = cfg.geometric
    sure_offsets = {n: joint.offsets_s[n] for n, ok in sure.items() if ok}
    traj = memo.call("triangulated", triangulate_pairs, {n: v.info for n, v in vids.items()}, cameras,
                     {n: t.xy for n, t in tracks.items()}, _sure_pairs(found, joint, sure, cameras, third), sure_offsets)
    checks = {}
    for c in sorted(n for n, ok in sure.items() if not ok and n not in skip):
        info = vids[c].info
        offsets = candidate_offsets(traj, info, 0.5 * info.frame_interval_s, grid, joint.origin)
        land = memo.call("transfer", transfer_landscape, traj, info, cameras[c], tracks[c].xy, offsets,
                         _transfer_radius_px(info, g), g.transfer_min_hits,
                         allowed=grid.within_window(joint.origin, c, offsets))
        chk = confirm_offset(c, joint.offsets_s[c], land, info.frame_interval_s,
                             g.transfer_agree_frames, g.transfer_min_z, g.transfer_min_supporters)
        checks[c] = chk
        msg = f"{c}: {chk.reason}"
        say(notes, msg, camera=c, confirmed=int(chk.confirmed), z=round(land.z, 2),
            trajectories=traj.num_trajectories)
        log.info(msg)
    return checks, traj
