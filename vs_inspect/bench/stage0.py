"""Stage 0 on real and rendered videos, cues to offsets, printed as tables (vs-inspect bench-stage0).

    vs-inspect bench-stage0 caliscope --trials 5 [--estimate | --board]
        caliscope: random numbers of leading frames cut, with the calibration, estimated cameras
        or cameras from the ChArUco board
    vs-inspect bench-stage0 visualsync [--scenes blenderbox pan160906]
        VisualSync web clips: error in frames per scene (true offsets from the file names)
    vs-inspect bench-stage0 speed [--estimate]
        4 videos x ~10 s x 720p at 30 fps (caliscope upsampled by frame blending)
    vs-inspect bench-stage0 rendered --seeds 0 1 2
        rendered scenes with their exact calibration, with and without the geometric track pairs
    vs-inspect bench-stage0 arcs [--scenes a60_c4m1_s12 ...] [--set SET] [--calibrated] --workdir W
        scenes whose cameras share a view (arcs of 30-90°), estimated cameras: offsets over 2
        frames, the cameras and the track pairs against the truth (bench/stage0_arcs.py)

caliscope, visualsync and rendered take the track settings too (--klt-window, --no-anchor, ...).

Truth for caliscope: frame k of cam_N.mp4 is row k of that camera in timestamps.csv; a clip cut
by c frames starts at frame_time[c], so offset_s[v] = frame_time_v[c_v] - frame_time_ref[c_ref]
(DESIGN.md: the global time of the clip's local time 0). Clips are re-encoded at the nominal
6 fps (constant rate), as a user's cut would be.
VisualSync: clip <scene>_<cam>_<start>_<end>_<k>.mp4 shows common-timeline frames start, start+1,
... at 10 fps, so offset_s = start / 10 (relative to the reference clip).
"""

from __future__ import annotations

import contextlib
import json
import re
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np  # before pycolmap

from ..cues import CueConfig
from ..cues.config import CameraConfig, GeometricPairConfig
from ..io.atomic import write_json_atomic
from ..io.calibration import rig_to_json
from ..io.video import VideoWriter, iter_frames, open_video
from ..pipeline.board import estimate_from_board
from ..pipeline.config import RunConfig
from ..pipeline.run import run as run_pipeline
from ..pipeline.stage12 import sync_bundle
from .arcs import frame_errors
from .datasets import corner_sync_bias_s, load_caliscope, read_caliscope_frame_times

CALISCOPE = "caliscope_post_optimization"
CLIPS = "visualsync_clips"
CLIP_NAME = re.compile(r"_(\d+)_(\d+)_(\d+)$")  # <scene>_<cam>_<start>_<end>_<k>
CLIP_FPS = 10.0


def caliscope_truth(frame_times: dict[str, np.ndarray], cuts: dict[str, int]) -> dict[str, float]:
    """Each cut clip's true start (s, the host clock): frame_times[v][cuts[v]]. Offsets are these
    less the reference's (DESIGN.md: the global time of each clip's local time 0)."""
    return {n: float(frame_times[n][c]) for n, c in cuts.items()}


def visualsync_truth(paths) -> dict[str, float]:
    """{clip stem: start / 10 s} of VisualSync clips named <scene>_<cam>_<start>_<end>_<k>.mp4;
    ValueError for a name without the frame numbers."""
    out = {}
    for p in paths:
        m = CLIP_NAME.search(Path(p).stem)
        if m is None:
            raise ValueError(f"{Path(p).name}: not a VisualSync clip name <scene>_<cam>_<start>_<end>_<k>")
        out[Path(p).stem] = int(m.group(1)) / CLIP_FPS
    return out


def write_cut(src_path: Path, dest: Path, cut: int, last: int | None = None) -> None:
    src = open_video(src_path)
    with VideoWriter(dest, src.info.width, src.info.height, src.info.fps or 6.0, crf=16) as w:
        for k, img in iter_frames(src):
            if k >= cut and (last is None or k < last):
                w.write(img)


def camera_config(args) -> CameraConfig:
    """The camera estimation asked for on the command line (--features,
    --sfm-frames, --sfm-max-features, --sfm-aliked-frames, --sfm-asift)."""
    static_frames, moving_frames = args.sfm_frames
    return CameraConfig(features=args.features, static_frames=static_frames,
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
    """caliscope's four webcams, each cut by a random number of leading frames (args: the
    bench-stage0 caliscope options)."""
    root = args.data / CALISCOPE
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
            truth = caliscope_truth(ft, cuts)
            cfg = CueConfig(max_side=args.max_side,
                            keyframes=args.keyframes, camera=camera_config(args),
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
    """The VisualSync clips of each scene, no calibration (args: the bench-stage0 visualsync
    options)."""
    root = args.data / CLIPS
    for scene in args.scenes:
        paths = sorted((root / scene).glob("*.mp4"))
        truth = visualsync_truth(paths)
        res, stats, tc, ts = run(paths, None, CueConfig(camera=camera_config(args), geometric=GeometricPairConfig(
            joint=args.geometric == "joint")))
        err = errors_ms(res, truth)
        fr = {k: (None if v is None else round(v / 100.0, 2)) for k, v in err.items()}
        print(f"{scene}: error in frames {fr}  cues {tc:.1f}s sync {ts:.1f}s  "
              f"cameras {stats.registered_cameras}/{len(paths)} "
              f"pairs {[(p.a[-12:], p.b[-12:], p.decision.accepted, p.num_track_pairs) for p in res.pairs]}"
              + unresolved_lines(res), flush=True)


def bench_speed(args) -> None:
    """caliscope's videos blended up to 30 fps and 720p-long clips, timed per stage (args: the
    bench-stage0 speed options)."""
    import cv2

    root = args.data / CALISCOPE
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
    from .videos import rendered_scene

    rows = {"descriptor pairs only": [], "descriptor + geometric pairs": []}
    # --workdir keeps one rendering for repeated runs
    with (contextlib.nullcontext(args.workdir) if args.workdir else tempfile.TemporaryDirectory()) as tmp:
        for seed in args.seeds:
            for label in rows:
                cfg = CueConfig(geometric=GeometricPairConfig(enabled="geometric" in label))
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
