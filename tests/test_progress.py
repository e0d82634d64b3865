"""Progress in a log: tqdm's carriage-return updates become plain lines (first state, at most one
per interval, last state), other output passes through; a step without a count shows a line."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

from vs_inspect.progress import PlainLines, plain_lines_when_logged, stage


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_carriage_return_updates_become_periodic_plain_lines():
    from tqdm import tqdm
    raw, clock = io.StringIO(), Clock()
    out = PlainLines(raw, interval_s=10.0, clock=clock)
    out.write("a log line\n")
    bar = tqdm(total=30, desc="pair landscapes", file=out, mininterval=0, leave=False)
    for k in range(30):
        clock.t = k  # one second per item
        bar.update(1)
    bar.close()
    out.write("next line\n")
    text = raw.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert lines[0] == "a log line" and lines[-1] == "next line"
    states = [ln for ln in lines if ln.startswith("pair landscapes")]
    # the first state, one every 10 s, the last one; no bar graphics
    assert 3 <= len(states) <= 5, states
    assert states[0].startswith("pair landscapes: 0%") and "30/30" in states[-1]
    assert not any("█" in s or "|" in s for s in states)


def test_a_terminal_keeps_its_bars_and_a_log_gets_lines(monkeypatch):
    class Tty(io.StringIO):
        def isatty(self):
            return True
    tty = Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    with plain_lines_when_logged():
        assert sys.stderr is tty
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    with plain_lines_when_logged():
        assert isinstance(sys.stderr, PlainLines)
        with stage("cameras: estimating them", tick_s=0.05):
            import time
            time.sleep(0.2)
    assert sys.stderr is log
    assert "\r" not in log.getvalue()
    assert log.getvalue().startswith("cameras: estimating them: 00:00")


def test_a_command_piped_to_a_log_writes_no_carriage_return(tmp_path):
    """The console entry point (python -m vs_inspect) with stderr to a file: its bars as lines."""
    from vs_inspect.io.bundle import write_bundle
    from vs_inspect.synth.cues import CueSceneConfig, make_cue_scene
    bundle = write_bundle(make_cue_scene(CueSceneConfig(cameras=3, moving=0, seconds=3.0, pairs_per_view_pair=60,
                                                        max_offset_s=0.8, seed=2)).bundle, tmp_path / "b")
    with open(tmp_path / "log.txt", "w") as err:
        r = subprocess.run([sys.executable, "-m", "vs_inspect", "sync", "--bundle", str(bundle), "--out",
                            str(tmp_path / "out"), "--no-rrd"], stderr=err, stdout=subprocess.PIPE, text=True,
                           timeout=300, cwd=Path(__file__).resolve().parents[1])
    log = (tmp_path / "log.txt").read_text()
    assert r.returncode == 0, log
    assert "\r" not in log
    assert "pair landscapes: 0% 0/3" in log, log  # the bar's first state as a line
