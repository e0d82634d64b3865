"""The people cue (people_types.PeopleCue) in a rerun recording: each video's people and their
landmarks over its frames, every pair's association, its evidence at each candidate shift (the
F's inliers, the cost, the search's score) and its decision, and the cameras and 3D landmarks
the cue made. Takes the stream explicitly (no global recording).

Entities (below each video's and pair's own, io/recording_paths.py):
    videos/<v>/people                Points2D per frame (frame timeline): class = person track,
                                     keypoints = BlazePose landmarks, drawn as a skeleton
    pairs/<a>__<b>/people/evidence   series over Δ (offset_ms timeline): inliers, cost, evidence, search
    pairs/<a>__<b>/people/decision   the pair's verdict, shift, margins and association (markdown)
    world/people/cameras/<v>         Pinhole + Transform3D of each camera the cue placed
    world/people/points              the landmarks the bundle adjustment triangulated
    cues/people                      the cue's summary: offsets, refusals, timings (markdown)
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from .. import palette
from ..geometry.skeleton import LANDMARK_NAMES, SKELETON_EDGES
from ..io.recording_paths import TIMELINE_FRAME, TIMELINE_OFFSET_MS, WORLD, entity_name, pair_path, video_path
from ..people_types import PeopleCue, PeoplePair

PEOPLE_CUE = "cues/people"
PEOPLE_WORLD = f"{WORLD}/people"


def people_path(video: str) -> str:
    return f"{video_path(video)}/people"


def pair_people_path(a: str, b: str) -> str:
    return f"{pair_path(a, b)}/people"


def _skeleton(num_people: int) -> rr.AnnotationContext:
    keypoints = [rr.AnnotationInfo(id=k, label=n) for k, n in enumerate(LANDMARK_NAMES)]
    return rr.AnnotationContext([
        rr.ClassDescription(info=rr.AnnotationInfo(id=p, label=f"person {p}", color=palette.instance_colour(p)),
                            keypoint_annotations=keypoints, keypoint_connections=list(SKELETON_EDGES))
        for p in range(max(num_people, 1))])


def log_people(rec: rr.RecordingStream, cue: PeopleCue) -> None:
    """Each video's people on its frame timeline (landmarks seen, as a skeleton per person)."""
    for name, people in cue.people.items():
        base = people_path(name)
        rec.log(base, _skeleton(people.num_people), static=True)
        lm = people.landmarks
        seen = np.nan_to_num(lm[..., 2], nan=0.0) >= people.min_visibility
        for k in range(lm.shape[1]):
            p, l = np.nonzero(seen[:, k])
            if not len(p):
                continue
            rec.set_time(TIMELINE_FRAME, sequence=k)
            rec.log(base, rr.Points2D(lm[p, k, l, :2], class_ids=p, keypoint_ids=l, radii=rr.Radius.ui_points(3.0)))
        rec.reset_time()


def _decision_text(p: PeoplePair) -> str:
    lines = [f"**{p.a} / {p.b}**: " + (f"Δ = {p.offset_s:+.4f} s" + (f" ± {p.offset_std_s:.4f}" if p.offset_std_s else "")
                                        if p.accepted else "refused"), "", p.reason, ""]
    for label, value in (("best candidate Δ", p.best_grid_offset_s), ("next-best distinct Δ", p.second_offset_s),
                         ("margin", p.margin), ("contrast", p.contrast), ("noise unit (px)", p.noise_px),
                         ("inliers after refinement", p.refined_inliers)):
        if value is not None:
            lines.append(f"- {label}: {value:.4g}" if isinstance(value, float) else f"- {label}: {value}")
    if p.associations:
        lines += ["", "| person in " + p.a + " | person in " + p.b + " | labelling |", "| --- | --- | --- |"]
        lines += [f"| {s.person_a} | {s.person_b} | {'mirrored' if s.mirrored else 'as given'} |" for s in p.associations]
    return "\n".join(lines)


def log_pairs(rec: rr.RecordingStream, cue: PeopleCue) -> list[str]:
    """Every pair's evidence over the candidate shifts and its decision; each series named by its
    pair's short names, so that the pairs' plots can share one view. Returns "a__b" of the pairs
    whose evidence was logged."""
    from ..analysis.display_names import display_names

    short = display_names([v.name for v in cue.videos])
    logged = []
    for p in cue.pairs:
        base = pair_people_path(p.a, p.b)
        pair = f"{short.get(p.a, p.a)}→{short.get(p.b, p.b)}"
        rec.log(f"{base}/decision", rr.TextDocument(_decision_text(p), media_type=rr.MediaType.MARKDOWN), static=True)
        if not len(p.offsets_s):
            continue
        logged.append(f"{p.a}__{p.b}")
        ms = np.rint(1000 * np.asarray(p.offsets_s)).astype(np.int64)
        series = (("inliers", p.inliers, "inlier correspondences of the association's F"),
                  ("cost", p.cost, "mean truncated Sampson cost (noise units², 0..1)"),
                  ("evidence", p.evidence, "evidence: (median cost - cost) x sqrt(correspondences)"),
                  ("search", p.search_score, "search: inliers per frame of the best association"))
        for leaf, values, label in series:
            if values is None:
                continue
            path = f"{base}/evidence/{leaf}"
            rec.log(path, rr.SeriesLines(names=[f"{pair} {label}"]), static=True)
            rec.send_columns(path, [rr.TimeColumn(TIMELINE_OFFSET_MS, sequence=ms)],
                             rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64)))
        if p.accepted:
            rec.set_time(TIMELINE_OFFSET_MS, sequence=int(round(1000 * p.offset_s)))
            rec.log(f"{base}/evidence/chosen", rr.SeriesPoints(names=[f"{pair} chosen Δ"], markers="diamond",
                                                               marker_sizes=8.0))
            rec.log(f"{base}/evidence/chosen", rr.Scalars(float(np.nanmax(p.evidence)) if p.evidence is not None else 0.0))
            rec.reset_time()
    return logged


def log_cameras(rec: rr.RecordingStream, cue: PeopleCue) -> None:
    """The cameras the cue placed and the landmarks it triangulated."""
    infos = {v.name: v for v in cue.videos}
    for name, cam in cue.cameras.items():
        T = cam.cam_from_world
        path = f"{PEOPLE_WORLD}/cameras/{entity_name(name)}"
        rec.log(path, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3], relation=rr.TransformRelation.ChildFromParent),
                static=True)
        rec.log(path, rr.Pinhole(image_from_camera=cam.K, width=infos[name].width, height=infos[name].height,
                                 camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=0.3), static=True)
    pts = np.asarray(cue.points_world, dtype=np.float64)
    pts = pts[np.isfinite(pts).all(1)] if len(pts) else pts
    if len(pts):
        rec.log(f"{PEOPLE_WORLD}/points", rr.Points3D(pts.astype(np.float32), radii=rr.Radius.ui_points(2.0)), static=True)


def log_summary(rec: rr.RecordingStream, cue: PeopleCue) -> None:
    """The cue's offsets, refusals and timings as one markdown page."""
    lines = ["**People as correspondences**", "", f"reference: {cue.reference}", "",
             "| video | offset_s | camera | reprojection px |", "| --- | --- | --- | --- |"]
    for v in cue.videos:
        off = cue.offsets_s.get(v.name)
        lines.append(f"| {v.name} | {'' if off is None else f'{off:+.4f}'} | "
                     f"{'placed' if v.name in cue.cameras else 'refused'} | "
                     f"{cue.reprojection_px.get(v.name, float('nan')):.2f} |")
    if cue.refused:
        lines += ["", "Refused:"] + [f"- {v}: {why}" for v, why in cue.refused.items()]
    lines += ["", "Seconds: " + ", ".join(f"{k} {t:.1f}" for k, t in cue.timings_s.items())]
    rec.log(PEOPLE_CUE, rr.TextDocument("\n".join(lines), media_type=rr.MediaType.MARKDOWN), static=True)


def log_people_cue(rec: rr.RecordingStream, cue: PeopleCue) -> list[str]:
    """Everything above, into rec; "a__b" of the pairs whose shift evidence was logged."""
    log_summary(rec, cue)
    log_people(rec, cue)
    logged = log_pairs(rec, cue)
    log_cameras(rec, cue)
    return logged
