"""vs-inspect bench SUB: the benchmarks, one sub-command each (argument parsing and printing only;
the work is in vs_inspect.bench)."""

from __future__ import annotations

import argparse
import os
import shlex
import tempfile
from contextlib import nullcontext
from pathlib import Path

from ..errors import InputError
from ..pipeline.config import RunConfig
from . import _help
from ._common import (add_config_file_option, add_cue_options, add_sync_options, positive_float,
                      positive_int, run_config)

DATA_HELP = "folder with the real data (default: $VS_INSPECT_DATA or ../shared/data beside the project)"


def register(sub) -> None:
    p = sub.add_parser("bench", help="benchmarks: accuracy, Stage 0 on videos, speed, drift, scale, ...",
                       description="Each benchmark is a sub-command with its own --help; their latest "
                                   "tables are in BENCHMARKS.md.")
    benches = p.add_subparsers(dest="bench", metavar="BENCHMARK", required=True)
    for name, add in (("accuracy", _accuracy), ("stage0", _stage0), ("timing", _timing),
                      ("energy", _energy), ("scale", _scale), ("drone", _drone), ("drift", _drift),
                      ("people", _people), ("rules", _rules), ("recording", _recording),
                      ("interrupts", _interrupts)):
        add(benches, name)
        _help.apply(benches.choices[name], f"bench {name}")


def _parser(benches, name: str, summary: str, description: str, run=None) -> argparse.ArgumentParser:
    q = benches.add_parser(name, help=summary, description=description)
    if run is not None:
        q.set_defaults(func=run)
    return q


def data_folder(args: argparse.Namespace) -> Path:
    """--data, else $VS_INSPECT_DATA, else ../shared/data beside the project."""
    if getattr(args, "data", None) is not None:
        return args.data
    here = Path(__file__).resolve().parents[2]
    return Path(os.environ.get("VS_INSPECT_DATA", here.parent / "shared" / "data"))


class _SyncArgsParser(argparse.ArgumentParser):
    def error(self, message: str):
        raise InputError(message)


def sync_args(text: str) -> tuple[str, ...]:
    """argparse type of --sync-args: sync's options as one string, checked by sync's own parser."""
    args = tuple(shlex.split(text))
    try:
        config_of(args)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return args


def config_of(args: tuple[str, ...]) -> RunConfig:
    """The run config that `vs-inspect sync ARGS` would use (the dataset gives videos and cameras)."""
    p = _SyncArgsParser(prog="sync", add_help=False)
    add_config_file_option(p)
    add_sync_options(p)
    add_cue_options(p)
    parsed = p.parse_args(list(args))
    if parsed.calib is not None or parsed.fps is not None:
        raise InputError("--calib and --fps come from the benchmark's data")
    return run_config(parsed)


def _add_sync_args(q: argparse.ArgumentParser) -> None:
    q.add_argument("--sync-args", type=sync_args, default=(), metavar="'ARGS'",
                   help="options of `vs-inspect sync` for every run, e.g. '--max-side 480' (default: none)")


def _folder(path: Path | None, prefix: str):
    """path itself (kept), or a temporary folder removed at the end."""
    return nullcontext(path) if path is not None else tempfile.TemporaryDirectory(prefix=prefix)


# ---- accuracy ---------------------------------------------------------------------------------

def _accuracy(benches, name):
    q = _parser(benches, name, "accuracy against the paper's ablations and two classical peers (BENCHMARKS.md)",
                "Runs vs_inspect (with the paper's ablations: residual, solver, spurious-pair filter, "
                "pairs used, true vs estimated cameras) and two classical peers (motion-signal "
                "cross-correlation, RANSAC-inlier criterion) on the same data: cue-level synthetic "
                "scenes, the caliscope session with cut leading frames, the VisualSync clips and a "
                "rendered scene (videos through pipeline.run, then the ablations on the cue bundle "
                "the run wrote), and prints the tables. --quick runs a small subset (a few minutes); "
                "the full run writes BENCHMARKS.md.", _run_accuracy)
    q.add_argument("--quick", action="store_true", help="small subset (1 synthetic scene, 1 caliscope cut)")
    q.add_argument("--out", type=Path, default=None,
                   help="markdown file to write (default: BENCHMARKS.md for the full run, none for --quick)")
    q.add_argument("--json", type=Path, default=None, help="also write every row as JSON here")
    q.add_argument("--data", type=Path, default=None, help=DATA_HELP)
    q.add_argument("--only", default=None, metavar="PREFIX",
                   help="run only the datasets whose name starts with PREFIX (comma-separated; e.g. "
                        "cue/easy, caliscope, clips)")
    q.add_argument("--skip", default=None, metavar="PREFIX", help="leave out the datasets whose name starts with PREFIX")
    q.add_argument("--from-json", type=Path, nargs="+", default=None, metavar="JSON",
                   help="do not run: write the tables of earlier runs' --json files (a dataset in a "
                        "later file replaces its rows from earlier ones)")
    q.add_argument("--no-progress", action="store_true", help="no progress bar")


def _run_accuracy(args) -> int:
    from ..bench.runner import run_accuracy, tables_from_json

    if args.from_json is not None:
        print(tables_from_json(args.from_json, args.out))
        return 0
    text, rows, skipped, wall = run_accuracy(args.quick, data_folder(args), args.only, args.skip,
                                             args.out if args.out or args.quick else Path("BENCHMARKS.md"),
                                             args.json, not args.no_progress)
    print(text)
    for s in skipped:
        print(f"{s.name}: {s.why}")
    print(f"{len(rows)} runs on {len({r.dataset for r in rows})} datasets in {wall:.0f} s")
    return 0


# ---- stage0 -----------------------------------------------------------------------------------

def _stage0(benches, name):
    from ..bench.scenes import DEFAULT_SET, SCENE_SETS
    from ..bench.videos import CLIP_SCENES

    q = _parser(benches, name, "videos to offsets on real and rendered videos, one table row per set",
                "Runs each set of videos through the whole pipeline as `vs-inspect sync` does "
                "(pipeline.run, default settings unless --sync-args) and prints one table row per "
                "set from its result: each offset's error in frames of the slower video (null with "
                "its reason), the cameras, the track pairs (judged against the true cameras when a "
                "rendered scene's calibration is given), the seconds of Stage 0 and of Stage 1 + 2; "
                "then how many offsets are within 1 frame, at 1-2 frames and over 2 frames.")
    data = q.add_subparsers(dest="dataset", metavar="DATASET", required=True)
    c = data.add_parser("caliscope", help="caliscope's 4 webcams (6 fps), random leading frames cut",
                        description="caliscope's 4 webcams, each cut by a random number of leading "
                                    "frames; true offsets from the session's frame timestamps.")
    c.add_argument("--trials", type=positive_int, default=5, help="random cuts")
    c.add_argument("--max-cut", type=int, default=12, help="most leading frames cut")
    c.add_argument("--seed", type=int, default=0, help="seed of the cuts")
    c.add_argument("--cameras", choices=("calibration", "estimated", "board"), default="calibration",
                   help="the session's calibration, cameras estimated from the videos, or from the "
                        "ChArUco board in the cut videos (as calibrate-board makes them)")
    v = data.add_parser("clips", help="the VisualSync clips (10 fps), estimated cameras",
                        description="The VisualSync clips of each scene, cameras estimated from the "
                                    "videos; true offsets from the clips' file names.")
    v.add_argument("--scenes", nargs="+", default=list(CLIP_SCENES), help="scenes of visualsync_clips")
    r = data.add_parser("rendered", help="rendered scenes with exact truth",
                        description="Rendered scenes (rendered once into --workdir): rendered_s<seed> "
                                    "(3 static + 1 hand-held camera, 5 s, 480x360, 24-60 fps), demo, or "
                                    "a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed] (cameras on an arc of "
                                    "30-90°, 640x480, 6 s, 30 fps or mixed rates).")
    r.add_argument("--set", choices=list(SCENE_SETS), default=DEFAULT_SET,
                   help="a named list of scenes: rendered (seeds 0-2), seeds-0-9 (14 arc scenes), "
                        "seeds-10-21 ... seeds-58-69 (12 each, one mix of arcs and cameras), "
                        "mixed-rates (seeds 70-81, each camera at 24-60 fps)")
    r.add_argument("--scenes", nargs="+", type=_scene_name, metavar="NAME", help="these scenes instead of --set")
    r.add_argument("--cameras", choices=("calibration", "estimated"), default="estimated",
                   help="each scene's exact calibration, or cameras estimated from the videos")
    s = data.add_parser("speed", help="4 videos x 10 s of 720p at 30 fps (caliscope blended), seconds per step",
                        description="caliscope's videos blended up to 30 fps and 10 s: a real 720p "
                                    "workload; prints the table and the seconds of every step.")
    s.add_argument("--seconds", type=positive_int, default=10, help="length of every video")
    s.add_argument("--cameras", choices=("calibration", "estimated"), default="calibration",
                   help="the session's calibration, or cameras estimated from the videos")
    for d in (c, v, r, s):
        d.set_defaults(func=_run_stage0)
        d.add_argument("--workdir", type=Path, default=None,
                       help="keep the inputs made (cuts, renderings: reused) and every run folder "
                            "(result.json, cues/) here (default: a temporary folder)")
        _add_sync_args(d)
        if d is not r:
            d.add_argument("--data", type=Path, default=None, help=DATA_HELP)
        _help.apply(d, f"bench stage0 {d.prog.split()[-1]}")


def _scene_name(text: str) -> str:
    from ..bench.scenes import scene_config
    try:
        scene_config(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _run_stage0(args) -> int:
    from ..bench import videos as vs
    from ..bench.stage0 import bench_sets, timings_lines

    config = config_of(args.sync_args)
    with _folder(args.workdir, "vs-inspect-stage0-") as work:
        work = Path(work)
        if args.dataset == "caliscope":
            sets = vs.caliscope_sets(data_folder(args), work, args.trials, args.max_cut, args.seed, args.cameras)
        elif args.dataset == "clips":
            sets = [vs.clip_set(data_folder(args), scene) for scene in args.scenes]
        elif args.dataset == "rendered":
            from ..bench.scenes import SCENE_SETS
            sets = (vs.rendered_set(n, work, args.cameras == "calibration")
                    for n in args.scenes or SCENE_SETS[args.set])
        else:
            sets = [vs.speed_set(data_folder(args), work, args.seconds, args.cameras == "calibration")]
        runs = bench_sets(sets, config, work / "runs", lambda line: print(line, flush=True))
        if args.dataset == "speed":
            print("\n" + "\n".join(timings_lines(runs[0])))
        if args.workdir is not None:
            print(f"run folders (result.json, cues/) in {work / 'runs'}")
    return 0


# ---- timing -----------------------------------------------------------------------------------

def _timing(benches, name):
    from ..bench.timing import TARGET_S, TIMING_SCENE as d
    from .synth_video import add_image_and_clock_options

    q = _parser(benches, name, "end-to-end time of sync on 4 rendered 720p videos against the 3-minute target",
                "Renders a scene (3 static + 1 hand-held camera, every video as long, exact truth) "
                "into a work folder, then times `vs-inspect sync` with default settings on its videos "
                "in a fresh process, with estimated cameras and with the scene's calibration. Prints "
                "each stage's seconds (result.json), the rest of the wall time (start-up, recording, "
                "writing), wall and CPU time and peak memory of the process, the offsets' errors "
                "against the truth, and whether the run met the target. Rendering is not timed.",
                _run_timing)
    add_image_and_clock_options(q, d)
    q.add_argument("--seconds", type=positive_float, default=d.seconds, help="length of every video")
    q.add_argument("--seed", type=int, default=d.seed, help="seed of the scene")
    q.add_argument("--cameras", nargs="+", choices=("estimated", "calibration"),
                   default=["estimated", "calibration"], help="camera modes to time")
    q.add_argument("--reference", action="store_true",
                   help="also time the 480x360 5 s rendered scene in the same run and print each run's "
                        "wall time as a multiple of it (a shared machine's load changes the seconds "
                        "more than the ratio)")
    q.add_argument("--target-s", type=positive_float, default=TARGET_S, help="the time target (s)")
    q.add_argument("--workdir", type=Path, default=None,
                   help="keep the rendered scenes and runs here (reused when rendered with the same "
                        "settings; default: a temporary folder, removed at the end)")
    q.add_argument("--timeout-s", type=positive_float, default=None, help="give up on a run after this long")
    _add_sync_args(q)


def _run_timing(args) -> int:
    import dataclasses

    from ..bench.timing import TIMING_SCENE, ratios, run_timing_bench, table_header, table_line

    scene = dataclasses.replace(TIMING_SCENE, width=args.width, height=args.height, seconds=args.seconds,
                                fps=args.fps or None, max_offset_s=args.max_offset_s, seed=args.seed)
    print(table_header(), flush=True)
    with _folder(args.workdir, "vs-inspect-timing-") as work:
        rows, ref = run_timing_bench(Path(work), scene, tuple(args.cameras), args.reference, args.target_s,
                                     args.sync_args, args.timeout_s,
                                     on_row=lambda row: print(table_line(row), flush=True))
    for line in ratios(rows, ref):
        print(line)
    return 0


# ---- energy, scale, drone, drift --------------------------------------------------------------

def _energy(benches, name):
    q = _parser(benches, name, "speed of the energy landscape (5,000 track pairs x 300 frames x 201 offsets)",
                "Times the compiled landscape kernel and a straightforward numpy reference in the "
                "same process, for a static pair and a pair with a moving camera, and prints a table "
                "with the speed-up and the largest difference of their energies.", _run_energy)
    q.add_argument("--repeats", type=positive_int, default=3, help="timed repeats of the kernel (median reported)")
    q.add_argument("--reference-offsets", type=positive_int, default=201,
                   help="offsets the reference actually evaluates (its time is scaled to 201)")


def _run_energy(args) -> int:
    from ..bench.energy import format_rows, run_energy_bench

    print(format_rows(run_energy_bench(args.repeats, args.reference_offsets)))
    return 0


def _pairs_mode(text: str) -> str:
    from ..sync.config import PairSelection
    try:
        PairSelection.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _scale(benches, name):
    q = _parser(benches, name, "wall time, memory and accuracy against rig size, local vs Ray",
                "Runs cue-level synthetic ring rigs of each size from their cue bundle with each pair "
                "selection on each engine (every cell in a fresh process) and prints wall time, pairs, "
                "per-pair cost, peak memory of the driver and of the Ray workers, and the offset "
                "errors; then whether the engines gave identical offsets.", _run_scale)
    q.add_argument("--cameras", type=positive_int, nargs="+", default=[8, 16, 32, 64], help="rig sizes")
    q.add_argument("--engines", nargs="+", choices=("local", "ray"), default=["local", "ray"],
                   help="engines to run every cell on")
    q.add_argument("--pairs", nargs="+", type=_pairs_mode, default=["all", "rst", "knn:4"],
                   help="pair selections (as sync's --pairs)")
    q.add_argument("--ray-cpus", type=positive_int, default=None, help="CPUs of the embedded Ray (default: all cores)")
    q.add_argument("--timeout-s", type=positive_float, default=None, help="give up on a cell after this long")
    q.add_argument("--jsonl", type=Path, default=None, help="also append every row to this JSON-lines file")


def _run_scale(args) -> int:
    from ..bench.scale import format_rows, run_scale_bench, same_offsets

    rows = run_scale_bench(args.cameras, args.engines, args.pairs, args.ray_cpus, args.jsonl, args.timeout_s)
    print("\n" + format_rows(rows))
    for (n, mode), same in sorted(same_offsets(rows).items()):
        print(f"{n} cameras, {mode}: offsets {'identical' if same else 'DIFFER'} across engines")
    return 0


def _drone(benches, name):
    q = _parser(benches, name, "pose-free sync with clock drift on the drone dataset (offset and ppm errors)",
                "Estimates every camera pair's time shift, clock rate and fundamental matrix from the "
                "drone detections alone, runs the energy with that F and solves per-camera offset and "
                "drift (camera 0 fixed), the path of `sync --drift`, and prints the errors against the "
                "dataset's ground truth, with the constant-offset model as the ablation.", _run_drone)
    q.add_argument("path", type=Path, help="a bundle written by import-drone, or the dataset folder")
    q.add_argument("--workers", type=positive_int, default=2,
                   help="CPUs of an embedded Ray running the pairs in parallel; 1: in this process")


def _run_drone(args) -> int:
    from ..bench.drone import format_table, load_drone_bundle, run_drone_bench

    bundle, drift = load_drone_bundle(args.path)
    print(format_table(run_drone_bench(bundle, drift, workers=args.workers), bundle))
    return 0


def _people(benches, name):
    from ..bench.people import SCENES
    from ..cues.config import PEOPLE_MODES

    q = _parser(benches, name, "people as cross-view correspondences: cameras and offsets from video alone",
                "Runs each scene through the pipeline as `vs-inspect sync` does, with no calibration and "
                "the people in view as Stage 0's camera source (--people only: the background's cameras "
                "turned off; auto: as sync runs by default); prints each video's error against the "
                "truth, the people cue's own error before Stage 1, the reason of every null and the "
                "seconds spent, beside the VisualSync paper's numbers.", _run_people)
    q.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES),
                   help=f"scenes (default: {' '.join(SCENES)})")
    q.add_argument("--data", type=Path, default=None, help=DATA_HELP)
    q.add_argument("--people", default="only", choices=[m for m in PEOPLE_MODES if m != "off"],
                   help="the people's cameras alone (only, default) or when the background's time no video (auto)")
    q.add_argument("--workdir", type=Path, default=None,
                   help="where the run folders and caliscope's cut videos go (default: a temporary folder)")
    q.add_argument("--seed", type=int, default=0, help="seed of caliscope's leading cuts")


def _run_people(args) -> int:
    import tempfile

    from ..bench.people import format_table, run_benchmark

    data = data_folder(args)
    if not data.is_dir():
        raise InputError(f"{data}: no data folder (give --data or set VS_INSPECT_DATA)")
    with tempfile.TemporaryDirectory(prefix="vs-inspect-people-") as tmp:
        runs = run_benchmark(data, args.workdir or Path(tmp), args.scenes, args.people, seed=args.seed,
                             log=lambda s: print(s, flush=True))
    print()
    print(format_table(runs))
    return 0


def _rules(benches, name):
    q = _parser(benches, name, "each of Stage 0's acceptance rules left out in turn, offsets counted per set",
                "Runs the whole pipeline on the measured sets with every acceptance rule and camera "
                "path, then with each one left out, and prints per set the offsets within 1 frame, over "
                "2 frames and null; then drops, in order, each rule whose absence makes no set worse. "
                "Each scene's expensive steps are kept in --scratch, so the variants replay decisions "
                "only and a stopped run resumes.", _run_rules)
    q.add_argument("--sets", nargs="+", default=["clips", "caliscope", "demo", "small", "arcs:seeds-10-21"],
                   help="clips, caliscope, demo, small (ten small calibrated rendered rigs), arcs:SET "
                        "(default: all five, arcs:seeds-10-21)")
    q.add_argument("--scratch", type=Path, required=True, help="folder for the inputs made and the kept steps")
    q.add_argument("--rules", nargs="+", help="only these rules (default: all, in their order)")
    q.add_argument("--markdown", type=Path, help="also write the tables here")
    q.add_argument("--data", type=Path, default=None, help=DATA_HELP)


def _run_rules(args) -> int:
    import datetime

    from ..bench.rules import run as ablate
    from ..bench.runner import machine
    from ..io.atomic import write_text_atomic

    args.scratch.mkdir(parents=True, exist_ok=True)
    tables = ablate(args.sets, data_folder(args), args.scratch, args.rules, lambda m: print(m, flush=True))
    m = machine()
    text = (f"Command: `vs-inspect bench rules --sets {' '.join(args.sets)}`, {datetime.date.today()}, commit "
            f"{m.get('git_commit', '?')}, {m.get('cpu', m['processor'])}, {m['cpu_count']} cores.\n\n{tables}")
    print(text)
    if args.markdown:
        write_text_atomic(text, args.markdown)
    return 0


def _drift(benches, name):
    from ..bench.datasets import DIFFICULTIES

    q = _parser(benches, name, "--drift against constant offsets on synthetic cue scenes whose clocks drift",
                "Synthetic cue scenes (5 cameras) whose non-reference clocks run ± --drift-ppm off; "
                "each is synchronized with the drift model and with constant offsets (the ablation). "
                "Prints the offset errors (ms, at local time 0 and at each video's last frame) and the "
                "drift errors.", _run_drift)
    q.add_argument("--difficulty", choices=sorted(DIFFICULTIES), default="default", metavar="LEVEL",
                   help="noise and wrong pairs of the scenes: easy, hard or default")
    q.add_argument("--seeds", type=positive_int, default=5, help="scenes 0..N-1")
    q.add_argument("--drift-ppm", type=float, default=200.0,
                   help="clock drift of every non-reference video, ± this with a random sign (ppm)")
    q.add_argument("--seconds", type=positive_float, default=None,
                   help="typical video length (default: the scenes' usual 8 s)")


def _run_drift(args) -> int:
    from ..bench.drift_cues import per_scene, run_drift_cues, summarize

    rows = run_drift_cues(args.difficulty, tuple(range(args.seeds)), args.drift_ppm, args.seconds)
    print(summarize(rows))
    print(per_scene(rows))
    return 0


# ---- recording, interrupts --------------------------------------------------------------------

def _recording(benches, name):
    from ..bench.recording import CASES

    q = _parser(benches, name, "size and write time of recordings (.rrd), one line per case",
                "Writes recordings of the demo's cue scene (default options, --rrd-minimal, "
                "--rrd-all-offsets --rrd-all-tracks), of the size budget (4 videos x 10 s x 30 fps "
                "720p, every frame and mask sent) and of the caliscope session, checks each with "
                "`rerun rrd verify` and prints its size, the time spent recording and the run's time.",
                _run_recording)
    q.add_argument("cases", nargs="*", choices=CASES + ("all",), default="all", metavar="CASE",
                   help=f"cases to run: {', '.join(CASES)} or all (default: all)")
    q.add_argument("--out", type=Path, default=None, help="folder for the .rrd files (default: a temporary one, kept)")
    q.add_argument("--data", type=Path, default=None, help=DATA_HELP)


def _run_recording(args) -> int:
    from ..bench.recording import CASES, run_recording_bench

    out = args.out or Path(tempfile.mkdtemp(prefix="vs-inspect-bench-rrd-"))
    out.mkdir(parents=True, exist_ok=True)
    run_recording_bench(CASES if "all" in args.cases else tuple(args.cases), out, data_folder(args),
                        lambda s: print(s, flush=True))
    print(f"recordings in {out}")
    return 0


def _interrupts(benches, name):
    q = _parser(benches, name, "interrupt every long command at a sweep of moments",
                "Makes small synthetic inputs in --workdir, then runs each long command (sync from "
                "videos during Stage 0 and during Stage 1, sync of a bundle, report during 3D "
                "rendering and during PNG writing, export --mosaic, demo) once to time it, and again "
                "for each signal (SIGINT, SIGTERM) and each moment of a sweep over that time: each "
                "must exit 130 or 143 with exactly one line on stderr, no traceback, no crash, and "
                "leave its outputs exactly as they were before (or complete, when the signal came "
                "after its work was done). Prints a table: command, signal, runs, ok, missed "
                "(finished before the signal), failures, and the seconds from the signal to the end "
                "of the process (median, max). Exit 2 when a run failed.", _run_interrupts)
    q.add_argument("--workdir", type=Path, required=True, help="folder for the inputs and the runs (inputs are reused)")
    q.add_argument("--moments", type=positive_int, default=10, help="moments per command and signal")
    q.add_argument("--repeats", type=positive_int, default=3, help="times the whole sweep is run")
    q.add_argument("--only", nargs="+", default=None, metavar="WORD",
                   help="only the commands whose name contains one of these words (e.g. report demo)")
    q.add_argument("--grace-s", type=positive_float, default=10.0,
                   help="VS_INSPECT_STOP_GRACE_S of the interrupted commands")


def _run_interrupts(args) -> int:
    import time

    from ..bench.interrupts import run_sweep, table
    from ..bench.runner import machine

    t0 = time.perf_counter()
    outcomes = run_sweep(args.workdir, args.moments, args.repeats, args.only, grace_s=args.grace_s,
                         report=lambda s: print(s, flush=True))
    info = machine()
    print(f"\nbench interrupts --moments {args.moments} --repeats {args.repeats}: "
          f"{time.strftime('%Y-%m-%d', time.gmtime())}, commit {info.get('git_commit', '?')}, "
          f"{info['processor']}, {len(outcomes)} runs in {time.perf_counter() - t0:.0f} s")
    print(table(outcomes))
    return 0 if all(o.ok for o in outcomes) else 2
