"""Videos to offsets (`vs-inspect bench stage0`): each set of videos through pipeline.run as
`vs-inspect sync` runs it, one table row per set read from its result (offsets against the
truth, cameras, track pairs, the stages' seconds, the reason of every null), and a summary that
counts the offsets within 1 frame, at 1-2 frames and over 2 frames (the safety target: none).

With the exact cameras of a rendered scene given to the run, the row also says how right the
run's cross-view track pairs are (bench.pairing: precision and recall against the true cameras
and offsets, read from the cue bundle the run wrote).
"""

from __future__ import annotations

import re

from collections.abc import Callable, Iterable
from pathlib import Path

from ..pipeline.config import RunConfig
from .videos import SetRun, Summary, VideoSet, run_set, summarize

HEAD = ("| set | reference | offsets (frames; null: why) | cameras | track pairs | stage 0 s | sync s |\n"
        "| --- | --- | --- | --- | --- | --- | --- |")


def bench_sets(sets: Iterable[VideoSet], config: RunConfig, workdir: Path,
               say: Callable[[str], None]) -> list[SetRun]:
    """Run every set into its run folder in workdir (named after the set), saying the table as
    the rows come, then the summary; returns the runs."""
    say(HEAD)
    runs = []
    for vs in sets:
        runs.append(run_set(vs, config, Path(workdir) / re.sub(r"[^\w.-]+", "_", vs.name)))
        say(row(runs[-1]))
    say("")
    say(summary_line(summarize([e for r in runs for e in r.errors_frames.values()],
                               [e for r in runs for e in r.errors_s.values()]), len(runs)))
    return runs


def row(r: SetRun) -> str:
    """One set's table row (module docstring)."""
    res, t = r.result, r.result.timings_s
    why = res.headlines()
    shown = ", ".join(f"{v} " + (f"null ({why.get(v, 'no offset')})" if e is None else
                                 f"{e:+.2f}" + (" **over 2**" if abs(e) > 2 else ""))
                      for v, e in r.errors_frames.items())
    if res.offsets_s.get(res.reference) is None:
        shown += f"; reference null ({why.get(res.reference, 'no offset')})"
    cues = res.cues
    cameras = "-" if cues is None else f"{cues.camera_source} {cues.registered_cameras}/{len(r.videos.videos)}"
    stage0 = t.get("stage0_with_io_s", float("nan"))
    return (f"| {r.videos.name} | {res.reference} | {shown} | {cameras} | {track_pairs(r)} | "
            f"{stage0:.1f} | {t.get('total_s', float('nan')) - stage0:.1f} |")


def track_pairs(r: SetRun) -> str:
    """The run's cross-view track pairs; judged against the true cameras when the run was given
    them (precision: right of judged; recall: right of the most one-to-one right pairs)."""
    cues = r.result.cues
    if cues is None:
        return "-"
    if r.videos.true_cameras is None or r.videos.calibration != r.videos.true_cameras \
            or not (r.folder / "cues" / "bundle.json").is_file():
        return str(cues.track_pairs)
    from ..io.bundle import read_bundle
    from ..io.calibration import load_calibration, to_camera_track
    from .pairing import bundle_pair_truth

    bundle = read_bundle(r.folder / "cues")
    cams = {n: to_camera_track(c) for n, c in load_calibration(r.videos.true_cameras, bundle.names).items()}
    judged = bundle_pair_truth(bundle, cams, r.videos.truth_s).values()
    right, seen, possible = (sum(getattr(j, k) for j in judged) for k in ("right", "judged", "possible"))
    return (f"{cues.track_pairs}, precision {right / max(seen, 1):.2f}, recall "
            f"{right / max(possible, 1):.2f}")


def summary_line(s: Summary, sets: int) -> str:
    def f(x, unit):
        return "-" if x is None else f"{x:.2f}{unit}"

    return (f"{sets} sets, {s.offsets} offsets: {s.resolved} resolved ({s.within_1} within 1 frame, "
            f"{s.from_1_to_2} at 1-2 frames, **{s.over_2} over 2 frames**), {s.offsets - s.resolved} null; "
            f"|error| median {f(s.median_abs_frames, ' frames')} ({f(s.median_abs_ms, ' ms')}), "
            f"max {f(s.max_abs_frames, ' frames')} ({f(s.max_abs_ms, ' ms')})")


def timings_lines(r: SetRun) -> list[str]:
    """The run's seconds per step (result.json's timings_s: Stage 0's steps, then Stage 1 and 2's)."""
    return [f"{k:<28}{v:>10.2f}" for k, v in r.result.timings_s.items()]
