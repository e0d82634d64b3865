"""Every person in a frame, with BlazePose's 33 landmarks: MediaPipe's PoseLandmarker (several
people per image) on the whole frame and on overlapping square windows of it, so that people too
small for the detector's 224 px input on the whole frame are found in a window.

PoseLandmarker takes a .task bundle (a zip of pose_detector.tflite and
pose_landmarks_detector.tflite). The mediapipe 0.10.14 wheel ships the same two networks for its
one-person solution (modules/pose_detection, modules/pose_landmark) without the input metadata
the task reads; the bundle is made here, in memory, from those files with that metadata added
(the normalisation each network was trained with). Nothing is downloaded.
"""

from __future__ import annotations

import functools
import io
import math
import threading
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..geometry.skeleton import NUM_LANDMARKS, box_overlap, landmark_box, person_scale_px, pose_distance
from .people import _MODELS, _quiet_native_logs, heads_unavailable

# (file in the wheel, name in the task bundle, input normalisation (mean, std) of its RGB 0-255
# input, output tensors): the detector sees [-1, 1], the landmark network [0, 1]
_BUNDLE = (
    ("modules/pose_detection/pose_detection.tflite", "pose_detector.tflite", (127.5, 127.5), 2),
    ("modules/pose_landmark/pose_landmark_full.tflite", "pose_landmarks_detector.tflite", (0.0, 255.0), 5),
)
assert {f for f, *_ in _BUNDLE} == set(_MODELS)


def people_unavailable() -> str | None:
    """Why people cannot be detected here (one line), or None when they can."""
    why = heads_unavailable()
    return why.replace("head detection", "people detection") if why else None


@functools.lru_cache(maxsize=1)
def pose_task_bundle() -> bytes:
    """The PoseLandmarker .task bundle (zip bytes) made from the wheel's two BlazePose networks."""
    why = people_unavailable()
    if why:
        raise RuntimeError(why)
    import mediapipe as mp
    from mediapipe.tasks.python.metadata.metadata_writers import metadata_writer

    root = Path(mp.__file__).parent
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for src, name, (mean, std), outputs in _BUNDLE:
            writer = metadata_writer.MetadataWriter.create(bytearray((root / src).read_bytes()))
            writer.add_general_info(name, "BlazePose network from the mediapipe wheel").add_image_input([mean], [std])
            for _ in range(outputs):
                writer.add_feature_output()
            model, _ = writer.populate()
            z.writestr(name, bytes(model))
    return buf.getvalue()


@dataclass(frozen=True)
class DetectorConfig:
    """How people are looked for in one frame."""

    max_people: int = 6
    """People the landmarker returns per window at most."""
    min_detection: float = 0.3
    """Least confidence of BlazePose's person detector."""
    min_presence: float = 0.3
    """Least confidence of the landmark network that a person is there."""
    window_overlap: float = 0.25
    """Square windows overlap by at least this share of a side."""
    window_levels: int = 2
    """Sizes of square windows besides the whole frame: 1, squares of the frame's shorter side;
    2, also of half of it (people a tenth of the frame high); 0, the whole frame only."""
    min_window_px: int = 160
    """No window is smaller than this."""
    duplicate_share: float = 0.12
    """Two poses whose landmarks lie within this share of the person's size of each other
    (median)..."""
    duplicate_iou: float = 0.6
    """...or whose landmark boxes overlap this much (intersection over union) are one person
    found twice."""
    part_inside: float = 0.8
    """A pose whose landmarks' box lies this much inside a larger pose's box, and is at most
    half its size, is a part of that person found alone (a hand in a window) and is dropped."""

    def __post_init__(self) -> None:
        if self.max_people < 1 or not (0 <= self.window_overlap < 1):
            raise ValueError(f"DetectorConfig out of range: {self}")


def frame_windows(width: int, height: int, cfg: DetectorConfig = DetectorConfig()
                  ) -> list[tuple[int, int, int, int]]:
    """(x0, y0, x1, y1) px windows looked at in a frame: the whole frame, then overlapping
    squares of the shorter side and of its halves (cfg.window_levels), each covering the frame;
    a square that would cover the whole frame nearly alone is skipped."""
    out = [(0, 0, width, height)]

    def starts(length: int, side: int) -> list[int]:
        if side >= length:
            return [0]
        n = math.ceil((length - side) / (side * (1 - cfg.window_overlap))) + 1
        return [int(round(x)) for x in np.linspace(0, length - side, n)]

    for level in range(1, cfg.window_levels + 1):
        side = min(width, height) // (2 ** (level - 1))
        if side < cfg.min_window_px:
            break
        if side * side >= (1 - cfg.window_overlap) * width * height:
            continue  # about the whole frame again
        out += [(x, y, x + side, y + side) for y in starts(height, side) for x in starts(width, side)]
    return out


@dataclass(frozen=True)
class FramePeople:
    """The people found in one frame."""

    landmarks: np.ndarray  # (K,33,3) x px, y px (the frame's pixels), visibility 0..1
    window: np.ndarray  # (K,) int: index of the frame_windows window each was kept from

    def __post_init__(self) -> None:
        lm = np.asarray(self.landmarks, dtype=np.float64).reshape(-1, NUM_LANDMARKS, 3)
        object.__setattr__(self, "landmarks", lm)
        object.__setattr__(self, "window", np.asarray(self.window, dtype=np.int64).reshape(len(lm)))


def _margin_share(xy: np.ndarray, window: tuple[int, int, int, int]) -> float:
    """How far the pose's seen landmarks stay from the window's edges, as a share of the pose's
    size (negative: some outside)."""
    x0, y0, x1, y1 = window
    seen = xy[np.isfinite(xy).all(1)]
    if not len(seen):
        return -np.inf
    size = max(float(person_scale_px(seen)), 1.0)
    m = min(seen[:, 0].min() - x0, x1 - seen[:, 0].max(), seen[:, 1].min() - y0, y1 - seen[:, 1].max())
    return m / size


def merge_duplicates(poses: list[np.ndarray], windows: list[tuple[int, int, int, int]],
                     window_of: list[int], cfg: DetectorConfig = DetectorConfig()) -> FramePeople:
    """One pose per person from poses (each (33,3) frame px + visibility) found in several
    windows: of two poses closer than cfg.duplicate_share of their size (or overlapping by
    cfg.duplicate_iou), the one whose window
    holds it with the widest margin is kept (a person cut by a window's edge gets guessed
    limbs); a pose that is a small part of a larger one (cfg.part_inside) is dropped."""
    if not poses:
        return FramePeople(np.zeros((0, NUM_LANDMARKS, 3)), np.zeros(0, np.int64))
    P = np.stack(poses)
    xy = np.where(P[..., 2:3] >= 0.5, P[..., :2], np.nan)
    size = person_scale_px(xy)
    box = landmark_box(xy)
    margin = np.array([_margin_share(P[k, :, :2], windows[w]) for k, w in enumerate(window_of)])
    kept: list[int] = []
    for k in np.argsort(-margin, kind="stable"):
        if not np.isfinite(size[k]):
            continue
        if all(pose_distance(xy[k], xy[j]) > cfg.duplicate_share * max(size[k], size[j])
               and box_overlap(box[k], box[j])[0] < cfg.duplicate_iou for j in kept):
            kept.append(int(k))
    parts = set()
    for k in kept:
        for j in kept:
            if j != k and size[k] <= 0.5 * size[j] and box_overlap(box[k], box[j])[1] >= cfg.part_inside:
                parts.add(k)
    kept = sorted(k for k in kept if k not in parts)
    return FramePeople(P[kept], np.array([window_of[k] for k in kept], dtype=np.int64))


_STARTING = threading.Lock()  # one detector starts at a time: each silences the process's stderr meanwhile


class PeopleDetector:
    """BlazePose PoseLandmarker over a frame's windows (frame_windows). Starting it writes native
    notes to stderr, silenced meanwhile (one start at a time, so that stderr comes back); use each
    detector from one thread; close() (or a with block) frees it."""

    def __init__(self, cfg: DetectorConfig = DetectorConfig()):
        self.cfg = cfg
        # its protobuf 4 code calls a deprecated protobuf function (see cues/people.start_pose)
        warnings.filterwarnings("ignore", message="SymbolDatabase.GetPrototype", category=UserWarning)
        model = pose_task_bundle()
        with _STARTING, _quiet_native_logs():
            from mediapipe.tasks.python import BaseOptions, vision

            opts = vision.PoseLandmarkerOptions(
                base_options=BaseOptions(model_asset_buffer=model), running_mode=vision.RunningMode.IMAGE,
                num_poses=cfg.max_people, min_pose_detection_confidence=cfg.min_detection,
                min_pose_presence_confidence=cfg.min_presence)
            self._landmarker = vision.PoseLandmarker.create_from_options(opts)
            self._landmarker.detect(_mp_image(np.zeros((64, 64, 3), np.uint8)))  # start-up logs here
            crop = vision.PoseLandmarkerOptions(
                base_options=BaseOptions(model_asset_buffer=model), running_mode=vision.RunningMode.IMAGE,
                num_poses=2, min_pose_detection_confidence=cfg.min_detection,
                min_pose_presence_confidence=cfg.min_presence)
            self._crop_landmarker = vision.PoseLandmarker.create_from_options(crop)
            self._crop_landmarker.detect(_mp_image(np.zeros((64, 64, 3), np.uint8)))

    def poses_in(self, rgb: np.ndarray, windows: list[tuple[int, int, int, int]], crop: bool = False
                 ) -> tuple[list[np.ndarray], list[int]]:
        """(poses (33,3) in frame px + visibility, index of the window each came from) found in
        windows of an (H,W,3) RGB frame; crop: with the landmarker of at most two people (a crop
        around one person)."""
        landmarker = self._crop_landmarker if crop else self._landmarker
        poses, window_of = [], []
        for i, (x0, y0, x1, y1) in enumerate(windows):
            found = landmarker.detect(_mp_image(rgb[y0:y1, x0:x1])).pose_landmarks
            for person in found:
                poses.append(np.array([[x0 + p.x * (x1 - x0), y0 + p.y * (y1 - y0), p.visibility]
                                       for p in person], dtype=np.float64))
                window_of.append(i)
        return poses, window_of

    def detect(self, frame_bgr: np.ndarray) -> FramePeople:
        """The people of one (H,W,3) uint8 BGR frame, landmarks in its px, looked for in every
        window (frame_windows)."""
        import cv2

        h, w = frame_bgr.shape[:2]
        windows = frame_windows(w, h, self.cfg)
        poses, window_of = self.poses_in(cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2RGB), windows)
        return merge_duplicates(poses, windows, window_of, self.cfg)

    def close(self) -> None:
        self._landmarker.close()
        self._crop_landmarker.close()

    def __enter__(self) -> PeopleDetector:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class DetectorPool:
    """Several PeopleDetector's, each on a thread of its own, looking at the windows of one frame
    at once (BlazePose releases the GIL while it runs). The result is the same whatever the
    number of workers: each window is looked at alone. close() (or a with block) frees them."""

    def __init__(self, cfg: DetectorConfig = DetectorConfig(), workers: int = 1):
        from concurrent.futures import ThreadPoolExecutor

        if workers < 1:
            raise ValueError(f"a detector pool needs one worker or more, got {workers}")
        self._detectors: list[PeopleDetector] = []
        self._threads = []
        try:
            for i in range(workers):
                self._detectors.append(PeopleDetector(cfg))
                if workers > 1:
                    self._threads.append(ThreadPoolExecutor(1, thread_name_prefix=f"people-{i}"))
        except BaseException:
            self.close()
            raise

    def poses_in(self, rgb: np.ndarray, windows: list[tuple[int, int, int, int]], crop: list[bool]
                 ) -> list[list[np.ndarray]]:
        """Per window of an (H,W,3) RGB frame, the poses (33,3) found in it (frame px +
        visibility); crop[i]: window i is a crop around one person (PeopleDetector.poses_in)."""
        n = len(self._detectors)

        def look(d: int) -> list[list[np.ndarray]]:
            out = []
            for i in range(d, len(windows), n):
                found, _ = self._detectors[d].poses_in(rgb, [windows[i]], crop=crop[i])
                out.append(found)
            return out

        if n == 1:
            shares = [look(0)]
        else:  # each detector always on its own thread
            shares = [f.result() for f in [t.submit(look, d) for d, t in enumerate(self._threads)]]
        return [shares[i % n][i // n] for i in range(len(windows))]

    def close(self) -> None:
        for t in self._threads:
            t.shutdown(wait=True)
        for d in self._detectors:
            d.close()

    def __enter__(self) -> DetectorPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _mp_image(rgb: np.ndarray):
    import mediapipe as mp

    return mp.Image(image_format=mp.ImageFormat.SRGB, data=np.ascontiguousarray(rgb))
