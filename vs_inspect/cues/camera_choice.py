"""Stage 0's cameras when none are given: which estimate's cameras the videos get.

pycolmap's models (cues/cameras.py: SIFT's, then XFeat's and ALIKED's when the first leaves a
video untrusted) and the moving points' own cameras (cues/pairwise.py) are each voted on
(cues/joint_vote.py); the set whose joint vote trusts the most videos is kept, and every
video's reason says what each model made of it. No I/O beyond the models' own scratch folders.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import logging
import time
from dataclasses import dataclass

import numpy as np

from ..geometry.offsets import OffsetGrid
from ..progress import stage
from ..record.sink import DeferredSink, Sink
from ..types import FROM_MOVING_POINTS, CameraTrack, Tracks, first_clause, refusal_texts
from .config import CueConfig
from .joint_vote import add_geometric_pairs, check_fitted_offsets
from .video_cues import VideoCues

log = logging.getLogger(__name__)


MOVING_POINTS = "moving points"  # the kind of the camera set _estimate builds from the moving points alone


OWN = " own"  # a weak model's kind with this suffix: its own cameras, voted on after the moving points' failed


def _owner(kind: str) -> str:
    """Whose cameras a set of `kind` are, for messages: "SIFT's", "the moving points'", "SIFT's own"."""
    if kind == MOVING_POINTS:
        return "the moving points'"
    if kind.endswith(OWN):
        return f"{kind.removesuffix(OWN).upper()}'s own"
    return f"{kind.upper()}'s"


@dataclass
class CameraSet:
    """One set of cameras for the videos and what the pairing made of them."""

    cameras: dict[str, CameraTrack]
    tracks: dict[str, Tracks]  # undistorted with the cameras' lenses
    points: np.ndarray | None  # (P,3) static points of the reconstruction, None without one
    colors: np.ndarray | None  # (P,3) uint8
    undistort: dict  # name -> function undistorting (...,2) full-resolution px
    pairs: dict | None = None  # (a, b) -> TrackPairs after the pairing
    used: frozenset = frozenset()  # cameras with a pair whose geometric Δ the pairing trusted
    peaks: dict | None = None  # (a, b) -> the pair's vote peaks Δ_ab (s)
    voting_s: float = 0.0  # seconds spent voting
    stats: dict | None = None  # CueStats' dict as this set left it (estimated cameras)
    events: DeferredSink | None = None  # its reports, held until the set is kept


def _copy_stats(stats: dict) -> dict:
    """A copy of stats to try a set of cameras on; the timings stay shared."""
    return {k: (v if k == "timings_s" else copy.deepcopy(v)) for k, v in stats.items()}


def vote_on_cameras(cams: CameraSet, vids: dict, all_pairs: dict, cfg: CueConfig, stats: dict, sink: Sink,
                    progress: bool, estimated: bool, other_peaks: dict | None = None,
                    other: str = "", grid: OffsetGrid = OffsetGrid()) -> CameraSet:
    """cams with its pairs: the descriptor pairs of its cameras plus the geometric ones
    (add_geometric_pairs; other_peaks, other: another camera model's vote peaks and its name;
    grid: the limits of the offsets voted for), a camera fitted to the moving points at an offset
    its votes refuse taken out."""
    cameras = dict(cams.cameras)
    for name, why in stats["dropped"].items():
        if name in vids:
            sink.stage_event("cameras", f"{name}: {why}")
    for name, r in (stats.get("sfm") or {}).get("frame_registration", {}).items():
        if name in cameras:  # the moving camera's own poses, each frame registered on its own
            sink.stage_event("cameras", f"{name}: {r['registered']} of {r['tried']} frames outside the "
                                        f"reconstruction registered against it (median {r['median_inliers']:.0f} "
                                        f"inliers, {r['refused']} refused); the rest slerped",
                             registered=r["registered"], tried=r["tried"], refused=r["refused"])
    pairs = {k: v for k, v in all_pairs.items() if k[0] in cameras and k[1] in cameras}
    used, peaks, voting_s = frozenset(), {}, 0.0
    if cfg.geometric.enabled:
        t0 = time.perf_counter()
        pairing = add_geometric_pairs(pairs, cameras, cams.tracks, vids, cfg, stats, sink, progress,
                                      estimated=estimated, other_peaks=other_peaks, other=other, grid=grid)
        pairs, voted = pairing.pairs, pairing.voted
        fallback = (stats.get("sfm") or {}).get("fallback") or {}
        if fallback.get("used"):
            refused = check_fitted_offsets(fallback, voted, vids)
            for n, why in refused.items():
                cameras.pop(n, None)
                stats["dropped"][n] = why
                sink.stage_event("cameras", f"{n}: {why}")
                log.warning("%s: %s", n, why)
            pairs = {k: v for k, v in pairs.items() if k[0] in cameras and k[1] in cameras}
        used = frozenset(n for k in voted for n in k if n in cameras)
        peaks = {k: pairing.peaks_s.get(k, ()) for k in pairs}
        voting_s = time.perf_counter() - t0
    return dataclasses.replace(cams, cameras=cameras, pairs=pairs, used=used, peaks=peaks, voting_s=voting_s)


def estimated_cameras(vids: dict[str, VideoCues], cfg: CueConfig, stats: dict, all_pairs: dict,
                      frame_images: dict, sink: Sink, progress: bool, grid: OffsetGrid = OffsetGrid()) -> CameraSet:
    """The cameras pycolmap estimates and their pairs (frame_images: name -> (a function giving a
    moving camera's frames to register, how many), as cameras.CameraModels takes them). With
    camera features "auto", when the joint vote on SIFT's cameras leaves a video without a
    trusted geometric Δ, XFeat's model is tried too (cameras.CameraModels.second), its sure cameras held to SIFT's vote peaks
    (geometric_pairs.disputed_by_other_model); the set with more such videos is kept, SIFT's on
    a tie. When the kept set still leaves one untrusted, ALIKED's model is tried last
    (CameraModels.third), held to the first set's peaks too, and kept only when it trusts more videos.
    stats ends as the kept set left it, with every tried set's counts in stats["sfm"]["models"].
    grid: the limits of every offset Stage 0 searches (the moving points' cameras' and the votes')."""
    from .cameras import CameraModels

    frames = {n: v.sfm_frames for n, v in vids.items() if v.sfm_frames is not None}
    sizes = {n: (v.info.width, v.info.height) for n, v in vids.items()}
    with CameraModels(frames, sizes, {n: v.info.num_frames for n, v in vids.items()},
                      {n: v.camera_motion == "moving" for n, v in vids.items()}, cfg.camera,
                      frame_features={n: v.frame_features for n, v in vids.items() if v.frame_features is not None},
                      frame_images=frame_images,
                      progress=progress) as models:

        memo: dict = {}

        def attempt(est, other_peaks=None, other="", from_tracks=False,
                    as_built=False) -> tuple[str, CameraSet] | None:
            own = _copy_stats(stats)
            events = DeferredSink(sink.options)
            cams = _estimate(vids, cfg, own, all_pairs, est, from_tracks, memo, as_built, grid)
            if from_tracks and not (own["sfm"].get("fallback") or {}).get("used"):
                return None  # est's own cameras again, already voted on
            out = vote_on_cameras(cams, vids, all_pairs, cfg, own, events, progress, estimated=True,
                                  other_peaks=other_peaks, other=other, grid=grid)
            kind = MOVING_POINTS if from_tracks else est.features + (OWN if as_built else "")
            return kind, dataclasses.replace(out, stats=own, events=events)

        with stage("cameras: estimating them from the videos (pycolmap)", progress):
            kept_est = models.first()
        first_est = kept_est
        kind, kept = attempt(kept_est)
        first_kind, first_peaks = kind, kept.peaks
        tried, failed = [(kind, kept)], []
        for which, build in (("second", models.second), ("third", models.third)):
            if not cfg.geometric.enabled or kept.used >= set(vids):
                break
            try:
                with stage(f"cameras: the {which} camera model", progress):
                    est = build()
                if est is None:
                    continue
                log.info("the joint vote trusted %d of %d videos on %s's cameras: trying %s's model",
                         len(kept.used), len(vids), kind.upper(), est.features.upper())
                # each later model is held to the first one's vote peaks
                tried.append(attempt(est, first_peaks, f"{first_kind.upper()}'s model"))
            except Exception as exc:  # another opinion that fails leaves the earlier ones standing
                failed.append(f"the {which} camera model failed ({type(exc).__name__}: {exc}); "
                              f"{kind.upper()}'s kept")
                log.warning("%s", failed[-1])
                continue
            if len(tried[-1][1].used) > len(kept.used):
                (kind, kept), kept_est = tried[-1], est
        if (cfg.geometric.enabled and cfg.camera.fallback_when_untrusted and cfg.camera.fallback_from_tracks
                and not kept.used
                and not any(c.stats["sfm"].get("fallback") for _, c in tried)):
            # every model placed the static cameras, and none was trusted: the moving points' own cameras
            log.info("the joint vote trusted no video on any camera model: trying the moving points' cameras")
            points = attempt(kept_est, from_tracks=True)
            if points is not None:
                tried.append(points)
                if points[1].used:
                    kind, kept = points
        if (cfg.geometric.enabled and cfg.camera.weak_model_when_replaced and not kept.used
                and (tried[0][1].stats["sfm"].get("fallback") or {}).get("used") and len(first_est.cameras) >= 2):
            # the first model was weak and the moving points' cameras replaced its own, and no video
            # was trusted on any set: its own cameras get their vote too (a weak model may be right:
            # the moving points' cameras are judged on track pairs at their own coarse offsets)
            log.info("the joint vote trusted no video on any camera set: trying %s own cameras", _owner(first_kind))
            own = attempt(first_est, as_built=True)
            tried.append(own)
            if own[1].used:
                kind, kept = own
        skipped = models.third_skipped
    kept.events.replay(sink)
    stats.clear()
    stats.update(kept.stats)
    _note_other_models(stats, kind, kept, [(k, c) for k, c in tried if c is not kept], vids)
    if len(tried) > 1:
        stats["sfm"]["models"] = [{"features": k, "cameras": len(c.cameras), "trusted": sorted(c.used),
                                   "kept": c is kept} for k, c in tried]
        msg = (f"camera models: {_owner(kind)} kept; the joint vote trusted "
               + ", ".join(f"{len(c.used)} video(s) on {_owner(k)}" for k, c in tried))
        sink.stage_event("cameras", msg)
        log.info(msg)
    if failed:
        stats["sfm"]["models_failed"] = "; ".join(failed)
        sink.stage_event("cameras", stats["sfm"]["models_failed"])
    if skipped:
        stats["sfm"]["models_skipped"] = skipped
        sink.stage_event("cameras", skipped)
    return kept


def _note_other_models(stats: dict, kind: str, kept: CameraSet, others: list[tuple[str, CameraSet]],
                       vids: dict) -> None:
    """What the other models tried made of each video the kept set (of kind) gives no offset:
    added to the reason of a video it has no camera for (stats' "dropped"), and kept in sfm's
    "other_models" for a video it placed but did not trust, so a null says whether any model
    could time it; sfm's "other_models_headline" says it in a few words for both ({video: {whose
    cameras: why}}), and "kept_model" whose set was kept."""
    if not others:
        return
    untrusted, headlines = {}, {}
    for n in vids:
        placed = n in kept.cameras
        if (n in kept.used) if placed else (n not in stats["dropped"]):
            continue  # timed, or kept out for a reason of its own (unreadable)
        verdicts = {_whose(k): _verdict(k, c, n) for k, c in others}  # whose -> (whole clause, few words)
        said = "; ".join(whole for whole, _ in verdicts.values())
        if placed:
            untrusted[n] = said
        else:
            stats["dropped"][n] += f" (also tried: {said})"
        headlines[n] = {whose: short for whose, (_, short) in verdicts.items()}
    if headlines and stats.get("sfm") is not None:
        stats["sfm"].update({"kept_model": _whose(kind), "other_models_headline": headlines})
        if untrusted:
            stats["sfm"]["other_models"] = untrusted


def _whose(kind: str) -> str:
    """Whose cameras a set of kind are, for messages: "SIFT's model", "the moving points' cameras"."""
    return f"{_owner(kind)} {'cameras' if kind == MOVING_POINTS else 'model'}"


def _verdict(kind: str, c: CameraSet, n: str) -> tuple[str, str]:
    """What camera set c (of kind) made of video n: (one clause, the same in a few words). It
    trusted n, placed it but did not trust it (and why its joint vote gave no geometric pairs),
    or why it has no camera."""
    whose = _whose(kind)
    joint = c.stats.get("geometric_joint") or {}
    if n in c.cameras:
        refusal = None if n in c.used else refusal_texts(c.stats["pairs"], c.stats["dropped"], joint, n)
        whole = (f"{whose} registered it, but its set was not kept (its joint vote trusted {len(c.used)} video(s)"
                 + (f"; for this one: {refusal[1]}" if refusal else "") + ")")
        short = (f"timed it, but its set ({len(c.used)} video(s)) was not kept" if n in c.used else
                 refusal[0] if refusal else "not trusted")
        return whole, short
    dropped = c.stats["dropped"].get(n, "no camera")
    dissent = (joint.get("dissent") or {}).get(n)  # e.g. a refused camera's rival offset
    # the reason's first clause: the rest repeats for every model (the moving points' cameras)
    whole = f"{whose}: {dropped.split('; ')[0]}" + (f" (its joint vote: {dissent})" if dissent else "")
    # a refused camera's rival offset says more than "refused"
    return whole, (joint.get("dissent_short") or {}).get(n) or first_clause(dropped)


def _estimate(vids: dict[str, VideoCues], cfg: CueConfig, stats: dict, pairs: dict, est,
              from_tracks: bool = False, memo: dict | None = None, as_built: bool = False,
              grid: OffsetGrid = OffsetGrid()) -> CameraSet:
    """The cameras of est (cameras.CameraEstimate) and the tracks undistorted with them, or the
    cameras the moving points give when their cameras explain the points better and est is weak,
    or from_tracks (the joint vote trusted no video on est's cameras; the moving points' cameras
    may then be fewer). memo: kept between calls on the same videos and pairs, so that the moving
    points' cameras, which do not depend on est, are fitted once. as_built: est's cameras even
    when weak (the moving points' are not fitted nor compared)."""
    from .cameras import lens_record, undistort_with_colmap
    from .pairwise import cameras_from_tracks, epipolar_fit_px

    stats["sfm"] = {"features": est.features, "images": est.num_images, "registered_images": est.num_registered,
                    "registered_frames": {n: c.registered_frames.tolist() for n, c in est.cameras.items()},
                    "image_pairs": list(est.image_pairs),
                    # the tracks are undistorted with it; other image points (e.g. an evidence
                    # script's detections) need it too
                    "lens": {n: lens_record(c) for n, c in est.cameras.items()}}
    regs = {n: c.frame_registration for n, c in est.cameras.items() if c.frame_registration is not None}
    if regs:
        stats["sfm"]["frame_registration"] = regs
    if est.features == "xfeat":
        stats["sfm"]["xfeat_matcher"] = cfg.camera.xfeat_matcher
    static = [n for n, v in vids.items() if v.camera_motion != "moving"]
    if est.features == "sift" and cfg.camera.asift_per_view and static:  # the static cameras' images
        stats["sfm"]["static_images"] = f"ASIFT, {cfg.camera.asift_per_view} features per simulated view"
    # a model resting on few points per image, or missing a static camera, is checked against the
    # moving points: such models can pass the point threshold with wrong focals and rotations
    fewest = min((c.points_seen for c in est.cameras.values()), default=0)
    weak = len(est.cameras) < 2 or any(n not in est.cameras for n in static) or \
        fewest < 2 * cfg.camera.min_inliers
    weak_why = (f"the background reconstruction rests on few points (fewest {fewest} per image) or left a "
                f"static camera out")
    # the moving points give static cameras only, so when the model placed more videos than there
    # are static ones their cameras cannot replace it (`use` below): not fitted (it would cost seconds)
    outnumbered = not from_tracks and len(est.cameras) > len(static)
    compared = (weak or from_tracks) and cfg.camera.fallback_from_tracks and len(static) >= 2 and not as_built
    if compared and outnumbered:
        why = (f"{weak_why}; the moving points' cameras were not fitted: they would be {len(static)} static "
               f"camera(s) at most, fewer than its {len(est.cameras)}, so they could not replace it")
        stats["sfm"]["fallback"] = {"why": why, "used": False}
        log.warning("%s", why)
    elif compared:
        ref = max(vids, key=lambda n: sum(len(p.index) for k, p in pairs.items() if n in k))
        infos = {n: v.info for n, v in vids.items()}
        xy = {n: v.xy_full for n, v in vids.items()}
        if memo is not None and "from_tracks" in memo:  # the same track pairs for every model
            cams, reasons, details = copy.deepcopy(memo["from_tracks"])
        else:
            cams, reasons, details = cameras_from_tracks(
                ref, infos, xy, pairs, {n: v.camera_motion == "moving" for n, v in vids.items()},
                joint=cfg.camera.fallback_joint_offsets, grid=grid)
            if memo is not None:
                memo["from_tracks"] = copy.deepcopy((cams, reasons, details))
        if from_tracks:  # the background did reconstruct; these cameras are the static ones only
            reasons = {n: ("camera could not be registered: a moving camera, and the moving points give "
                           "static cameras only" if vids[n].camera_motion == "moving" else reason)
                       for n, reason in reasons.items()}
        if len(est.cameras) < 2:
            why = f"the background reconstruction registered {len(est.cameras)} camera(s)"
        elif weak:
            why = weak_why
        else:
            why = "the joint vote trusted no video on any camera model's cameras"
        if len(cams) == 2 and not cfg.camera.fallback_unchecked_pair:
            # the coarse offset and F were chosen by the same track pairs; Stage 1 then finds the
            # minimum they were fitted for, right or wrong, and no third camera can refuse it
            lone = ("only two cameras came out, whose geometry and offset would both come from the same "
                    "track pairs with no third camera to check them")
            reasons = reasons | dict.fromkeys(cams, f"camera could not be registered: {lone}")
            why += f"; {lone}"
            cams = {}
        use = len(cams) >= 2
        if use and len(est.cameras) >= 2:
            # both: keep the one whose cameras explain the moving points better, on the pairs of
            # the background model's static cameras (tracks undistorted with its lens)
            coarse = {n: d["coarse_offset_s"] for n, d in details.items() if "coarse_offset_s" in d} | {ref: 0.0}
            sfm_static = {n: c.track for n, c in est.cameras.items() if n in static}
            sfm_px, n_sfm = epipolar_fit_px(sfm_static, infos, {n: undistort_with_colmap(est.cameras[n], xy[n])
                                                                  for n in sfm_static}, pairs, coarse)
            fb_px, n_fb = epipolar_fit_px({n: c for n, c in cams.items() if n in sfm_static}, infos, xy, pairs, coarse)
            use = (len(cams) >= len(est.cameras) or from_tracks) and n_fb >= n_sfm and fb_px < sfm_px
            if n_sfm == 0:  # e.g. one static camera and a moving one: nothing to compare on
                why += (f"; no pair of its {len(sfm_static)} static camera(s) has enough aligned track pairs "
                        f"to compare it with the moving points' cameras on, so it is kept")
            else:
                why += (f"; on the moving points its cameras leave a median epipolar distance of {sfm_px:.1f} px, "
                        f"the moving points' own cameras {fb_px:.1f} px")
        stats["sfm"]["fallback"] = {"reference": ref, "pairs": details, "why": why, "used": bool(use)}
        log.warning("%s; cameras from the moving points: %d (%s)", why, len(cams), "used" if use else "not used")
        if use:
            # the offsets the cameras were fitted at, relative to the reference (check_fitted_offsets)
            stats["sfm"]["fallback"]["fitted_offsets_s"] = {ref: 0.0} | {
                n: details[n]["coarse_offset_s"] for n in cams if n != ref}
            stats["camera_source"] = "estimated from moving points (two-view geometry)"
            stats["sfm"]["lens"] = {}  # these cameras are pinhole: the tracks stay as they were
            stats["dropped"].update(reasons)
            for n, reason in reasons.items():
                log.warning("%s: %s", n, reason)
            # pinhole cameras: their points are not undistorted
            return CameraSet(cams, {n: Tracks(vids[n].xy_full, vids[n].instance) for n in cams}, None, None, {})
        if len(est.cameras) < 2:  # neither worked: say why for both
            est = dataclasses.replace(est, unregistered={
                n: (f"{sfm_why}; {FROM_MOVING_POINTS}{reasons[n].removeprefix('camera could not be registered: ')}"
                    if n in reasons else sfm_why) for n, sfm_why in est.unregistered.items()})
    stats["dropped"].update(est.unregistered)
    for n, why in est.unregistered.items():
        log.warning("%s: %s", n, why)
    cameras, tracks, undistort = {}, {}, {}
    for n, c in est.cameras.items():
        cameras[n] = c.track
        undistort[n] = functools.partial(undistort_with_colmap, c)
        tracks[n] = Tracks(undistort[n](vids[n].xy_full), vids[n].instance)
    return CameraSet(cameras, tracks, est.points_world, est.colors, undistort)
