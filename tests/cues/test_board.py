"""Cameras from a ChArUco board: a rendered board moved in front of two unsynchronized cameras,
the board description reader, and the CLI on the real caliscope session."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vs_inspect.cli import main
from vs_inspect.cues.board import (BoardDetections, BoardDetector, BoardSpec, board_view,
                                   calibrate_intrinsics, detect_frames, estimate_rig,
                                   pose_between_board_views)
from vs_inspect.errors import InputError
from vs_inspect.io.board import load_board
from vs_inspect.types import VideoInfo

SPEC = BoardSpec(5, 7, 0.04, 0.03, "DICT_4X4_50")
PX_PER_M = 4000.0  # board image resolution
W, H, FPS = 640, 480, 10.0
K = np.array([[700.0, 0, 320], [0, 700.0, 240], [0, 0, 1]])


def _world_from_board(t: float) -> np.ndarray:
    """The board waved about 1 m in front of both cameras, tilting up to about 35°."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec([0.6 * np.sin(1.3 * t), 0.6 * np.sin(0.9 * t + 1.0),
                                      0.3 * np.sin(0.5 * t)]).as_matrix()
    T[:3, 3] = [0.25 * np.sin(0.7 * t) - 0.1, 0.15 * np.cos(0.8 * t) - 0.14, 1.0 + 0.2 * np.sin(0.6 * t)]
    return T


def _render(board_img: np.ndarray, cam_from_board: np.ndarray) -> np.ndarray:
    """Exact pinhole image of the planar board: the homography K [r1 r2 t] from board px."""
    to_m = np.diag([1 / PX_PER_M, 1 / PX_PER_M, 1.0])
    Hm = K @ cam_from_board[:3, [0, 1, 3]] @ to_m
    return cv2.warpPerspective(board_img, Hm, (W, H), borderValue=160)


def _info(name: str, n: int) -> VideoInfo:
    return VideoInfo(name, W, H, n, np.arange(n) / FPS, FPS)


@pytest.fixture(scope="module")
def two_cameras():
    board_img = SPEC.board().generateImage((int(SPEC.columns * SPEC.square_m * PX_PER_M),
                                            int(SPEC.rows * SPEC.square_m * PX_PER_M)))
    b_from_a = np.eye(4)
    b_from_a[:3, :3] = Rotation.from_euler("y", -25, degrees=True).as_matrix()
    b_from_a[:3, 3] = [0.45, 0.02, 0.1]
    delta_true = 0.3  # a's frame i + 3 shows the moment of b's frame i
    n = 60
    frames_a = [(i, _render(board_img, _world_from_board(i / FPS))) for i in range(n)]
    frames_b = [(j, _render(board_img, b_from_a @ _world_from_board(j / FPS + delta_true)))
                for j in range(n)]
    det = BoardDetector(SPEC)
    return (detect_frames(frames_a, det), detect_frames(frames_b, det), b_from_a, delta_true, n)


def test_rig_from_a_board_recovers_offset_pose_and_focal(two_cameras):
    det_a, det_b, b_from_a, delta_true, n = two_cameras
    assert sum(len(i) >= 6 for i in det_a.ids) >= 30 and sum(len(i) >= 6 for i in det_b.ids) >= 30
    rig = estimate_rig([_info("a", n), _info("b", n)], {"a": det_a, "b": det_b}, SPEC)
    assert not rig.unregistered
    assert np.allclose(rig.cameras["a"].cam_from_world, np.eye(4))
    placed_from, rp = rig.links["b"]
    assert placed_from == "a"
    assert rp.offset_s == pytest.approx(delta_true, abs=1e-6)
    T = rig.cameras["b"].cam_from_world
    angle = np.degrees(Rotation.from_matrix(T[:3, :3] @ b_from_a[:3, :3].T).magnitude())
    assert angle < 1.0  # measured 0.56°; a pose fitted at a wrong offset is off by many degrees
    assert np.linalg.norm(T[:3, 3] - b_from_a[:3, 3]) < 0.01  # metres
    for name in "ab":
        assert rig.cameras[name].K[0, 0] == pytest.approx(700.0, rel=0.02)
        assert rig.intrinsics[name].rms_px < 1.0


def test_pose_between_board_views_direction_and_offset(two_cameras):
    det_a, det_b, b_from_a, delta_true, n = two_cameras
    views = {name: board_view(_info(name, n), det, calibrate_intrinsics(det, SPEC, (W, H)), SPEC)
             for name, det in (("a", det_a), ("b", det_b))}
    ab = pose_between_board_views(views["a"], views["b"], SPEC)
    assert ab.offset_s == pytest.approx(delta_true, abs=1e-6)
    assert np.linalg.norm(ab.b_from_a[:3, 3] - b_from_a[:3, 3]) < 0.01  # metres
    assert ab.inliers >= 4 and ab.inliers <= ab.pairings
    # the other way round: a from b, and the offset changes sign
    ba = pose_between_board_views(views["b"], views["a"], SPEC)
    assert ba.offset_s == pytest.approx(-delta_true, abs=1e-6)
    assert np.linalg.norm(ba.b_from_a[:3, 3] - np.linalg.inv(b_from_a)[:3, 3]) < 0.01


def test_board_shown_to_one_camera_only_is_named(two_cameras):
    det_a, _, _, _, n = two_cameras
    empty = BoardDetections(tuple(np.zeros(0, np.int64) for _ in range(n)),
                            tuple(np.zeros((0, 2)) for _ in range(n)))
    rig = estimate_rig([_info("a", n), _info("b", n)], {"a": det_a, "b": empty}, SPEC)
    assert set(rig.cameras) == {"a"}
    assert "board is seen in 0 frames" in rig.unregistered["b"]
    # a board that b sees only while a does not: no offset pairs its views, b is not placed
    late = BoardDetections(tuple(np.zeros(0, np.int64) for _ in range(40)) + det_a.ids[40:],
                           tuple(np.zeros((0, 2)) for _ in range(40)) + det_a.xy[40:])
    early = BoardDetections(det_a.ids[:10] + tuple(np.zeros(0, np.int64) for _ in range(n - 10)),
                            det_a.xy[:10] + tuple(np.zeros((0, 2)) for _ in range(n - 10)))
    rig = estimate_rig([_info("a", n), _info("b", n)], {"a": early, "b": late}, SPEC,)
    assert "at no offset" in rig.unregistered.get("b", "")


def test_board_spec_checks():
    with pytest.raises(ValueError, match="dictionary"):
        BoardSpec(4, 5, 0.05, 0.04, "DICT_NOPE")
    with pytest.raises(ValueError, match="marker side"):
        BoardSpec(4, 5, 0.05, 0.06, "DICT_4X4_50")


def test_load_board_caliscope_keys(tmp_path):
    p = tmp_path / "charuco.toml"
    p.write_text('columns = 4\nrows = 5\nboard_height = 11.0\nboard_width = 8.5\n'
                 'dictionary = "DICT_4X4_1000"\nunits = "inch"\naruco_scale = 0.75\ninverted = true\n')
    spec = load_board(p)
    assert spec.square_m == pytest.approx(8.5 / 4 * 0.0254)  # the largest square that fits
    assert spec.marker_m == pytest.approx(0.75 * spec.square_m) and spec.inverted
    p.write_text(p.read_text() + "square_size_override_cm = 5.4\n")
    assert load_board(p).square_m == pytest.approx(0.054)
    p.write_text("columns = 4\nrows = 5\n")
    with pytest.raises(InputError, match="lacks.*dictionary"):
        load_board(p)
    with pytest.raises(InputError, match="not found"):
        load_board(tmp_path / "missing.toml")


def test_calibrate_board_cli_on_caliscope(shared_data, tmp_path):
    root = shared_data / "caliscope_post_optimization"
    if not root.is_dir():
        pytest.skip("caliscope session not in the shared data")
    videos = sorted((root / "calibration" / "extrinsic").glob("cam_*.mp4"))
    out = tmp_path / "board.json"
    assert main(["calibrate-board", *map(str, videos), "--board", str(root / "charuco.toml"),
                 "--out", str(out), "--no-progress"]) == 0
    data = json.loads(out.read_text())
    assert sorted(data["cameras"]) == ["cam_0", "cam_1", "cam_2", "cam_3"]
    # the videos are synchronized: every coarse offset is within a frame (6 fps) of zero
    for name, info in data["board"].items():
        if name != "cam_0":
            assert abs(info["coarse_offset_s"]) <= 1 / 6 + 1e-3
            assert info["median_reprojection_px"] < 5.0
    # against caliscope's own calibration: the same camera centres within 10 cm
    from vs_inspect.io.calibration import load_calibration
    ref = load_calibration(root / "camera_array.toml", [v.stem for v in videos])
    w0 = ref["cam_0"].cam_from_world
    for name, cam in data["cameras"].items():
        T_ref = ref[name].cam_from_world @ np.linalg.inv(w0)
        T = np.asarray(cam["cam_from_world"])
        c_ref = -T_ref[:3, :3].T @ T_ref[:3, 3]
        c = -T[:3, :3].T @ T[:3, 3]
        assert np.linalg.norm(c - c_ref) < 0.10


def test_calibrate_board_cli_bad_board_file(tmp_path, capsys):
    bad = tmp_path / "board.toml"
    bad.write_text('columns = 4\nrows = 5\ndictionary = "DICT_4X4_NOPE"\nsquare_size_override_cm = 5\n')
    out = tmp_path / "calib.json"
    assert main(["calibrate-board", "a.mp4", "b.mp4", "--board", str(bad), "--out", str(out)]) == 2
    assert "unknown ArUco dictionary 'DICT_4X4_NOPE'" in capsys.readouterr().err
    assert not out.exists()
