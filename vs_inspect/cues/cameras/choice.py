"""Stage 0's cameras when none are given: which estimate's cameras the videos get.

pycolmap's models (cues/cameras/sfm.py: SIFT's, then XFeat's and ALIKED's when the first leaves a
video untrusted) and the moving points' own cameras (cues/cameras/moving_points.py) are each voted on
(cues/pairing/joint.py); the set whose joint vote trusts the most videos is kept, and every
video's reason says what each model made of it. No I/O beyond the models' own scratch folders.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import time

from ...camera_stats import ModelTried
from ...cue_stats import refusal_texts
from ...errors import InputError
from ...geometry.offsets import OffsetGrid
from ...types import Tracks, first_clause
from ..config import CueConfig
from ...memo import NO_MEMO, Memo, digest
from ...progress import stage
from ..records import Note, say_cameras
from ..rules import ALL
from ..pairing.pairing import add_geometric_pairs
from ..video.extract import VideoCues
from .camera_set import CameraSet
from .model_or_points import _estimate

log = logging.getLogger(__name__)


MOVING_POINTS = "moving points"  # the kind of the camera set _estimate builds from the moving points alone


def _owner(kind: str) -> str:
    """Whose cameras a set of `kind` are, for messages: "SIFT's", "the moving points'"."""
    if kind == MOVING_POINTS:
        return "the moving points'"
    return f"{kind.upper()}'s"


def calibrated_cameras(calibration: dict, vids: dict[str, VideoCues]) -> CameraSet:
    """The cameras of an imported calibration (name -> CameraCalibration) fitted to each video,
    the tracks undistorted with their lenses; a video the calibration cannot serve is dropped
    with the reason."""
    from ...io.calibration import fit_to_video, to_camera_track, undistort_points

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
    return CameraSet(cams, tracks, None, None, undistort, dropped, "calibration")


def vote_on_cameras(cams: CameraSet, vids: dict, all_pairs: dict, cfg: CueConfig,
                    progress: bool, estimated: bool, grid: OffsetGrid = OffsetGrid(),
                    rules: frozenset[str] = ALL, memo: Memo = NO_MEMO) -> CameraSet:
    """cams with its pairs: the descriptor pairs of its cameras plus the geometric ones
    (add_geometric_pairs; grid: the limits of the offsets voted for)."""
    cameras, dropped, sfm = cams.cameras, cams.dropped, cams.sfm
    notes: list[Note] = []
    for name, why in dropped.items():
        if name in vids:
            say_cameras(notes, f"{name}: {why}")
    for name, r in ((sfm.frame_registration if sfm else None) or {}).items():
        if name in cameras:  # the moving camera's own poses, each frame registered on its own
            say_cameras(notes, f"{name}: {r.registered} of {r.tried} frames outside the reconstruction registered "
                               f"against it (median {r.median_inliers:.0f} inliers, {r.refused} refused); the rest "
                               "slerped", registered=r.registered, tried=r.tried, refused=r.refused)
    pairs = {k: v for k, v in all_pairs.items() if k[0] in cameras and k[1] in cameras}
    used, voting_s, pairing = frozenset(), 0.0, None
    if cfg.geometric.enabled:
        t0 = time.perf_counter()
        pairing = add_geometric_pairs(pairs, cameras, cams.tracks, vids, cfg, progress,
                                      estimated=estimated, grid=grid, rules=rules, memo=memo)
        pairs, voted = pairing.pairs, pairing.voted
        notes += pairing.notes
        used = frozenset(n for k in voted for n in k if n in cameras)
        voting_s = time.perf_counter() - t0
    return dataclasses.replace(cams, pairs=pairs, used=used, voting_s=voting_s, pairing=pairing, notes=tuple(notes))


def estimated_cameras(vids: dict[str, VideoCues], cfg: CueConfig, all_pairs: dict,
                      frame_images: dict, progress: bool, grid: OffsetGrid = OffsetGrid(),
                      rules: frozenset[str] = ALL, memo: Memo = NO_MEMO) -> CameraSet:
    """The cameras pycolmap estimates and their pairs (frame_images: name -> (a function giving a
    moving camera's frames to register, how many), as cameras.CameraModels takes them). With
    camera features "auto", when the joint vote on SIFT's cameras leaves a video without a
    trusted geometric Δ, XFeat's model is tried too (cameras.CameraModels.second); the set with
    more such videos is kept, SIFT's on a tie. When the kept set still leaves one untrusted,
    ALIKED's model is tried last (CameraModels.third), and kept only when it trusts more videos.
    When no set trusts any video, the moving points' own cameras are tried last (_try_moving_points).
    The kept set's sfm record holds every tried set's counts (models).
    grid: the limits of every offset Stage 0 searches (the moving points' cameras' and the votes')."""

    def attempt(est, from_tracks=False) -> tuple[str, CameraSet] | None:
        cams = _estimate(vids, cfg, all_pairs, est, from_tracks, grid, rules, memo)
        if from_tracks and not (cams.sfm.fallback is not None and cams.sfm.fallback.used):
            return None  # est's own cameras again, already voted on
        out = vote_on_cameras(cams, vids, all_pairs, cfg, progress, estimated=True, grid=grid, rules=rules,
                              memo=memo)
        kind = MOVING_POINTS if from_tracks else est.features
        return kind, out

    with _kept_models(vids, cfg, frame_images, progress, memo) as models:
        with stage("cameras: estimating them from the videos (pycolmap)", progress):
            kept_est = models.first()
        kind, kept = attempt(kept_est)
        tried, failed = [(kind, kept)], []
        kind, kept, kept_est = _try_later_models(models, attempt, kind, kept, kept_est, tried, failed, vids, cfg,
                                                 rules, progress)
        kind, kept = _try_moving_points(attempt, kind, kept, kept_est, tried, cfg, rules)
        skipped = models.third_skipped
    return _choice_noted(kind, kept, tried, failed, skipped, vids)


def _kept_models(vids: dict[str, VideoCues], cfg: CueConfig, frame_images: dict, progress: bool,
                 memo: Memo) -> _KeptModels:
    """pycolmap's camera models of the videos (cameras.CameraModels, built only when needed), each
    estimate kept in memo under a digest of the camera settings, frames and features."""
    from .sfm import CameraModels

    frames = {n: v.sfm_frames for n, v in vids.items() if v.sfm_frames is not None}
    sizes = {n: (v.info.width, v.info.height) for n, v in vids.items()}
    features = {n: v.frame_features for n, v in vids.items() if v.frame_features is not None}
    key = digest(cfg.camera, frames, features)

    def build():
        return CameraModels(frames, sizes, {n: v.info.num_frames for n, v in vids.items()},
                            {n: v.camera_motion == "moving" for n, v in vids.items()}, cfg.camera,
                            frame_features=features, frame_images=frame_images, progress=progress)

    return _KeptModels(build, memo, key)


def _try_later_models(models: _KeptModels, attempt, kind: str, kept: CameraSet, kept_est, tried: list, failed: list,
                      vids: dict, cfg: CueConfig, rules: frozenset[str], progress: bool) -> tuple[str, CameraSet, object]:
    """(kind, kept set, its estimate) after the second and third camera models were tried while a
    video is left untrusted, each voted on with attempt and kept when its joint vote trusts more
    videos; tried gets each set tried, failed why a model failed."""
    for which, build_next in (("second", models.second), ("third", models.third)):
        if not cfg.geometric.enabled or kept.used >= set(vids):
            break
        if f"{which}_model" not in rules:
            continue
        try:
            with stage(f"cameras: the {which} camera model", progress):
                est = build_next()
            if est is None:
                continue
            log.info("the joint vote trusted %d of %d videos on %s's cameras: trying %s's model",
                     len(kept.used), len(vids), kind.upper(), est.features.upper())
            tried.append(attempt(est))
        except Exception as exc:  # another opinion that fails leaves the earlier ones standing
            failed.append(f"the {which} camera model failed ({type(exc).__name__}: {exc}); "
                          f"{kind.upper()}'s kept")
            log.warning("%s", failed[-1])
            continue
        if len(tried[-1][1].used) > len(kept.used):
            (kind, kept), kept_est = tried[-1], est
    return kind, kept, kept_est


def _try_moving_points(attempt, kind: str, kept: CameraSet, kept_est, tried: list, cfg: CueConfig,
                       rules: frozenset[str]) -> tuple[str, CameraSet]:
    """(kind, kept set) after the last resort when no video was trusted on any set: the moving
    points' own cameras, kept when their joint vote trusts a video; tried gets them when tried."""
    if (cfg.geometric.enabled and cfg.camera.fallback_when_untrusted and cfg.camera.fallback_from_tracks
            and "points_when_untrusted" in rules and not kept.used):
        # every model placed the static cameras, and none was trusted: the moving points' own cameras
        log.info("the joint vote trusted no video on any camera model: trying the moving points' cameras")
        points = attempt(kept_est, from_tracks=True)
        if points is not None:
            tried.append(points)
            if points[1].used:
                kind, kept = points
    return kind, kept


def _choice_noted(kind: str, kept: CameraSet, tried: list, failed: list, skipped: str | None,
                  vids: dict) -> CameraSet:
    """The kept set (of kind) with its notes and sfm record saying what every camera set tried
    made of the videos, which one was kept, which models failed and which were skipped."""
    notes = list(kept.notes)  # only the kept set's notes are reported, then the choice
    models_tried = tuple(ModelTried(k, len(c.cameras), tuple(sorted(c.used)), c is kept) for k, c in tried)
    kept = _note_other_models(kind, kept, [(k, c) for k, c in tried if c is not kept], vids)
    sfm = kept.sfm
    if len(tried) > 1:
        sfm = dataclasses.replace(sfm, models=models_tried)
        msg = (f"camera models: {_owner(kind)} kept; the joint vote trusted "
               + ", ".join(f"{len(c.used)} video(s) on {_owner(k)}" for k, c in tried))
        say_cameras(notes, msg)
        log.info(msg)
    if failed:
        sfm = dataclasses.replace(sfm, models_failed="; ".join(failed))
        say_cameras(notes, sfm.models_failed)
    if skipped:
        sfm = dataclasses.replace(sfm, models_skipped=skipped)
        say_cameras(notes, skipped)
    return dataclasses.replace(kept, sfm=sfm, notes=tuple(notes))


class _KeptModels:
    """CameraModels' first, second and third estimates, each kept in the memo under key; the
    models are built (and first() run, which the others need) only for an estimate not kept."""

    def __init__(self, build, memo: Memo, key: str):
        self._build, self._memo, self._key = build, memo, key
        self._stack = contextlib.ExitStack()
        self._models = None
        self._first = None
        self.third_skipped: str | None = None

    def __enter__(self) -> _KeptModels:
        return self

    def __exit__(self, *exc) -> None:
        self._stack.close()

    def _built(self):
        if self._models is None:
            self._models = self._stack.enter_context(self._build())
            self._first = self._models.first()
        return self._models

    def first(self):
        def compute():
            self._built()
            return self._first

        return self._memo.get(f"model-first-{self._key}", compute)

    def second(self):
        return self._memo.get(f"model-second-{self._key}", lambda: self._built().second())

    def third(self):
        def build():
            models = self._built()
            return models.third(), models.third_skipped

        est, self.third_skipped = self._memo.get(f"model-third-{self._key}", build)
        return est


def _note_other_models(kind: str, kept: CameraSet, others: list[tuple[str, CameraSet]], vids: dict) -> CameraSet:
    """kept with what the other models tried made of each video it (of kind) gives no offset:
    added to the reason of a video it has no camera for (its dropped), and kept in its sfm
    record's other_models for a video it placed but did not trust, so a null says whether any
    model could time it; other_models_headline says it in a few words for both ({video: {whose
    cameras: why}}), and kept_model whose set was kept."""
    if not others:
        return kept
    untrusted, headlines, dropped = {}, {}, dict(kept.dropped)
    for n in vids:
        placed = n in kept.cameras
        if (n in kept.used) if placed else (n not in dropped):
            continue  # timed, or kept out for a reason of its own (unreadable)
        verdicts = {_whose(k): _verdict(k, c, n) for k, c in others}  # whose -> (whole clause, few words)
        said = "; ".join(whole for whole, _ in verdicts.values())
        if placed:
            untrusted[n] = said
        else:
            dropped[n] += f" (also tried: {said})"
        headlines[n] = {whose: short for whose, (_, short) in verdicts.items()}
    sfm = kept.sfm
    if headlines and sfm is not None:
        sfm = dataclasses.replace(sfm, kept_model=_whose(kind), other_models_headline=headlines,
                                  other_models=untrusted or None)
    return dataclasses.replace(kept, dropped=dropped, sfm=sfm)


def _whose(kind: str) -> str:
    """Whose cameras a set of kind are, for messages: "SIFT's model", "the moving points' cameras"."""
    return f"{_owner(kind)} {'cameras' if kind == MOVING_POINTS else 'model'}"


def _verdict(kind: str, c: CameraSet, n: str) -> tuple[str, str]:
    """What camera set c (of kind) made of video n: (one clause, the same in a few words). It
    trusted n, placed it but did not trust it (and why its joint vote gave no geometric pairs),
    or why it has no camera."""
    whose = _whose(kind)
    joint = c.pairing.joint if c.pairing is not None else None
    if n in c.cameras:
        refusal = None if n in c.used else refusal_texts(c.votes(), c.dropped, joint, n)
        whole = (f"{whose} registered it, but its set was not kept (its joint vote trusted {len(c.used)} video(s)"
                 + (f"; for this one: {refusal[1]}" if refusal else "") + ")")
        short = (f"timed it, but its set ({len(c.used)} video(s)) was not kept" if n in c.used else
                 refusal[0] if refusal else "not trusted")
        return whole, short
    dropped = c.dropped.get(n, "no camera")
    dissent = ((joint.dissent if joint else None) or {}).get(n)  # e.g. a refused camera's rival offset
    # the reason's first clause: the rest repeats for every model (the moving points' cameras)
    whole = f"{whose}: {dropped.split('; ')[0]}" + (f" (its joint vote: {dissent})" if dissent else "")
    # a refused camera's rival offset says more than "refused"
    return whole, ((joint.dissent_short if joint else None) or {}).get(n) or first_clause(dropped)
