"""BlazePose's 33 body landmarks: their names, the left/right permutation, and a person's size.

A person seen from behind is often labelled as if seen from the front: left and right swap. The
swap is a fixed permutation of the 33 landmarks (MIRROR), so a mirrored labelling is one of two
hypotheses about the same body, not an outlier. Pure numpy, no I/O.
"""

from __future__ import annotations

import numpy as np

from ._shapes import check_shape

LANDMARK_NAMES = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
    "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel", "right_heel",
    "left_foot_index", "right_foot_index",
)
NUM_LANDMARKS = len(LANDMARK_NAMES)


def _mirror_permutation() -> np.ndarray:
    index = {n: i for i, n in enumerate(LANDMARK_NAMES)}
    other = {"left": "right", "right": "left", "mouth_left": "mouth_right", "mouth_right": "mouth_left"}
    perm = np.arange(NUM_LANDMARKS)
    for i, n in enumerate(LANDMARK_NAMES):
        if n in other:
            perm[i] = index[other[n]]
        elif n.startswith(("left_", "right_")):
            side, rest = n.split("_", 1)
            perm[i] = index[f"{other[side]}_{rest}"]
    return perm


MIRROR = _mirror_permutation()
"""(33,) int: landmark MIRROR[k] of a person is landmark k of the same person with left and right
swapped (an involution: MIRROR[MIRROR] is the identity)."""

# the landmarks the geometry uses by default: points on the body's surface and extremities (the
# face, the hands, the feet) and the shoulders; the hips, knees and elbows are joints inside the
# body, whose image position each view estimates differently (and the hips are often hidden)
GEOMETRY_LANDMARKS = tuple(LANDMARK_NAMES.index(n) for n in (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear", "mouth_left", "mouth_right",
    "left_shoulder", "right_shoulder", "left_wrist", "right_wrist", "left_index", "right_index",
    "left_thumb", "right_thumb", "left_ankle", "right_ankle", "left_heel", "right_heel",
    "left_foot_index", "right_foot_index"))


def mirrored(landmarks: np.ndarray) -> np.ndarray:
    """(..., 33, C) the same landmarks with left and right swapped (MIRROR along axis -2)."""
    landmarks = np.asarray(landmarks)
    check_shape("landmarks", landmarks, (NUM_LANDMARKS, None))
    return landmarks[..., MIRROR, :]


def subset_mirror(landmarks: tuple[int, ...]) -> np.ndarray:
    """(L,) int: within a subset of landmark indices (closed under MIRROR), the position of each
    one's mirror image; ValueError when the subset is not closed."""
    pos = {k: i for i, k in enumerate(landmarks)}
    missing = [LANDMARK_NAMES[MIRROR[k]] for k in landmarks if MIRROR[k] not in pos]
    if missing:
        raise ValueError(f"the landmark subset lacks the mirror images {missing}")
    return np.array([pos[MIRROR[k]] for k in landmarks], dtype=np.int64)


def person_scale_px(xy: np.ndarray) -> np.ndarray:
    """(...,) a person's size in px: the diagonal of the box around its seen landmarks xy (..., L, 2)
    (NaN where unseen); NaN where fewer than two are seen."""
    xy = np.asarray(xy, dtype=np.float64)
    check_shape("xy", xy, (None, 2))
    seen = np.isfinite(xy).all(-1)
    lo = np.where(seen[..., None], xy, np.inf).min(-2)
    hi = np.where(seen[..., None], xy, -np.inf).max(-2)
    with np.errstate(invalid="ignore"):
        size = np.hypot(hi[..., 0] - lo[..., 0], hi[..., 1] - lo[..., 1])
    return np.where(seen.sum(-1) >= 2, size, np.nan)


def pose_distance(xy_a: np.ndarray, xy_b: np.ndarray, min_common: int = 4) -> np.ndarray:
    """(...,) median distance (px) between the landmarks two poses xy_a, xy_b (..., L, 2) both see,
    the smaller of the labelling as given and the mirrored one; inf where fewer than min_common
    landmarks are seen by both. L = 33 (the mirror needs the whole skeleton)."""
    xy_a = np.asarray(xy_a, dtype=np.float64)
    xy_b = np.asarray(xy_b, dtype=np.float64)
    check_shape("xy_a", xy_a, (NUM_LANDMARKS, 2))
    check_shape("xy_b", xy_b, (NUM_LANDMARKS, 2))
    out = []
    for other in (xy_b, mirrored(xy_b)):
        d = np.linalg.norm(xy_a - other, axis=-1)
        n = np.isfinite(d).sum(-1)
        # the median of the finite distances: NaN sorts last, so take the middle of the first n
        d = np.sort(d, axis=-1)
        lo = np.take_along_axis(d, np.maximum((n - 1) // 2, 0)[..., None], -1)[..., 0]
        hi = np.take_along_axis(d, np.maximum(n // 2, 0)[..., None], -1)[..., 0]
        out.append(np.where(n >= min_common, 0.5 * (lo + hi), np.inf))
    return np.minimum(*out)


def landmark_box(xy: np.ndarray) -> np.ndarray:
    """(...,4) x0, y0, x1, y1 px of the box around the seen landmarks xy (...,L,2) (NaN: unseen);
    NaN where none is seen."""
    xy = np.asarray(xy, dtype=np.float64)
    check_shape("xy", xy, (None, 2))
    seen = np.isfinite(xy).all(-1)
    lo = np.where(seen[..., None], xy, np.inf).min(-2)
    hi = np.where(seen[..., None], xy, -np.inf).max(-2)
    box = np.concatenate([lo, hi], -1)
    return np.where(seen.any(-1)[..., None], box, np.nan)


def box_overlap(box_a: np.ndarray, box_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(IoU, share of the smaller box inside the other) of boxes (...,4) x0, y0, x1, y1 (broadcast)."""
    a, b = np.asarray(box_a, np.float64), np.asarray(box_b, np.float64)
    w = np.clip(np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0]), 0, None)
    h = np.clip(np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1]), 0, None)
    inter = w * h
    area_a = (a[..., 2] - a[..., 0]) * (a[..., 3] - a[..., 1])
    area_b = (b[..., 2] - b[..., 0]) * (b[..., 3] - b[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        iou = inter / (area_a + area_b - inter)
        inside = inter / np.minimum(area_a, area_b)
    return np.nan_to_num(iou), np.nan_to_num(inside)


# BlazePose's skeleton: the landmarks a drawing of a person joins (the face's outline, the
# shoulders and hips, the arms with their hands, the legs with their feet)
SKELETON_EDGES = tuple((LANDMARK_NAMES.index(a), LANDMARK_NAMES.index(b)) for a, b in (
    ("nose", "left_eye_inner"), ("left_eye_inner", "left_eye"), ("left_eye", "left_eye_outer"),
    ("left_eye_outer", "left_ear"), ("nose", "right_eye_inner"), ("right_eye_inner", "right_eye"),
    ("right_eye", "right_eye_outer"), ("right_eye_outer", "right_ear"), ("mouth_left", "mouth_right"),
    ("left_shoulder", "right_shoulder"), ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
    ("left_wrist", "left_pinky"), ("left_wrist", "left_index"), ("left_wrist", "left_thumb"),
    ("left_pinky", "left_index"), ("right_shoulder", "right_elbow"), ("right_elbow", "right_wrist"),
    ("right_wrist", "right_pinky"), ("right_wrist", "right_index"), ("right_wrist", "right_thumb"),
    ("right_pinky", "right_index"), ("left_shoulder", "left_hip"), ("right_shoulder", "right_hip"),
    ("left_hip", "right_hip"), ("left_hip", "left_knee"), ("left_knee", "left_ankle"),
    ("left_ankle", "left_heel"), ("left_heel", "left_foot_index"), ("left_ankle", "left_foot_index"),
    ("right_hip", "right_knee"), ("right_knee", "right_ankle"), ("right_ankle", "right_heel"),
    ("right_heel", "right_foot_index"), ("right_ankle", "right_foot_index")))
