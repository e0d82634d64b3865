"""Video datasets of the benchmark: the VisualSync clips through the video pipeline (Stage 0 =
vs_inspect.pipeline.run_stage0 with estimated cameras, no calibration).

Clip <scene>_<cam>_<start>_<end>_<k>.mp4 shows frames start, start+1, ... of one common timeline
at 10 fps, so the true offset_s of a clip is start / 10 (DESIGN.md convention).
"""

from __future__ import annotations

import dataclasses
import re
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from .datasets import BenchData

CLIP_FPS = 10.0
CLIP_SCENES = ("blenderbox", "pan160906", "sequence69", "fencing1")
_CLIP = re.compile(r"_(\d+)_(\d+)_(\d+)$")


def video_pipeline_available() -> bool:
    try:
        from ..pipeline.stage0 import run_stage0  # noqa: F401
    except ImportError:
        return False
    return True


def clip_truth(paths: list[Path]) -> dict[str, float]:
    truth = {}
    for p in paths:
        m = _CLIP.search(p.stem)
        if not m:
            raise InputError(f"{p.name}: not a VisualSync clip name (<scene>_<cam>_<start>_<end>_<k>.mp4)")
        truth[p.stem] = int(m.group(1)) / CLIP_FPS
    return truth


def frame_motion_signal(src, max_side: int = 320) -> tuple[np.ndarray, np.ndarray]:
    """Mean absolute grey-level difference of consecutive frames per second (peer 1 on video)."""
    import cv2

    from ..baselines.motion_xcorr import motion_signal_from_frames
    from ..io.video import iter_frames

    frames = (cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) for _, img in iter_frames(src, max_side=max_side))
    return motion_signal_from_frames(frames, src.info.timestamps_s)


def _through_stage0(name: str, group: str, srcs: list, calibration, truth: dict[str, float],
                    frame_interval_s: float, cue_config=None
                    ) -> tuple[BenchData, float, BaseException | None]:
    # srcs: the opened videos (for the motion signals); calibration: the calibration file or None
    """Motion signals of the peer (from the decoded frames, so that it runs even when Stage 0
    fails), then Stage 0: (BenchData, Stage 0 seconds, Stage 0 error or None).

    On success data.bundle is the extracted cue bundle with the true offsets (videos that Stage 0
    drops stay in the truth, so every method counts them as unresolved); on failure it is None."""
    from ..cues import CueConfig
    from ..pipeline.stage0 import run_stage0

    signals = {s.info.name: frame_motion_signal(s) for s in srcs}
    notes = {"motion_signals": signals, "truth": truth, "videos_info": [s.info for s in srcs],
             "videos": len(srcs)}
    t0 = time.perf_counter()
    try:
        bundle, stats, _ = run_stage0([s.path for s in srcs], calibration, None,
                                      cue_config or CueConfig(), progress=False)
    except Exception as exc:  # noqa: BLE001  (Stage 0 failing is a result)
        return BenchData(name, group, None, None, frame_interval_s, notes), time.perf_counter() - t0, exc
    stage0 = time.perf_counter() - t0
    notes.update(dropped=stats.dropped, stage0_timings_s=stats.timings_s)
    bundle = dataclasses.replace(bundle, gt_offsets_s=truth)
    return BenchData(name, group, bundle, None, frame_interval_s, notes), stage0, None


def clip_scene(root: Path, scene: str) -> tuple[BenchData, float, BaseException | None]:
    """(BenchData, Stage 0 seconds, Stage 0 error or None) of one scene of clips (estimated cameras)."""
    from ..io.video import open_video

    paths = sorted((root / scene).glob("*.mp4"))
    if len(paths) < 2:
        raise InputError(f"{root / scene}: fewer than 2 clips")
    truth = clip_truth(paths)
    srcs = [open_video(p) for p in paths]
    return _through_stage0(f"clips/{scene}", "clips", srcs, None, truth, 1.0 / CLIP_FPS)


RENDERED_SCENES = (0,)


def rendered_scene(seed: int, workdir: Path, cue_config=None) -> tuple[BenchData, float, BaseException | None]:
    """A rendered multi-camera scene (vs_inspect.synth) through Stage 0 with its calibration,
    as a user with calibrated cameras would run it: (BenchData, Stage 0 s, error or None).

    3 static cameras + 1 hand-held, 5 s, 480x360, mixed frame rates, one variable-rate video.
    The scene is rendered into workdir/rendered_s<seed> unless a finished rendering of the same
    settings is there. The exact cameras are kept for the GT-camera rows; the true cues are not
    used here. cue_config: Stage 0 settings (CueConfig(); None = defaults).
    """
    import json

    from ..io.calibration import load_calibration, to_camera_track
    from ..io.video import open_video
    from ..synth.videos import render_unless_cached
    from ..synth.world import SceneConfig

    cfg = SceneConfig(cameras=4, moving=1, seconds=5.0, width=480, height=360, fps=None,
                      variable_rate=1, seed=seed)
    folder = Path(workdir) / f"rendered_s{seed}"
    render_unless_cached(folder, cfg, progress=False)
    truth = json.loads((folder / "gt.json").read_text())["offsets_s"]
    srcs = [open_video(p) for p in sorted(folder.glob("cam*.mp4"))]
    calib = load_calibration(folder / "calibration.json", [s.info.name for s in srcs])
    data, stage0, error = _through_stage0(f"rendered/s{seed}", "rendered", srcs,
                                          folder / "calibration.json", truth,
                                          1.0 / 30.0, cue_config)
    if error is None:
        exact = {n: to_camera_track(c) for n, c in calib.items() if n in data.bundle.cameras}
        data = dataclasses.replace(data, true_cameras=exact)
    return data, stage0, error
