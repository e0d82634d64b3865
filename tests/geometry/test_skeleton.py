"""BlazePose's landmarks: the left/right mirror, subsets, sizes, pose distances and boxes."""

from __future__ import annotations

import numpy as np
import pytest

from vs_inspect.geometry.skeleton import (GEOMETRY_LANDMARKS, LANDMARK_NAMES, MIRROR, NUM_LANDMARKS, box_overlap,
                                          landmark_box, mirrored, person_scale_px, pose_distance, subset_mirror)


def test_mirror_swaps_left_and_right_and_is_an_involution():
    assert NUM_LANDMARKS == 33 and len(MIRROR) == 33
    np.testing.assert_array_equal(MIRROR[MIRROR], np.arange(33))
    name = dict(enumerate(LANDMARK_NAMES))
    assert name[MIRROR[0]] == "nose"  # on the body's middle: its own image
    assert name[MIRROR[LANDMARK_NAMES.index("left_wrist")]] == "right_wrist"
    assert name[MIRROR[LANDMARK_NAMES.index("right_foot_index")]] == "left_foot_index"
    assert name[MIRROR[LANDMARK_NAMES.index("mouth_left")]] == "mouth_right"
    for k, n in enumerate(LANDMARK_NAMES):  # every other landmark trades its side
        if n != "nose":
            assert MIRROR[k] != k
            assert name[MIRROR[k]].replace("left", "X").replace("right", "X") == n.replace("left", "X").replace("right", "X")


def test_mirrored_permutes_the_landmark_axis():
    lm = np.arange(2 * 33 * 3, dtype=float).reshape(2, 33, 3)
    out = mirrored(lm)
    np.testing.assert_array_equal(out[:, 11], lm[:, 12])  # left shoulder <- right shoulder
    np.testing.assert_array_equal(mirrored(out), lm)
    with pytest.raises(ValueError, match=r"\(\.\.\.,33,N\)"):
        mirrored(np.zeros((5, 3)))


def test_subset_mirror_within_the_geometry_landmarks():
    pos = subset_mirror(GEOMETRY_LANDMARKS)
    sub = np.array(GEOMETRY_LANDMARKS)
    np.testing.assert_array_equal(sub[pos], MIRROR[sub])
    with pytest.raises(ValueError, match="mirror images"):
        subset_mirror((LANDMARK_NAMES.index("left_wrist"),))


def test_person_scale_box_and_overlap():
    xy = np.full((33, 2), np.nan)
    xy[0], xy[5] = (10, 20), (40, 60)
    assert person_scale_px(xy) == pytest.approx(50.0)
    np.testing.assert_allclose(landmark_box(xy), [10, 20, 40, 60])
    assert np.isnan(person_scale_px(np.full((33, 2), np.nan)))
    iou, inside = box_overlap(np.array([0, 0, 10, 10.0]), np.array([5, 0, 15, 10.0]))
    assert iou == pytest.approx(50 / 150) and inside == pytest.approx(0.5)


def test_pose_distance_takes_the_better_labelling():
    rng = np.random.default_rng(0)
    pose = rng.uniform(0, 100, (33, 2))
    assert pose_distance(pose, pose + [3.0, 4.0]) == pytest.approx(5.0)
    assert pose_distance(pose, pose[MIRROR] + [3.0, 4.0]) == pytest.approx(5.0)  # mirrored: same person
    few = np.full((33, 2), np.nan)
    few[:3] = pose[:3]
    assert pose_distance(pose, few) == np.inf  # fewer than 4 in common
