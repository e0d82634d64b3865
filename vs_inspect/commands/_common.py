"""Shared CLI helpers: options generated from the run config (pipeline.config), and the offsets table."""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

from ..errors import InputError
from ..eval.metrics import offset_errors_ms
from ..pipeline.config import RunConfig, add_config_options, config_from_args


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (frame rates, sizes)."""
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text!r}")
    return x


def positive_int(text: str) -> int:
    """argparse type: an integer > 0."""
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if x <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return x


def add_force_option(p: argparse.ArgumentParser, what: str = "--out") -> None:
    """--force: the one overwrite switch of every command that writes (--overwrite is its alias)."""
    p.add_argument("--force", "--overwrite", dest="force", action="store_true",
                   help=f"replace what an earlier run left in {what} (default: refuse)")


def check_output_folder(out: Path, force: bool, option: str = "--out") -> None:
    """Before any work: `out` must be (or become) a folder, and an empty one unless force."""
    out = Path(out)
    for parent in [out, *out.parents]:
        if parent.exists() and not parent.is_dir():
            raise InputError(f"{option} {out}: {parent} is a file, not a folder")
        if parent.exists():
            break
    if out.is_dir() and any(out.iterdir()) and not force:
        raise InputError(f"{option} {out} exists and is not empty (it holds an earlier run?); "
                         "use --force to replace it")


def check_videos_exist(videos) -> None:
    """Before any work: every video file or image folder given exists (InputError naming the
    missing ones, and the files found beside them that look alike)."""
    missing = [Path(v) for v in videos if not Path(v).exists()]
    if not missing:
        return
    names = ", ".join(str(m) for m in missing)
    there = sorted({p.name for m in missing if m.parent.is_dir() for p in m.parent.iterdir()
                    if p.suffix.lower() == m.suffix.lower() and p.suffix})[:8]
    raise InputError(f"no such video file or image folder: {names}"
                     + (f" (in {missing[0].parent}: {', '.join(there)})" if there else ""))


def check_output_file(path: Path, force: bool, option: str) -> None:
    """Before any work: `path` must name a file in a folder (not a folder), new unless force."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{option} {path} is a folder; give a file name")
    check_output_folder(path.parent, True, f"{option}'s folder")
    if path.exists() and not force:
        raise InputError(f"{option} {path} exists; use --force to replace it")


def add_config_file_option(p: argparse.ArgumentParser) -> None:
    from ..pipeline.config import PRESETS

    p.add_argument("--config", type=Path, default=None, metavar="FILE",
                   help="settings from a config.json that `sync` wrote (OUT/config.json); options "
                        "given on the command line override the file's values")
    p.add_argument("--preset", choices=list(PRESETS), default=None,
                   help="named settings in place of the usual ones (the other options apply on top): "
                        + "; ".join(f"{n}: {doc}" for n, (doc, _) in PRESETS.items()))
    p.add_argument("--set", action="append", default=[], metavar="PATH=VALUE", dest="set_items",
                   help="any setting by its path in config.json, e.g. sync.landscape.range_s=5 or "
                        "cues.camera.features=sift (repeatable; applied last)")


def add_sync_options(p: argparse.ArgumentParser) -> None:
    """The Stage 1 + 2 options, generated from sync.config's fields (help = their docstrings)."""
    add_config_options(p, ("sync", "engine"))


def add_cue_options(p: argparse.ArgumentParser) -> None:
    """Stage 0's inputs (--calib, --fps) and options generated from cues.config's fields."""
    g = p.add_argument_group("cue extraction (Stage 0)")
    g.add_argument("--calib", type=Path, default=None,
                   help="camera calibration: COLMAP or EasyMocap folder, JSON, Pose2Sim/anipose/"
                        "FreeMoCap/caliscope TOML, Qualisys .qca.txt, Vicon .xcp (see 'calib "
                        "convert'); without it the cameras are estimated from the videos with "
                        "pycolmap. A video a few rows/columns smaller than its calibration (a "
                        "crop) or binned is accepted with a warning")
    g.add_argument("--fps", type=positive_float, default=None,
                   help="frame rate of image folders (and of files whose timestamps are unusable)")
    add_config_options(p, ("cues",), group=g)


def run_config(args: argparse.Namespace) -> RunConfig:
    """The run's config: --config FILE, --preset or the defaults, then the options on the command
    line, then --set, then the recording presets (--rrd-minimal, --rrd-all-*)."""
    from ..pipeline.config import parse_set, preset, with_settings

    path = getattr(args, "config", None)
    base = RunConfig.load(path) if path is not None else RunConfig()
    if getattr(args, "preset", None):
        if path is not None:
            raise InputError(f"--preset {args.preset} and --config {path}: a config.json holds every setting "
                             "already; give one of them")
        if args.preset == "calibrated" and getattr(args, "calib", None) is None and not getattr(args, "bundle", None):
            raise InputError("--preset calibrated: give the rig's calibration with --calib")
        base = with_settings(RunConfig(), preset(args.preset), f"--preset {args.preset}")
    cfg = config_from_args(args, base)
    if getattr(args, "set_items", None):
        cfg = with_settings(cfg, parse_set(args.set_items))
    if hasattr(args, "rrd_minimal"):
        from ._record import record_options
        cfg = dataclasses.replace(cfg, record=record_options(args, cfg.record))
    return cfg


def add_gt_option(p: argparse.ArgumentParser, also: str = "") -> None:
    """--gt FILE: true offsets, so that the command shows every error against them (also: what
    else the command does with them)."""
    p.add_argument("--gt", type=Path, default=None, metavar="FILE",
                   help="true offsets (a gt.json: {\"offsets_s\": {\"cam0\": 0.0, ...}}): show each "
                        "video's error in ms and in frames against them" + also)


def load_gt(path: Path | None, names: list[str], reference: str) -> dict[str, float] | None:
    """The --gt file for these videos (None without --gt): it must name only known videos and
    give the reference's true offset (errors are measured after aligning the reference)."""
    if path is None:
        return None
    from ..io.bundle import read_gt
    return gt_with_reference(read_gt(path, names), path, reference)


def gt_with_reference(gt: dict[str, float] | None, path: Path | None, reference: str) -> dict[str, float] | None:
    """gt (read from the --gt file path) when it gives the reference's true offset (errors are
    measured after aligning the reference), else an InputError; None stays None."""
    if gt is not None and reference not in gt:
        raise InputError(f"--gt {path}: no true offset for the reference video {reference!r} "
                         "(errors are measured relative to it)")
    return gt


def error_frames(errors_ms: dict[str, float | None],
                 frame_s: dict[str, float] | None) -> dict[str, float | None]:
    """Each error in frames of its own video (None where the error or the clock is unknown)."""
    out: dict[str, float | None] = {}
    for v, e in errors_ms.items():
        dt = (frame_s or {}).get(v)
        out[v] = e / (1000.0 * dt) if e is not None and dt and math.isfinite(dt) else None
    return out


def fmt_s(x) -> str:
    return "null" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:+.4f}"


def offsets_table(offsets: dict, uncertainty: dict, truth: dict | None, reference: str,
                  unresolved: dict, frame_s: dict[str, float] | None = None) -> str:
    """A short plain-text table of offsets, with the truth and error when known (and the error
    in frames of each video when its frame interval frame_s[v], seconds, is given)."""
    lines = []
    w = max([16] + [len(v) + 2 for v in offsets])  # long names (32 characters and more) stay aligned
    head = f"{'video':<{w}}{'offset_s':>11}{'± s':>9}"
    if truth:
        head += f"{'true_s':>11}{'error_ms':>10}" + (f"{'frames':>8}" if frame_s else "")
    lines.append(head)
    errors_ms = offset_errors_ms(offsets, truth, reference) if truth else {}
    frames = error_frames(errors_ms, frame_s) if frame_s else {}
    for v, off in offsets.items():
        u = uncertainty.get(v)
        row = f"{v:<{w}}{fmt_s(off):>11}{('%.4f' % u) if u is not None else '-':>9}"
        if truth and v in truth:
            tv = truth[v] - truth.get(reference, 0.0)
            row += f"{tv:>+11.4f}"
            e = errors_ms.get(v)
            row += f"{e:>10.1f}" if e is not None else f"{'-':>10}"
            if frame_s:
                f = frames.get(v)
                row += f"{f:>8.2f}" if f is not None else f"{'-':>8}"
        if off is None:
            row += f"   ({unresolved.get(v, 'unresolved')})"
        lines.append(row)
    return "\n".join(lines)


def sign_in_words(offsets: dict, reference: str) -> str:
    """The offsets' sign said once in words: 'cam2 starts 0.240 s after cam0; cam1 starts 0.100 s
    before cam0' (offset_s > 0: the video's first frame came later than the reference's)."""
    parts = []
    for v, off in offsets.items():
        if v == reference or off is None:
            continue
        if abs(off) < 5e-4:
            parts.append(f"{v} starts with {reference}")
        else:
            parts.append(f"{v} starts {abs(off):.3f} s {'after' if off > 0 else 'before'} {reference}")
    if not parts:
        return ""
    return "; ".join(parts) + f" (offset_s = the moment a video starts, on {reference}'s clock)"


def print_run(result, path, truth: dict | None = None,
              frame_s: dict[str, float] | None = None) -> None:
    """The offsets table (input order, truth from the run or given; errors in frames when the
    frame intervals frame_s are given) and the pair counts."""
    names = list(result.inputs.videos) or list(result.offsets_s)
    truth = truth if truth is not None else result.gt_offsets_s
    shown_truth = {n: truth[n] for n in names if n in truth} if truth else None
    print(offsets_table({n: result.offsets_s.get(n) for n in names},
                        {n: result.uncertainty_s.get(n) for n in names}, shown_truth,
                        result.reference, result.headlines(), frame_s if shown_truth else None))
    words = sign_in_words({n: result.offsets_s.get(n) for n in names}, result.reference)
    if words:
        print(words)
    if any(result.offsets_s.get(n) is None for n in names) and result.unresolved_headline:
        print(f"each null's reason in full: \"unresolved\" in {path}")
    if result.drift_ppm is not None:  # --drift: t_global = offset_s + (1 + drift) * t_local
        std = result.drift_std_ppm or {}
        gd = result.gt_drift_ppm or {}
        print("clock drift (ppm): " + ", ".join(
            f"{n} " + ("-" if result.drift_ppm.get(n) is None else
                       f"{result.drift_ppm[n]:+.1f} ± {std.get(n) or 0.0:.1f}"
                       + (f" (true {gd[n]:+.1f})" if n in gd else "")) for n in names))
    acc = sum(p.decision.accepted for p in result.pairs)
    print(f"pairs: {acc} accepted, {len(result.pairs) - acc} rejected; wrote {path}")
