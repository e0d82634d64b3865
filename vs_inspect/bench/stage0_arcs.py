"""vs-inspect bench-stage0 arcs: rendered scenes whose cameras share a view (vs_inspect.bench.arcs)
through the whole pipeline, with the cameras and the track pairs against the scene's truth."""

from __future__ import annotations

import contextlib
import json
import tempfile
import time
from pathlib import Path

import numpy as np  # before pycolmap

from ..cues import CueConfig
from ..errors import InputError
from ..pipeline.stage12 import sync_bundle
from .arcs import SCENE_SETS, camera_errors_px, fit_body_points, frame_errors, judge_pairs, parse_scene, summarize
from .stage0 import camera_config


def bench_arcs(args) -> None:
    """Rendered scenes on arcs of 30-90° (vs_inspect.bench.arcs) with estimated cameras (or with
    --calibrated, the scene's exact calibration), the whole pipeline as `vs-inspect sync VIDEOS`
    runs it: every offset's error in frames, and how many are over 2 frames (the safety target)."""
    from ..pipeline.stage0 import run_stage0
    from ..synth.videos import render_unless_cached

    names = args.scenes or SCENE_SETS[args.set]
    try:
        scenes = [parse_scene(n) for n in names]
    except ValueError as exc:
        raise InputError(str(exc)) from None
    all_errors: list[float | None] = []
    print("| scene | reference | offsets (frames; null = unresolved) | cameras | camera px "
          "| track pairs: same / other point / not rigid | stage 0 s | sync s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    with (contextlib.nullcontext(args.workdir) if args.workdir else tempfile.TemporaryDirectory()) as tmp:
        for sc in scenes:
            folder, scene_cfg = Path(tmp) / sc.name, sc.scene_config()
            render_unless_cached(folder, scene_cfg, progress=False)
            truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
            videos = sorted(folder.glob("cam*.mp4"))
            t0 = time.perf_counter()
            try:
                calib = folder / "calibration.json" if args.calibrated else None
                bundle, stats, _ = run_stage0(videos, calib, None, CueConfig(camera=camera_config(args)),
                                              progress=False)
            except InputError as exc:
                all_errors.extend([None] * (len(truth) - 1))  # every offset but the reference's null
                print(f"| {sc.name} | - | Stage 0 failed: {exc} | - | - | - | {time.perf_counter() - t0:.1f} | - |", flush=True)
                continue
            t1 = time.perf_counter()
            res = sync_bundle(bundle, progress=False)
            t2 = time.perf_counter()
            rates = {c["name"]: c["fps"] for c in json.loads((folder / "scene.json").read_text())["cameras"]}
            errors = frame_errors(res.reference, res.offsets_s, truth, rates)
            all_errors.extend(errors.values())
            shown = ", ".join(f"{v} " + ("null" if e is None else f"{e:+.2f}" + (" **over 2**" if abs(e) > 2 else ""))
                              for v, e in errors.items())
            print(f"| {sc.name} | {res.reference} | {shown} | {camera_models(stats)} | {camera_px(folder, bundle, stats)} "
                  f"| {true_pairs(sc, bundle, stats)} | {t1 - t0:.1f} | {t2 - t1:.1f} |", flush=True)
    s = summarize(all_errors)
    med = "-" if s.median_abs_frames is None else f"{s.median_abs_frames:.2f}"
    mx = "-" if s.max_abs_frames is None else f"{s.max_abs_frames:.2f}"
    print(f"\n{len(scenes)} scenes, {s.offsets} offsets: {s.resolved} resolved ({s.within_1} within 1 frame, "
          f"{s.from_1_to_2} at 1-2 frames, **{s.over_2} over 2 frames**), {s.offsets - s.resolved} null; "
          f"|error| median {med}, max {mx} frames")


def camera_px(folder: Path, bundle, stats) -> str:
    """The cameras against the scene's truth (vs_inspect.bench.arcs.camera_errors_px): the median
    and the largest over the camera pairs of their true points' median distance from the
    epipolar lines, in px ("-": fewer than two cameras)."""
    from ..io.calibration import load_calibration, undistort_points

    names = [v.name for v in bundle.videos]
    truth = load_calibration(folder / "calibration.json", names)
    lens = stats.sfm.lens if stats.sfm is not None else {}
    # the tracks were undistorted with the estimated lens, or with the calibration's
    undistort = {n: (lambda xy, n=n: lens[n].undistort(first_K(bundle, n), xy))
                 for n in lens if n in bundle.cameras}
    for n, cal in truth.items():
        undistort.setdefault(n, lambda xy, cal=cal: undistort_points(cal, xy))
    trajectories = np.load(folder / "trajectories.npz")
    errors = camera_errors_px(bundle.cameras, truth,
                              {v.name: v.timestamps_s for v in bundle.videos},
                              json.loads((folder / "gt.json").read_text())["offsets_s"],
                              trajectories["times_global_s"], trajectories["points_world"], undistort)
    if not errors:
        return "-"
    px = list(errors.values())
    return f"{float(np.median(px)):.2f} / {max(px):.2f}"


def true_pairs(sc, bundle, stats) -> str:
    """The bundle's cross-view track pairs against the scene's true motion
    (vs_inspect.bench.arcs.judge_pairs): the share of pairs whose two tracks follow one body
    point (within 5 cm), two different points, or a track no rigid point, of all pairs."""
    from ..synth.world import make_scene

    scene = make_scene(sc.scene_config())
    bodies = [b.world_from_body for b in scene.world.bodies if b.moving]
    lens = stats.sfm.lens if stats.sfm is not None else {}
    fits = {}
    for cam in scene.cameras:
        if cam.name not in bundle.tracks:
            continue
        xy = bundle.tracks[cam.name].xy
        if cam.name in lens:  # back to the video's pixels (the rendered cameras have no distortion)
            xy = lens[cam.name].distort(first_K(bundle, cam.name), xy)
        fits[cam.name] = fit_body_points(xy, cam.global_times_s, cam.K, cam.pose_fn(cam.global_times_s), bodies)
    judged = [judge_pairs(tp.index, fits[a], fits[b]) for (a, b), tp in bundle.pairs.items()]
    total = sum(j.total for j in judged)
    if not total:
        return "-"
    return " / ".join(f"{100 * sum(getattr(j, k) for j in judged) / total:.0f}"
                      for k in ("same_point", "other_point", "not_rigid")) + f" % of {total}"


def first_K(bundle, name: str) -> np.ndarray:
    """(3,3) the camera's K (a moving camera's first frame's: an estimated lens is shared by its frames)."""
    return bundle.cameras[name].K.reshape(-1, 3, 3)[0]


def camera_models(stats) -> str:
    """Where a run's cameras came from: "calibration", the features of the model kept (or "moving
    points" when their cameras were used), and with two models tried how many videos the joint
    vote trusted on each ("xfeat (sift 0, xfeat 4)")."""
    sfm = stats.sfm
    if sfm is None:
        return stats.camera_source
    counts = ", ".join(f"{m.features} {len(m.trusted)}" for m in sfm.models or ())
    kept = "moving points" if sfm.fallback is not None and sfm.fallback.used else sfm.features
    return kept + (f" ({counts})" if counts else "")
