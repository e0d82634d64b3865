"""Progress a person can follow on a terminal and read in a log.

On a terminal, tqdm's bars update in place. In a log (stderr not a terminal), PlainLines turns
their carriage-return updates into plain lines: a bar's first state, then at most one line every
interval_s, then its last state, its bar graphics dropped (`pair landscapes: 33% 1/3 [00:04<00:09]`).
stage() shows a step that has no count of its own (estimating the cameras) as a line with its
elapsed time, so that no step of more than a second runs in silence.
"""

from __future__ import annotations

import contextlib
import re
import sys
import threading
import time
from collections.abc import Iterator

PLAIN_INTERVAL_S = 10.0  # in a log, a running bar's state at most this often
_GRAPHICS = re.compile(r"\|[^|\n]*\|\s*")  # tqdm's bar between its two pipes


class PlainLines:
    """A text stream (stderr of a log) that writes tqdm's in-place updates as plain lines.

    Text without a carriage return passes through unchanged; a carriage-return update is a bar's
    state: written as a line when it is the bar's first, when interval_s have passed since the
    last, and when the bar ends (cleared, or closed with a newline)."""

    def __init__(self, raw, interval_s: float = PLAIN_INTERVAL_S, clock=time.monotonic):
        self.raw = raw
        self.interval_s = interval_s
        self.clock = clock
        self._bar: str | None = None  # the running bar's description
        self._state: str | None = None  # its latest state, not written yet
        self._last = -float("inf")  # when a state was last written
        self._lock = threading.Lock()

    def write(self, s: str) -> int:
        with self._lock:
            if "\r" not in s:
                if s:
                    self._end()
                    self.raw.write(s)
                return len(s)
            head, *updates = s.split("\r")
            if head:
                self._end()
                self.raw.write(head)
            for seg in updates:
                text, newline, rest = seg.partition("\n")
                if text.strip():
                    self._update(text.strip())
                else:
                    self._end()  # cleared: the bar is gone
                if newline:
                    self._end()
                    if rest:
                        self.raw.write(rest)
            return len(s)

    def _update(self, state: str) -> None:
        plain = " ".join(_GRAPHICS.sub(" ", state).split())
        bar = plain.split(":", 1)[0]
        now = self.clock()
        if bar != self._bar:
            self._end()
            self._bar, self._last = bar, -float("inf")
        if now - self._last >= self.interval_s:
            self.raw.write(plain + "\n")
            self._last, self._state = now, None
        else:
            self._state = plain

    def _end(self) -> None:
        """Write the running bar's last state (if not written yet) and forget the bar."""
        if self._state is not None:
            self.raw.write(self._state + "\n")
        self._bar, self._state = None, None

    def flush(self) -> None:
        with self._lock:
            self.raw.flush()

    def isatty(self) -> bool:
        return False

    def __getattr__(self, name):  # fileno, encoding, errors, buffer...
        return getattr(self.raw, name)


@contextlib.contextmanager
def plain_lines_when_logged(stream_name: str = "stderr") -> Iterator[None]:
    """sys.stderr as PlainLines while the block runs, when it is not a terminal."""
    raw = getattr(sys, stream_name)
    isatty = getattr(raw, "isatty", None)
    if isinstance(raw, PlainLines) or (isatty is not None and isatty()):
        yield
        return
    setattr(sys, stream_name, PlainLines(raw))
    try:
        yield
    finally:
        stream = getattr(sys, stream_name)
        if isinstance(stream, PlainLines):
            with contextlib.suppress(Exception):
                stream.write("")  # nothing pending stays unwritten
                stream._end()
            setattr(sys, stream_name, raw)


@contextlib.contextmanager
def stage(desc: str, enabled: bool = True, tick_s: float = 1.0) -> Iterator[None]:
    """A line saying `desc` is running, with its elapsed time updated every tick_s, for a step
    with no count of its own; removed when the step ends."""
    if not enabled:
        yield
        return
    from tqdm import tqdm
    bar = tqdm(total=None, desc=desc, bar_format="{desc}: {elapsed}", leave=False)
    stop = threading.Event()

    def tick() -> None:
        while not stop.wait(tick_s):
            bar.refresh()

    thread = threading.Thread(target=tick, name="vs-inspect stage line", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        bar.close()
