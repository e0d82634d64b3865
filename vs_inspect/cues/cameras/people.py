"""Stage 0's last camera source: the people in view (cues/people_cue.py), for static cameras whose
background gives no cameras to time them by (views 90° or more apart, little shared background).

The cue's cameras come from the people's own landmarks, and so do its first track pairs: the
same landmark of the same person in two views. Its offsets are the cue's own, each kept only when
its pairs' shifts were sure (sync/people_pairs.py refuses a pair whose shift fits about as well a
frame away). The moving points then join (with_moving_points): their pairs are voted on with the
people's cameras within a few frames of the people's offsets, as any estimated camera set's are,
so that Stage 1 times each pair on both the landmarks and every moving point that follows the
cameras' epipolar geometry. No I/O.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...cue_stats import PeopleRecord, PeoplePairRecord
from ...geometry.offsets import OffsetGrid
from ...memo import NO_MEMO, Memo
from ...people_types import PeopleCue
from ...types import TrackPairs, Tracks
from ..config import CueConfig
from ..records import Note, say_cameras
from ..rules import ALL
from .camera_set import CameraSet
from .choice import vote_on_cameras

SOURCE = "estimated from people (their landmarks as correspondences)"


def wants_people(cfg: CueConfig, estimated: CameraSet | None, static_videos: int) -> bool:
    """Whether the people are tried: always with people "only"; with "auto" when the background's
    camera sets time no video (estimated.used empty) and two or more cameras are static (the cue
    places static cameras only)."""
    if cfg.people == "only":
        return True
    return cfg.people == "auto" and static_videos >= 2 and (estimated is None or not estimated.used)


def people_camera_set(cue: PeopleCue) -> CameraSet:
    """The people cue's cameras as a camera set: its landmark tracks (pinhole cameras: nothing to
    undistort) and landmark track pairs; every placed video counts as timed (used)."""
    placed = [v.name for v in cue.videos if v.name in cue.cameras]
    pairs = {k: tp for k, tp in cue.track_pairs.items() if k[0] in cue.cameras and k[1] in cue.cameras}
    notes: list[Note] = []
    for p in cue.pairs:
        shift = f"Δ {p.offset_s:+.3f} s" if p.accepted else "refused"
        say_cameras(notes, f"people {p.a}__{p.b}: {shift} ({p.reason})",
                    people_associated=len(p.associations))
    for v in placed:
        say_cameras(notes, f"{v}: placed by the people (median reprojection "
                           f"{cue.reprojection_px.get(v, float('nan')):.1f} px)")
    for v, why in cue.refused.items():
        say_cameras(notes, f"{v}: the people: {why}")
    return CameraSet(dict(cue.cameras), {v: cue.tracks[v] for v in placed}, None, None, {},
                     dict(cue.refused), SOURCE, pairs=pairs, used=frozenset(placed) if len(placed) >= 2 else frozenset(),
                     notes=tuple(notes))


def people_record(cue: PeopleCue, kept: bool, why: str) -> PeopleRecord:
    """What the people cue found, for result.json and `inspect`."""
    return PeopleRecord(
        kept, why, cue.reference, {n: p.num_people for n, p in cue.people.items()},
        {f"{p.a}__{p.b}": PeoplePairRecord(p.reason, len(p.associations), p.offset_s, p.offset_std_s)
         for p in cue.pairs},
        dict(cue.offsets_s), dict(cue.refused), {v: round(r, 2) for v, r in cue.reprojection_px.items()},
        {k: round(t, 2) for k, t in cue.timings_s.items()})


WINDOW_FRAMES = 2.0
"""The moving points are voted on within this many frames of each video's offset from the
people (whose pairs are sure within a frame)."""


def people_grid(cue: PeopleCue, grid: OffsetGrid, frames: float = WINDOW_FRAMES) -> OffsetGrid:
    """grid with a window of frames frame lengths around each placed video's offset from the
    people (their reference at 0)."""
    frame_s = {v.name: v.frame_interval_s for v in cue.videos}
    windows = tuple((v, o - frames * frame_s[v], o + frames * frame_s[v])
                    for v, o in cue.offsets_s.items() if v in cue.cameras and v != cue.reference)
    return dataclasses.replace(grid, windows_s=windows, reference=cue.reference)


def with_moving_points(people: CameraSet, cue: PeopleCue, vids: dict, descriptor_pairs: dict, cfg: CueConfig,
                       progress: bool, grid: OffsetGrid, rules: frozenset[str] = ALL,
                       memo: Memo = NO_MEMO) -> CameraSet:
    """people (people_camera_set's) with the moving points added: each placed video's point tracks
    (before its landmarks), and the pairs the joint vote on the people's cameras keeps within the
    people's windows (people_grid) besides the landmark pairs. The videos timed stay the people's."""
    placed = list(people.cameras)
    points = {n: Tracks(vids[n].xy_full, vids[n].instance) for n in placed}
    voted = vote_on_cameras(CameraSet(dict(people.cameras), points, None, None, {}, {}, SOURCE), vids,
                            descriptor_pairs, cfg, progress, estimated=True, grid=people_grid(cue, grid),
                            rules=rules, memo=memo)
    tracks, first_landmark = {}, {}
    for n in placed:
        p, lm = points[n], people.tracks[n]
        first_landmark[n] = p.num_tracks
        inst = p.instance if p.instance is not None else np.zeros(p.num_tracks, np.int64)
        # the people's own instances after the moving regions'
        tracks[n] = Tracks(np.concatenate([p.xy, lm.xy.astype(p.xy.dtype)]),
                           np.concatenate([inst, lm.instance + int(inst.max(initial=0)) + 1]))
    pairs = {}
    for key in set(voted.pairs or {}) | set(people.pairs or {}):
        a, b = key
        moving = (voted.pairs or {}).get(key)
        landmark = (people.pairs or {}).get(key)
        pairs[key] = _joined(a, b, moving, landmark, first_landmark[a], first_landmark[b])
    notes = people.notes + voted.notes
    return dataclasses.replace(people, tracks=tracks, pairs=pairs, voting_s=voted.voting_s,
                               pairing=voted.pairing, notes=notes)


def _joined(a: str, b: str, moving: TrackPairs | None, landmark: TrackPairs | None, shift_a: int,
            shift_b: int) -> TrackPairs:
    """One pair's moving-point rows and its landmark rows (indices moved past the point tracks).
    The vote's Δ stays the pair's chosen one: the landmark rows fit it (the windows are the
    people's). No row stays unchecked: the people's own pairs found both offsets sure, and the
    vote's Δ lies within frames of theirs, a check independent of the moving points, as a third
    camera's would be."""
    rows = [] if moving is None else [moving.index]
    weight = [] if moving is None else [moving.weight if moving.weight is not None else np.ones(len(moving.index))]
    if landmark is not None:
        rows.append(landmark.index + np.array([shift_a, shift_b]))
        weight.append(landmark.weight if landmark.weight is not None else np.ones(len(landmark.index)))
    any_weight = (moving is not None and moving.weight is not None) or (landmark is not None and landmark.weight is not None)
    return TrackPairs(a, b, np.concatenate(rows), np.concatenate(weight) if any_weight else None,
                      None, moving.chosen_at_offset_s if moving is not None else None)
