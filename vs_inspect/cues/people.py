"""Optional: where a person's head is in each frame, for the worn-camera sightings
(geometry/sightings.py). MediaPipe's BlazePose (pose_landmark_full and pose_detection) ships inside
the mediapipe 0.10.14 wheel (Apache-2.0); nothing is downloaded. Installed with --no-deps (its
declared opencv-contrib-python would replace the headless OpenCV; it needs protobuf < 5), as
`make setup` does; without it Stage 0 says so and skips the sightings.

BlazePose follows one person, the most prominent; in a frame with several it may take any of
them. Its landmark smoothing is off: smoothed heads lag their motion, which makes the sightings
late.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import warnings
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

# BlazePose landmarks 0-6: nose and both eyes (inner, centre, outer); worn glasses sit there
HEAD_LANDMARKS = tuple(range(7))
_MODELS = ("modules/pose_landmark/pose_landmark_full.tflite", "modules/pose_detection/pose_detection.tflite")


def heads_unavailable() -> str | None:
    """Why heads cannot be found here (one line), or None when they can: mediapipe with its legacy
    pose solution and the two BlazePose models shipped in its wheel."""
    spec = importlib.util.find_spec("mediapipe")
    if spec is None or not spec.submodule_search_locations:
        return ("head detection needs mediapipe 0.10.14, whose wheel ships BlazePose: make setup installs it "
                "(pip install --no-deps mediapipe==0.10.14, then absl-py flatbuffers 'protobuf>=4.25.3,<5')")
    root = Path(next(iter(spec.submodule_search_locations)))
    missing = [m for m in _MODELS if not (root / m).is_file()]
    if missing:
        return (f"head detection needs BlazePose's weights in the mediapipe wheel (0.10.14 ships them); "
                f"not found in {root}: {', '.join(missing)}")
    return None


def head_points(landmarks: np.ndarray, min_visibility: float = 0.5) -> np.ndarray:
    """(T,2) mean of the visible head landmarks of (T,33,3) x, y, visibility (NaN: none visible)."""
    head = np.asarray(landmarks, np.float64)[:, list(HEAD_LANDMARKS)]
    vis = np.nan_to_num(head[..., 2], nan=0.0) >= min_visibility
    n = vis.sum(1)
    total = np.where(vis[..., None], np.nan_to_num(head[..., :2]), 0.0).sum(1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n[:, None] > 0, total / n[:, None], np.nan)


@contextlib.contextmanager
def _quiet_native_logs() -> Iterator[None]:
    """MediaPipe's C++ side writes start-up notes to the process's stderr (fd 2); keep them out of
    a CLI's output."""
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def start_pose():
    """A BlazePose tracker, started, for one video's frames (detect_landmarks). Its start-up writes
    native notes to the process's stderr (fd 2), which is silenced meanwhile: start trackers on the
    thread that logs, before other work runs beside them; their frames may then go to any thread.
    Raises RuntimeError with heads_unavailable()'s reason."""
    why = heads_unavailable()
    if why:
        raise RuntimeError(why)
    # its protobuf 4 code calls a deprecated protobuf function at start-up and on frames, from
    # whichever thread runs them; ignored for the process (warnings.catch_warnings is not thread-safe)
    warnings.filterwarnings("ignore", message="SymbolDatabase.GetPrototype", category=UserWarning)
    with _quiet_native_logs():
        import mediapipe as mp

        pose = mp.solutions.pose.Pose(static_image_mode=False, model_complexity=1, smooth_landmarks=False)
        pose.process(np.zeros((64, 64, 3), np.uint8))  # its models start (and log) here; no one is found
    return pose


def detect_landmarks(frames_bgr: Iterable[np.ndarray], pose=None) -> np.ndarray:
    """(T,33,3) BlazePose landmarks (x, y in the frames' px, visibility) of one video's frames in
    order, NaN where no person was found. pose: a tracker from start_pose, used for these frames
    only and closed here (None: one is started here). Raises RuntimeError with
    heads_unavailable()'s reason."""
    import cv2

    pose = pose if pose is not None else start_pose()
    rows = []
    try:
        for bgr in frames_bgr:
            h, w = bgr.shape[:2]
            found = pose.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)).pose_landmarks
            rows.append(np.array([[p.x * w, p.y * h, p.visibility] for p in found.landmark])
                        if found else np.full((33, 3), np.nan))
    finally:
        pose.close()
    return np.stack(rows) if rows else np.zeros((0, 33, 3))
