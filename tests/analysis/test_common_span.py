"""The common time span of synchronized videos, with exact frame indices."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.analysis.common_span import common_span
from vs_inspect.commands._common import sign_in_words
from vs_inspect.types import VideoInfo


def info(name, fps, n, ts=None):
    ts = np.arange(n) / fps if ts is None else np.asarray(ts, float)
    return VideoInfo(name=name, width=64, height=48, num_frames=len(ts), timestamps_s=ts,
                     fps=None if fps is None else fps)


def test_span_frames_at_each_rate():
    # a: 10 fps from 0 s (0.0 .. 1.9); b: 25 fps, starts 0.335 s later; c: variable rate, earlier
    a = info("a", 10.0, 20)
    b = info("b", 25.0, 40)
    c = info("c", None, 5, ts=[0.0, 0.3, 0.55, 0.9, 1.6])
    span = common_span([a, b, c, info("d", 30.0, 9)], {"a": 0.0, "b": 0.335, "c": -0.12, "d": None}, "a")
    # c on the global clock: -0.12, 0.18, 0.43, 0.78, 1.48. Latest start 0.335 (b), earliest end
    # 1.48 (c). The slowest video is c (median spacing 0.325 s): its frames inside the span are
    # 0.43 (k=2) .. 1.48 (k=4)
    assert span.anchor == "c"
    assert span.start_s == pytest.approx(0.43) and span.end_s == pytest.approx(1.48)
    sa, sb, sc = span.videos["a"], span.videos["b"], span.videos["c"]
    assert (sc.first_frame, sc.last_frame) == (2, 4)
    assert (sa.first_frame, sa.last_frame) == (4, 15)  # 0.4 nearest 0.43, 1.5 nearest 1.48
    assert (sb.first_frame, sb.last_frame) == (2, 29)  # 0.335 + 2/25 = 0.415, + 29/25 = 1.495
    assert sb.offset_frames == pytest.approx(0.335 * 25)
    for s in (sa, sb, sc):  # every video starts within half of its own frame of the anchor's
        assert abs(s.first_time_s - span.start_s) <= 0.5 * s.frame_interval_s + 1e-12
    assert span.skipped == {"d": "no offset (not synchronized)"}


def test_no_overlap_and_no_offsets_refused():
    a, b = info("a", 10.0, 10), info("b", 10.0, 10)
    with pytest.raises(ValueError, match="do not overlap"):
        common_span([a, b], {"a": 0.0, "b": 5.0}, "a")
    with pytest.raises(ValueError, match="no video has an offset"):
        common_span([a, b], {"a": None, "b": None}, "a")


def test_sign_in_words():
    words = sign_in_words({"cam0": 0.0, "cam1": -0.1, "cam2": 0.24, "cam3": None}, "cam0")
    assert words.startswith("cam1 starts 0.100 s before cam0; cam2 starts 0.240 s after cam0 (")
    assert "cam3" not in words
    assert sign_in_words({"cam0": 0.0}, "cam0") == ""
