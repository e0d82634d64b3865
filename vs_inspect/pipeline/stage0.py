"""Stage 0 of a run: video files or image folders in, a cue bundle and its records out.

The controller: each numbered step below calls into cues/ and gets a typed record back; this
module alone reports those records to the sink and keeps each step's time. A video that cannot
be opened or used is left out with its reason in CueStats.dropped; when no video can be used,
NoUsableVideos carries those reasons instead of a bundle.

    1. open the videos (and read the calibration, when one is given)
    2. each video's own cues: decoding, moving regions, tracks, keyframe features (engine tasks)
    3. descriptor track pairs between every two videos
    4. the cameras: the calibration's, or estimated camera sets; each voted on (the geometric
       track pairs and the joint vote), the set the vote trusts most kept; when the background's
       sets time no video, the people in view (their landmarks as correspondences)
    5. the people's heads, when a camera moves (the worn-camera sightings)
    6. the bundle of the videos with a camera, and CueStats
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import logging
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..cue_stats import CueStats, PairCueStats, VideoCueStats
from ..cues.cameras.people import wants_people
from ..cues.config import CueConfig
from ..engine import Engine, LocalEngine, TaskFailed
from ..errors import BadVideoName, InputError, NoUsableVideos
from ..cues.rules import ALL
from ..geometry.offsets import OffsetGrid
from ..geometry.point_cloud import clean_point_cloud
from ..memo import NO_MEMO, Memo, digest
from ..progress import stage
from ..record.sink import NullSink, Sink
from ..sync.config import SyncConfig
from ..types import CueBundle, TrackPairs

log = logging.getLogger(__name__)

PathLike = str | os.PathLike


def open_sources(paths: Sequence[PathLike], fps: float | None
                 ) -> tuple[list, dict[str, str], dict[str, str]]:
    """(opened sources, {name: path} of every input, {name: reason} for those not opened)."""
    from ..io.video import open_video

    sources, inputs, dropped = [], {}, {}
    for p in paths:
        p = Path(p)
        try:
            src = open_video(p, fps=fps)
        except BadVideoName:  # the caller's to fix (rename the file), not a video to leave out
            raise
        except InputError as exc:
            name = p.stem if p.suffix else p.name
            dropped[name] = f"could not be opened: {exc}"
            inputs[name] = str(p)
            log.warning("%s", exc)
            continue
        sources.append(src)
        inputs[src.info.name] = str(p)
    return sources, inputs, dropped


def check_cue_config(cfg: CueConfig) -> None:
    """Settings that need an optional package fail before any decoding."""
    from ..cues.cameras.sfm import camera_features_unavailable

    if why := camera_features_unavailable(cfg.camera.features):
        raise InputError(f"--sfm-features {cfg.camera.features}: {why}")


def run_stage0(videos: Sequence[PathLike], calibration: PathLike | None = None,
               fps: float | None = None, cfg: CueConfig = CueConfig(), sink: Sink | None = None,
               progress: bool = True, engine: Engine | None = None, sync: SyncConfig = SyncConfig(),
               memo: Memo = NO_MEMO, rules: frozenset[str] = ALL) -> tuple[CueBundle, CueStats, dict[str, str]]:
    """Stage 0 on video files or image folders: (bundle, stats, {name: path} of every input).

    calibration: a file or folder that io.calibration.load_calibration reads, or None to estimate
    the cameras. fps: frame rate of image folders (and of files whose timestamps are unusable).
    engine: where each video's own cues are extracted, one task per video (default: in this
    process); everything else, and every report to the sink, stays here in video order. sync:
    the run's Stage 1 + 2 settings, whose limits of the candidate offsets (--min-overlap-s,
    --range-s, --around) Stage 0's searches obey too. memo: where the expensive steps' results
    are kept (default: nowhere); rules: the acceptance rules and camera paths applied (cues.rules;
    default: all).
    InputError when fewer than two videos are given; NoUsableVideos (an InputError that carries
    every video's reason) when fewer than two can be opened or none can be used.
    """
    from ..signals import import_pycolmap

    # loaded here, on the calling thread: glog installs its own SIGTERM handler when pycolmap
    # loads, and only the main thread can put ours back (a first import on a worker thread could not)
    import_pycolmap()
    from ..io.calibration import load_calibration

    sink = sink or NullSink()
    if len(videos) < 2:
        raise InputError(f"need at least 2 videos to synchronize, got {len(videos)}")
    check_cue_config(cfg)
    # 1. the videos
    sources, inputs, dropped = open_sources(videos, fps)
    grid = sync.offset_grid(list(inputs))
    if len(sources) < 2:
        why = "; ".join(f"{n}: {r}" for n, r in dropped.items())
        alone = {s.info.name: "the only readable video: there is no other video to synchronize it with"
                 for s in sources}
        raise NoUsableVideos(f"fewer than 2 readable videos ({why})",
                             _no_cues({**dropped, **alone}, calibration is not None), inputs)
    names = [s.info.name for s in sources]
    if dup := sorted({n for n in names if names.count(n) > 1}):
        raise InputError(f"video names must be unique, got {dup} more than once "
                         "(rename the files or put them in differently named folders)")
    calib = None if calibration is None else load_calibration(calibration, names)
    bundle, stats = _stage0(sources, calib, cfg, sink, progress, engine or LocalEngine(), grid, dropped, inputs,
                            memo, rules)
    return bundle, stats, inputs


def _stage0(sources, calibration: dict | None, cfg: CueConfig, sink: Sink, progress: bool, engine: Engine,
            grid: OffsetGrid, dropped: dict[str, str], inputs: dict[str, str], memo: Memo = NO_MEMO,
            rules: frozenset[str] = ALL) -> tuple[CueBundle, CueStats]:
    """Steps 2-6 on the opened sources; dropped: the videos left out so far, with their reasons."""
    from ..cues.heads import HEADS_MAX_HZ, HeadsAhead, find_heads

    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    names = [s.info.name for s in sources]
    # 2. each video's own cues
    vids, videos = _video_cues(sources, cfg, sink, engine, progress, calibration is None, timings, dropped, memo)
    # a camera seen moving: the heads are found on a thread of their own while the cameras are
    # estimated (COLMAP's mapping keeps one core) and the geometric pairs voted; they are only
    # used when a camera moves in the end
    ahead = HeadsAhead.start(sources, vids, cfg) \
        if cfg.heads and memo.folder is None and any(v.camera_motion == "moving" for v in vids.values()) else None
    with ahead or contextlib.nullcontext():
        # 3. descriptor track pairs
        t0 = time.perf_counter()
        all_pairs, matched = _descriptor_pairs([n for n in names if n in vids], vids, sink, progress, memo)
        timings["matching_s"] = time.perf_counter() - t0
        # 4. the cameras, voted on; the people in view when the background's time no video
        t0 = time.perf_counter()
        kept = None if calibration is None and cfg.people == "only" else \
            _cameras(sources, vids, all_pairs, calibration, cfg, progress, grid, rules, memo)
        if kept is not None:
            timings["cameras_s"] = time.perf_counter() - t0 - kept.voting_s
            if cfg.geometric.enabled:
                timings["geometric_pairs_s"] = kept.voting_s
        people_record = None
        if calibration is None and wants_people(cfg, kept, sum(v.camera_motion != "moving" for v in vids.values())):
            t0 = time.perf_counter()
            kept, people_record = _people_cameras(sources, vids, all_pairs, kept, cfg, sink, engine, progress, grid,
                                                  rules, memo)
            timings["people_s"] = time.perf_counter() - t0
        _report_cameras(sink, kept)
        dropped.update(kept.dropped)
        # 5. the heads
        heads, heads_record = {}, None
        if cfg.heads and any(c.is_moving for c in kept.cameras.values()):
            t0 = time.perf_counter()
            heads, heads_record = memo.get(f"heads-{digest(kept.cameras, HEADS_MAX_HZ, cfg.max_side)}",
                                           lambda: find_heads(sources, vids, kept.cameras, kept.undistort, cfg,
                                                              progress, ahead))
            _report_heads(sink, heads_record, {n: v.info.num_frames for n, v in vids.items()})
            timings["heads_s"] = time.perf_counter() - t0
    # 6. the bundle and the record
    cameras, pairs = kept.cameras, kept.pairs
    points, colors = None, None
    if cameras:  # after the moving points' cameras were checked: a refused one is not drawn
        points, colors = kept.points, kept.colors
        if points is not None:  # strays out, an even density (open3d)
            points, colors = clean_point_cloud(points, colors)
        sink.cameras(cameras, points, colors)
    timings["total_s"] = time.perf_counter() - t_all
    for n in names:  # every video left out says why, whatever step lost it
        if n not in cameras and n not in dropped:
            dropped[n] = "no camera for this video"
    pairing = kept.pairing
    votes = pairing.votes if pairing is not None else {}
    transfer_new = pairing.transfer_new if pairing is not None else {}
    stats = CueStats(kept.source, len(cameras), int(sum(t.num_tracks for t in kept.tracks.values())),
                     int(sum(len(p.index) for p in pairs.values())), videos,
                     {f"{a}__{b}": PairCueStats(ps.matches, ps.snapped, ps.instance_pairs, ps.track_pairs,
                                                votes.get((a, b)), transfer_new.get((a, b)))
                      for (a, b), ps in matched.items()},
                     dict(dropped), timings, pairing.status if pairing is not None else None, kept.sfm,
                     pairing.joint if pairing is not None else None, heads_record, people_record)
    usable = [n for n in names if n in cameras]
    if not usable:
        reasons = "; ".join(f"{n}: {r}" for n, r in dropped.items())
        raise NoUsableVideos(f"no video could be used: {reasons}", stats, inputs)
    bundle = CueBundle(tuple(vids[n].info for n in usable), {n: cameras[n] for n in usable},
                       {n: kept.tracks[n] for n in usable}, pairs,
                       heads={n: h for n, h in heads.items() if n in usable},
                       static_points=points if points is not None and len(points) else None,
                       static_colors=colors if points is not None and len(points) else None)
    sink.stage_event("cues", "cue extraction finished", tracks=stats.tracks, track_pairs=stats.track_pairs,
                     cameras=len(cameras))
    return bundle, stats


def _video_cues(sources, cfg: CueConfig, sink: Sink, engine: Engine, progress: bool, need_sfm: bool,
                timings: dict[str, float], dropped: dict[str, str], memo: Memo = NO_MEMO
                ) -> tuple[dict, dict[str, VideoCueStats]]:
    """Step 2: ({name: cues.video.extract.VideoCues} of the videos read, {name: their counts}); a
    video that could not be read goes to dropped."""
    from ..analysis.record_views import record_frame, record_mask
    from ..cues.video.extract import VideoCuesOutcome, video_cues_task

    vids, videos = {}, {}
    t0 = time.perf_counter()
    # two videos at a time on threads locally: one video alone keeps 2 cores only partly busy (the
    # tracks are the same either way)
    task = (cfg, sink.options is not None, need_sfm)
    keys = {s.info.name: f"video-{s.info.name}-{digest(str(s.path), s.info, task)}" for s in sources}
    todo = [s for s in sources if not memo.has(keys[s.info.name])]
    done = dict(zip([s.info.name for s in todo],
                    engine.map(video_cues_task, todo, shared=task, desc="cues per video", unit="video",
                               progress=progress, threads=True)))
    for src in sources:
        out = memo.get(keys[src.info.name], lambda: done[src.info.name])
        name = src.info.name
        sink.video(src.info, str(src.path))
        if isinstance(out, TaskFailed):  # its worker or node died
            out = VideoCuesOutcome(None, out.reason, (), {})
        for k, img, _ in out.shown:
            sink.video_frame(name, k, record_frame(img, sink.options))
        for k, _, instances in out.shown:
            sink.dynamic_mask(name, k, record_mask(instances, sink.options))
        for step, sec in out.timings_s.items():
            timings[step] = timings.get(step, 0.0) + sec
        if out.cues is None:
            dropped[name] = f"could not be read: {out.error}"
            sink.stage_event("cues", f"{name}: could not be read: {out.error}")
            log.warning("%s: could not be read: %s", name, out.error)
            continue
        v = vids[name] = out.cues
        n_tracks = v.xy_full.shape[0]
        note = None
        if v.moving_fraction == 0 or n_tracks == 0:
            note = "no moving regions found (nothing moves in this video)" if v.moving_fraction == 0 \
                else "no point tracks inside the moving regions"
            sink.stage_event("cues", f"{name}: {note}")
            log.warning("%s: %s", name, note)
        videos[name] = VideoCueStats(
            v.path, v.camera_motion, round(v.background_motion_px, 3), round(v.moving_fraction, 4), int(n_tracks),
            int(len(np.unique(v.instance[v.instance > 0]))), int(len(v.features.frame)),
            int((v.features.track >= 0).sum()), note)
    # the per-video steps' times are sums over videos, which may run two at a time: this is the wall time
    timings["videos_s"] = time.perf_counter() - t0
    return vids, videos


def _descriptor_pairs(names: list[str], vids: dict, sink: Sink, progress: bool,
                      memo: Memo = NO_MEMO) -> tuple[dict[tuple[str, str], TrackPairs], dict]:
    """Step 3: ({(a, b): TrackPairs}, {(a, b): cues.pairing.descriptors.PairStats}) of every two videos read."""
    from ..cues.pairing.descriptors import match_tracks

    pairs, matched = {}, {}
    for a, b in tqdm(list(itertools.combinations(names, 2)), desc="cross-view pairs", unit="pair",
                     disable=not progress, leave=False):
        tp, ps = memo.call("match", match_tracks, a, b, vids[a].features, vids[b].features, vids[a].instance,
                           vids[b].instance)
        pairs[(a, b)], matched[(a, b)] = tp, ps
        sink.pair_matches(a, b, vids[a].features.keyframes, vids[b].features.keyframes, ps.keyframe_matches)
        log.info("%s__%s: %d matches, %d snapped, %d instance pairs, %d track pairs",
                 a, b, ps.matches, ps.snapped, ps.instance_pairs, ps.track_pairs)
    return pairs, matched


def _cameras(sources, vids: dict, all_pairs: dict, calibration: dict | None, cfg: CueConfig, progress: bool,
             grid: OffsetGrid, rules: frozenset[str] = ALL, memo: Memo = NO_MEMO):
    """Step 4: the kept cues.cameras.camera_set.CameraSet, its pairs and records."""
    from ..cues.cameras.choice import calibrated_cameras, estimated_cameras, vote_on_cameras
    from ..cues.video.extract import registration_images

    if calibration is not None:
        return vote_on_cameras(calibrated_cameras(calibration, vids), vids, all_pairs, cfg, progress,
                               estimated=False, grid=grid, rules=rules, memo=memo)
    by_name = {s.info.name: s for s in sources}
    frame_images = {n: (functools.partial(registration_images, by_name[n], v, cfg), len(v.register_masks[0]))
                    for n, v in vids.items() if v.register_masks is not None}
    return estimated_cameras(vids, cfg, all_pairs, frame_images, progress, grid, rules, memo)


def _people_cameras(sources, vids: dict, all_pairs: dict, kept, cfg: CueConfig, sink: Sink, engine: Engine,
                    progress: bool, grid: OffsetGrid, rules: frozenset[str] = ALL, memo: Memo = NO_MEMO):
    """Step 4's last source, the people in view (cues/people_cue.py), reported to the sink:
    (the camera set kept, cue_stats.PeopleRecord or None). kept: the background's set (None: not
    estimated). When the people cue fails, the background's set stands."""
    from ..cues.cameras.people import with_moving_points
    from ..cues.people_cue import PeopleCueConfig, find_people_cameras

    read = [s for s in sources if s.info.name in vids]
    motion = {n: v.camera_motion for n, v in vids.items()}
    try:
        with stage("cameras: the people in view as correspondences (BlazePose)", progress):
            cue = find_people_cameras(read, grid, PeopleCueConfig(), engine=engine, progress=progress,
                                      camera_motion=motion, memo=memo)
    except Exception as exc:  # one more opinion: its failure leaves the background's standing
        if kept is None:
            raise
        log.warning("the people cue failed (%s: %s)", type(exc).__name__, exc)
        sink.stage_event("cameras", f"the people cue failed ({type(exc).__name__}: {exc})")
        return kept, None
    sink.people_cue(cue)
    kept, record = _with_people(kept, cue)
    if record.kept and len(kept.cameras) >= 2:
        kept = with_moving_points(kept, cue, vids, all_pairs, cfg, progress, grid, rules, memo)
    return kept, record


def _with_people(kept, cue):
    """(the camera set kept, cue_stats.PeopleRecord): the people's set when it times more videos
    than the background's (kept; None: not estimated), else kept."""
    from ..cues.cameras.people import people_camera_set, people_record

    people = people_camera_set(cue)
    if kept is None:
        return people, people_record(cue, True, "the people alone were asked for (--people only)")
    if len(people.used) > len(kept.used):
        why = (f"the background's cameras timed {len(kept.used)} video(s), the people {len(people.used)}: "
               "the people's cameras were used")
        return people, people_record(cue, True, why)
    why = (f"the background's cameras timed {len(kept.used)} video(s), the people {len(people.used)}: "
           "the background's cameras were kept")
    return kept, people_record(cue, False, why)


def _report_cameras(sink: Sink, kept) -> None:
    """The kept camera set's notes, and its pairing's checks and votes, to the sink."""
    from ..cues.pairing.votes import vote_z

    for note in kept.notes:
        sink.stage_event(note.stage, note.message, **note.numbers)
    pairing = kept.pairing
    if pairing is None:
        return
    for c, chk in pairing.three_view.items():
        sink.three_view_landscape(c, chk.landscape.offsets_s, chk.landscape.supporters, chk.joint_offset_s,
                                  chk.passed)
    for c, chk in pairing.transfer.items():
        land = chk.landscape
        sink.transfer_landscape(c, land.offsets_s, land.share, chk.joint_offset_s, land.offset_s, chk.confirmed)
    for (a, b), gs in pairing.found.items():
        if gs.votes is not None and len(gs.votes):
            sink.pair_votes(a, b, gs.vote_offsets_s, gs.votes, vote_z(gs)[1], pairing.chosen_s.get((a, b)))


def _report_heads(sink: Sink, record, num_frames: dict[str, int]) -> None:
    """Step 5's record to the sink: each video's heads, or why none were looked for."""
    if record.skipped:
        sink.stage_event("cues", f"worn-camera sightings skipped: {record.skipped}")
        return
    for n, found in (record.frames_with_a_head or {}).items():
        sink.stage_event("cues", f"{n}: a person's head in {found} of {num_frames[n]} frames", heads=found)
    for n, why in (record.failed or {}).items():
        sink.stage_event("cues", f"{n}: no heads: {why}")


def _no_cues(dropped: dict[str, str], calibrated: bool) -> CueStats:
    """Stage 0's record when it stopped before extracting any cue."""
    return CueStats("calibration" if calibrated else "estimated", 0, 0, 0, {}, {}, dict(dropped), {})
