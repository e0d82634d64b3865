"""The Stage 0 controller (pipeline/stage0.py): its order of work and what it reports."""

from __future__ import annotations

import pytest

from vs_inspect.cues.config import CueConfig


def test_videos_own_cues_run_two_at_a_time_on_threads():
    """Each video's own cues share no state (SIFT keyframes), so the local engine may run two on
    threads."""
    from types import SimpleNamespace

    from vs_inspect.engine import LocalEngine
    from vs_inspect.geometry.offsets import OffsetGrid
    from vs_inspect.pipeline.stage0 import _stage0
    from vs_inspect.record.sink import NullSink

    class Stop(Exception):
        pass

    class Spy(LocalEngine):
        def map(self, fn, items, **options):
            asked.append(options.get("threads"))
            raise Stop

    asked: list = []
    sources = [SimpleNamespace(info=SimpleNamespace(name=n), path=f"{n}.mp4") for n in "ab"]
    with pytest.raises(Stop):
        _stage0(sources, None, CueConfig(), NullSink(), False, Spy(), OffsetGrid(), {}, {})
    assert asked == [True]


def test_cues_report_nothing_themselves():
    """cues/ holds no sink and imports neither record/ nor analysis/: its steps return records,
    and the controller reports them."""
    import ast
    from pathlib import Path

    import vs_inspect.cues

    for path in Path(vs_inspect.cues.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):  # from ..record... or from vs_inspect.record...
                package = (node.module or "").split(".")[0 if node.level == 2 else 1] \
                    if node.level == 2 or (node.module or "").startswith("vs_inspect.") else ""
                assert package not in ("record", "analysis"), (path.name, node.module)
            assert not (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                        and node.value.id == "sink"), (path.name, node.lineno)


def test_people_only_on_worn_cameras_gives_nulls_with_the_reason(shared_data, tmp_path):
    """Stage 0 with the people as its only camera source, on three real head-worn cameras (the
    first 30 frames of each): the people cue runs through the controller and refuses every
    camera as moving, and the run stops with each video's reason and the cue's record."""
    from vs_inspect.errors import NoUsableVideos
    from vs_inspect.io.video import VideoWriter, iter_frames, open_video
    from vs_inspect.pipeline.stage0 import run_stage0

    clips = sorted((shared_data / "visualsync_clips" / "fencing1").glob("*.mp4"))
    if len(clips) < 2:
        pytest.skip(f"no fencing1 clips in {shared_data}")
    paths = []
    for clip in clips:
        src = open_video(clip)
        paths.append(tmp_path / clip.name)
        with VideoWriter(paths[-1], src.info.width, src.info.height, src.info.fps, crf=18) as w:
            for k, img in iter_frames(src):
                if k < 30:
                    w.write(img)
    with pytest.raises(NoUsableVideos) as err:
        run_stage0(paths, cfg=CueConfig(people="only"), progress=False)
    stats = err.value.stats
    assert stats.people is not None and stats.people.kept
    assert set(stats.people.refused) == {p.stem for p in paths}
    for p in paths:
        assert "moving camera" in stats.dropped[p.stem], stats.dropped[p.stem]
