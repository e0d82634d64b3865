"""Interrupt every long command at a sweep of moments and check that it ends cleanly.

For each case (a command line on small synthetic inputs) the command is run once uninterrupted,
with -v, to measure its wall time and when its phases happen (Stage 0 and Stage 1 of a sync from
videos, the 3D rendering and the PNG files of a report). Then, for each signal (SIGINT, SIGTERM)
and each moment of a sweep over the phase, the command is started again, sent the signal at that
moment, and checked:

- exit code 128 + signal (130, 143), never a crash (a negative code: killed by a signal);
- exactly one line on stderr after the signal, the `vs-inspect CMD: interrupted by ...` line, and
  no traceback anywhere;
- the outputs' exact contents afterwards: what was there before the run (nothing, or an earlier
  result byte for byte), or, when the signal came after the command had finished its work, the
  complete result; and no temporary, lock or leftover beside them.

Inputs are made once in the work folder by the command line itself (synth-cues, synth-video,
sync), small enough that the whole sweep takes minutes.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

SIGNALS = (signal.SIGINT, signal.SIGTERM)


@dataclass(frozen=True)
class Case:
    """One command to interrupt."""

    name: str  # shown in the table
    argv: tuple[str, ...]  # the command's arguments (after `vs-inspect`)
    outputs: tuple[str, ...]  # paths (relative to the case folder) whose contents are checked
    phase: str = "run"  # which part of the run the moments sweep: run, stage0, stage1, render3d, png
    before: Callable[[Path], None] | None = None  # makes the earlier result (None: outputs absent)
    exit_codes: tuple[int, ...] = (0,)  # of a finished run (sync: 2 when fewer than two offsets)


@dataclass
class Outcome:
    case: str
    signal: str
    moment_s: float
    ok: bool
    missed: bool = False  # the command had finished before the signal was sent
    stop_s: float | None = None  # from the signal to the end of the process
    problems: list[str] = field(default_factory=list)


def _env(workdir: Path) -> dict[str, str]:
    env = dict(os.environ)
    here = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (here, env.get("PYTHONPATH", "")) if p)
    env["VS_INSPECT_RECORDINGS"] = str(workdir / "recordings-default")
    env.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    return env


def _cli(args: list[str], cwd: Path, env: dict[str, str], check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "vs_inspect", *args], cwd=cwd, env=env,
                       stdin=subprocess.DEVNULL, capture_output=True, text=True)
    if check and r.returncode != 0:
        raise RuntimeError(f"vs-inspect {' '.join(args)} failed ({r.returncode}): {r.stderr.strip()[-500:]}")
    return r


SCENE_CAMERAS = 4  # the rendered scene's cameras


def prepare_inputs(workdir: Path, demo: bool = True) -> dict[str, Path]:
    """Small synthetic inputs, made once: a cue bundle, a rendered scene, a run folder with its
    recording (for report), a run of the scene's true cues (for export) and, with demo, the demo's
    own rendered scene (minutes)."""
    workdir.mkdir(parents=True, exist_ok=True)
    env = _env(workdir)
    inputs = workdir / "inputs"
    inputs.mkdir(exist_ok=True)
    p = {"bundle": inputs / "cues", "scene": inputs / "scene", "run": inputs / "run",
         "rrd": inputs / "run.rrd", "videos_run": inputs / "videos_run"}
    if not (p["bundle"] / "bundle.json").is_file():
        _cli(["synth-cues", "--out", str(p["bundle"]), "--cameras", "4", "--seconds", "4", "--force"], inputs, env)
    if not (p["scene"] / "COMPLETE").is_file():
        # four cameras, so that Stage 1 has six pairs of geometric track pairs to work on for seconds
        _cli(["synth-video", "--out", str(p["scene"]), "--cameras", str(SCENE_CAMERAS), "--moving", "0",
              "--seconds", "4", "--width", "320", "--height", "240", "--fps", "30", "--same-length",
              "--seed", "3", "--no-progress", "--force"], inputs, env)
    if not (p["run"] / "result.json").is_file():
        _cli(["sync", "--bundle", str(p["bundle"]), "--out", str(p["run"]), "--rrd", str(p["rrd"]),
              "--no-progress", "--force"], inputs, env)
    if not (p["videos_run"] / "result.json").is_file():  # the scene's true cues: every offset found
        _cli(["sync", "--bundle", str(p["scene"] / "bundle"), "--out", str(p["videos_run"]), "--no-rrd",
              "--no-progress", "--force"], inputs, env)
    p["demo_scene"] = inputs / "demo" / "scene"
    if demo and not (p["demo_scene"] / "COMPLETE").is_file():  # the demo's own scene, rendered once (minutes)
        _cli(["demo", "--out", str(inputs / "demo"), "--true-cues-only", "--no-rrd", "--no-progress"], inputs, env)
    return p


def cases(p: dict[str, Path]) -> list[Case]:
    videos = [str(p["scene"] / f"cam{i}.mp4") for i in range(SCENE_CAMERAS)]
    calib = str(p["scene"] / "calibration.json")

    return [
        Case("sync videos (Stage 0)", ("sync", *videos, "--calib", calib, "--out", "out", "--rrd",
                                       "recs/run.rrd", "--no-progress"), ("out", "recs"), "stage0", exit_codes=(0, 2)),
        Case("sync videos (Stage 1)", ("sync", *videos, "--calib", calib, "--out", "out", "--rrd",
                                       "recs/run.rrd", "--no-progress"), ("out", "recs"), "stage1", exit_codes=(0, 2)),
        Case("sync bundle", ("sync", "--bundle", str(p["bundle"]), "--out", "out", "--rrd", "recs/run.rrd",
                             "--no-progress"), ("out", "recs")),
        Case("report (3D rendering)", ("report", str(p["rrd"]), "--out", "rep", "--force"), ("rep",),
             "render3d", before=_make_previous_report(p)),
        Case("report (PNG files)", ("report", str(p["run"]), "--out", "rep", "--force"), ("rep",), "png",
             before=_make_previous_report(p)),
        Case("export --mosaic", ("export", str(p["videos_run"]), "--videos", *videos, "--mosaic", "m/mosaic.mp4",
                                 "--no-progress", "--tile-width", "160", "--force"), ("m",),
             before=_make_previous_mosaic()),
        Case("demo", ("demo", "--out", "demo", "--rrd", "recs/demo.rrd", "--no-progress", "--true-cues-only"),
             ("demo", "recs"), before=_cached_demo_scene(p)),
    ]


def _make_previous_report(p: dict[str, Path]) -> Callable[[Path], None]:
    def make(folder: Path) -> None:
        rep = folder / "rep"
        rep.mkdir()
        (rep / "index.html").write_text("<p>an earlier report</p>\n")
        (rep / "landscapes.png").write_bytes(b"an earlier figure")
    return make


def _make_previous_mosaic() -> Callable[[Path], None]:
    def make(folder: Path) -> None:
        (folder / "m").mkdir()
        (folder / "m" / "mosaic.mp4").write_bytes(b"an earlier mosaic")
    return make


def _cached_demo_scene(p: dict[str, Path]) -> Callable[[Path], None]:
    """The demo's OUT/scene as a cached rendering (the small scene, recorded as rendered with the
    demo's settings would not be true: the demo renders its own scene when this one differs)."""
    def make(folder: Path) -> None:
        src = p.get("demo_scene")
        if src is not None and src.is_dir():
            shutil.copytree(src, folder / "demo" / "scene", symlinks=True)
    return make


def snapshot(folder: Path, outputs: tuple[str, ...]) -> dict[str, str]:
    """{relative path: content hash ("dir" for folders)} of every output and of every entry beside
    them (temporaries, locks and leftovers are dot-names there)."""
    snap: dict[str, str] = {}
    parents = {(folder / o).parent for o in outputs}
    for parent in parents:
        if not parent.is_dir():
            continue
        for entry in parent.iterdir():
            if entry.name in ("stdout.txt",):
                continue
            rel = entry.relative_to(folder)
            if entry.is_dir() and not entry.is_symlink():
                snap[str(rel) + "/"] = "dir"
                for sub in sorted(entry.rglob("*")):
                    r = str(sub.relative_to(folder))
                    snap[r + ("/" if sub.is_dir() else "")] = "dir" if sub.is_dir() else _hash(sub)
            else:
                snap[str(rel)] = _hash(entry)
    return snap


def _hash(p: Path) -> str:
    try:
        return hashlib.sha1(p.read_bytes()).hexdigest()[:16]
    except OSError as exc:
        return f"unreadable ({exc.strerror})"


class _Reader(threading.Thread):
    """Reads a pipe's lines with the time each arrived."""

    def __init__(self, pipe):
        super().__init__(daemon=True)
        self.pipe, self.lines = pipe, []

    def run(self) -> None:
        for line in iter(self.pipe.readline, ""):
            self.lines.append((time.monotonic(), line.rstrip("\n")))


def _start(case: Case, folder: Path, env: dict[str, str], verbose: bool = False):
    argv = [sys.executable, "-m", "vs_inspect", *(["-v"] if verbose else []), *case.argv]
    out = open(folder / "stdout.txt", "w")
    proc = subprocess.Popen(argv, cwd=folder, env=env, stdin=subprocess.DEVNULL, stdout=out,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    out.close()
    reader = _Reader(proc.stderr)
    reader.start()
    return proc, reader


def _printed_before(stdout: Path, t_wall: float) -> bool:
    """Whether a command's stdout file holds output last written before t_wall (time.time())."""
    try:
        st = stdout.stat()
    except OSError:
        return False
    return st.st_size > 0 and st.st_mtime < t_wall


def _fresh_folder(case: Case, root: Path) -> Path:
    folder = root / "case"
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    if case.before is not None:
        case.before(folder)
    return folder


@dataclass(frozen=True)
class Measured:
    wall_s: float
    window_s: tuple[float, float]  # the phase's start and end, seconds after the start
    complete: frozenset[str]  # the outputs' paths after an uninterrupted run
    exit_code: int  # of the uninterrupted run


def measure(case: Case, root: Path, env: dict[str, str]) -> Measured:
    """Run the case once, uninterrupted and with -v: wall time, phase window, complete outputs."""
    folder = _fresh_folder(case, root)
    t0 = time.monotonic()
    proc, reader = _start(case, folder, env, verbose=True)
    rc = proc.wait(timeout=900)
    reader.join(5)
    wall = time.monotonic() - t0
    if rc not in case.exit_codes:
        raise RuntimeError(f"{case.name}: the uninterrupted run failed ({rc}): "
                           + " | ".join(l for _, l in reader.lines[-5:]))
    lines = [(t - t0, l) for t, l in reader.lines]
    lo, hi = _window(case.phase, lines, wall)
    # the last moments a little before the measured end: a run seldom takes exactly as long twice
    window = (lo, max(lo + 0.05, min(hi, wall - 0.3)))
    return Measured(wall, window, frozenset(snapshot(folder, case.outputs)), rc)


def _window(phase: str, lines: list[tuple[float, str]], wall: float) -> tuple[float, float]:
    def first(needle: str) -> float | None:
        return next((t for t, l in lines if needle in l), None)

    def last(needle: str) -> float | None:
        ts = [t for t, l in lines if needle in l]
        return ts[-1] if ts else None

    start = min(0.3, 0.05 * wall)  # the interpreter and the handlers start first
    if phase == "stage0":
        end = first("vs_inspect.pipeline.stage12") or first("vs_inspect.cues.pairing.") or 0.8 * wall
        return start, max(start + 0.1, end - 0.2)
    if phase == "stage1":
        begin = last("vs_inspect.cues.") or 0.8 * wall
        return max(start, begin - 0.2), wall
    if phase == "render3d":
        done = first("scene3d.png")
        if done is None:
            return start, wall
        took = _seconds_in(next(l for _, l in lines if "scene3d.png" in l))
        return max(start, done - took), done
    if phase == "png":
        done = first("scene3d.png")
        return (done if done is not None else start), wall
    return start, wall


def _seconds_in(line: str) -> float:
    """The '(1.23 s)' of a 'wrote ... (1.23 s)' log line."""
    try:
        return float(line.rsplit("(", 1)[1].split()[0])
    except (IndexError, ValueError):
        return 0.0


def interrupt_once(case: Case, root: Path, env: dict[str, str], sig: int, moment_s: float,
                   measured: Measured, grace_s: float) -> Outcome:
    folder = _fresh_folder(case, root)
    before = snapshot(folder, case.outputs)
    t0 = time.monotonic()
    proc, reader = _start(case, folder, env)
    name = signal.Signals(sig).name
    out = Outcome(case.name, name, moment_s, ok=False)
    while time.monotonic() - t0 < moment_s and proc.poll() is None:
        time.sleep(0.01)
    if proc.poll() is not None:
        reader.join(5)
        out.missed, out.ok = True, proc.returncode == measured.exit_code
        if not out.ok:
            out.problems.append(f"ended with {proc.returncode} before the signal")
        return out
    t_sig, t_sig_wall = time.monotonic(), time.time()
    proc.send_signal(sig)
    try:
        rc = proc.wait(timeout=grace_s + 60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        rc = proc.wait()
        out.problems.append(f"still running {grace_s + 60:.0f} s after the signal (killed)")
    out.stop_s = time.monotonic() - t_sig
    reader.join(5)
    after = [l for t, l in reader.lines if t >= t_sig]
    if rc == measured.exit_code and not after and _printed_before(folder / "stdout.txt", t_sig_wall) \
            and frozenset(snapshot(folder, case.outputs)) == measured.complete:
        # its last output was flushed (at exit: stdout to a file is written then) before the
        # signal was sent: the process was ending, past its last check for a signal
        out.missed, out.ok, out.stop_s = True, True, None
        return out
    text = "\n".join(l for _, l in reader.lines)
    if rc < 0:
        out.problems.append(f"crashed: killed by {signal.Signals(-rc).name}")
    elif rc != 128 + sig:
        out.problems.append(f"exit {rc}, expected {128 + sig}")
    if "Traceback" in text:
        out.problems.append("a traceback on stderr")
    want = f"vs-inspect {case.argv[0]}: interrupted by {name}"
    if len(after) != 1 or not after[0].startswith(want):
        out.problems.append(f"{len(after)} stderr lines after the signal, expected one '{want} ...': "
                            + " | ".join(after[:3])[:300])
    now = snapshot(folder, case.outputs)
    finished = any("after it had finished" in l for l in after)
    if now != before and not (finished and frozenset(now) == measured.complete):
        gone = sorted(set(before) - set(now))
        new = sorted(set(now) - set(before))
        changed = sorted(k for k in set(now) & set(before) if now[k] != before[k])
        out.problems.append("outputs changed: " + "; ".join(
            f"{what} {items[:4]}" for what, items in (("new", new), ("gone", gone), ("changed", changed))
            if items))
    out.ok = not out.problems
    return out


def moments(window: tuple[float, float], n: int, repeat: int) -> list[float]:
    """n moments spread over the window, shifted by a fixed fraction per repeat."""
    lo, hi = window
    shift = (0.5, 0.25, 0.75, 0.125, 0.625)[repeat % 5]
    return [lo + (hi - lo) * (i + shift) / n for i in range(n)]


def run_sweep(workdir: Path, n_moments: int = 10, repeats: int = 3, only: list[str] | None = None,
              signals_: tuple[int, ...] = SIGNALS, grace_s: float = 10.0,
              report: Callable[[str], None] = print) -> list[Outcome]:
    workdir = Path(workdir).resolve()
    p = prepare_inputs(workdir)
    env = _env(workdir)
    env["VS_INSPECT_STOP_GRACE_S"] = str(grace_s)
    all_cases = cases(p)
    chosen = [c for c in all_cases if not only or any(o.lower() in c.name.lower() for o in only)]
    if not chosen:
        raise ValueError(f"no case matches {only}; cases: {[c.name for c in all_cases]}")
    outcomes: list[Outcome] = []
    for case in chosen:
        m = measure(case, workdir / "runs", env)
        report(f"{case.name}: {m.wall_s:.1f} s uninterrupted; moments in {m.window_s[0]:.2f}-{m.window_s[1]:.2f} s")
        for r in range(repeats):
            for sig in signals_:
                for t in moments(m.window_s, n_moments, r):
                    o = interrupt_once(case, workdir / "runs", env, sig, t, m, grace_s)
                    outcomes.append(o)
                    if not o.ok:
                        report(f"  FAILED {o.signal} at {t:.2f} s: {'; '.join(o.problems)}")
    shutil.rmtree(workdir / "runs", ignore_errors=True)
    return outcomes


def table(outcomes: list[Outcome]) -> str:
    rows: dict[tuple[str, str], list[Outcome]] = {}
    for o in outcomes:
        rows.setdefault((o.case, o.signal), []).append(o)
    w = max([len("command")] + [len(c) for c, _ in rows])
    lines = [f"{'command':<{w}}  {'signal':<7} {'runs':>4} {'ok':>4} {'missed':>6} {'failures':>8} "
             f"{'stop_s median':>13} {'max':>6}"]
    for (c, s), os_ in rows.items():
        stops = sorted(o.stop_s for o in os_ if o.stop_s is not None)
        med = f"{stops[len(stops) // 2]:.2f}" if stops else "-"
        top = f"{stops[-1]:.2f}" if stops else "-"
        lines.append(f"{c:<{w}}  {s:<7} {len(os_):>4} {sum(o.ok for o in os_):>4} "
                     f"{sum(o.missed for o in os_):>6} {sum(not o.ok for o in os_):>8} {med:>13} {top:>6}")
    return "\n".join(lines)
