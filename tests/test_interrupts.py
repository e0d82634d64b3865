"""Ctrl-C and SIGTERM at arbitrary moments of the long commands, locks on outputs, leftovers of
killed writers, and arrays whose dtype is not a number type.

The interrupt runs are a small subset of `vs-inspect bench interrupts` (vs_inspect.bench.interrupts):
real commands in subprocesses on small synthetic inputs, a real signal at a fixed moment, and the
same checks (exit 130/143, one line, no traceback, no crash, the outputs exactly as before).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from vs_inspect.bench import interrupts as bench
from vs_inspect.errors import BundleError, OutputBusy
from vs_inspect.io.atomic import atomic_dir, write_json_atomic
from vs_inspect.io.lock import lock_path, output_lock

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The bench's small inputs (without the demo's scene, which takes minutes to render)."""
    return bench.prepare_inputs(tmp_path_factory.mktemp("interrupts"), demo=False)


@pytest.fixture(scope="module")
def env(inputs):
    e = bench._env(inputs["bundle"].parents[1])
    e["VS_INSPECT_STOP_GRACE_S"] = "10"
    return e


def _case(inputs, name: str) -> bench.Case:
    return next(c for c in bench.cases(inputs) if c.name == name)


# (case, moments in seconds after the start): early enough that the command is still working on
# a loaded machine, spread over its phases
SUBSET = [("sync bundle", (1.0, 3.0)), ("sync videos (Stage 0)", (2.0,)), ("report (PNG files)", (1.6, 2.6)),
          ("export --mosaic", (1.2,))]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("name,moments", SUBSET, ids=[n for n, _ in SUBSET])
def test_interrupted_command_ends_cleanly(inputs, env, tmp_path, name, moments, sig):
    case = _case(inputs, name)
    nothing_complete = bench.Measured(0.0, (0.0, 0.0), frozenset(), 0)
    for t in moments:
        o = bench.interrupt_once(case, tmp_path, env, sig, t, nothing_complete, 10.0)
        assert o.ok, f"{name}, {o.signal} at {t} s: {o.problems}"


def test_demo_interrupted_while_rendering_leaves_nothing(inputs, env, tmp_path):
    """The demo's first step renders its scene (minutes): a signal then removes the fresh OUT."""
    case = _case(inputs, "demo")
    case = bench.Case(case.name, case.argv, case.outputs)  # no cached scene: it renders
    o = bench.interrupt_once(case, tmp_path, env, signal.SIGTERM, 2.5,
                             bench.Measured(0.0, (0.0, 0.0), frozenset(), 0), 10.0)
    assert o.ok and not o.missed, o.problems


def test_a_stuck_command_is_ended_by_the_watchdog(tmp_path, env):
    """A command inside a call that never reaches a safe point still ends with the one line and
    exit 143, within the grace period, and its temporaries are removed."""
    script = textwrap.dedent("""
        import sys, time
        from vs_inspect import _entry, signals
        import vs_inspect.commands.synth_cues as s
        from vs_inspect.io.atomic import atomic_path
        def stuck(args):
            with atomic_path("out.json") as tmp:
                tmp.write_text("{}")
                print("READY", flush=True)
                time.sleep(120)  # no checkpoint here
            return 0
        s.run = stuck  # what register() binds
        _entry.main(["synth-cues", "--out", "b"])
    """)
    e = {**env, "VS_INSPECT_STOP_GRACE_S": "1"}
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=tmp_path, env=e, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert "READY" in proc.stdout.readline()
    t = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    assert time.monotonic() - t < 10
    assert err.strip().splitlines() == ["vs-inspect synth-cues: interrupted by SIGTERM; nothing written to b"]
    assert sorted(os.listdir(tmp_path)) == []


# ---- two runs into one place ---------------------------------------------------------------------


def test_a_second_run_into_the_same_out_refuses_naming_the_first(inputs, env, tmp_path):
    first = subprocess.Popen([sys.executable, "-m", "vs_inspect", "sync", "--bundle", str(inputs["bundle"]),
                              "--out", "out", "--rrd", "recs/a.rrd", "--no-progress"], cwd=tmp_path, env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        locks = (tmp_path / ".out.lock", tmp_path / "recs" / ".a.rrd.lock")
        while not all(p.exists() for p in locks) and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.2)  # its pid and start time are written
        first.send_signal(signal.SIGSTOP)  # paused, still holding both locks, however fast it is
        assert all(p.exists() for p in locks) and first.poll() is None
        for argv, option in ((["--out", "out", "--rrd", "recs/b.rrd"], "--out out"),
                             (["--out", "other", "--rrd", "recs/a.rrd"], "--rrd recs/a.rrd")):
            second = subprocess.run([sys.executable, "-m", "vs_inspect", "sync", "--bundle", str(inputs["bundle"]),
                                     *argv, "--no-progress"], cwd=tmp_path, env=env, capture_output=True,
                                    text=True, timeout=120)
            lines = second.stderr.strip().splitlines()
            assert second.returncode == 2, second.stderr
            assert len(lines) == 1 and lines[0].startswith(f"vs-inspect sync: error: {option} ")
            assert f"is being written by another run (pid {first.pid}, started " in lines[0]
            assert "Traceback" not in second.stderr
        assert not (tmp_path / "other").exists() and not (tmp_path / "recs" / "b.rrd").exists()
    finally:
        first.send_signal(signal.SIGTERM)
        first.send_signal(signal.SIGCONT)
        first.wait(timeout=60)
    assert first.returncode == 143
    assert sorted(os.listdir(tmp_path)) == []  # no out, no recording, no lock


def test_a_lock_of_a_dead_process_is_taken_over(tmp_path):
    target = tmp_path / "out"
    script = textwrap.dedent(f"""
        import os, signal
        from vs_inspect.io.lock import output_lock
        with output_lock({str(target)!r}):
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    r = subprocess.run([sys.executable, "-c", script], env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.returncode == -signal.SIGKILL
    assert lock_path(target).exists()  # what the killed run left: recognizable by its name
    with output_lock(target):
        with pytest.raises(OutputBusy, match=rf"pid {os.getpid()}, started "):
            _lock_from_another_process(target)
    assert not lock_path(target).exists()


def _lock_from_another_process(target: Path) -> None:
    """flock is per open file: a second output_lock in this process refuses like another process."""
    from vs_inspect.io import lock
    held = set(lock._HELD)
    lock._HELD.clear()
    try:
        with output_lock(target):
            pass
    finally:
        lock._HELD.update(held)


# ---- what killed writers leave -----------------------------------------------------------------


def _killed_writer(tmp_path: Path, code: str) -> None:
    script = textwrap.dedent("""
        import os, signal
        from vs_inspect.io.atomic import atomic_dir, atomic_path
    """) + textwrap.dedent(code)
    r = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.returncode == -signal.SIGKILL


def test_leftovers_of_a_killed_writer_are_removed_by_the_next(tmp_path):
    _killed_writer(tmp_path, """
        with atomic_path("result.json") as tmp:
            tmp.write_text("half")
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    _killed_writer(tmp_path, """
        with atomic_dir("rep") as tmp:
            (tmp / "a.png").write_bytes(b"half")
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    left = sorted(os.listdir(tmp_path))
    assert len(left) == 2 and left[0].startswith(".rep.partial-") and left[1].startswith(".result.json.partial-")
    write_json_atomic({"ok": True}, tmp_path / "result.json")
    with atomic_dir(tmp_path / "rep") as tmp:
        (tmp / "index.html").write_text("x")
    assert sorted(os.listdir(tmp_path)) == ["rep", "result.json"]
    assert os.listdir(tmp_path / "rep") == ["index.html"]


def test_leftovers_of_a_live_writer_are_kept(tmp_path):
    """Another live run's temporary is not someone's leftover: it stays."""
    live = tmp_path / f".result.json.partial-{os.getppid()}-0123abcd"
    live.write_text("being written")
    write_json_atomic({"ok": True}, tmp_path / "result.json")
    assert live.exists()


# ---- arrays that are not numbers -----------------------------------------------------------------


@pytest.fixture(scope="module")
def small_bundle(inputs):
    return inputs["bundle"]


@pytest.mark.parametrize("bad,kind", [(np.zeros((5, 2, 2), bool), "bool"), (np.full((5, 2, 2), "x"), "string")])
def test_tracks_that_are_not_coordinates_are_refused(small_bundle, tmp_path, bad, kind):
    import json
    import shutil

    from vs_inspect.io.bundle import read_bundle
    b = tmp_path / "b"
    shutil.copytree(small_bundle, b)
    name = json.loads((b / "bundle.json").read_text())["videos"][0]["name"]
    T = json.loads((b / "bundle.json").read_text())["videos"][0]["num_frames"]
    xy = np.resize(bad, (5, T, 2))
    np.savez(b / "tracks" / f"{name}.npz", xy=xy)
    with pytest.raises(BundleError) as e:
        read_bundle(b)
    assert str(e.value) == f"{b / 'tracks' / (name + '.npz')}: xy has dtype {kind}; need float pixel coordinates"


def test_an_object_array_is_refused_without_unpickling(small_bundle, tmp_path):
    import json
    import shutil

    from vs_inspect.io.bundle import read_bundle
    b = tmp_path / "b"
    shutil.copytree(small_bundle, b)
    name = json.loads((b / "bundle.json").read_text())["videos"][0]["name"]
    cam = dict(np.load(b / "cameras" / f"{name}.npz"))
    K = np.empty((3, 3), object)
    K[:] = 1.0
    np.savez(b / "cameras" / f"{name}.npz", **{**cam, "K": K})
    with pytest.raises(BundleError, match=r"cameras/.*\.npz: K has dtype object; need numbers"):
        read_bundle(b)


def test_bool_flags_stay_allowed(small_bundle):
    from vs_inspect.io.bundle import check_numeric_dtype
    check_numeric_dtype("cameras/cam0.npz", "valid", np.dtype(bool))
    with pytest.raises(BundleError, match="index has dtype bool; need integer track indices"):
        check_numeric_dtype("pairs/a__b.npz", "index", np.dtype(bool))
