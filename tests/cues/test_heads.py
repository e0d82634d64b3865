"""Stage 0's heads of each video (cues/heads.py): a video whose heads cannot be found is named and
the others kept; the heads found ahead on a thread of their own are the heads found after, and
leaving stops that thread and closes every tracker."""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest

from vs_inspect.cues import people


def test_a_video_whose_heads_cannot_be_found_is_named_and_the_others_kept(monkeypatch):
    """A failure of the second decoding pass (or the detector) on one video costs that video its
    heads only; the run goes on and result.json names it. At most about 10 frames a second are
    looked at."""
    from types import SimpleNamespace

    import vs_inspect.io.video as video_mod
    from vs_inspect.cues.heads import find_heads

    T = 4

    def landmarks(frames, pose=None):
        frames = list(frames)
        if frames[0] is None:
            raise RuntimeError("the decoder gave up")
        lm = np.full((len(frames), 33, 3), np.nan)
        lm[:, 0] = [10.0, 20.0, 0.9]  # the nose only
        return lm
    monkeypatch.setattr(people, "heads_unavailable", lambda: None)
    monkeypatch.setattr(people, "detect_landmarks", landmarks)
    monkeypatch.setattr(video_mod, "iter_frames", lambda src, step=1, max_side=None: (
        (k, src.frame) for k in range(0, src.info.num_frames, step)))
    frame = np.zeros((4, 4, 3), np.uint8)
    infos = {"a": SimpleNamespace(name="a", num_frames=T, frame_interval_s=0.1),
             "b": SimpleNamespace(name="b", num_frames=T, frame_interval_s=0.1),
             "c": SimpleNamespace(name="c", num_frames=7, frame_interval_s=1 / 30)}
    sources = [SimpleNamespace(info=infos[n], frame=None if n == "b" else frame) for n in "abc"]
    vids = {n: SimpleNamespace(info=infos[n], scale_xy=(2.0, 2.0)) for n in "abc"}
    heads, record = find_heads(sources, vids, dict.fromkeys("abc"), {}, SimpleNamespace(max_side=640),
                               False)
    assert list(heads) == ["a", "c"]
    np.testing.assert_allclose(heads["a"], np.tile([20.5, 40.5], (T, 1)))  # working px x2, centres kept
    # at 30 fps every third frame is looked at (at most about 10 a second), NaN between
    assert np.flatnonzero(np.isfinite(heads["c"][:, 0])).tolist() == [0, 3, 6]
    assert record.frames_with_a_head == {"a": T, "c": 3}
    assert record.failed == {"b": "RuntimeError: the decoder gave up"}


class _FakePose:
    """A started tracker: a person whose nose is at the frame's first pixel value (x) and 20 px."""

    def __init__(self, log: list):
        self.log, self.closed = log, False

    def process(self, rgb):
        self.log.append(threading.current_thread().name)
        lm = [SimpleNamespace(x=float(rgb[0, 0, 0]) / rgb.shape[1], y=20.0 / rgb.shape[0],
                              visibility=0.9 if k == 0 else 0.1) for k in range(33)]
        return SimpleNamespace(pose_landmarks=SimpleNamespace(landmark=lm))

    def close(self):
        self.closed = True


def _fake_videos(monkeypatch, frames_of, poses: list, seen: list):
    """Three videos whose frames frames_of(name, k) gives, decoded by a stand-in for iter_frames,
    and trackers that record where they ran."""
    import vs_inspect.io.video as video_mod

    monkeypatch.setattr(people, "heads_unavailable", lambda: None)
    monkeypatch.setattr(people, "start_pose", lambda: poses.append(_FakePose(seen)) or poses[-1])
    monkeypatch.setattr(video_mod, "iter_frames", lambda src, step=1, max_side=None: (
        (k, frames_of(src.info.name, k)) for k in range(0, src.info.num_frames, step)))
    infos = {n: SimpleNamespace(name=n, num_frames=6, frame_interval_s=0.1) for n in "abc"}
    sources = [SimpleNamespace(info=infos[n]) for n in "abc"]
    vids = {n: SimpleNamespace(info=infos[n], scale_xy=(1.0, 1.0)) for n in "abc"}
    return sources, vids, SimpleNamespace(max_side=640)


def test_heads_found_ahead_on_their_own_thread_are_the_heads_found_after(monkeypatch):
    from vs_inspect.cues.heads import HeadsAhead, find_heads

    def frame(name, k):
        if name == "b":
            time.sleep(0.05)  # b's frames are slow: its time on the heads thread shows it
        return np.full((8, 10, 3), 1 + k + 10 * "abc".index(name), np.uint8)
    poses, seen = [], []
    sources, vids, cfg = _fake_videos(monkeypatch, frame, poses, seen)
    after, _ = find_heads(sources, vids, dict.fromkeys("abc"), {}, cfg, False)
    assert set(seen) == {"MainThread"} and len(seen) == 18 and all(p.closed for p in poses)
    poses.clear(), seen.clear()
    monkeypatch.setattr(HeadsAhead, "max_videos", 2)  # each tracker holds memory till its video is done
    with HeadsAhead(sources, vids, cfg) as ahead:
        assert len(poses) == 2  # the trackers start on the calling thread
        found, record = find_heads(sources, vids, dict.fromkeys("abc"), {}, cfg, False, ahead)
    assert len(seen) == 18 and all(name.startswith("heads") for name in seen[:12]), set(seen)
    assert set(seen[12:]) == {"MainThread"}  # c's heads: found by find_heads itself
    assert all(p.closed for p in poses)
    assert found.keys() == after.keys() == set("abc")
    for n in "abc":
        np.testing.assert_array_equal(found[n], after[n])
    np.testing.assert_allclose(found["b"][:, 0], 11 + np.arange(6))  # the nose at the frame's value
    assert record.frames_with_a_head == {"a": 6, "b": 6, "c": 6}
    spent = record.found_ahead_s  # the heads thread's own time, per video found ahead
    assert spent.keys() == {"a", "b"} and spent["b"] >= 0.3 > spent["a"] >= 0.0, spent


def test_leaving_stops_the_heads_thread_and_closes_every_tracker(monkeypatch):
    """Heads that turn out not to be needed (no camera moves in the end, or an error) cost at most
    the frame being looked at: the thread stops there, and the trackers of videos it never
    reached are closed unused."""
    from vs_inspect.cues.heads import HeadsAhead

    first, release = threading.Event(), threading.Event()

    def frame(name, k):
        if name == "a" and k == 1:
            first.set()
            release.wait(10)  # the thread is inside video a when the caller leaves
        return np.zeros((8, 10, 3), np.uint8)
    poses, seen = [], []
    sources, vids, cfg = _fake_videos(monkeypatch, frame, poses, seen)
    ahead = HeadsAhead(sources, vids, cfg)
    with ahead:
        assert first.wait(10)
        threading.Timer(0.3, release.set).start()  # after leaving has told the thread to stop
    assert len(seen) == 1 and seen[0].startswith("heads")  # a's frame 0 only: stopped before frame 1
    assert len(poses) == 3 and all(p.closed for p in poses)
    with pytest.raises(InterruptedError):
        ahead.landmarks("a")
