"""vs-inspect export --mosaic: real clips written with VideoWriter, a result.json, and the mosaic
decoded back to check which frame each tile shows at each global time."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vs_inspect.cli import main
from vs_inspect.io.video import VideoWriter, iter_frames, open_video
from vs_inspect.report.mosaic import BLANK_BGR, HEADER_PX, plan_mosaic
from vs_inspect.types import VideoInfo

CLIPS = {  # name: (fps, frames, width, height, px between the bars of consecutive frames)
    "left": (10.0, 20, 160, 96, 7),
    "right": (15.0, 24, 120, 90, 4),
    "lost": (10.0, 10, 160, 96, 9),
}
OFFSETS = {"left": 0.0, "right": 1.02, "lost": None}  # 1.02: no ties between two frames
BAR_PX = 4


def bar_x(name: str, k: int) -> float:
    """Centre column of the white bar that marks frame k (robust to lossy coding)."""
    return 4 + CLIPS[name][4] * k + (BAR_PX - 1) / 2


def clip_frame(name: str, k: int) -> np.ndarray:
    _, _, w, h, _ = CLIPS[name]
    img = np.full((h, w, 3), 40, np.uint8)
    x = 4 + CLIPS[name][4] * k
    img[:, x:x + BAR_PX] = 255
    return img


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    paths = {}
    for name, (fps, n, w, h, _) in CLIPS.items():
        paths[name] = d / f"{name}.mp4"
        with VideoWriter(paths[name], w, h, fps) as vw:
            for k in range(n):
                vw.write(clip_frame(name, k))
    result = {"reference": "left", "offsets_s": OFFSETS,
              "unresolved": {"lost": "no accepted pair"},
              "input": {"videos": {n: str(p) for n, p in paths.items()}}}
    (d / "result.json").write_text(json.dumps(result))
    return d


def test_plan_nearest_frames():
    infos = [VideoInfo.constant_rate("a", 10, 10, 5, 10.0), VideoInfo.constant_rate("b", 10, 10, 3, 5.0)]
    plan = plan_mosaic(infos, [0.0, 0.25], fps=10.0)
    # b: frames at local 0, 0.2, 0.4 -> global 0.25, 0.45, 0.65; a: 0 .. 0.4
    np.testing.assert_allclose(plan.times_s, np.arange(7) / 10.0)
    assert plan.frame_index[0].tolist() == [0, 1, 2, 3, 4, -1, -1]
    # b at g=0.1: tau=-0.15, more than half a frame (0.1) before its first frame: blank;
    # g=0.2: tau=-0.05 -> frame 0; g=0.3: tau=0.05 -> frame 0; g=0.4: tau=0.15 -> frame 1
    assert plan.frame_index[1].tolist() == [-1, -1, 0, 0, 1, 1, 2]


def test_export_mosaic(run_dir, tmp_path):
    out = tmp_path / "mosaic.mp4"
    assert main(["export", str(run_dir), "--mosaic", str(out), "--fps", "10",
                 "--tile-width", "160", "--no-progress"]) == 0
    src = open_video(out)
    # global timeline from 0 (left starts) to 1.02 + 23/15 s (right ends)
    G = int(np.floor((1.02 + 23 / 15) * 10)) + 1
    assert src.info.num_frames == G
    np.testing.assert_allclose(src.info.timestamps_s, np.arange(G) / 10.0, atol=1e-3)
    tile_w, tile_h = 160, 120  # 3 tiles in a row, height from the tallest aspect (90/120)
    assert (src.info.width, src.info.height) == (3 * tile_w, HEADER_PX + tile_h)
    for gi, img in iter_frames(src):
        g = gi / 10.0
        for col, name in enumerate(("left", "right", "lost")):
            fps, n, w, h, _ = CLIPS[name]
            tile = img[HEADER_PX:HEADER_PX + tile_h, col * tile_w:(col + 1) * tile_w]
            profile = np.zeros(tile_w)  # middle rows, clear of the labels and the tile border
            profile[2:-2] = tile[45:75, 2:-2].mean(axis=(0, 2))
            off = OFFSETS[name]
            tau = None if off is None else g - off
            if tau is None or tau < -0.5 / fps or tau > (n - 1) / fps + 0.5 / fps:
                assert profile.max() < BLANK_BGR[0] + 15, (gi, name, profile.max())
                continue
            k = int(np.clip(np.round(tau * fps), 0, n - 1))
            # letterbox of the clip in its tile
            s = min(tile_w / w, tile_h / h)
            x_off = (tile_w - round(w * s)) // 2
            expected = [x_off + (bar_x(name, j) + 0.5) * s - 0.5 for j in range(n)]
            seen = float(np.argmax(profile))
            assert int(np.argmin([abs(seen - e) for e in expected])) == k, (gi, name, seen, k)


def test_export_errors(run_dir, tmp_path):
    # --videos overrides result.json; a name the result does not know is an error (exit 2)
    assert main(["export", str(run_dir), "--mosaic", str(tmp_path / "m.mp4"),
                 "--videos", str(run_dir / "left.mp4"), str(run_dir / "right.mp4")]) == 2
    assert not (tmp_path / "m.mp4").exists()
    ok = main(["export", str(run_dir / "result.json"), "--mosaic", str(tmp_path / "m2.mp4"),
               "--no-progress", "--tile-width", "64", "--videos", str(run_dir / "left.mp4"),
               f"right={run_dir / 'right.mp4'}", f"lost={run_dir / 'lost.mp4'}"])
    assert ok == 0
    # default rate: the highest input rate (15 fps)
    assert open_video(tmp_path / "m2.mp4").info.fps == pytest.approx(15.0)
    assert main(["export", str(tmp_path / "nowhere"), "--mosaic", str(tmp_path / "m3.mp4")]) == 2
