"""Stage 0's order of work (cues/extract.py): each video's own cues on threads."""

from __future__ import annotations

import pytest

from vs_inspect.cues.config import CueConfig


def test_videos_own_cues_run_two_at_a_time_on_threads_with_sift_keyframes_only():
    """Each video's own cues share no state with SIFT keyframes, so the local engine may run two
    on threads; learned keyframe descriptors set torch's process-wide thread count per call, so
    their videos run one after another."""
    from types import SimpleNamespace

    from vs_inspect.cues.config import MatchConfig
    from vs_inspect.cues.extract import extract_cues
    from vs_inspect.engine import LocalEngine

    class Stop(Exception):
        pass

    class Spy(LocalEngine):
        def map(self, fn, items, **options):
            asked.append(options.get("threads"))
            raise Stop

    asked: list = []
    sources = [SimpleNamespace(info=SimpleNamespace(name=n)) for n in "ab"]
    for descriptor in ("sift", "xfeat"):
        with pytest.raises(Stop):
            extract_cues(sources, cfg=CueConfig(match=MatchConfig(descriptor=descriptor)), engine=Spy(),
                         progress=False)
    assert asked == [True, False]
