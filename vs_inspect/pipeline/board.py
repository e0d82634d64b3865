"""Board calibration as a stage: a rig's cameras from a ChArUco board waved in its videos."""

from __future__ import annotations

import logging
import time
from pathlib import Path

from tqdm import tqdm

from ..cues.board import BoardDetector, RigEstimate, detect_frames, estimate_rig
from ..io.board import load_board
from ..io.video import iter_frames

log = logging.getLogger(__name__)


def estimate_from_board(sources: list, board_path: Path, progress: bool = True) -> tuple[RigEstimate, float]:
    """Detect the board in every opened video and estimate the rig: (RigEstimate, seconds)."""
    spec = load_board(board_path)
    t0 = time.perf_counter()
    detector = BoardDetector(spec)
    detections = {}
    for src in tqdm(sources, desc="board corners", unit="video", disable=not progress, leave=False):
        detections[src.info.name] = detect_frames(iter_frames(src), detector)
    rig = estimate_rig([s.info for s in sources], detections, spec)
    for name, why in rig.unregistered.items():
        log.warning("%s: no camera from the board: %s", name, why)
    return rig, time.perf_counter() - t0
