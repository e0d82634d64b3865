"""What each of Stage 0's acceptance rules and camera paths is worth: the whole pipeline on measured
sets with every rule, then with each one left out, counted per set (offsets within 1 frame, over 2
frames, null), and the rules that pay kept by backward elimination.

Each scene's expensive steps (each video's cues, the camera models, the pairs' votes, the checks,
the pairs' landscapes) are kept on disk under a digest of their inputs (vs_inspect.memo), so that
every variant after the first replays only the decisions. Errors are in frames of the slower of
the video and the reference.

The sets: the VisualSync clips, caliscope's webcams cut by random leading frames (estimated
cameras), the demo's rendered videos with their calibration, and rendered scenes on arcs
(vs_inspect.bench.arcs) with estimated cameras.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np  # before pycolmap

from ..cues.config import CueConfig
from ..errors import InputError
from ..memo import Memo
from ..sync.config import SyncConfig

log = logging.getLogger(__name__)

CLIP_SCENES = ("blenderbox", "pan160906", "sequence69", "fencing1")


@dataclass(frozen=True)
class Scene:
    """One measured input: its videos, calibration (None: estimated cameras) and true offsets."""

    set: str  # the set it is counted in
    name: str
    videos: tuple[Path, ...]
    calibration: Path | None
    truth_s: dict[str, float]  # video -> true offset_s (any origin)
    fps: dict[str, float]  # video -> frames per second (errors in frames of the slower video)


@dataclass(frozen=True)
class Count:
    """A set's offsets under one variant."""

    offsets: int  # non-reference videos
    within_1: int  # |error| <= 1 frame
    over_2: int  # |error| > 2 frames
    nulls: int

    def __add__(self, o: Count) -> Count:
        return Count(self.offsets + o.offsets, self.within_1 + o.within_1, self.over_2 + o.over_2,
                     self.nulls + o.nulls)

    def worse_than(self, o: Count) -> bool:
        """Fewer offsets within a frame, more over 2 frames, or more nulls than o."""
        return self.within_1 < o.within_1 or self.over_2 > o.over_2 or self.nulls > o.nulls

    def text(self) -> str:
        return f"{self.within_1} / {self.over_2} / {self.nulls}"


def count(errors: Iterable[float | None]) -> Count:
    errors = list(errors)
    got = [abs(e) for e in errors if e is not None]
    return Count(len(errors), sum(e <= 1.0 for e in got), sum(e > 2.0 for e in got), len(errors) - len(got))


# ---- the sets ----------------------------------------------------------------------------------


def _fps_of(paths: Sequence[Path]) -> dict[str, float]:
    from ..io.video import open_video

    out = {}
    for p in paths:
        info = open_video(p).info
        out[info.name] = 1.0 / info.frame_interval_s
    return out


def clip_scenes(data: Path, names: Sequence[str] = CLIP_SCENES) -> list[Scene]:
    """The VisualSync clips: clip <scene>_<cam>_<start>_<end>_<k>.mp4 starts at frame start of a
    common 10 fps timeline."""
    from .videos import clip_truth

    out = []
    for name in names:
        paths = tuple(sorted((data / "visualsync_clips" / name).glob("*.mp4")))
        if not paths:
            raise InputError(f"no clips of {name} in {data / 'visualsync_clips'}")
        out.append(Scene("clips", name, paths, None, clip_truth(paths), _fps_of(paths)))
    return out


def caliscope_scenes(data: Path, scratch: Path, trials: int = 3, max_cut: int = 12, seed: int = 0) -> list[Scene]:
    """caliscope's four webcams, each cut by a random number of leading frames (the cuts of
    `bench stage0 caliscope --trials N`), estimated cameras; truth from the frames' timestamps."""
    from .datasets import read_caliscope_frame_times
    from .videos import caliscope_truth, write_cut

    root = data / "caliscope_post_optimization"
    frame_times = read_caliscope_frame_times(root)
    rng = np.random.default_rng(seed)
    out = []
    for trial in range(trials):
        cuts = {f"cam_{i}": int(c) for i, c in enumerate(rng.integers(0, max_cut + 1, 4))}
        folder = scratch / "inputs" / f"caliscope_t{trial}"
        paths = []
        for name, c in cuts.items():
            p = folder / f"{name}.mp4"
            if not p.exists():
                folder.mkdir(parents=True, exist_ok=True)
                write_cut(root / "calibration" / "extrinsic" / f"{name}.mp4", p.with_suffix(".partial.mp4"), c)
                p.with_suffix(".partial.mp4").rename(p)
            paths.append(p)
        out.append(Scene("caliscope", f"caliscope_t{trial}", tuple(paths), None, caliscope_truth(frame_times, cuts),
                         _fps_of(paths)))
    return out


def demo_scene(scratch: Path) -> Scene:
    """The demo's rendered videos with their calibration (rendered once into scratch)."""
    from ..commands.demo import DEMO_SCENE
    from ..synth.videos import render_unless_cached

    folder = scratch / "inputs" / "demo"
    render_unless_cached(folder, DEMO_SCENE, progress=False)
    paths = tuple(sorted(folder.glob("cam*.mp4")))
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    return Scene("demo", "demo", paths, folder / "calibration.json", truth, _fps_of(paths))


SMALL_SEEDS = tuple(range(10))


def small_scenes(scratch: Path, seeds: Sequence[int] = SMALL_SEEDS) -> list[Scene]:
    """Small rendered rigs with their exact calibration: 4 static cameras around the scene, 320x240
    at 30 fps, 4 s, offsets within ±0.4 s (few pixels per moving point, so a wrong Δ costs little)."""
    from ..synth.videos import render_unless_cached
    from ..synth.world import SceneConfig

    out = []
    for seed in seeds:
        folder = scratch / "inputs" / f"small_s{seed}"
        render_unless_cached(folder, SceneConfig(cameras=4, moving=0, seconds=4.0, same_length=True, width=320,
                                                 height=240, fps=30.0, max_offset_s=0.4, seed=seed), progress=False)
        paths = tuple(sorted(folder.glob("cam*.mp4")))
        truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
        out.append(Scene("small", f"small_s{seed}", paths, folder / "calibration.json", truth, _fps_of(paths)))
    return out


def arc_scenes(set_name: str, scratch: Path) -> list[Scene]:
    """The rendered scenes of one arcs set (vs_inspect.bench.arcs), estimated cameras."""
    from ..synth.videos import render_unless_cached
    from .scenes import SCENE_SETS, scene_config

    out = []
    for name in SCENE_SETS[set_name]:
        folder = scratch / "inputs" / name
        render_unless_cached(folder, scene_config(name), progress=False)
        paths = tuple(sorted(folder.glob("cam*.mp4")))
        truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
        rates = {c["name"]: c["fps"] for c in json.loads((folder / "scene.json").read_text())["cameras"]}
        out.append(Scene(f"arcs {set_name}", name, paths, None, truth, rates))
    return out


# ---- one run of one scene ----------------------------------------------------------------------


@dataclass(frozen=True)
class Outcome:
    errors: dict[str, float | None]  # non-reference video -> signed error in frames (None: null)
    seconds: float


def run_scene(scene: Scene, scratch: Path, off: frozenset[str] = frozenset(),
              cfg: CueConfig = CueConfig(), sync: SyncConfig = SyncConfig()) -> Outcome:
    """The whole pipeline on one scene with the rules of `off` left out, every expensive step
    kept in scratch/<scene>."""
    from ..cues.rules import RULES, stage1_config
    from ..errors import NoUsableVideos
    from ..pipeline.stage0 import run_stage0
    from ..pipeline.stage12 import sync_bundle
    from .videos import offset_errors_s

    unknown = off - set(RULES)
    if unknown:
        raise InputError(f"unknown rules {sorted(unknown)}; known: {', '.join(RULES)}")
    memo = Memo(scratch / "memo" / scene.name)
    t0 = time.perf_counter()
    names = [p.stem if p.suffix else p.name for p in scene.videos]
    try:
        bundle, _, _ = run_stage0(list(scene.videos), scene.calibration, None, cfg, progress=False,
                                  memo=memo, rules=frozenset(RULES) - off)
    except NoUsableVideos:
        ref = names[0]
        return Outcome({v: None for v in scene.truth_s if v != ref}, time.perf_counter() - t0)
    res = sync_bundle(bundle, stage1_config(sync, frozenset(RULES) - off), progress=False, memo=memo)
    offsets = {v: res.offsets_s.get(v) for v in scene.truth_s}
    errors = offset_errors_s(res.reference, offsets, scene.truth_s)
    frames = {v: None if e is None else e * min(scene.fps[v], scene.fps[res.reference]) for v, e in errors.items()}
    return Outcome(frames, time.perf_counter() - t0)


# ---- the ablation ------------------------------------------------------------------------------


class Results:
    """Every (scene, rules left out) measured so far, kept in a JSON file, so that an ablation
    stopped half way resumes where it was."""

    def __init__(self, path: Path):
        self.path = path
        self.data: dict[str, dict] = json.loads(path.read_text()) if path.exists() else {}

    def errors(self, scene: Scene, off: frozenset[str], scratch: Path, progress=print) -> dict[str, float | None]:
        key = f"{scene.name}|{','.join(sorted(off))}"
        if key not in self.data:
            out = run_scene(scene, scratch, off)
            self.data[key] = {"errors": out.errors, "seconds": round(out.seconds, 1)}
            tmp = self.path.with_suffix(".partial")
            tmp.write_text(json.dumps(self.data, indent=1))
            tmp.replace(self.path)
            progress(f"  {scene.name} without {sorted(off) or 'nothing'}: "
                     + ", ".join(f"{v} " + ("null" if e is None else f"{e:+.2f}") for v, e in out.errors.items())
                     + f" ({out.seconds:.0f} s)")
        return self.data[key]["errors"]


@dataclass(frozen=True)
class Variant:
    off: frozenset[str]
    counts: dict[str, Count]  # set -> its count


def measure(scenes: Sequence[Scene], scratch: Path, results: Results, off: frozenset[str], progress=print
            ) -> Variant:
    by_set: dict[str, Count] = {}
    for sc in scenes:
        c = count(results.errors(sc, off, scratch, progress).values())
        by_set[sc.set] = by_set.get(sc.set, Count(0, 0, 0, 0)) + c
    return Variant(off, by_set)


def ablate(scenes: Sequence[Scene], scratch: Path, rules: Sequence[str], progress=print
           ) -> tuple[Variant, list[Variant], list[tuple[str, Variant, bool]]]:
    """(every rule, each rule left out alone, the backward elimination: per rule in order, the
    variant without it and those dropped before, and whether it was dropped). A rule is dropped
    when leaving it out makes no set worse than with every rule (Count.worse_than). Scene by
    scene first, every rule then each left out alone (the first run of a scene computes its
    expensive steps, the others replay decisions)."""
    results = Results(scratch / "results.json")
    for sc in scenes:
        for off in [frozenset()] + [frozenset({r}) for r in rules]:
            results.errors(sc, off, scratch, progress)
    full = measure(scenes, scratch, results, frozenset(), progress)
    alone = [measure(scenes, scratch, results, frozenset({r}), progress) for r in rules]
    dropped: frozenset[str] = frozenset()
    steps = []
    for r in rules:
        trial = measure(scenes, scratch, results, dropped | {r}, progress)
        ok = not any(trial.counts[s].worse_than(full.counts[s]) for s in full.counts)
        if ok:
            dropped |= {r}
        steps.append((r, trial, ok))
    return full, alone, steps


def markdown(full: Variant, alone: list[Variant], steps: list[tuple[str, Variant, bool]], docs: dict[str, str]
             ) -> str:
    """Two tables: each rule left out alone, and the elimination. Each cell: offsets within 1
    frame / over 2 frames / null."""
    sets = list(full.counts)
    totals = ", ".join(f"{s} {full.counts[s].offsets}" for s in sets)
    head = ("| left out | what it does | " + " | ".join(sets) + " |\n| --- | --- | "
            + " | ".join("---" for _ in sets) + " |\n")
    rows = ["| nothing (every rule) | | " + " | ".join(full.counts[s].text() for s in sets) + " |"]
    for v in alone:
        r = next(iter(v.off))
        rows.append(f"| `{r}` | {docs.get(r, '')} | " + " | ".join(
            v.counts[s].text() + (" **worse**" if v.counts[s].worse_than(full.counts[s]) else "") for s in sets) + " |")
    elim = ["| rule | " + " | ".join(sets) + " | |", "| --- | " + " | ".join("---" for _ in sets) + " | --- |"]
    for r, v, ok in steps:
        elim.append(f"| `{r}` | " + " | ".join(v.counts[s].text() for s in sets)
                    + f" | {'dropped' if ok else 'kept'} |")
    return (f"Offsets per set: {totals}. Each cell: offsets within 1 frame / over 2 frames / null.\n\n"
            + head + "\n".join(rows) + "\n\nBackward elimination, in the rules' order: each rule left out "
            "with every rule dropped before it; dropped when no set is worse than with every rule.\n\n"
            + "\n".join(elim) + "\n")


def run(sets: Sequence[str], data: Path, scratch: Path, rules: Sequence[str] | None = None, progress=print) -> str:
    """The ablation on the named sets ("clips", "caliscope", "demo", "small", "arcs:SET"); returns the
    markdown of the tables."""
    from ..cues.rules import RULES

    scenes: list[Scene] = []
    for s in sets:
        if s == "clips":
            scenes += clip_scenes(data)
        elif s == "caliscope":
            scenes += caliscope_scenes(data, scratch)
        elif s == "demo":
            scenes.append(demo_scene(scratch))
        elif s == "small":
            scenes += small_scenes(scratch)
        elif s.startswith("arcs:"):
            scenes += arc_scenes(s.removeprefix("arcs:"), scratch)
        else:
            raise InputError(f"unknown set {s!r}: use clips, caliscope, demo, small or arcs:SET")
    names = list(rules or RULES)
    full, alone, steps = ablate(scenes, scratch, names, progress)
    return markdown(full, alone, steps, RULES)
