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
import tempfile
import time
from collections import defaultdict
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from .. import __version__
from ..errors import InputError
from ..io.atomic import write_json_atomic, write_text_atomic
from .datasets import CALISCOPE, DIFFICULTIES, BenchData, caliscope_cuts, cue_scene, load_caliscope
from .suite import PlanOptions, Row, failed, run_dataset, run_videos
from .videos import CLIP_SCENES, CLIPS, clip_set, rendered_set

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
    plan += [DatasetPlan("rendered/s0", PlanOptions())]
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
    sessions: dict = {}
    for dp in tqdm(plan, desc="benchmark datasets", unit="dataset", disable=not progress):
        if after_each is not None and (rows or skipped):
            after_each(rows, skipped)
        got = _dataset_rows(dp, Path(data_root), sessions)
        if isinstance(got, Skipped):
            skipped.append(got)
        else:
            rows += got
    return rows, skipped


def _dataset_rows(dp: DatasetPlan, data_root: Path, sessions: dict) -> list[Row] | Skipped:
    """One dataset's rows (sessions: the caliscope session, parsed once)."""
    kind, _, rest = dp.name.partition("/")
    if kind == "cue":
        diff, seed = rest.split("/")
        return run_dataset(cue_scene(diff, int(seed[1:])), dp.opts)
    if kind == "caliscope":
        root = data_root / CALISCOPE
        if not root.is_dir():
            return Skipped(dp.name, f"not run: {root} not found")
        sessions.setdefault(CALISCOPE, load_caliscope(root))
        i = int(rest.removeprefix("cut"))
        return run_dataset(caliscope_cuts(sessions[CALISCOPE], i + 1)[i], dp.opts)
    if kind == "clips":
        if not (data_root / CLIPS / rest).is_dir():
            return Skipped(dp.name, f"not run: {data_root / CLIPS / rest} not found")
        return _videos(dp, lambda: clip_set(data_root, rest), "clips")
    if kind == "rendered":
        with tempfile.TemporaryDirectory(prefix="vs_bench_render_") as tmp:
            return _videos(dp, lambda: rendered_set(f"rendered_{rest}", Path(tmp)), "rendered")
    raise ValueError(f"unknown dataset {dp.name!r}")


def _videos(dp: DatasetPlan, make, group: str) -> list[Row]:
    """A video dataset's rows (suite.run_videos), or failed rows when its videos cannot be read."""
    try:
        vs = make()
        return run_videos(vs, dp.name, group, dp.opts)
    except Exception as exc:  # noqa: BLE001  (unreadable videos are a result too)
        data = BenchData(dp.name, group, None, None, float("nan"), {})
        return [failed(data, m, "default", f"{type(exc).__name__}: {exc}")
                for m in ("vs_inspect", "motion-xcorr", "ransac-inlier")]


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
        "run's Stage 1. Peak MB = peak traced Python/numpy memory of one run from a cue bundle (tracemalloc; "
        "not traced for the video datasets' default runs, which go from the videos through pipeline.run).", "",
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
    if out is not None:
        keep = ""
        if out.is_file():
            old = out.read_text()
            if DISCUSSION_MARK in old:
                keep = old.split(DISCUSSION_MARK, 1)[1].lstrip("\n")
        write_text_atomic(to_markdown(rows, skipped, wall_s, command, keep, machine_info), out)
    if json_out is not None:
        write_json_atomic(rows_to_json(rows, skipped, wall_s, command, machine_info), json_out)


def run_accuracy(quick: bool, data_root: Path, only: str | None = None, skip: str | None = None,
                 out: Path | None = None, json_out: Path | None = None, progress: bool = True
                 ) -> tuple[str, list[Row], list[Skipped], float]:
    """Run the quick or full plan (only / skip: comma-separated dataset name prefixes), write the
    markdown (out) and the rows (json_out, also after every dataset); (text tables, rows,
    skipped, wall s)."""
    plan = quick_plan() if quick else full_plan()
    if only:
        plan = [d for d in plan if d.name.startswith(tuple(only.split(",")))]
    if skip:
        plan = [d for d in plan if not d.name.startswith(tuple(skip.split(",")))]
    cmd = "vs-inspect bench accuracy" + (" --quick" if quick else "") + (f" --only {only}" if only else "") \
        + (f" --skip {skip}" if skip else "")
    info, t0 = machine(), time.perf_counter()

    def save_partial(rows, skipped):  # a long run keeps what it has measured so far
        if json_out is not None:
            write_json_atomic(rows_to_json(rows, skipped, time.perf_counter() - t0, cmd + " (partial)", info,
                                           [d.name for d in plan]), json_out)

    rows, skipped = run_plan(plan, data_root, progress, save_partial)
    wall = time.perf_counter() - t0
    write_outputs(rows, skipped, wall, cmd, out, json_out, info)
    return to_text(rows, skipped), rows, skipped, wall


def tables_from_json(files: list[Path], out: Path | None) -> str:
    """The tables of earlier runs' JSON files (a dataset in a later file replaces its rows from
    earlier ones), written to out when given; the text tables."""
    rows, skipped, walls, cmds, info, commits = [], [], [], [], None, {}
    for f in files:
        if not f.is_file():
            raise InputError(f"{f} not found")
        d = json.loads(f.read_text())
        r, s = rows_from_json(d)
        again = {x.dataset for x in r} | {x.name for x in s}
        rows = [x for x in rows if x.dataset not in again] + r
        skipped = [x for x in skipped if x.name not in again] + s
        walls.append(d.get("wall_s") or float("nan"))
        cmds.append(d.get("command", "vs-inspect bench accuracy"))
        info = info or d.get("machine")
        commits[f.name] = (d.get("machine") or {}).get("git_commit")
    if info is not None and len(set(commits.values())) > 1:  # rows of different code: say which is which
        info = {**info, "git_commit": ", ".join(f"{c} ({n})" for n, c in commits.items())}
    cmd = "; ".join(f"{c} --json {f.name}" for c, f in zip(cmds, files))
    write_outputs(rows, skipped, max(walls), cmd, out, None, info)
    return to_text(rows, skipped)
