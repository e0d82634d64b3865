"""Plans of the quick and full benchmark, running them, and the tables (text and markdown).

The quick plan is a subset of the full plan (same datasets, seeds and settings for the rows it
has), so its numbers equal the corresponding rows of a full run.
"""

from __future__ import annotations

import datetime as _dt
import json
import logging
import math
import os
import platform
import time
from collections import defaultdict
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from .. import __version__
from .datasets import CALISCOPE, DIFFICULTIES, caliscope_cuts, cue_scene, load_caliscope
from .suite import PlanOptions, Row, failed, run_dataset, stage0_failed
from .videos import (CLIP_SCENES, RENDERED_SCENES, clip_scene, rendered_scene,
                     video_pipeline_available)

log = logging.getLogger(__name__)

CUE_SEEDS = (0, 1)
CALISCOPE_CUTS = 5
DISCUSSION_MARK = "<!-- discussion: text below this line is kept when the benchmark rewrites this file -->"


@dataclass(frozen=True)
class DatasetPlan:
    name: str  # cue/<difficulty>/s<seed> | caliscope/cut<i> | clips/<scene> | rendered/s<seed>
    opts: PlanOptions


def full_plan() -> list[DatasetPlan]:
    plan = [DatasetPlan(f"caliscope/cut{i}", PlanOptions()) for i in range(CALISCOPE_CUTS)]
    plan += [DatasetPlan(f"cue/{d}/s{s}", PlanOptions()) for s in CUE_SEEDS for d in DIFFICULTIES]
    plan += [DatasetPlan(f"clips/{s}", PlanOptions()) for s in CLIP_SCENES]
    plan += [DatasetPlan(f"rendered/s{s}", PlanOptions()) for s in RENDERED_SCENES]
    return plan


def quick_plan() -> list[DatasetPlan]:
    """cue/default/s0 without the Stage 1 re-runs, and caliscope/cut0 with everything."""
    return [DatasetPlan("cue/default/s0", PlanOptions(residuals=("sampson",), true_cameras=False)),
            DatasetPlan("caliscope/cut0", PlanOptions())]


@dataclass(frozen=True)
class Skipped:
    name: str
    why: str


def run_plan(plan: list[DatasetPlan], data_root: Path, progress: bool = True,
             after_each=None) -> tuple[list[Row], list[Skipped]]:
    """Run every dataset of the plan; after_each(rows, skipped) is called after each one (e.g. to
    save partial results of a long run)."""
    rows: list[Row] = []
    skipped: list[Skipped] = []
    session = None
    for dp in tqdm(plan, desc="benchmark datasets", unit="dataset", disable=not progress):
        if after_each is not None and (rows or skipped):
            after_each(rows, skipped)
        kind = dp.name.split("/")[0]
        if kind == "cue":
            _, diff, seed = dp.name.split("/")
            rows += run_dataset(cue_scene(diff, int(seed[1:])), dp.opts)
        elif kind == "caliscope":
            root = Path(data_root) / CALISCOPE
            if not root.is_dir():
                skipped.append(Skipped(dp.name, f"not run: {root} not found"))
                continue
            session = session or load_caliscope(root)
            i = int(dp.name.split("cut")[1])
            rows += run_dataset(caliscope_cuts(session, i + 1)[i], dp.opts)
        elif kind == "clips":
            scene = dp.name.split("/")[1]
            root = Path(data_root) / "visualsync_clips"
            if not video_pipeline_available():
                skipped.append(Skipped(dp.name, "not run: video pipeline not available in this build"))
                continue
            if not (root / scene).is_dir():
                skipped.append(Skipped(dp.name, f"not run: {root / scene} not found"))
                continue
            try:
                data, stage0, error = clip_scene(root, scene)
            except Exception as exc:  # noqa: BLE001  (unreadable clips are a result too)
                from .datasets import BenchData
                n = len(list((root / scene).glob("*.mp4")))
                dummy = BenchData(dp.name, "clips", None, None, 0.1, {"videos": n})
                for method in ("vs_inspect", "motion-xcorr", "ransac-inlier"):
                    rows.append(failed(dummy, method, "default", exc))
                continue
            if error is not None:
                rows += stage0_failed(data, error, stage0)
                continue
            rows += run_dataset(data, dp.opts, stage0_s=stage0)
        elif kind == "rendered":
            import tempfile
            seed = int(dp.name.split("/s")[1])
            with tempfile.TemporaryDirectory(prefix="vs_bench_render_") as tmp:
                data, stage0, error = rendered_scene(seed, Path(tmp))
            if error is not None:
                rows += stage0_failed(data, error, stage0)
                continue
            rows += run_dataset(data, dp.opts, stage0_s=stage0)
        else:
            raise ValueError(f"unknown dataset {dp.name!r}")
    return rows, skipped


# ---- tables ---------------------------------------------------------------------------------


def _f(x: float, nd: int = 1) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:.{nd}f}"


def _ms(values: list[float]) -> tuple[float, float]:
    v = np.array([x for x in values if math.isfinite(x)])
    return (float(v.mean()), float(v.std())) if v.size else (float("nan"), float("nan"))


def _pm(values: list[float], nd: int = 1, std: bool = False) -> str:
    m, s = _ms(values)
    if not math.isfinite(m):
        return "–"
    return f"{m:.{nd}f} ± {s:.{nd}f}" if std else f"{m:.{nd}f}"


def _variant_family(v: str) -> str:
    return v.split("/seed=")[0]


def failed_variants(rows: list[Row]) -> list[Row]:
    """A failed row for each vs_inspect variant that a dataset did not get because its default run
    failed (Stage 0 or Stage 1 raised, so nothing was left to vary), for every variant that another
    dataset of its group ran. Without them a variant's mean would leave out the datasets that the
    default's mean counts as failed: on the clips, where two of four scenes give no cue bundle, LS
    and the spurious-pair filter off had looked twice as good as the default."""
    ran: dict[str, set[str]] = defaultdict(set)
    for r in rows:
        if r.method == "vs_inspect" and r.variant != "default":
            ran[r.group].add(r.variant)
    have = {r.key for r in rows}
    nan = float("nan")
    return [replace(r, variant=v, stage0_s=nan, stage1_s=nan, stage2_s=nan, peak_mb=nan)
            for r in rows if r.method == "vs_inspect" and r.variant == "default" and r.error
            for v in sorted(ran[r.group]) if (r.dataset, r.method, v) not in have]


def aggregate(rows: list[Row]) -> dict:
    """{(group, method, family): [rows]} with pair seeds folded into their family; a dataset whose
    default run failed counts as failed in every variant of its group (failed_variants)."""
    agg: dict = defaultdict(list)
    for r in rows + failed_variants(rows):
        agg[(r.group, r.method, _variant_family(r.variant))].append(r)
    return agg


def _summary_cells(rs: list[Row], std: bool = False) -> list[str]:
    unres = sum(r.unresolved for r in rs)
    vids = sum(r.videos for r in rs)
    fails = sum(1 for r in rs if r.error)
    return [_pm([r.a100 for r in rs], 1, std), _pm([r.a500 for r in rs], 1, std),
            _pm([r.delta_mean_ms for r in rs], 1, std), _pm([r.delta_med_ms for r in rs], 1, std),
            _pm([r.delta_med_frames for r in rs], 2, std), f"{unres}/{vids}", str(fails), str(len(rs))]


def _md(head: list[str], body: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in body]
    return "\n".join(lines)


METRIC_HEAD = ["A@100 %", "A@500 %", "δ_mean ms", "δ_med ms", "δ_med frames", "unresolved", "failed", "runs"]

KEY_VARIANTS = [  # the paper's Table 3 order: cameras, energy terms, solver
    ("vs_inspect", "cameras=true", "GT cameras, Sampson, IRLS"),
    ("ransac-inlier", "default", "no cameras, RANSAC inliers (Albl et al.), IRLS"),
    ("vs_inspect", "residual=cosine", "est. cameras, cosine, IRLS"),
    ("vs_inspect", "residual=algebraic", "est. cameras, algebraic, IRLS"),
    ("vs_inspect", "residual=symmetric", "est. cameras, symmetric epipolar, IRLS"),
    ("vs_inspect", "solver=ls", "est. cameras, Sampson, LS"),
    ("vs_inspect", "default", "est. cameras, Sampson, IRLS (vs_inspect)"),
]
INPUT_VARIANTS = [  # the paper's Table 2 order
    ("pairs=rst", "RST, filter on, full"), ("pairs=0.5", "50 %, filter on, full"),
    ("pairs=0.8", "80 %, filter on, full"), ("stage1-only", "100 %, filter on, Stage 1 only"),
    ("filter=off", "100 %, filter off, full"), ("default", "100 %, filter on, full (vs_inspect)"),
]


def tables(rows: list[Row], skipped: list[Skipped]) -> list[tuple[str, str]]:
    """[(title, markdown table)] in reading order."""
    agg = aggregate(rows)
    groups = sorted({r.group for r in rows}, key=lambda g: (g.split("/")[0] != "cue", g))
    out = []
    body = []
    for g in groups:
        for method in ("vs_inspect", "motion-xcorr", "ransac-inlier"):
            rs = agg.get((g, method, "default"), [])
            if not rs:
                continue
            body.append([g, method] + _summary_cells(rs) +
                        [_pm([r.stage0_s for r in rs], 2), _pm([r.stage1_s for r in rs], 2),
                         _pm([r.stage2_s for r in rs], 3),
                         _f(max((r.peak_mb for r in rs if math.isfinite(r.peak_mb)), default=float("nan")), 1)])
    out.append(("vs_inspect and the two peers (mean over the runs of each group)",
                _md(["data", "method"] + METRIC_HEAD + ["stage 0 s", "stage 1 s", "stage 2 s", "peak MB"], body)))
    body = []
    for g in groups:
        for method, variant, label in KEY_VARIANTS:
            rs = agg.get((g, method, variant), [])
            if rs:
                body.append([g, label] + _summary_cells(rs))
    out.append(("Key components (the paper's Table 3 on this data)", _md(["data", "setting"] + METRIC_HEAD, body)))
    body = []
    for g in groups:
        for fam, label in INPUT_VARIANTS:
            rs = agg.get((g, "vs_inspect", fam), [])
            if rs:
                cells = _summary_cells(rs, std=fam.startswith("pairs="))
                if fam == "stage1-only":
                    cells = cells[:2] + ["–"] * 3 + ["–", cells[6], cells[7]]
                body.append([g, label] + cells)
    out.append(("Input settings, spurious-pair filter, stages (the paper's Table 2 on this data; "
                "pairs: mean ± std over datasets × 5 pair seeds)", _md(["data", "setting"] + METRIC_HEAD, body)))
    body = [[r.dataset, r.method, r.variant, _f(r.a100), _f(r.a500), _f(r.delta_mean_ms), _f(r.delta_med_ms),
             _f(r.delta_med_frames, 2), "–" if r.variant == "stage1-only" else f"{r.unresolved}/{r.videos}",
             _f(r.stage0_s, 2), _f(r.stage1_s, 2),
             _f(r.stage2_s, 3), _f(r.peak_mb, 1), r.error or ""] for r in rows]
    out.append(("Every run", _md(["dataset", "method", "variant", "A@100", "A@500", "δ_mean ms", "δ_med ms",
                                  "δ_med fr", "unresolved", "st0 s", "st1 s", "st2 s", "peak MB", "error"], body)))
    if skipped:
        out.append(("Datasets not run", _md(["dataset", "why"], [[s.name, s.why] for s in skipped])))
    return out


def ranking_checks(rows: list[Row]) -> list[str]:
    """Plain statements comparing the paper's rankings with the measured ones, per group."""
    agg = aggregate(rows)
    groups = sorted({r.group for r in rows})
    lines = []

    def med(g, m, v):
        rs = agg.get((g, m, v), [])
        return _ms([r.delta_med_ms for r in rs])[0], _ms([r.a100 for r in rs])[0], sum(r.unresolved for r in rs)

    for g in groups:
        res = {v: med(g, "vs_inspect", v) for v in ("default", "residual=symmetric", "residual=cosine",
                                                   "residual=algebraic")}
        res = {k: v for k, v in res.items() if math.isfinite(v[1])}
        if len(res) > 1:
            order = sorted(res, key=lambda k: (-res[k][1], res[k][0]))
            lines.append(f"- {g}: residuals by A@100 (then δ_med): " + " > ".join(
                f"{k.replace('residual=', '').replace('default', 'sampson')} ({res[k][1]:.1f} %, {_f(res[k][0])} ms)"
                for k in order) + ("; paper: sampson > symmetric > algebraic > cosine"))
        pairs = [(lab, med(g, "vs_inspect", v)) for v, lab in (("solver=ls", "LS"), ("default", "IRLS"))]
        if all(math.isfinite(p[1][1]) for p in pairs):
            lines.append(f"- {g}: solver LS {pairs[0][1][1]:.1f} % / {_f(pairs[0][1][0])} ms vs IRLS "
                         f"{pairs[1][1][1]:.1f} % / {_f(pairs[1][1][0])} ms (A@100 / δ_med; paper: IRLS better)")
        fo, fd = med(g, "vs_inspect", "filter=off"), med(g, "vs_inspect", "default")
        if math.isfinite(fo[1]) and math.isfinite(fd[1]):
            lines.append(f"- {g}: spurious-pair filter off {fo[1]:.1f} % / {_f(fo[0])} ms / {fo[2]} unresolved vs on "
                         f"{fd[1]:.1f} % / {_f(fd[0])} ms / {fd[2]} unresolved (paper: filter on better)")
        pr = [(lab, med(g, "vs_inspect", v)) for v, lab in (("pairs=rst", "RST"), ("pairs=0.5", "50%"),
                                                             ("pairs=0.8", "80%"), ("default", "100%"))]
        if all(math.isfinite(p[1][1]) for p in pr):
            lines.append(f"- {g}: pairs used, A@100: " + ", ".join(f"{lab} {v[1]:.1f} %" for lab, v in pr)
                         + " (paper: RST < 50% < 80% < 100%)")
        peers = {m: med(g, m, "default") for m in ("vs_inspect", "motion-xcorr", "ransac-inlier")}
        if all(math.isfinite(v[1]) for v in peers.values()):
            lines.append(f"- {g}: methods by A@100: " + " > ".join(
                f"{m} ({peers[m][1]:.1f} %)" for m in sorted(peers, key=lambda m: -peers[m][1])))
    return lines


def machine() -> dict:
    info = {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpu_count": os.cpu_count(), "python": platform.python_version(), "vs_inspect": __version__}
    try:
        import numba
        info["numba_threads"] = numba.get_num_threads()
    except Exception:  # noqa: BLE001
        pass
    try:
        import subprocess
        repo = Path(__file__).resolve().parents[2]
        head = subprocess.run(["git", "-C", str(repo), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=10).stdout.strip()
        if head:
            info["git_commit"] = head
    except Exception:  # noqa: BLE001  (not a git checkout)
        pass
    try:
        info["load_average_1_5_15min"] = " / ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        pass
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return info


def to_text(rows: list[Row], skipped: list[Skipped]) -> str:
    parts = []
    for title, table in tables(rows, skipped):
        if title == "Every run":
            continue
        parts.append(f"## {title}\n\n{table}\n")
    checks = ranking_checks(rows)
    if checks:
        parts.append("## Ranking checks\n\n" + "\n".join(checks) + "\n")
    return "\n".join(parts)


def to_markdown(rows: list[Row], skipped: list[Skipped], wall_s: float, command: str,
                keep: str = "", machine_info: dict | None = None) -> str:
    m = machine_info or machine()
    head = [
        "# Benchmarks", "",
        f"Written by `{command}` on {_dt.datetime.now(_dt.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}, "
        f"wall time {wall_s / 60:.1f} min.", "",
        "Machine: " + ", ".join(f"{k} {v}" for k, v in m.items()) + ".", "",
        "Metrics as in the VisualSync paper: A@100 / A@500 = pairwise AUC of |Δ error| up to 100 / 500 ms "
        "over every pair of videos (a pair with an unresolved video counts as wrong), δ_mean / δ_med = "
        "per-video error in ms against the reference video (resolved videos only; `unresolved` says how "
        "many have no offset), δ_med in frames of the dataset's typical frame interval. Values are means "
        "over the runs of a group (datasets × seeds); a dataset whose default run failed (e.g. Stage 0 gave no "
        "cue bundle) counts as failed in every variant of its group, so that each setting is averaged over the "
        "same datasets. Times: stage 0 = cue extraction from video, stage 1 = "
        "pair landscapes (peers: pair scores), stage 2 = global solve; `–` where a variant reuses the default "
        "run's Stage 1. Peak MB = peak traced Python/numpy memory of one run (tracemalloc).", "",
        "Data: `cue/<level>` = cue-level synthetic scenes (vs_inspect.synth.cues, 5 cameras of which 2 "
        "hand-held, 1 variable-rate, 1 pair without matches and 1 pair with only wrong matches; easy = 0.3 px "
        "noise, 10 % wrong pairs, 0.1° pose error; default = 0.8 px, 25 %, 0.5°; hard = 1.5 px, 35 %, 1°; "
        "seeds 0 and 1); `caliscope` = real ChArUco corners of 4 webcams read from xy.csv, undistorted with the "
        "session's calibration, per-frame timestamps, offsets made by cutting 0-12 leading frames (5 random "
        "cuts); `clips` = the VisualSync web clips through the video pipeline (estimated cameras); `rendered` = a rendered scene of vs_inspect.synth (3 static + 1 hand-held camera, 5 s, 480x360, mixed frame rates, one variable-rate video) through the video pipeline with its exact calibration (so its GT-camera rows equal the default).", "",
        "Peers: `motion-xcorr` = one motion scalar per frame (mean track speed for cue data, mean absolute "
        "frame difference for video) cross-correlated over vs_inspect's search range; `ransac-inlier` = "
        "RANSAC F inlier count per candidate offset (frame-step grid, 2 px threshold, fixed seed). Both use "
        "vs_inspect's Stage 2 (Huber IRLS).", "",
    ]
    body = []
    for title, table in tables(rows, skipped):
        body.append(f"## {title}\n\n{table}\n")
    checks = ranking_checks(rows)
    body.append("## Ranking checks (computed)\n\n" + "\n".join(checks) + "\n")
    fails = [r for r in rows if r.error]
    body.append("## Failures\n\n" + ("\n".join(f"- {r.dataset} {r.method} {r.variant}: {r.error}" for r in fails)
                                    if fails else "None: every run produced a result (unresolved videos are counted above).") + "\n")
    text = "\n".join(head) + "\n" + "\n".join(body) + "\n" + DISCUSSION_MARK + "\n"
    return text + keep


def rows_to_json(rows: list[Row], skipped: list[Skipped], wall_s: float = float("nan"),
                 command: str = "", machine_info: dict | None = None, plan: list[str] | None = None) -> dict:
    def clean(d):
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
    return {"rows": [clean(asdict(r)) for r in rows], "skipped": [asdict(s) for s in skipped],
            "machine": machine_info or machine(), "wall_s": wall_s, "command": command,
            "plan": list(plan or [])}


def rows_from_json(d: dict) -> tuple[list[Row], list[Skipped]]:
    rows = [Row(**{k: (float("nan") if v is None else v) for k, v in r.items()}) for r in d["rows"]]
    skipped = [Skipped(**s) for s in d.get("skipped", [])]
    done = {r.dataset for r in rows} | {s.name for s in skipped}
    skipped += [Skipped(n, "not run: the run stopped before this dataset (time budget)")
                for n in d.get("plan", []) if n not in done]
    return rows, skipped


def write_outputs(rows, skipped, wall_s, command, out: Path | None, json_out: Path | None,
                  machine_info: dict | None = None) -> None:
    from ..io.atomic import write_json_atomic, write_text_atomic
    if out is not None:
        keep = ""
        if out.is_file():
            old = out.read_text()
            if DISCUSSION_MARK in old:
                keep = old.split(DISCUSSION_MARK, 1)[1].lstrip("\n")
        write_text_atomic(to_markdown(rows, skipped, wall_s, command, keep, machine_info), out)
    if json_out is not None:
        write_json_atomic(rows_to_json(rows, skipped, wall_s, command, machine_info), json_out)


def timed_run(plan, data_root, progress=True, after_each=None):
    t = time.perf_counter()
    rows, skipped = run_plan(plan, data_root, progress, after_each)
    return rows, skipped, time.perf_counter() - t


__all__ = ["DatasetPlan", "full_plan", "quick_plan", "run_plan", "timed_run", "tables", "to_text",
           "to_markdown", "write_outputs", "rows_to_json", "rows_from_json", "json"]
