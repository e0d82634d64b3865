"""Where a person's head is in each frame of each video, for the worn-camera sightings
(geometry/sightings.py): each video decoded again and handed to the detector (cues/people.py),
ahead on a thread of its own while the cameras are estimated (HeadsAhead), the rest after."""

from __future__ import annotations

import logging
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from tqdm import tqdm

from ..cue_stats import HeadsRecord
from ..errors import InputError
from ..types import VideoInfo
from .config import CueConfig
from .video.extract import VideoCues, frame_step, to_full_px

log = logging.getLogger(__name__)

HEADS_MAX_HZ = 10.0  # heads looked for in at most about this many frames a second (every 3rd at 30 fps)


def _video_landmarks(src, info: VideoInfo, cfg: CueConfig, pose=None, stop: threading.Event | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(frames looked at (K,), their (K,33,3) BlazePose landmarks) of one video decoded again at
    working resolution, at most about HEADS_MAX_HZ frames a second. pose: a started tracker
    (people.start_pose) or None; stop: set to end early (InterruptedError)."""
    from ..io.video import iter_frames
    from .people import detect_landmarks

    step = frame_step(info, HEADS_MAX_HZ)

    def frames():
        for _, img in iter_frames(src, step=step, max_side=cfg.max_side):
            if stop is not None and stop.is_set():
                raise InterruptedError("heads no longer needed")
            yield img
    return np.arange(0, info.num_frames, step), detect_landmarks(frames(), pose)


class HeadsAhead:
    """The landmarks (_video_landmarks) of the first max_videos readable videos, found one video
    after another on a thread of their own while the cameras are estimated and the geometric
    pairs voted. The trackers are started here, on the calling thread (their start-up silences
    stderr), each holding some 80 MB until its video is done: hence the cap; _heads finds the
    other videos' heads itself. Leaving the with block stops the thread at its next frame and
    waits for it."""

    max_videos = 4

    def __init__(self, sources, vids: dict[str, VideoCues], cfg: CueConfig):
        from .people import start_pose

        self._stop = threading.Event()
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="heads")
        self._poses, self._jobs, self._seconds = {}, {}, {}
        try:
            for src in sources:
                n = src.info.name
                if n in vids and len(self._jobs) < self.max_videos:
                    self._poses[n] = start_pose()
                    self._jobs[n] = self._pool.submit(self._timed, n, src, vids[n].info, cfg)
        except BaseException:
            self.__exit__()
            raise

    def _timed(self, name: str, src, info: VideoInfo, cfg: CueConfig) -> tuple[np.ndarray, np.ndarray]:
        t0 = time.perf_counter()
        try:
            return _video_landmarks(src, info, cfg, self._poses[name], self._stop)
        finally:
            self._seconds[name] = time.perf_counter() - t0

    def seconds(self) -> dict[str, float]:
        """{video: seconds its heads took on the heads thread} of the videos done (or stopped) so
        far: that time overlaps the cameras and geometric pairs, so no stage's time shows it."""
        return dict(self._seconds)

    @classmethod
    def start(cls, sources, vids: dict[str, VideoCues], cfg: CueConfig) -> HeadsAhead | None:
        """None where it would not help or cannot run: one core, or no detector installed."""
        from .people import heads_unavailable

        if (os.cpu_count() or 1) < 2 or heads_unavailable():
            return None
        try:
            return cls(sources, vids, cfg)
        except (RuntimeError, OSError, ValueError) as exc:  # _heads then says, per video, what fails
            log.warning("heads not found ahead: a tracker did not start (%s: %s)", type(exc).__name__, exc)
            return None

    def landmarks(self, name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """_video_landmarks of that video (waits for them; raises what they raised), None when it
        was not among the videos looked at here."""
        return self._jobs[name].result() if name in self._jobs else None

    def __enter__(self) -> HeadsAhead:
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        for n, job in self._jobs.items():
            if job.cancel():  # never started: its tracker is closed here
                self._poses[n].close()
        self._pool.shutdown(wait=True)


def find_heads(sources, vids: dict[str, VideoCues], cameras: dict, undistort: dict, cfg: CueConfig,
               progress: bool, ahead: HeadsAhead | None = None
               ) -> tuple[dict[str, np.ndarray], HeadsRecord]:
    """({video: (T,2) undistorted full-resolution px of the head the person detector found in a
    frame (NaN: none, or a frame beyond HEADS_MAX_HZ not looked at)}, the record of the run)
    for every video with a camera, decoded again at working resolution (or taken from ahead); {}
    with the reason in the record when the detector is not installed."""
    from .people import head_points, heads_unavailable

    why = heads_unavailable()
    if why:
        log.info("worn-camera sightings skipped: %s", why)
        return {}, HeadsRecord(skipped=why)
    out, found, failed = {}, {}, {}
    for src in tqdm([s for s in sources if s.info.name in cameras], desc="heads", unit="video",
                    disable=not progress, leave=False):
        n = src.info.name
        info = vids[n].info
        try:
            done = ahead.landmarks(n) if ahead is not None else None
            todo, landmarks = done if done is not None else _video_landmarks(src, info, cfg)
        except (InputError, OSError, ValueError, RuntimeError) as exc:  # this decoding pass failed
            failed[n] = f"{type(exc).__name__}: {exc}"
            continue
        if len(landmarks) != len(todo):
            failed[n] = f"decoded {len(landmarks)} frames again, not {len(todo)}"
            continue
        heads = np.full((info.num_frames, 2), np.nan)
        heads[todo] = head_points(landmarks)
        raw = to_full_px(heads, vids[n].scale_xy)
        out[n] = undistort[n](raw) if n in undistort else raw
        found[n] = int(np.isfinite(out[n][:, 0]).sum())
    for n, why in failed.items():
        log.warning("%s: no heads: %s", n, why)
    spent = ahead.seconds() if ahead is not None else {}
    log.info("heads found: %s", ", ".join(f"{n} {k}" for n, k in found.items()))
    return out, HeadsRecord(detector="mediapipe BlazePose (pose_landmark_full)", frames_with_a_head=found,
                            found_ahead_s={n: round(t, 3) for n, t in spent.items()} or None,
                            failed=failed or None)

