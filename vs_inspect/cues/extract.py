"""Stage 0: videos in, a cue bundle out (cameras, tracks inside moving regions, cross-view pairs).

Each step is a function in its own module (each video's own cues in video_cues: decoding,
motion, tracking, keyframe features; matching across videos; which cameras in camera_choice,
the joint vote on them in joint_vote; the people's heads in heads); this module calls them in
order, reports to the sink and keeps per-stage timings.
A video that cannot be used (unreadable, no camera) is left out of the bundle with its reason
in CueStats.dropped, so that the caller can report it as not synchronized; when no video can be
used, NoUsableVideos carries those reasons instead of a bundle.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import logging
import time

import numpy as np
from tqdm import tqdm

from ..engine import Engine, LocalEngine, TaskFailed
from ..errors import InputError, NoUsableVideos
from ..geometry.offsets import OffsetGrid
from ..record.sink import NullSink, Sink
from ..cue_stats import CueStats, PairCueStats, VideoCueStats
from ..types import CueBundle, TrackPairs, Tracks
from .camera_choice import CameraSet, estimated_cameras, vote_on_cameras
from .config import CueConfig
from .heads import HeadsAhead, find_heads
from .matching import PairStats, match_tracks
from .video_cues import VideoCues, VideoCuesOutcome, registration_images, video_cues_task

log = logging.getLogger(__name__)


def _import_cameras(calibration: dict, vids: dict[str, VideoCues]) -> tuple[dict, dict, dict, dict]:
    """(cameras, undistorted tracks, dropped, {video: undistort (...,2) full px like its tracks})
    from an imported calibration."""
    from ..io.calibration import fit_to_video, to_camera_track, undistort_points

    cams, tracks, dropped, undistort = {}, {}, {}, {}
    for name, v in vids.items():
        cal = calibration.get(name)
        if cal is None:
            dropped[name] = "the calibration has no camera for this video"
            continue
        try:
            cal = fit_to_video(cal, v.info.width, v.info.height, name=name)
        except InputError as exc:
            dropped[name] = str(exc)
            continue
        if cal.cam_from_world.ndim == 3 and len(cal.cam_from_world) != v.info.num_frames:
            dropped[name] = (f"the calibration has {len(cal.cam_from_world)} per-frame poses but the "
                             f"video has {v.info.num_frames} frames")
            continue
        cams[name] = to_camera_track(cal)
        undistort[name] = functools.partial(undistort_points, cal)  # (...,2), NaN kept
        tracks[name] = Tracks(undistort[name](v.xy_full), v.instance)
    return cams, tracks, dropped, undistort


def extract_cues(sources, calibration: dict | None = None, cfg: CueConfig = CueConfig(),
                 sink: Sink | None = None, progress: bool = True,
                 engine: Engine | None = None, grid: OffsetGrid = OffsetGrid()) -> tuple[CueBundle, CueStats]:
    """Cues of every video: (CueBundle of the usable videos, CueStats).

    engine: where each video's own cues (decoding, moving regions, tracks, features) are
    computed, one task per video (default: in this process); matching across videos, the
    cameras and everything reported to the sink stay here, in video order.

    sources: VideoSource list (vs_inspect.io.video.open_video). calibration: name ->
    CameraCalibration (vs_inspect.io.calibration.load_calibration) or None to estimate the
    cameras with pycolmap. CueStats: timings per step, per-video and per-pair counts, the videos
    left out of the bundle with their reason, the cameras' source. grid: the limits of every
    offset Stage 0 searches (--min-overlap-s, --range-s, --around), as Stage 1's.
    """
    sink = sink or NullSink()
    if len(sources) < 2:
        raise InputError(f"need at least 2 videos to synchronize, got {len(sources)}")
    names = [s.info.name for s in sources]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"video names must be unique, got {dup} more than once "
                         "(rename the files or put them in differently named folders)")
    timings: dict[str, float] = {}
    videos: dict[str, VideoCueStats] = {}
    dropped: dict[str, str] = {}
    matched: dict[tuple[str, str], PairStats] = {}
    t_all = time.perf_counter()
    vids: dict[str, VideoCues] = {}
    engine = engine or LocalEngine()
    task = (cfg, sink.options, calibration is None)
    t_videos = time.perf_counter()
    # two videos at a time on threads locally: one video alone keeps 2 cores only partly busy (the
    # tracks are the same either way). Not with learned keyframe
    # descriptors: they set torch's process-wide thread count around each call
    for src, out in zip(sources, engine.map(video_cues_task, sources, shared=task, desc="cues per video",
                                            unit="video", progress=progress,
                                            threads=cfg.match.descriptor == "sift")):
        sink.video(src.info, str(src.path))
        if isinstance(out, TaskFailed):  # its worker or node died
            out = VideoCuesOutcome(None, out.reason, (), (), {})
        for k, img in out.frames:
            sink.video_frame(src.info.name, k, img)
        for k, mask in out.masks:
            sink.dynamic_mask(src.info.name, k, mask)
        for step, sec in out.timings_s.items():
            timings[step] = timings.get(step, 0.0) + sec
        if out.cues is None:
            dropped[src.info.name] = f"could not be read: {out.error}"
            sink.stage_event("cues", f"{src.info.name}: could not be read: {out.error}")
            log.warning("%s: could not be read: %s", src.info.name, out.error)
            continue
        v = out.cues
        vids[src.info.name] = v
        n_tracks = v.xy_full.shape[0]
        msg = None
        if v.moving_fraction == 0 or n_tracks == 0:
            msg = "no moving regions found (nothing moves in this video)" if v.moving_fraction == 0 \
                else "no point tracks inside the moving regions"
        videos[src.info.name] = VideoCueStats(
            v.path, v.camera_motion, round(v.background_motion_px, 3), round(v.moving_fraction, 4), int(n_tracks),
            int(len(np.unique(v.instance[v.instance > 0]))), int(len(v.features.frame)),
            int((v.features.track >= 0).sum()), msg)
        if msg is not None:
            sink.stage_event("cues", f"{src.info.name}: {msg}")
            log.warning("%s: %s", src.info.name, msg)

    # the per-video steps' times are sums over videos, which may run two at a time: this is the wall time
    timings["videos_s"] = time.perf_counter() - t_videos
    # a camera seen moving: the heads are found on a thread of their own while the cameras are
    # estimated (COLMAP's mapping keeps one core) and the geometric pairs voted; they are only
    # used when a camera moves in the end
    ahead = HeadsAhead.start(sources, vids, cfg) \
        if cfg.heads and any(v.camera_motion == "moving" for v in vids.values()) else None
    with ahead or contextlib.nullcontext():
        t0 = time.perf_counter()
        all_pairs: dict[tuple[str, str], TrackPairs] = {}
        for a, b in tqdm(list(itertools.combinations([n for n in names if n in vids], 2)), desc="cross-view pairs",
                         unit="pair", disable=not progress, leave=False):
            tp, ps = match_tracks(a, b, vids[a].features, vids[b].features, vids[a].instance,
                                  vids[b].instance, cfg.match)
            all_pairs[(a, b)] = tp
            sink.pair_matches(a, b, vids[a].features.keyframes, vids[b].features.keyframes, ps.keyframe_matches)
            matched[(a, b)] = ps
            log.info("%s__%s: %d matches, %d snapped, %d instance pairs, %d track pairs",
                     a, b, ps.matches, ps.snapped, ps.instance_pairs, ps.track_pairs)
        timings["matching_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        if calibration is not None:
            cameras, tracks, refused, undistort = _import_cameras(calibration, vids)
            kept = vote_on_cameras(CameraSet(cameras, tracks, None, None, undistort, refused, "calibration"), vids,
                                   all_pairs, cfg, sink, progress, estimated=False, grid=grid)
        else:
            by_name = {s.info.name: s for s in sources}
            frame_images = {n: (functools.partial(registration_images, by_name[n], v, cfg), len(v.register_masks[0]))
                            for n, v in vids.items() if v.register_masks is not None}
            kept = estimated_cameras(vids, cfg, all_pairs, frame_images, sink, progress, grid)
        dropped.update(kept.dropped)
        cameras, tracks, undistort, pairs = kept.cameras, kept.tracks, kept.undistort, kept.pairs
        points, colors = kept.points, kept.colors
        timings["cameras_s"] = time.perf_counter() - t0 - kept.voting_s
        if cfg.geometric.enabled:
            timings["geometric_pairs_s"] = kept.voting_s
        heads, heads_record = {}, None
        if cfg.heads and any(c.is_moving for c in cameras.values()):
            t0 = time.perf_counter()
            heads, heads_record = find_heads(sources, vids, cameras, undistort, cfg, sink, progress, ahead)
            timings["heads_s"] = time.perf_counter() - t0
    if cameras:  # after the moving points' cameras were checked: a refused one is not drawn
        sink.cameras(cameras, points, colors)
    usable = [n for n in names if n in cameras]
    timings["total_s"] = time.perf_counter() - t_all
    for n in names:  # every video left out says why, whatever step lost it
        if n not in cameras and n not in dropped:
            dropped[n] = "no camera for this video"
    pairing = kept.pairing
    votes = pairing.votes if pairing is not None else {}
    transfer_new = pairing.transfer_new if pairing is not None else {}
    stats = CueStats(kept.source, len(cameras), int(sum(t.num_tracks for t in tracks.values())),
                     int(sum(len(p.index) for p in pairs.values())), videos,
                     {f"{a}__{b}": PairCueStats(ps.matches, ps.snapped, ps.instance_pairs, ps.track_pairs,
                                                votes.get((a, b)), transfer_new.get((a, b)))
                      for (a, b), ps in matched.items()},
                     dropped, timings, pairing.status if pairing is not None else None, kept.sfm,
                     pairing.joint if pairing is not None else None, heads_record)
    if not usable:
        reasons = "; ".join(f"{n}: {r}" for n, r in dropped.items())
        raise NoUsableVideos(f"no video could be used: {reasons}", stats, {s.info.name: str(s.path) for s in sources})
    bundle = CueBundle(tuple(vids[n].info for n in usable), {n: cameras[n] for n in usable},
                       {n: tracks[n] for n in usable}, pairs, heads={n: h for n, h in heads.items() if n in usable})
    sink.stage_event("cues", "cue extraction finished", tracks=stats.tracks,
                     track_pairs=stats.track_pairs, cameras=len(cameras))
    return bundle, stats
