"""One camera model's cameras for the videos, or, when the joint vote trusted no video on any
model's cameras, the moving points' own cameras (cues/cameras/moving_points.py fits them) when
the model placed fewer than two or they explain the moving points better. No I/O beyond the
models' own scratch folders.
"""

from __future__ import annotations

import dataclasses
import functools
import logging

from ...camera_stats import (ImagePairMatches, JointCoarseOffsets, JointFit, MovingPointsCameras, MovingPointsPair,
                             SfmRecord)
from ...geometry.offsets import OffsetGrid
from ...json_records import from_json
from ...memo import NO_MEMO, Memo
from ...types import FROM_MOVING_POINTS, Tracks
from ..config import CueConfig
from ..rules import ALL
from ..video.extract import VideoCues
from .camera_set import CameraSet

log = logging.getLogger(__name__)


def _estimate(vids: dict[str, VideoCues], cfg: CueConfig, pairs: dict, est, from_tracks: bool = False,
              grid: OffsetGrid = OffsetGrid(), rules: frozenset[str] = ALL, kept: Memo = NO_MEMO) -> CameraSet:
    """The cameras of est (cameras.CameraEstimate) and the tracks undistorted with them; with
    from_tracks (the joint vote trusted no video on any model's cameras), the cameras the moving
    points give instead, when est placed fewer than two or theirs explain the moving points better
    (they may be fewer)."""
    static = [n for n, v in vids.items() if v.camera_motion != "moving"]
    sfm = _sfm_record(est, cfg, static)
    if not (from_tracks and cfg.camera.fallback_from_tracks and len(static) >= 2):
        return _model_set(est, vids, sfm)
    ref = max(vids, key=lambda n: sum(len(p.index) for k, p in pairs.items() if n in k))
    infos = {n: v.info for n, v in vids.items()}
    xy = {n: v.xy_full for n, v in vids.items()}
    cams, reasons, details = _fitted_moving_points(ref, infos, xy, vids, cfg, pairs, grid, rules, kept)
    cams, reasons, why = _without_a_lone_pair(cams, reasons, _why_fitted(est, static), cfg, rules)
    use = len(cams) >= 2
    if use and len(est.cameras) >= 2:
        use, why = _explain_better(est, cams, details, ref, static, infos, xy, pairs, why)
    fallback = _moving_points_record(ref, details, why, bool(use))
    log.warning("%s; cameras from the moving points: %d (%s)", why, len(cams), "used" if use else "not used")
    if use:
        return _moving_points_set(cams, reasons, fallback, sfm, vids)
    sfm = dataclasses.replace(sfm, fallback=fallback)
    if len(est.cameras) < 2:  # neither worked: say why for both
        est = dataclasses.replace(est, unregistered={
            n: (f"{sfm_why}; {FROM_MOVING_POINTS}{reasons[n].removeprefix('camera could not be registered: ')}"
                if n in reasons else sfm_why) for n, sfm_why in est.unregistered.items()})
    return _model_set(est, vids, sfm)


def _why_fitted(est, static: list[str]) -> str:
    """What the moving points' cameras' record says of est (cameras.CameraEstimate; static: the
    static videos) when they are fitted: it placed fewer than two cameras, rests on few points per
    image or left a static camera out, or none of its videos was trusted."""
    from .sfm import MIN_INLIERS

    fewest = min((c.points_seen for c in est.cameras.values()), default=0)
    if len(est.cameras) < 2:
        return f"the background reconstruction registered {len(est.cameras)} camera(s)"
    if any(n not in est.cameras for n in static) or fewest < 2 * MIN_INLIERS:
        return (f"the background reconstruction rests on few points (fewest {fewest} per image) or left a "
                f"static camera out")
    return "the joint vote trusted no video on any camera model's cameras"


def _sfm_record(est, cfg: CueConfig, static: list[str]) -> SfmRecord:
    """The record of est (cameras.CameraEstimate): its images, registered frames, matches and
    lenses (static: the static videos, whose images SIFT's model gave ASIFT features)."""
    regs = {n: c.frame_registration for n, c in est.cameras.items() if c.frame_registration is not None}
    return SfmRecord(est.features, est.num_images, est.num_registered,
                     {n: tuple(c.registered_frames.tolist()) for n, c in est.cameras.items()},
                     tuple(ImagePairMatches(**p) for p in est.image_pairs),
                     # the tracks are undistorted with it; other image points (e.g. an evidence
                     # script's detections) need it too
                     {n: c.lens for n, c in est.cameras.items()},
                     frame_registration=regs or None,
                     # the static cameras' images
                     static_images=f"ASIFT, {cfg.camera.asift_per_view} features per simulated view"
                     if est.features == "sift" and cfg.camera.asift_per_view and static else None)


def _fitted_moving_points(ref: str, infos: dict, xy: dict, vids: dict[str, VideoCues], cfg: CueConfig, pairs: dict,
                          grid: OffsetGrid, rules: frozenset[str], kept: Memo) -> tuple[dict, dict, dict]:
    """(cameras, {video: why it has none}, details) the moving points give relative to ref
    (cameras_from_tracks); a moving camera's reason says the moving points give static cameras
    only."""
    from .moving_points import cameras_from_tracks

    cams, reasons, details = kept.call(
        "moving_points", cameras_from_tracks, ref, infos, xy, pairs,
        {n: v.camera_motion == "moving" for n, v in vids.items()},
        joint=cfg.camera.fallback_joint_offsets and "joint_coarse_offsets" in rules, grid=grid)
    reasons = {n: ("camera could not be registered: a moving camera, and the moving points give "
                   "static cameras only" if vids[n].camera_motion == "moving" else reason)
               for n, reason in reasons.items()}
    return cams, reasons, details


def _without_a_lone_pair(cams: dict, reasons: dict, why: str, cfg: CueConfig,
                         rules: frozenset[str]) -> tuple[dict, dict, str]:
    """(cams, reasons, why), none of the cameras kept when only two came out (their geometry and
    offset would come from the same track pairs), each reason and why saying so."""
    if len(cams) == 2 and not cfg.camera.fallback_unchecked_pair and "two_point_cameras" in rules:
        # the coarse offset and F were chosen by the same track pairs; Stage 1 then finds the
        # minimum they were fitted for, right or wrong, and no third camera can refuse it
        lone = ("only two cameras came out, whose geometry and offset would both come from the same "
                "track pairs with no third camera to check them")
        reasons = reasons | dict.fromkeys(cams, f"camera could not be registered: {lone}")
        why += f"; {lone}"
        cams = {}
    return cams, reasons, why


def _explain_better(est, cams: dict, details: dict, ref: str, static: list[str], infos: dict, xy: dict, pairs: dict,
                    why: str) -> tuple[bool, str]:
    """(whether the moving points' cameras are used instead of est's, why with the comparison
    added): they must leave the moving points a smaller median epipolar distance, on as many track
    pairs, over the pairs of est's static cameras."""
    from .moving_points import epipolar_fit_px
    from .sfm import undistort_with_colmap

    # both: keep the one whose cameras explain the moving points better, on the pairs of
    # the background model's static cameras (tracks undistorted with its lens)
    coarse = {n: d["coarse_offset_s"] for n, d in details.items() if "coarse_offset_s" in d} | {ref: 0.0}
    sfm_static = {n: c.track for n, c in est.cameras.items() if n in static}
    sfm_px, n_sfm = epipolar_fit_px(sfm_static, infos, {n: undistort_with_colmap(est.cameras[n], xy[n])
                                                          for n in sfm_static}, pairs, coarse)
    fb_px, n_fb = epipolar_fit_px({n: c for n, c in cams.items() if n in sfm_static}, infos, xy, pairs, coarse)
    use = n_fb >= n_sfm and fb_px < sfm_px
    if n_sfm == 0:  # e.g. one static camera and a moving one: nothing to compare on
        why += (f"; no pair of its {len(sfm_static)} static camera(s) has enough aligned track pairs "
                f"to compare it with the moving points' cameras on, so it is kept")
    else:
        why += (f"; on the moving points its cameras leave a median epipolar distance of {sfm_px:.1f} px, "
                f"the moving points' own cameras {fb_px:.1f} px")
    return use, why


def _moving_points_set(cams: dict, reasons: dict, fallback: MovingPointsCameras, sfm: SfmRecord,
                       vids: dict[str, VideoCues]) -> CameraSet:
    """The moving points' cameras as the videos' set (pinhole, tracks as seen), fallback their record."""
    for n, reason in reasons.items():
        log.warning("%s: %s", n, reason)
    # pinhole cameras: their points are not undistorted, and there is no lens
    return CameraSet(cams, {n: Tracks(vids[n].xy_full, vids[n].instance) for n in cams}, None, None, {},
                     dict(reasons), "estimated from moving points (two-view geometry)",
                     dataclasses.replace(sfm, lens={}, fallback=fallback))


def _model_set(est, vids: dict[str, VideoCues], sfm: SfmRecord) -> CameraSet:
    """est's cameras as the videos' set, the tracks undistorted with their lenses; a video it has
    no camera for dropped with its reason."""
    from .sfm import undistort_with_colmap

    for n, why in est.unregistered.items():
        log.warning("%s: %s", n, why)
    cameras, tracks, undistort = {}, {}, {}
    for n, c in est.cameras.items():
        cameras[n] = c.track
        undistort[n] = functools.partial(undistort_with_colmap, c)
        tracks[n] = Tracks(undistort[n](vids[n].xy_full), vids[n].instance)
    return CameraSet(cameras, tracks, est.points_world, est.colors, undistort, dict(est.unregistered), "estimated", sfm)


def _moving_points_record(ref: str, details: dict, why: str, used: bool) -> MovingPointsCameras:
    """The record of the moving points' cameras from cameras_from_tracks' details."""
    per = {n: MovingPointsPair(**d) for n, d in details.items() if n not in ("joint_offsets", "joint_fit")}
    return MovingPointsCameras(why, used, ref, per, from_json(JointCoarseOffsets | None, details.get("joint_offsets")),
                               from_json(JointFit | None, details.get("joint_fit")))
