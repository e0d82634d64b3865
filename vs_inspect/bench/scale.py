"""Scaling of Stage 1 + 2 with the rig size, on both engines (vs-inspect bench scale).

A cue-level synthetic ring rig (vs_inspect.synth.cues) of N cameras, run from its cue bundle with
every pair, a random spanning tree (rst) or each camera's k nearest cameras (knn:K), on the local
engine and on an embedded Ray. Each cell runs in a fresh Python process, so that its peak memory
is its own: the driver's from getrusage, the Ray workers' from their VmHWM (/proc) just before
Ray shuts down. Wall time includes starting Ray (and, for every cell, loading the compiled
kernels from numba's cache), because that is what a user waits for.
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..synth.cues import CueSceneConfig

# A light ring rig: 4 s videos, offsets within ±1 s, 15 tracked points per object, 60 track pairs
# per view pair, the search limited to ±1.5 s: about 0.2 s of Stage 1 per pair on one core.
RIG = {"seconds": 4.0, "max_offset_s": 1.0, "points_per_object": 15, "pairs_per_view_pair": 60}
RANGE_S = 1.5


def rig_config(cameras: int, seed: int = 0) -> CueSceneConfig:
    return CueSceneConfig(cameras=cameras, seed=seed, **RIG)


@dataclass(frozen=True)
class ScaleRow:
    cameras: int
    engine: str  # local | ray
    pairs_mode: str  # all | rst | knn:K
    pairs: int  # pairs evaluated in Stage 1
    wall_s: float  # run() including starting/joining Ray and shutting it down
    stage1_s: float  # the pairs' landscapes (the timing run() records)
    per_pair_ms: float  # stage1_s / pairs
    driver_peak_mb: float  # peak resident memory of the driver process
    worker_peak_mb: float  # largest peak resident memory of one Ray worker (nan for local)
    workers: int  # Ray worker processes seen (0 for local)
    resolved: int  # videos with an offset
    max_error_ms: float  # largest |offset - truth| over resolved videos (reference aligned)
    median_error_ms: float
    offsets: dict  # name -> offset_s or None, to compare engines


def _worker_peaks_mb() -> list[float]:
    """VmHWM of every Ray worker process started from this process (on this machine)."""
    me = os.getpid()
    children: dict[int, list[int]] = {}
    procs = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            status = (d / "status").read_text()
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
        ppid = int(fields.get("PPid", "0").strip())
        children.setdefault(ppid, []).append(int(d.name))
        procs[int(d.name)] = (cmd, fields.get("VmHWM", "0 kB").split()[0])
    out, todo = [], list(children.get(me, []))
    while todo:
        p = todo.pop()
        todo.extend(children.get(p, []))
        cmd, hwm = procs.get(p, ("", "0"))
        if cmd.startswith("ray::") or "default_worker.py" in cmd:  # Ray renames its workers
            out.append(int(hwm) / 1024.0)
    return out


def run_cell(cameras: int, engine: str, pairs_mode: str, ray_cpus: int | None, seed: int = 0) -> ScaleRow:
    """One cell in this process (bench scale runs each in a fresh process)."""
    from ..engine import EngineConfig, open_engine
    from ..pipeline.config import RunConfig
    from ..pipeline.run import run
    from ..sync.config import LandscapeConfig, PairSelection, SyncConfig
    from ..synth.cues import make_cue_scene

    bundle = make_cue_scene(rig_config(cameras, seed)).bundle
    cfg = RunConfig(sync=SyncConfig(landscape=LandscapeConfig(range_s=RANGE_S),
                                    pairs=PairSelection.parse(pairs_mode)),
                    engine=EngineConfig(engine, ray_cpus=ray_cpus))
    t0 = time.perf_counter()
    with open_engine(cfg.engine) as eng:
        res = run(bundle, cfg, progress=False, engine=eng)
        workers = _worker_peaks_mb() if engine == "ray" else []
    wall = time.perf_counter() - t0
    truth = bundle.gt_offsets_s
    ref = res.reference
    errs = [abs((v - (res.offsets_s[ref] or 0.0)) - (truth[n] - truth[ref])) * 1e3
            for n, v in res.offsets_s.items() if v is not None]
    n_pairs = len(res.pairs)
    return ScaleRow(cameras, engine, pairs_mode, n_pairs, wall, res.timings_s["stage1_s"],
                    1e3 * res.timings_s["stage1_s"] / max(n_pairs, 1),
                    resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                    max(workers) if workers else math.nan, len(workers), len(errs),
                    max(errs) if errs else math.nan, float(np.median(errs)) if errs else math.nan,
                    dict(res.offsets_s))


def run_scale_bench(cameras: list[int], engines: list[str], pairs_modes: list[str],
                    ray_cpus: int | None = None, out_jsonl: Path | None = None,
                    timeout_s: float | None = None) -> list[ScaleRow]:
    """Every (cameras, pairs mode, engine) cell in a fresh process; rows also appended to out_jsonl."""
    rows = []
    for n in cameras:
        for mode in pairs_modes:
            for engine in engines:
                code = ("import json,sys; from dataclasses import asdict; "
                        "from vs_inspect.bench.scale import run_cell; "
                        f"r = run_cell({n}, {engine!r}, {mode!r}, {ray_cpus!r}); "
                        "sys.stdout.write('ROW ' + json.dumps(asdict(r)) + '\\n')")
                try:
                    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False,
                                          timeout=timeout_s, env={**os.environ, "TQDM_DISABLE": "1"})
                except subprocess.TimeoutExpired:
                    print(f"# {n} cameras, {mode}, {engine}: over {timeout_s} s, not measured", flush=True)
                    continue
                line = next((ln for ln in done.stdout.splitlines() if ln.startswith("ROW ")), None)
                if line is None:
                    tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
                    print(f"# {n} cameras, {mode}, {engine}: failed: {tail}", flush=True)
                    continue
                row = ScaleRow(**json.loads(line[4:]))
                rows.append(row)
                print(format_rows([row], header=len(rows) == 1), flush=True)
                if out_jsonl is not None:
                    with open(out_jsonl, "a") as fh:
                        fh.write(json.dumps(asdict(row)) + "\n")
    return rows


def same_offsets(rows: list[ScaleRow]) -> dict[tuple[int, str], bool]:
    """(cameras, pairs mode) -> whether every engine gave exactly the same offsets."""
    by: dict[tuple[int, str], list[dict]] = {}
    for r in rows:
        by.setdefault((r.cameras, r.pairs_mode), []).append(r.offsets)
    return {k: all(o == v[0] for o in v[1:]) for k, v in by.items() if len(v) > 1}


def format_rows(rows: list[ScaleRow], header: bool = True) -> str:
    out = []
    if header:
        out.append(f"{'cams':>5} {'pairs_mode':<10} {'engine':<6} {'pairs':>6} {'wall_s':>8} {'stage1_s':>9} "
                   f"{'ms/pair':>8} {'driver_MB':>10} {'worker_MB':>10} {'workers':>8} {'resolved':>9} "
                   f"{'max_err_ms':>11} {'med_err_ms':>11}")
    for r in rows:
        out.append(f"{r.cameras:>5} {r.pairs_mode:<10} {r.engine:<6} {r.pairs:>6} {r.wall_s:>8.1f} "
                   f"{r.stage1_s:>9.1f} {r.per_pair_ms:>8.0f} {r.driver_peak_mb:>10.0f} "
                   f"{r.worker_peak_mb:>10.0f} {r.workers:>8} {r.resolved:>5}/{r.cameras:<3} "
                   f"{r.max_error_ms:>11.2f} {r.median_error_ms:>11.2f}")
    return "\n".join(out)
