"""Recording options shared by `sync` and `demo`: --rrd PATH, --no-rrd and how much to log."""

from __future__ import annotations

import argparse
import hashlib
import os
from pathlib import Path

from ..analysis.record_options import RecordOptions
from ..record.sink import NullSink, Sink

RECORDINGS_ENV = "VS_INSPECT_RECORDINGS"  # folder of default recordings (default: ./recordings)


def add_record_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("recording (rerun .rrd)")
    g.add_argument("--rrd", type=Path, default=None, metavar="PATH",
                   help="write the recording here (default: recordings/<name of --out>-<hash>.rrd, "
                        f"or ${RECORDINGS_ENV}/<name of --out>-<hash>.rrd when that variable is "
                        "set; <hash> is 8 hex digits of the absolute --out path, so a/out and b/out "
                        "get different recordings)")
    g.add_argument("--no-rrd", action="store_true", help="write no recording")
    g.add_argument("--rrd-minimal", action="store_true",
                   help="log only decisions, landscapes, graph, solve, cameras and the result "
                        "(no frames, tracks, epipolar views or 3D trajectories)")
    g.add_argument("--rrd-all-offsets", action="store_true",
                   help="epipolar view at every candidate offset (default: " +
                        f"{RecordOptions().epipolar_offsets} per pair)")
    g.add_argument("--rrd-full-frames", action="store_true",
                   help="full-resolution frames and masks (default: frames at most "
                        f"{RecordOptions().max_image_width_px} px wide)")
    g.add_argument("--rrd-all-tracks", action="store_true",
                   help="every track, epipolar line and triangulated track pair (default: "
                        f"{RecordOptions().max_tracks_per_video} tracks per video)")


def record_options(args: argparse.Namespace, base: RecordOptions = RecordOptions()) -> RecordOptions:
    """base (RunConfig.record) with the presets given on the command line applied."""
    if args.rrd_minimal:
        base = RecordOptions.minimal()
    return base.with_flags(all_offsets=args.rrd_all_offsets, full_frames=args.rrd_full_frames,
                           all_tracks=args.rrd_all_tracks)


def rrd_path(args: argparse.Namespace, out: Path) -> Path | None:
    if args.no_rrd:
        return None
    if args.rrd:
        return Path(args.rrd)
    return default_rrd_path(out)


def default_rrd_path(out: Path) -> Path:
    """recordings/<name of out>-<8 hex digits of its absolute path>.rrd (unique per --out)."""
    resolved = Path(out).resolve()
    tag = hashlib.sha1(os.fsencode(resolved)).hexdigest()[:8]
    return Path(os.environ.get(RECORDINGS_ENV) or "recordings") / f"{resolved.name}-{tag}.rrd"


def check_rrd_path(args: argparse.Namespace, out: Path) -> None:
    """Before any work: the recording's path is a file name whose folder can exist."""
    path = rrd_path(args, out)
    if path is None:
        return
    from ..errors import InputError
    if path.is_dir():
        raise InputError(f"--rrd {path} is a folder; give a file name such as {path / 'run.rrd'}")
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise InputError(f"--rrd {path}: {parent} is a file, not a folder")
        if parent.exists():
            break


def open_sink(args: argparse.Namespace, out: Path, options: RecordOptions | None = None,
              progress: bool = True) -> Sink:
    """A RerunSink writing to --rrd (or the default), or a NullSink with --no-rrd.

    options: what to record (RunConfig.record; default: the command line's presets).
    Use it as a context manager: the .rrd appears only when the block ends without an error.
    """
    path = rrd_path(args, out)
    if path is None:
        return NullSink()
    from ..record.rerun_sink import RerunSink
    return RerunSink(path, options=options or record_options(args), progress=progress)


def describe(sink: Sink) -> str | None:
    """One line about the written recording (None for NullSink)."""
    stats = getattr(sink, "stats", None)
    if not stats:
        return None
    return (f"recording: {sink.path} ({stats['size_mb']:.1f} MB; {stats['write_s']:.1f} s spent logging "
            f"during a {stats['open_s']:.1f} s run)")
