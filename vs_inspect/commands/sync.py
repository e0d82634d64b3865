"""vs-inspect sync: cue bundle (or videos) -> OUT/result.json, OUT/config.json and a table of offsets."""

from __future__ import annotations

import argparse
import logging
import shutil
from contextlib import ExitStack
from pathlib import Path

from .. import signals
from ..errors import InputError, VsInspectError
from ..io.lock import lock_outputs
from ..io.result import write_run_result
from ..pipeline import run as run_pipeline
from ._common import (add_config_file_option, add_cue_options, add_force_option, add_gt_option,
                      add_sync_options, check_output_folder, check_videos_exist, gt_with_reference, print_run,
                      run_config)
from ._record import add_record_options, check_rrd_path, describe, open_sink, rrd_path

log = logging.getLogger(__name__)


def register(sub) -> None:
    p = sub.add_parser("sync", help="synchronize videos or a cue bundle",
                       description="Estimate one time offset per video. Input is a cue bundle "
                                   "(--bundle DIR) or video files (then OUT/cues holds the "
                                   "extracted cue bundle). Writes OUT/result.json, the run's "
                                   "settings as OUT/config.json and the cameras it used as "
                                   "OUT/cameras.json ('calib convert' turns them into other "
                                   "tools' formats; 'export' writes offsets and trimmed videos "
                                   "for them). Settings: the defaults, then "
                                   "--config FILE, then the options given on the command line "
                                   "(the command line wins).",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("videos", nargs="*", help="video files or image folders (alternative to --bundle)")
    p.add_argument("--bundle", type=Path, help="cue bundle folder (see DESIGN.md, format v1)")
    p.add_argument("--out", type=Path, required=True, help="output folder for result.json")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_force_option(p)
    add_gt_option(p, "; they are also kept in result.json (and the written cue bundle) and drawn "
                     "in the recording, as each pair's true Δ")
    add_config_file_option(p)
    add_sync_options(p)
    add_record_options(p)
    add_cue_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    cfg = run_config(args)
    if args.bundle and args.videos:
        raise InputError("give either --bundle or video files, not both")
    if not args.bundle and not args.videos:
        raise InputError("nothing to synchronize: give --bundle DIR or video files")
    if args.videos:
        from ..pipeline.stage0 import check_cue_config
        check_cue_config(cfg.cues)
        check_videos_exist(args.videos)  # a missing one is named now, not after the others' cues
    out = Path(args.out)
    with ExitStack() as stack:
        # one run at a time into --out and the recording: taken before anything is checked
        lock_outputs(stack, (out, "--out"), (rrd_path(args, out), "--rrd"))
        return _checked_run(args, cfg, out)


def _checked_run(args: argparse.Namespace, cfg, out: Path) -> int:
    # every output is checked before any work, so a bad --out or --rrd fails in a second, not
    # after the whole run; an earlier run's result is replaced only with --force
    check_output_folder(out, args.force)
    check_rrd_path(args, out)
    video_names = [p.name if p.is_dir() else p.stem for p in map(Path, args.videos)]
    truth = None
    from ..io.bundle import read_gt, read_video_infos
    names = [v.name for v in read_video_infos(args.bundle)] if args.bundle else video_names
    cfg.sync.offset_grid(names)  # an --around window of no video (or the reference's without 0) fails now
    if args.gt is not None:  # a missing, malformed or mismatched truth fails now, not after the run
        truth = read_gt(args.gt, names)
    if args.videos and not args.no_rrd:  # names are known now: refuse a recording collision early
        from ..io.recording_paths import check_entity_names
        check_entity_names(video_names)
    fresh = not out.exists()
    if fresh:  # removed whole also if the process is ended from the watchdog
        signals.register_temporary(out)
    try:
        code = _run(args, cfg, out, truth)
        signals.unregister_temporary(out)
        return code
    except BaseException as exc:
        signals.unregister_temporary(out)
        if fresh and out.is_dir():
            if isinstance(exc, KeyboardInterrupt):  # interrupted: nothing of this run is left
                shutil.rmtree(out, ignore_errors=True)
            elif not any(out.iterdir()):
                out.rmdir()  # a failed run leaves no empty --out behind
        raise


def _run(args: argparse.Namespace, cfg, out: Path, truth: dict[str, float] | None) -> int:
    """truth: --gt's offsets, read once by run(): the recording draws each pair's true Δ, and
    result.json keeps it."""
    progress = not args.no_progress
    with open_sink(args, out, cfg.record, progress=progress) as sink:
        if args.bundle:
            result = run_pipeline(args.bundle, cfg, sink, progress=progress, truth_offsets_s=truth)
        else:
            result = run_pipeline(args.videos, cfg, sink, calibration=args.calib, fps=args.fps,
                                  bundle_out=out / "cues", progress=progress, truth_offsets_s=truth)
        # the offsets are known: the recording, config.json and result.json are written whole,
        # whatever signal comes now (else the recording could be new and result.json missing)
        signals.begin_commit()
    # after the recording is complete: result.json last, so its presence means a finished run
    cfg.save(out / "config.json")
    try:
        path = write_run_result(result, out / "result.json")
    except BaseException:
        (out / "config.json").unlink(missing_ok=True)
        raise
    if args.bundle and (out / "cues").is_dir():  # --force over a video run: its cues are not this run's
        shutil.rmtree(out / "cues")
    _write_cameras(args, out, list(result.inputs.videos) or list(result.offsets_s))
    if describe(sink):
        print(describe(sink))
    print_run(result, path, truth=gt_with_reference(truth, args.gt, result.reference),
              frame_s=_frame_intervals(args.bundle or out / "cues"))
    return exit_code(result)


def _write_cameras(args: argparse.Namespace, out: Path, names: list[str]) -> None:
    """OUT/cameras.json: the cameras the run used (given or estimated), for 'calib convert'.
    The result is already written: a problem here is a warning, not a failed run."""
    from ..io.bundle import read_bundle
    from ..io.calibration import RUN_CAMERAS, write_run_cameras
    (out / RUN_CAMERAS).unlink(missing_ok=True)  # --force: an earlier run's cameras are not these
    source = args.bundle or out / "cues"
    if not (Path(source) / "bundle.json").is_file():
        return
    try:
        write_run_cameras(out, read_bundle(source), None if args.bundle else args.calib, names)
    except (InputError, ValueError, OSError) as exc:
        log.warning("%s not written: %s", out / RUN_CAMERAS, exc)


def exit_code(result) -> int:
    """0 when at least two videos got offsets (or the only one), else 2."""
    resolved = len(result.resolved)
    return 0 if resolved >= 2 or len(result.offsets_s) == 1 else 2


def _frame_intervals(bundle_dir: Path) -> dict[str, float] | None:
    """Each video's frame interval (s) from the run's bundle.json, for errors in frames: 1/fps,
    or the mean spacing of a variable-rate video's frames (types.frame_length_s, as inspect,
    diagnose and report count them)."""
    from ..io.bundle import read_video_infos
    try:
        return {v.name: v.frame_length_s for v in read_video_infos(bundle_dir)}
    except (OSError, ValueError, VsInspectError):  # errors in ms are still shown; frames need clocks
        return None
