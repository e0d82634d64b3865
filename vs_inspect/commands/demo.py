"""vs-inspect demo: the main job on the built-in default input, offsets printed next to the truth.

The input is a rendered multi-camera scene (vs_inspect.synth: videos plus exact ground truth),
rendered once into OUT/scene and reused by later runs. run_demo() synchronizes the scene's TRUE
cue bundle (exact cameras, projected surface points, exact track pairs), which separates the
solver's errors from Stage 0's; run_video_pipeline() then sends the rendered videos through the
whole pipeline with their calibration (skipped with --true-cues-only). Each run writes its own
recording (unless --no-rrd): the video run's is the first one's name with "-videos" added, so a
failure of Stage 0 on the videos can be debugged from its .rrd like any `sync` run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import signals
from ..io.bundle import read_gt
from ..io.result import write_run_result
from ..pipeline import RunConfig
from ..pipeline import run as run_pipeline
from ..record.sink import Sink
from ..synth.videos import is_complete, render_scene, rendered_with
from ..synth.world import SceneConfig, make_scene
from ..result_types import RunInputs, RunResult
from ._common import offsets_table, print_run
from ._common import run_config as run_config_of
from ._record import add_record_options, describe, open_sink, rrd_path
from .sync import exit_code

DEMO_SCENE = SceneConfig(cameras=4, moving=1, seconds=8.0, width=640, height=480, fps=None,
                         variable_rate=1, exposure=True, seed=0)
"""The default demo scene: 4 cameras (one hand-held), mixed frame rates, one variable frame rate,
different exposures, 8 s, 640x480."""


def register(sub) -> None:
    p = sub.add_parser("demo", help="run on the built-in rendered scene and compare with the truth",
                       description="Renders the default synthetic multi-camera scene (cached in "
                                   "OUT/scene), synchronizes it and prints estimated against true "
                                   "offsets with the error in ms.",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder")
    p.add_argument("--true-cues-only", action="store_true",
                   help="skip the run of the rendered videos through Stage 0 (OUT/videos)")
    p.add_argument("--rerender", action="store_true", help="render the scene again even if cached")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_record_options(p)
    p.set_defaults(func=run)


def ensure_scene(folder: Path, config: SceneConfig = DEMO_SCENE, rerender: bool = False,
                 progress: bool = True) -> bool:
    """Render the scene into folder unless a finished one is there. Returns True if it rendered."""
    if not rerender and rendered_with(folder, config):
        print(f"demo input: cached rendered scene in {folder}")
        return False
    if is_complete(folder) and not rerender:
        print(f"demo input: the scene in {folder} was rendered with other settings; rendering again")
    c = config
    print(f"demo input: rendering the default scene into {folder} ({c.cameras} cameras, {c.moving} "
          f"hand-held, {c.seconds:g} s, {c.width}x{c.height}, "
          f"{'mixed frame rates' if c.fps is None else f'{c.fps:g} fps'}"
          f"{', variable frame rate' if c.variable_rate else ''}"
          f"{', exposure differences' if c.exposure else ''}) ...")
    t = render_scene(make_scene(config), folder, progress=progress)
    print(f"rendered {t['frames']} frames in {t['render_total_s']:.1f} s "
          f"({t['frames_per_s']:.1f} frames/s)")
    return True


def run_demo(out: Path, config: SceneConfig = DEMO_SCENE, run_config: RunConfig = RunConfig(),
             sink: Sink | None = None, rerender: bool = False, progress: bool = True,
             final: bool = False) -> RunResult:
    """Render (or reuse) the scene in out/scene, synchronize its true cues, write out/result.json.

    This is the scene's true cue bundle through Stage 1 + 2; run_video_pipeline sends the
    rendered videos through the whole pipeline. final: nothing follows in this command, so once
    the offsets are known the outputs are written whole whatever signal comes (signals.begin_commit).
    """
    out = Path(out)
    scene_dir = out / "scene"
    ensure_scene(scene_dir, config, rerender, progress)
    print(f"Stage 1 + 2 on the scene's true cues ({scene_dir / 'bundle'}): separates the "
          "solver's errors from Stage 0's")
    result = run_pipeline(scene_dir / "bundle", run_config, sink, progress=progress,
                          recorded_inputs=RunInputs(scene=str(scene_dir), cues="true cue bundle"))
    if final:
        signals.begin_commit()
    path = write_run_result(result, out / "result.json")
    print(offsets_table(result.offsets_s, result.uncertainty_s, result.gt_offsets_s,
                        result.reference, result.headlines()))
    for p in result.pairs:
        if not p.decision.accepted:
            print(f"rejected {p.a}__{p.b}: {p.decision.reason}")
    print(f"wrote {path}")
    return result


def video_rrd_path(true_cues_rrd: Path) -> Path:
    """The video run's recording beside the true-cue run's: <name>-videos.rrd."""
    return true_cues_rrd.with_name(f"{true_cues_rrd.stem}-videos.rrd")


def run_video_pipeline(out: Path, scene_dir: Path, run_config: RunConfig = RunConfig(),
                       progress: bool = True, sink: Sink | None = None, final: bool = False) -> int:
    """The rendered videos through the whole pipeline, exactly as a user's videos would go
    (`vs-inspect sync cam*.mp4 --calib calibration.json --gt gt.json`), printed against the
    truth; recorded to sink when given, with the truth (each pair's true Δ)."""
    videos = sorted(scene_dir.glob("cam*.mp4"))
    truth = read_gt(scene_dir / "gt.json")
    print("\n== the rendered videos through the whole pipeline (Stage 0 + 1 + 2), as "
          f"`vs-inspect sync cam*.mp4 --calib calibration.json --out {out}` ==")
    out = Path(out)
    # with the truth, as `sync --gt`: the recording's decision panels and result.json carry it
    result = run_pipeline(videos, run_config, sink, calibration=scene_dir / "calibration.json",
                          bundle_out=out / "cues", progress=progress, truth_offsets_s=truth)
    if final:  # as run_demo's final
        signals.begin_commit()
    path = write_run_result(result, out / "result.json")
    run_config.save(out / "config.json")
    print_run(result, path, truth=truth)
    return exit_code(result)


def run(args: argparse.Namespace) -> int:
    from contextlib import ExitStack

    from ..io.lock import lock_outputs

    out = Path(args.out)
    first = rrd_path(args, out)
    with ExitStack() as stack:  # one run at a time into OUT and the recordings
        lock_outputs(stack, (out, "--out"), (first, "--rrd"),
                     (None if args.true_cues_only or first is None else video_rrd_path(first), "--rrd"))
        fresh = not out.exists()
        if fresh:  # removed whole also if the process is ended from the watchdog
            signals.register_temporary(out)
        try:
            code = _run(args, out)
            signals.unregister_temporary(out)
            return code
        except KeyboardInterrupt:  # interrupted: a fresh OUT is removed whole (a cached scene stays)
            signals.unregister_temporary(out)
            if fresh and out.is_dir():
                import shutil
                shutil.rmtree(out, ignore_errors=True)
            raise


def _run(args: argparse.Namespace, out: Path) -> int:
    cfg = run_config_of(args)
    with open_sink(args, out, cfg.record, progress=not args.no_progress) as sink:
        run_demo(out, DEMO_SCENE, run_config=cfg, sink=sink, rerender=args.rerender,
                 progress=not args.no_progress, final=args.true_cues_only)
    if describe(sink):
        print(describe(sink))
    if not args.true_cues_only:
        first = rrd_path(args, out)
        video_args = argparse.Namespace(**{**vars(args), "rrd": video_rrd_path(first) if first else None})
        with open_sink(video_args, out / "videos", cfg.record, progress=not args.no_progress) as vsink:
            run_video_pipeline(out / "videos", out / "scene", cfg, progress=not args.no_progress,
                               sink=vsink, final=True)
        if describe(vsink):
            print(describe(vsink))
    return 0
