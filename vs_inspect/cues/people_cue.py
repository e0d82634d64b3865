"""People as correspondences that survive any viewpoint: a Stage 0 camera source for static
cameras whose views share people but little background.

The same landmark of the same person seen by two cameras at one moment is one 3D point, so the
people in the videos are a calibration target that moves. Steps (each its own module):

1. per video, every person found and followed (cues/people_video.py: BlazePose from the
   mediapipe wheel, cues/people_detect.py; tracks, cues/people_tracking.py);
2. per pair of videos, the association of their people, F_ab and the shift Δ_ab, found together,
   or a refusal with its reason (sync/people_pairs.py);
3. per-video offsets from the accepted pairs (sync/solve.py's robust solve), the people pooled
   into one identity across views, and the cameras: focal lengths from the F's, relative poses,
   a spanning tree, resection, then a bundle adjustment with the landmarks as 3D points
   (geometry/people_rig.py). A video no accepted pair reaches gets a refusal with the reasons
   of its pairs;
4. the landmarks as point tracks and the same landmark of one person in two placed videos as a
   cross-view track pair (people_types.PeopleCue.bundle), for Stage 1's energy.

Entry point: find_people_cameras(videos, grid, config) -> people_types.PeopleCue.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..engine import Engine, LocalEngine, TaskFailed
from ..memo import NO_MEMO, Memo, digest
from ..geometry.offsets import OffsetGrid, span_of
from ..geometry.people_rig import (Observations, PairF, PairPose, bundle_adjust, chain_poses, focals_from_pairs,
                                   intrinsics, pair_pose, register_views)
from ..geometry.skeleton import subset_mirror
from ..sync.people_config import PeoplePairConfig
from ..sync.people_pairs import estimate_people_pair
from ..sync.solve import PairMeasurement, solve_offsets
from ..people_types import PeopleCue, PeoplePair, VideoPeople
from ..types import CameraTrack, TrackPairs, Tracks, VideoInfo
from .video.motion import STATIC_MAX_MOTION_PX
from .people_video import PeopleVideoConfig, find_people

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PeopleCueConfig:
    """How people become cameras and cross-view correspondences."""

    video: PeopleVideoConfig = field(default_factory=PeopleVideoConfig)
    pairs: PeoplePairConfig = field(default_factory=PeoplePairConfig)
    static_max_motion_px: float = STATIC_MAX_MOTION_PX
    """A camera whose background moves less than this between frames (px, at the people step's
    motion_side) is static; the cue places static cameras only (cues/video/motion.py)."""
    focal_range: tuple[float, float] = (0.3, 5.0)
    """Focal lengths are searched within these multiples of the image's larger side."""
    max_pair_residual_frames: float = 1.0
    """An accepted pair whose shift the joint solve leaves more than this many frames off is dropped."""
    bundle_frames: int = 60
    """Moments (evenly spread over the common time) whose landmarks the bundle adjustment uses."""
    min_views_per_point: int = 2
    """A landmark at a moment is a 3D point when this many placed videos see it."""


@dataclass(frozen=True)
class VideoFrames:
    """A video given as decoded frames instead of an opened file."""

    info: VideoInfo
    frames: Sequence[np.ndarray]  # (T,) (H,W,3) uint8 BGR at info's size


def _frames_of(video):
    """(info, iterator of (frame index, BGR)) of an opened VideoSource or a VideoFrames."""
    if isinstance(video, VideoFrames):
        return video.info, enumerate(video.frames)
    from ..io.video import iter_frames

    return video.info, iter_frames(video)


def _people_task(cfg: PeopleVideoConfig, video) -> tuple[VideoPeople, float]:
    info, frames = _frames_of(video)
    people, stats = find_people(info.name, frames, info.timestamps_s, cfg)
    log.info("%s: %d people followed (%d frames, %d crops, %.1f s, background moves %.2f px)", info.name,
             people.num_people, stats.frames, stats.crops, stats.seconds, stats.background_motion_px)
    return people, stats.background_motion_px


def _pair_task(shared, item) -> PeoplePair:
    people, infos, grid, cfg = shared
    a, b = item
    A, B = people[a], people[b]
    step = min(infos[a].frame_interval_s, infos[b].frame_interval_s)
    offsets = grid.pair_offsets(a, span_of(A.times_s), b, span_of(B.times_s), step)
    return estimate_people_pair(a, A.times_s, A.seen_xy(cfg.landmarks), b, B.times_s, B.seen_xy(cfg.landmarks),
                                offsets, cfg)


def find_people_cameras(videos: Sequence, grid: OffsetGrid = OffsetGrid(), config: PeopleCueConfig = PeopleCueConfig(),
                        reference: str | None = None, engine: Engine | None = None, progress: bool = False,
                        camera_motion: dict[str, str] | None = None, memo: Memo = NO_MEMO) -> PeopleCue:
    """The people cue of the videos (opened io.video.VideoSource's or VideoFrames): people, pair
    geometries, offsets, cameras and landmark track pairs; reference (default: the grid's, else
    the first video) has offset 0. engine: where the per-video and per-pair work runs (default:
    this process, two videos at a time on threads). camera_motion: {video: "static" | "moving"}
    known (else measured from each video's background); a moving camera is refused (its F
    changes from frame to frame: this cue fits one per pair). memo: where each video's people are
    kept (default: nowhere)."""
    t0 = time.perf_counter()
    engine = engine or LocalEngine()
    infos = {v.info.name: v.info for v in videos}
    names = list(infos)
    if len(names) < 2:
        raise ValueError(f"the people cue needs two videos or more, got {len(names)}")
    reference = reference or grid.reference or names[0]
    if reference not in infos:
        raise ValueError(f"reference {reference!r} is not a video; known: {names}")
    timings = {}

    # 1. people per video
    people: dict[str, VideoPeople] = {}
    failed: dict[str, str] = {}
    motions: dict[str, float] = {}
    keys = {v.info.name: f"people-video-{v.info.name}-{digest(str(getattr(v, 'path', '')), v.info, config.video)}"
            for v in videos}
    todo = [v for v in videos if not memo.has(keys[v.info.name])]
    done = dict(zip([v.info.name for v in todo], engine.map(_people_task, todo, shared=config.video, desc="people",
                                                            unit="video", progress=progress, threads=True)))
    for v in videos:
        n = v.info.name
        # found now (kept for the next run unless it failed), or kept by an earlier run
        # (a kept result another version wrote, unreadable now, is found again here)
        out = done[n] if isinstance(done.get(n), TaskFailed) else \
            memo.get(keys[n], lambda: done[n] if n in done else _people_task(config.video, v))
        if isinstance(out, TaskFailed):
            failed[n] = f"finding its people failed: {out.reason}"
            continue
        people[n], motions[n] = out
    failed.update(moving_cameras(motions, config, camera_motion))
    timings["people"] = time.perf_counter() - t0

    cue = cameras_from_people(people, [infos[n] for n in names], grid, config, reference, engine, progress, failed)
    return dataclasses.replace(cue, timings_s={**timings, **cue.timings_s, "total": time.perf_counter() - t0},
                               background_motion_px=motions)


def moving_cameras(background_motion_px: dict[str, float], config: PeopleCueConfig = PeopleCueConfig(),
                   camera_motion: dict[str, str] | None = None) -> dict[str, str]:
    """{video: why it is refused} of the moving cameras: those camera_motion says move, else those
    whose background moves config.static_max_motion_px or more between frames."""
    out = {}
    for n, motion in background_motion_px.items():
        moving = (camera_motion or {}).get(n, "moving" if motion >= config.static_max_motion_px else "static")
        if moving == "moving":
            out[n] = (f"a moving camera (its background moves {motion:.1f} px between frames): the people cue "
                      f"fits one epipolar geometry per pair of static cameras")
    return out


def cameras_from_people(people: dict[str, VideoPeople], videos: Sequence[VideoInfo], grid: OffsetGrid = OffsetGrid(),
                        config: PeopleCueConfig = PeopleCueConfig(), reference: str | None = None,
                        engine: Engine | None = None, progress: bool = False,
                        failed: dict[str, str] | None = None) -> PeopleCue:
    """Steps 2-4 of find_people_cameras, from each video's people already found; a video in failed
    ({video: why}) or without people in `people` is left out (refused with failed's reason, or
    "no people found")."""
    t0 = time.perf_counter()
    engine = engine or LocalEngine()
    infos = {v.name: v for v in videos}
    names = list(infos)
    reference = reference or grid.reference or names[0]
    timings = {}
    usable = [n for n in names if n in people and n not in (failed or {})]
    items = [(a, b) for i, a in enumerate(usable) for b in usable[i + 1:]]
    pairs: list[PeoplePair] = []
    for item, out in zip(items, engine.map(_pair_task, items, shared=(people, infos, grid, config.pairs),
                                           desc="people pairs", unit="pair", progress=progress, processes=True)):
        if isinstance(out, TaskFailed):
            out = PeoplePair(item[0], item[1], None, f"its search failed: {out.reason}", float("nan"), np.zeros(0))
        pairs.append(out)
        log.info("%s__%s: %s", out.a, out.b, out.reason if out.offset_s is None else f"Δ {out.offset_s:+.3f} s")
    timings["pairs"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    offsets, refused, kept = _offsets(names, reference, infos, pairs, config)
    for v in names:
        if v not in usable:
            refused[v] = (failed or {}).get(v, "no people found")
    placed = [v for v in names if v in offsets and v in usable]  # the reference too only when usable
    identity, flip = _identities(people, kept)
    cameras, points, reproj, cam_refused = _cameras(placed, reference, infos, people, kept, offsets, identity, flip,
                                                    config)
    for v, why in cam_refused.items():  # a video left out earlier keeps its first reason
        refused.setdefault(v, why)
    timings["cameras"] = time.perf_counter() - t1

    L = len(config.pairs.landmarks)
    tracks = {v: _landmark_tracks(people[v], config.pairs.landmarks) for v in cameras}
    track_pairs = _track_pairs([v for v in names if v in cameras], people, identity, flip, config.pairs.landmarks, L)
    return PeopleCue(tuple(infos[n] for n in names), reference, people, tuple(pairs),
                     {v: offsets[v] for v in cameras}, cameras, refused, tracks, track_pairs, points, reproj,
                     tuple(config.pairs.landmarks), timings)


def _offsets(names, reference, infos, pairs: list[PeoplePair], cfg: PeopleCueConfig
             ) -> tuple[dict[str, float], dict[str, str], list[PeoplePair]]:
    """({video: offset_s} of the videos the accepted pairs connect to the reference, {video: why
    not}, the accepted pairs the solve kept)."""
    accepted = [p for p in pairs if p.accepted]
    frame = {n: infos[n].frame_interval_s for n in names}
    while True:
        meas = [PairMeasurement(p.a, p.b, p.offset_s, max(p.offset_std_s or 0.0, 0.05 * min(frame[p.a], frame[p.b])))
                for p in accepted]
        out = solve_offsets(names, reference, meas, huber_delta_s=min(frame.values()))
        worst, worst_r = None, 0.0
        for p in accepted:
            oa, ob = out.offsets_s.get(p.a), out.offsets_s.get(p.b)
            if oa is None or ob is None:
                continue
            r = abs(ob - oa - p.offset_s) / max(frame[p.a], frame[p.b])
            if r > cfg.max_pair_residual_frames and r > worst_r:
                worst, worst_r = p, r
        if worst is None:
            break
        log.info("%s__%s dropped: its shift is %.1f frames from the joint solution", worst.a, worst.b, worst_r)
        accepted = [p for p in accepted if p is not worst]
    offsets = {n: o for n, o in out.offsets_s.items() if o is not None}
    refused = {}
    for n in names:
        if n in offsets:
            continue
        mine = [p for p in pairs if n in (p.a, p.b)]
        why = "; ".join(f"{p.a}__{p.b}: {p.reason if not p.accepted else 'accepted, but it contradicts the other pairs'}"
                        for p in mine)
        refused[n] = f"no accepted pair of people links it to {reference} ({why})" if mine else "no pair tried"
    return offsets, refused, [p for p in accepted if p.a in offsets and p.b in offsets]


def _identities(people: dict[str, VideoPeople], pairs: list[PeoplePair]
                ) -> tuple[dict[tuple[str, int], int], dict[tuple[str, int], bool]]:
    """({(video, track): person id across videos}, {(video, track): labelled mirrored against
    that person's first track}) from the accepted pairs' associations (union of their links)."""
    parent: dict[tuple[str, int], tuple[str, int]] = {}
    flip_to_parent: dict[tuple[str, int], bool] = {}

    def find(x):
        if parent.setdefault(x, x) == x:
            flip_to_parent.setdefault(x, False)
            return x, False
        root, f = find(parent[x])
        parent[x], flip_to_parent[x] = root, f ^ flip_to_parent[x]
        return root, flip_to_parent[x]

    for p in pairs:
        for s in p.associations:
            ra, fa = find((p.a, s.person_a))
            rb, fb = find((p.b, s.person_b))
            if ra != rb:
                parent[rb] = ra
                flip_to_parent[rb] = fa ^ fb ^ s.mirrored
    ids, flip = {}, {}
    roots: dict[tuple[str, int], int] = {}
    for x in list(parent):
        r, f = find(x)
        ids[x] = roots.setdefault(r, len(roots))
        flip[x] = f
    return ids, flip


def _cameras(placed, reference, infos, people, pairs: list[PeoplePair], offsets, identity, flip,
             cfg: PeopleCueConfig):
    """({video: CameraTrack}, points (N,3), {video: median reprojection px}, {video: why no camera})."""
    if len(placed) < 2:
        return {}, np.zeros((0, 3)), {}, {v: "no accepted pair of people links it to another video" for v in placed}
    index = {v: i for i, v in enumerate(placed)}
    pp = np.array([[(infos[v].width - 1) / 2, (infos[v].height - 1) / 2] for v in placed])
    size = np.array([max(infos[v].width, infos[v].height) for v in placed], dtype=np.float64)
    lo, hi = cfg.focal_range
    focal = focals_from_pairs([PairF(index[p.a], index[p.b], p.F_ab, float(p.refined_inliers or 1)) for p in pairs],
                              pp, size, lo, hi)
    # each pair's relative pose, from its own landmarks at its shift
    L = cfg.pairs.landmarks
    poses = []
    for p in pairs:
        xa, xb = _pair_points(people[p.a], people[p.b], p, L)
        if len(xa) < 8:
            continue
        T = pair_pose(p.F_ab, intrinsics(focal[index[p.a]], pp[index[p.a]]), intrinsics(focal[index[p.b]], pp[index[p.b]]),
                      xa, xb)
        poses.append(PairPose(index[p.a], index[p.b], T, float(p.refined_inliers or 1)))
    chained = chain_poses(len(placed), index[reference], poses)
    obs = _observations(placed, people, offsets, identity, flip, L, cfg, pp, focal)
    f0 = {i: float(focal[i]) for i in chained}
    order = [i for i in chained if i != index[reference]]
    start = register_views(chained, f0, pp, obs, index[reference], order)
    rig = bundle_adjust(start, f0, pp, obs, index[reference],
                        focal_bounds_px={i: (lo * size[i], hi * size[i]) for i in chained})
    cams, reproj, refused = {}, {}, {}
    for v in placed:
        i = index[v]
        if i not in rig.cam_from_world:
            refused[v] = "its accepted pairs did not give it a relative pose"
            continue
        cams[v] = CameraTrack(intrinsics(rig.focal_px[i], pp[i]), rig.cam_from_world[i])
        r = rig.residual_px[obs.view == i]
        reproj[v] = float(np.nanmedian(r)) if np.isfinite(r).any() else float("nan")
    return cams, rig.points, reproj, refused


def _pair_points(A: VideoPeople, B: VideoPeople, p: PeoplePair, landmarks) -> tuple[np.ndarray, np.ndarray]:
    """(x_a (M,2), x_b (M,2)) px: the associated people's landmarks at the pair's shift (b at the
    nearest frame), b's in its association's labelling."""
    mirror = subset_mirror(landmarks)
    xa_all, xb_all = A.seen_xy(landmarks), B.seen_xy(landmarks)
    kb = np.rint(np.interp(A.times_s - p.offset_s, B.times_s, np.arange(len(B.times_s)), left=-1, right=-1)).astype(int)
    ok_t = kb >= 0
    xs_a, xs_b = [], []
    for s in p.associations:
        xb = xb_all[s.person_b][kb[ok_t]]
        if s.mirrored:
            xb = xb[:, mirror]
        xa = xa_all[s.person_a][ok_t]
        ok = np.isfinite(xa).all(-1) & np.isfinite(xb).all(-1)
        xs_a.append(xa[ok])
        xs_b.append(xb[ok])
    if not xs_a:
        return np.zeros((0, 2)), np.zeros((0, 2))
    return np.concatenate(xs_a), np.concatenate(xs_b)


def _observations(placed, people, offsets, identity, flip, landmarks, cfg: PeopleCueConfig, pp, focal) -> Observations:
    """Every placed video's sightings of each (person, landmark) at bundle_frames moments spread
    over the common time, each point a (person, landmark, moment); b's landmarks interpolated at
    the moment, in the person's canonical labelling."""
    mirror = subset_mirror(landmarks)
    L = len(landmarks)
    lo = max(offsets[v] + people[v].times_s[0] for v in placed)
    hi = min(offsets[v] + people[v].times_s[-1] for v in placed)
    if hi <= lo:  # no common time: the union instead
        lo = min(offsets[v] + people[v].times_s[0] for v in placed)
        hi = max(offsets[v] + people[v].times_s[-1] for v in placed)
    moments = np.linspace(lo, hi, cfg.bundle_frames)
    G = max(identity.values(), default=-1) + 1
    rows_p, rows_v, rows_xy, rows_u = [], [], [], []
    for vi, v in enumerate(placed):
        P = people[v]
        xy = P.seen_xy(landmarks)  # (P,T,L,2)
        t = moments - offsets[v]
        f = np.interp(t, P.times_s, np.arange(len(P.times_s)), left=np.nan, right=np.nan)
        ok_t = np.isfinite(f)
        k0 = np.clip(np.floor(np.nan_to_num(f)).astype(int), 0, max(len(P.times_s) - 2, 0))
        w = np.nan_to_num(f) - k0
        for track in range(P.num_people):
            g = identity.get((v, track))
            if g is None:
                continue
            x = xy[track]
            if flip.get((v, track), False):
                x = x[:, mirror]
            x0, x1 = x[k0], x[np.minimum(k0 + 1, len(P.times_s) - 1)]
            with np.errstate(invalid="ignore"):
                xt = np.where(w[:, None, None] > 0, x0 + w[:, None, None] * (x1 - x0), x0)
            xt[~ok_t] = np.nan
            size = np.nanmedian([np.hypot(*(np.nanmax(x[k], 0) - np.nanmin(x[k], 0))) for k in range(len(x))
                                 if np.isfinite(x[k]).any()]) if np.isfinite(x).any() else np.nan
            unit = max(cfg.pairs.noise_share * float(np.nan_to_num(size, nan=0.0)), cfg.pairs.min_noise_px)
            m, l = np.nonzero(np.isfinite(xt).all(-1))
            rows_p.append((g * len(moments) + m) * L + l)
            rows_v.append(np.full(len(m), vi))
            rows_xy.append(xt[m, l])
            rows_u.append(np.full(len(m), unit))
    if not rows_p:
        return Observations(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0))
    point, view = np.concatenate(rows_p), np.concatenate(rows_v)
    # points seen by too few views are left out
    counts = {}
    for pt, vw in zip(point, view):
        counts.setdefault(int(pt), set()).add(int(vw))
    keep = np.array([len(counts[int(pt)]) >= cfg.min_views_per_point for pt in point])
    return Observations(point[keep], view[keep], np.concatenate(rows_xy)[keep], np.concatenate(rows_u)[keep])


def _landmark_tracks(people: VideoPeople, landmarks) -> Tracks:
    """A video's people as point tracks: track p·L + l is landmark landmarks[l] of person p."""
    xy = people.seen_xy(landmarks)  # (P,T,L,2)
    P, T, L, _ = xy.shape
    return Tracks(xy.transpose(0, 2, 1, 3).reshape(P * L, T, 2), np.repeat(np.arange(P), L))


def _track_pairs(placed, people, identity, flip, landmarks, L: int) -> dict[tuple[str, str], TrackPairs]:
    """For every two placed videos, the same landmark of one person (by identity) in both, in the
    labelling that makes it the same landmark."""
    mirror = subset_mirror(landmarks)
    out = {}
    for i, a in enumerate(placed):
        for b in placed[i + 1:]:
            rows = []
            for pa in range(people[a].num_people):
                for pb in range(people[b].num_people):
                    ga, gb = identity.get((a, pa)), identity.get((b, pb))
                    if ga is None or ga != gb:
                        continue
                    swap = flip.get((a, pa), False) ^ flip.get((b, pb), False)
                    lab = mirror if swap else np.arange(L)
                    rows += [(pa * L + l, pb * L + lab[l]) for l in range(L)]
            if rows:
                out[(a, b)] = TrackPairs(a, b, np.array(rows, dtype=np.int64))
    return out

