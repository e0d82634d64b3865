"""Stage 0's last camera source: the people in view (cues/people_cue.py), for static cameras whose
background gives no cameras to time them by (views 90° or more apart, little shared background).

The cue's cameras come from the people's own landmarks, and so do the track pairs it hands to
Stage 1: the same landmark of the same person in two views. Its offsets are the cue's own, each
kept only when its pairs' shifts were sure (sync/people_pairs.py refuses a pair whose shift
fits about as well a frame away); Stage 1 then times the videos on these pairs like any other.
No I/O.
"""

from __future__ import annotations

from ...cue_stats import PeopleRecord, PeoplePairRecord
from ...types import PeopleCue
from ..config import CueConfig
from ..records import Note, say_cameras
from .choice import CameraSet

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
        {f"{p.a}__{p.b}": PeoplePairRecord(p.offset_s, p.offset_std_s, p.reason, len(p.associations))
         for p in cue.pairs},
        dict(cue.offsets_s), dict(cue.refused), {v: round(r, 2) for v, r in cue.reprojection_px.items()},
        {k: round(t, 2) for k, t in cue.timings_s.items()})
