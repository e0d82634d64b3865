"""The guide's template filled from what a run logged: the opening by whether offsets were
searched, the search range, the cap on pair containers, the short names' legend and the notes."""

from __future__ import annotations

import numpy as np
import rerun as rr

from vs_inspect.analysis.record_options import RecordOptions
from vs_inspect.record.blueprint import MAX_PAIR_CONTAINERS
from vs_inspect.record.context import RecordingContext, VideoBuffer
from vs_inspect.record.guide import MAX_NOTES, guide_markdown
from vs_inspect.types import VideoInfo


def context(names: list[str]) -> RecordingContext:
    ctx = RecordingContext(rr.RecordingStream("vs_inspect_test_guide"), RecordOptions(), progress=False)
    for n in names:
        ctx.videos[n] = VideoBuffer(VideoInfo(n, 64, 48, 10, np.arange(10) / 10.0, fps=10.0), None)
    return ctx


def test_a_run_without_pairs_opens_on_frame_and_lists_its_videos():
    md = guide_markdown(context(["a", "b"]), ["a", "b"], [])
    assert md.startswith("# How to read this recording\n\n**No pair offset was searched in this run**")
    assert "Only the" not in md and "short names" not in md and "## Notes" not in md
    assert md.endswith("Videos in this recording: a, b.\n")
    assert "$" not in md


def test_a_run_with_pairs_gives_its_range_cap_legend_and_last_notes():
    names = [f"blenderbox_cam{k:02d}_13_282_{k}" for k in range(7)]
    ctx = context(names)
    ctx.offset_ms_min, ctx.offset_ms_max = -1500, 2500
    ctx.notes.extend(f"stage0: note {k}" for k in range(MAX_NOTES + 5))
    pairs = [f"{a}__{b}" for i, a in enumerate(names) for b in names[i + 1:]]
    md = guide_markdown(ctx, names, pairs)
    assert "over the whole search range (-1.500 s to +2.500 s). Δ_ab" in md
    assert f" Only the {MAX_PAIR_CONTAINERS} most informative of the {len(pairs)} pairs have a container" in md
    assert "draw the videos by short names: **cam00** = blenderbox_cam00_13_282_0; " in md
    notes = md.split("## Notes from the stages\n\n")[1].splitlines()
    assert notes[0] == "- stage0: note 5" and notes[-1] == f"- stage0: note {MAX_NOTES + 4}"
    assert len(notes) == MAX_NOTES and "$" not in md
