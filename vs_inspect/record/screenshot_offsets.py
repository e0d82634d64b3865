"""The offsets a recording is shown at in screenshots: the front pair's chosen Δ and a wrong one
that teaches (its epipolar lines on screen, missing the points)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def default_offsets_ms(rrd: Path, pair: tuple[str, str] | None = None) -> dict[str, int | None]:
    """The offsets take_screenshots shows by default: {"chosen": ms, "wrong": ms}
    (chosen_and_wrong_ms), or {"opened": None} when no pair has a landscape (a run that
    synchronized nothing, the one most worth a look): there is no chosen Δ, often no offset_ms
    timeline at all, and the viewer is shot as it opens."""
    from ..io.recording import read_recording
    rec = read_recording(rrd)
    if not rec.landscapes:
        return {"opened": None}
    chosen, wrong = chosen_and_wrong_ms(rec, pair)
    return {"chosen": chosen, "wrong": wrong}


def chosen_and_wrong_ms(rec, pair: tuple[str, str] | None = None) -> tuple[int, int]:
    """(chosen, wrong) of a recording with landscapes (io.recording.Recording): the chosen (or
    best) Δ in ms of the pair (default: the front pair, the layout's active tab), and a wrong Δ
    that teaches: its epipolar lines are on screen and miss the points (wrong_ms), else an offset
    a third of the search range away."""
    from .viewer import front_offset_ms, front_pair
    pair = pair or front_pair(rec)
    all_ms = np.concatenate([s.offset_ms for p in rec.landscapes.values() for s in p.values()])
    lo, hi = int(all_ms.min()), int(all_ms.max())
    chosen = front_offset_ms(rec, pair) if pair else None
    if chosen is None:
        chosen = (lo + hi) // 2
    wrong = None
    if pair is not None:
        from ..io.recorded_series import read_epipolar_sweep
        sweep = read_epipolar_sweep(rec.path, *pair)
        wrong = wrong_ms(sweep, chosen) if sweep is not None else None
    if wrong is None:
        step = max(1, (hi - lo) // 3)
        wrong = chosen + step if chosen + step <= hi else chosen - step
    return chosen, wrong


def wrong_ms(sweep, chosen_ms: int) -> int | None:
    """A wrong Δ of an epipolar sweep (io.recorded_series.EpipolarSweepSeries) worth a screenshot: the
    offset nearest the chosen one whose lines are on screen (at least half as many as at the
    chosen Δ, and 3) but miss the points (median distance at least 4 times the smallest one near
    the chosen Δ, and 5 px more); None when no logged offset is such."""
    ms, lines, med = sweep.offset_ms, sweep.lines, sweep.median_px
    if not len(ms):
        return None
    i = int(np.argmin(np.abs(ms - chosen_ms)))
    # the best the lines meet the points near the chosen Δ (the sweep's offsets are the search
    # grid's: the nearest may be half a frame off the refined Δ)
    near = med[max(0, i - 2):i + 3]
    at = np.nanmin(near) if np.isfinite(near).any() else np.nan
    if not np.isfinite(at):
        return None
    ok = (lines >= max(3, 0.5 * lines[i])) & np.isfinite(med) & (med >= max(4 * at, at + 5.0))
    ok &= np.abs(np.arange(len(ms)) - i) >= 2
    if not ok.any():
        return None
    cand = np.flatnonzero(ok)
    return int(ms[cand[np.argmin(np.abs(ms[cand] - chosen_ms))]])
