"""People as correspondences on real videos, as a user runs them (vs-inspect bench people).

Each scene goes through `vs_inspect.pipeline.run` with no calibration and `cues.people` set
(default "only": the people's cameras alone, the background's turned off, to show what the cue
does by itself; "auto": as `vs-inspect sync` runs by default). Per video: its error against the
truth in frames, the people cue's own offset (from its pair shifts, before Stage 1), the reason
of every null; per scene the seconds of Stage 0, of its people step and of the whole run.

Truth (bench/videos.py): VisualSync clips show frames start, start+1, ... of a common 10 fps
timeline; caliscope's webcams are cut by seeded leading frames. The paper's numbers beside them
are its per-dataset video synchronization errors (Table 1, mean and median over each dataset's
scenes, ms) and, for fencing, its per-scene median (the appendix table of camera pose error
against synchronization accuracy); it gives no per-scene number for the other clips, and none for
caliscope (not in the paper).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from ..cues.config import PEOPLE_MODES
from ..errors import InputError
from ..pipeline.config import RunConfig
from .videos import CLIP_SCENES, SetRun, VideoSet, caliscope_sets, clip_set, offset_errors_s, run_set

SCENES = ("pan160906", "fencing1", "caliscope", "blenderbox", "sequence69")

# VisualSync (paper) Table 1, video synchronization, (mean, median) ms per dataset; the appendix
# table "Camera pose error vs. synchronization accuracy" gives Fencing's median: 9.6 ms
PAPER = {
    "pan160906": "CMU Panoptic: mean 112.6, median 41.5 ms (Table 1)",
    "fencing1": "EgoHumans: mean 122.1, median 46.6 ms (Table 1); Fencing median 9.6 ms (appendix)",
    "sequence69": "3D-POP: mean 114.7, median 77.8 ms (Table 1)",
    "blenderbox": "UDBD: mean 20.2, median 5.9 ms (Table 1)",
    "caliscope": "not in the paper",
}


@dataclass(frozen=True)
class PeopleRun:
    """One scene's run: the pipeline's, the people cue's own errors and the seconds."""

    scene: str
    run: SetRun
    cue_errors_frames: dict[str, float | None]  # video -> error of the people cue's own offset, frames
    seconds: float  # the whole run
    load: tuple[float, float]  # 1-minute load average at its start and end


def people_sets(data: Path, workdir: Path, scenes=SCENES, seed: int = 0) -> Iterator[tuple[str, VideoSet]]:
    """(scene, its videos with their truth), estimated cameras; caliscope cut as seed draws it."""
    for scene in scenes:
        if scene in CLIP_SCENES:
            yield scene, clip_set(data, scene)
        elif scene == "caliscope":
            vs = next(caliscope_sets(data, Path(workdir) / "caliscope", 1, seed=seed, cameras="estimated"))
            yield scene, vs
        else:
            raise InputError(f"unknown scene {scene!r}: one of {', '.join(SCENES)}")


def run_benchmark(data: Path, workdir: Path, scenes=SCENES, people: str = "only", config: RunConfig = RunConfig(),
                  seed: int = 0, log: Callable[[str], None] = print) -> list[PeopleRun]:
    """Every scene through the pipeline with cues.people = people; log(line) reports each."""
    if people not in PEOPLE_MODES:
        raise InputError(f"unknown people mode {people!r}: one of {', '.join(PEOPLE_MODES)}")
    config = dataclasses.replace(config, cues=dataclasses.replace(config.cues, people=people))
    runs = []
    for scene, vs in people_sets(data, workdir, scenes, seed):
        load0, t0 = os.getloadavg()[0], time.perf_counter()
        run = run_set(vs, config, Path(workdir) / f"{scene}-{people}")
        rec = run.result.cues.people if run.result.cues is not None else None
        cue = offset_errors_s(rec.reference, dict(rec.offsets_s), vs.truth_s) if rec and rec.offsets_s else {}
        cue_frames = {v: None if cue.get(v) is None else cue[v] * vs.fps[v] for v in vs.truth_s}
        runs.append(PeopleRun(scene, run, cue_frames, time.perf_counter() - t0, (load0, os.getloadavg()[0])))
        log(format_scene(runs[-1]))
    return runs


def _fmt(x: float | None, spec: str) -> str:
    return "null" if x is None else format(x, spec)


def format_scene(r: PeopleRun) -> str:
    """The scene's seconds and each people pair's verdict, a few lines."""
    res = r.run.result
    cues = res.cues
    people = cues.people if cues is not None else None
    t = (people.timings_s if people else {}) or {}
    lines = [f"{r.scene}: run {r.seconds:.1f} s, Stage 0 {(cues.timings_s if cues else {}).get('total_s', float('nan')):.1f} s, "
             f"people step {t.get('people', float('nan')):.1f} s, people pairs {t.get('pairs', float('nan')):.1f} s "
             f"(load {r.load[0]:.1f} -> {r.load[1]:.1f} on {os.cpu_count()} cores); "
             + (f"{cues.registered_cameras} camera(s) {cues.camera_source}" if cues else "no camera")]
    if people is not None:
        lines += [f"  {k}: " + ("refused" if p.offset_s is None else f"Δ {p.offset_s:+.3f} s") + f", {p.reason}"
                  for k, p in people.pairs.items()]
    return "\n".join(lines)


def format_table(runs: list[PeopleRun]) -> str:
    """One row per video: truth, the people cue's own error, the final error, why null, seconds."""
    head = ("| scene | video | true offset s | people cue error frames | error frames | error ms | why null |"
            " Stage 0 s | people step s | VisualSync (paper) |")
    out = [head, "| " + " | ".join(["---"] * 10) + " |"]
    for r in runs:
        res, vs = r.run.result, r.run.videos
        cues = res.cues
        people = cues.people if cues is not None else None
        stage0_s = (cues.timings_s if cues else {}).get("total_s", float("nan"))
        people_s = ((people.timings_s if people else {}) or {}).get("people", float("nan"))
        why = res.headlines()
        for i, v in enumerate(vs.truth_s):
            ref = v == res.reference
            e = r.run.errors_s.get(v)
            out.append(f"| {r.scene} | {v}{' (reference)' if ref else ''} | {vs.truth_s[v]:+.3f} | "
                       f"{'' if ref else _fmt(r.cue_errors_frames.get(v), '+.2f')} | "
                       f"{'' if ref else _fmt(r.run.errors_frames.get(v), '+.2f')} | "
                       f"{'' if ref else _fmt(None if e is None else 1000 * e, '+.0f')} | "
                       f"{why.get(v, '').replace('|', '/')[:200]} | {stage0_s:.1f} | {people_s:.1f} | "
                       f"{PAPER.get(r.scene, '') if i == 0 else ''} |")
    return "\n".join(out)
