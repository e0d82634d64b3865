"""Finding and following people: the detector's windows and duplicate merging, tracks with a
consistent left/right labelling, the PoseLandmarker bundle made from the mediapipe wheel, and a
real clip pair of caliscope's webcams (one person seen by two cameras about 90 degrees apart)."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

from vs_inspect.cues.people_detect import DetectorConfig, frame_windows, merge_duplicates, people_unavailable
from vs_inspect.cues.people_tracking import TrackingConfig, link_people
from vs_inspect.cues.people_video import crop_around
from vs_inspect.geometry.skeleton import MIRROR

NO_MEDIAPIPE = people_unavailable()


SHAPE = np.random.default_rng(0).uniform(-0.5, 0.5, (33, 2)) * [0.4, 1.0]
SHAPE[[0, -1], 1] = -0.5, 0.5  # from head to toe: a unit of height
SHAPE[11], SHAPE[12] = (-0.15, -0.3), (0.15, -0.3)  # the shoulders apart


def _pose(cx: float, cy: float, size: float, vis: float = 0.9) -> np.ndarray:
    """(33,3) one person-shaped pose, size px high, centred at (cx, cy)."""
    return np.c_[SHAPE * size + [cx, cy], np.full(33, vis)]


def test_windows_cover_a_wide_frame_with_squares():
    w = frame_windows(910, 512)
    assert w[0] == (0, 0, 910, 512)
    squares = w[1:]
    assert all(x1 - x0 == y1 - y0 for x0, y0, x1, y1 in squares)
    assert {x1 - x0 for x0, _, x1, _ in squares} == {512, 256}  # the shorter side and its half
    assert min(x0 for x0, *_ in squares) == 0 and max(x1 for *_, x1, _ in squares) == 910
    # a square frame: no window the size of the frame again, only the halves
    assert {x1 - x0 for x0, _, x1, _ in frame_windows(512, 512)[1:]} == {256}
    assert frame_windows(512, 512, DetectorConfig(window_levels=0)) == [(0, 0, 512, 512)]


def test_merge_keeps_one_pose_per_person_and_drops_parts():
    windows = [(0, 0, 910, 512), (0, 0, 512, 512), (398, 0, 910, 512)]
    a = _pose(200, 250, 300)
    same_a = a.copy()
    same_a[:, :2] += 4.0  # the same person seen again in a window
    b = _pose(700, 250, 280)
    hand = _pose(205, 250, 60)  # a part of person a found alone
    out = merge_duplicates([a, same_a, b, hand], windows, [0, 1, 2, 1])
    assert len(out.landmarks) == 2
    centres = sorted(float(np.nanmean(p[:, 0])) for p in out.landmarks)
    assert centres[0] == pytest.approx(200, abs=10) and centres[1] == pytest.approx(700, abs=10)


def test_tracks_follow_each_person_and_keep_their_labelling():
    T = 20
    times = np.arange(T) / 10.0
    frames = []
    for k in range(T):
        a = _pose(200 + 5 * k, 250, 300)
        b = _pose(700 - 4 * k, 240, 280)
        if 8 <= k < 12:
            a = a[MIRROR]  # left and right swapped for a few frames
        poses = [b, a] if k % 2 else [a, b]  # any order
        if k == 5:
            poses = [b]  # a missed once
        frames.append(np.stack(poses))
    vp = link_people("v", times, frames, TrackingConfig())
    assert vp.num_people == 2
    np.testing.assert_array_equal(np.sort(vp.frames_seen()), [T - 1, T])
    first = int(np.argmin([np.nanmean(vp.landmarks[p, 0, :, 0]) for p in range(2)]))
    track = vp.landmarks[first]
    # the swapped frames were put back: the left shoulder stays on the same side all along
    assert (track[np.isfinite(track[:, 11, 0]), 11, 0] < track[np.isfinite(track[:, 12, 0]), 12, 0]).all()


def test_crop_around_a_pose_stays_in_the_frame():
    x0, y0, x1, y1 = crop_around(_pose(20, 30, 100), 640, 360, 1.6, 128)
    assert (x0, y0) == (0, 0) and x1 - x0 == y1 - y0 == 160
    x0, y0, x1, y1 = crop_around(_pose(300, 200, 400), 640, 360, 1.6, 128)
    assert x1 - x0 == 360 and y0 == 0 and y1 == 360


@pytest.mark.skipif(NO_MEDIAPIPE is not None, reason=str(NO_MEDIAPIPE))
def test_the_task_bundle_is_made_from_the_wheels_networks():
    from vs_inspect.cues.people_detect import PeopleDetector, pose_task_bundle

    with zipfile.ZipFile(io.BytesIO(pose_task_bundle())) as z:
        assert sorted(z.namelist()) == ["pose_detector.tflite", "pose_landmarks_detector.tflite"]
    with PeopleDetector() as d:
        assert len(d.detect(np.zeros((240, 320, 3), np.uint8)).landmarks) == 0  # nobody in a black frame


@pytest.mark.skipif(NO_MEDIAPIPE is not None, reason=str(NO_MEDIAPIPE))
def test_two_detector_threads_find_the_same_people_as_one(shared_data):
    """A frame's crops and windows shared between two detectors: the same tracks, landmark for
    landmark (each window is looked at alone), on a real crowd clip."""
    from vs_inspect.cues.people_video import PeopleVideoConfig, find_people
    from vs_inspect.io.video import iter_frames, open_video

    path = sorted((shared_data / "visualsync_clips" / "pan160906").glob("*.mp4"))[1]
    video = open_video(path)
    frames = [f for _, f in zip(range(8), iter_frames(video))]
    times = video.info.timestamps_s[:8]
    # two frames searched whole, the others cropped; tracks of 0.5 s kept
    cfg = PeopleVideoConfig(discover_s=0.5, tracking=TrackingConfig(min_track_s=0.5))
    one, _ = find_people("v", iter(frames), times, cfg, workers=1)
    two, stats = find_people("v", iter(frames), times, cfg, workers=2)
    assert one.num_people >= 1 and stats.crops >= 1
    np.testing.assert_array_equal(one.landmarks, two.landmarks)
