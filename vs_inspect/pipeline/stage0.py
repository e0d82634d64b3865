"""Stage 0 of a run: video files or image folders in, a cue bundle and its counts out.

Opens the videos, loads the calibration and calls cues.extract.extract_cues. A video that cannot
be opened is left out with its reason in CueStats.dropped, like one that Stage 0 itself cannot use.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Sequence
from pathlib import Path

from ..cues.config import CueConfig
from ..engine import Engine
from ..errors import BadVideoName, InputError, NoUsableVideos
from ..record.sink import Sink
from ..sync.config import SyncConfig
from ..cue_stats import CueStats
from ..types import CueBundle

log = logging.getLogger(__name__)

PathLike = str | os.PathLike


def open_sources(paths: Sequence[PathLike], fps: float | None
                 ) -> tuple[list, dict[str, str], dict[str, str]]:
    """(opened sources, {name: path} of every input, {name: reason} for those not opened)."""
    from ..io.video import open_video

    sources, inputs, dropped = [], {}, {}
    for p in paths:
        p = Path(p)
        try:
            src = open_video(p, fps=fps)
        except BadVideoName:  # the caller's to fix (rename the file), not a video to leave out
            raise
        except InputError as exc:
            name = p.stem if p.suffix else p.name
            dropped[name] = f"could not be opened: {exc}"
            inputs[name] = str(p)
            log.warning("%s", exc)
            continue
        sources.append(src)
        inputs[src.info.name] = str(p)
    return sources, inputs, dropped


def check_cue_config(cfg: CueConfig) -> None:
    """Settings that need an optional package fail before any decoding."""
    from ..cues.cameras import camera_features_unavailable

    if why := camera_features_unavailable(cfg.camera.features):
        raise InputError(f"--sfm-features {cfg.camera.features}: {why}")


def run_stage0(videos: Sequence[PathLike], calibration: PathLike | None = None,
               fps: float | None = None, cfg: CueConfig = CueConfig(), sink: Sink | None = None,
               progress: bool = True, engine: Engine | None = None, sync: SyncConfig = SyncConfig()
               ) -> tuple[CueBundle, CueStats, dict[str, str]]:
    """Stage 0 on video files or image folders: (bundle, stats, {name: path} of every input).

    calibration: a file or folder that io.calibration.load_calibration reads, or None to estimate
    the cameras. fps: frame rate of image folders (and of files whose timestamps are unusable).
    engine: where each video's cues are extracted (default: in this process). sync: the run's
    Stage 1 + 2 settings, whose limits of the candidate offsets (--min-overlap-s, --range-s,
    --around) Stage 0's searches obey too.
    InputError when fewer than two videos are given; NoUsableVideos (an InputError that carries
    every video's reason) when fewer than two can be opened or none can be used.
    """
    from ..signals import import_pycolmap
    from ..cues.extract import extract_cues

    # loaded here, on the calling thread: glog installs its own SIGTERM handler when pycolmap
    # loads, and only the main thread can put ours back (a first import on a worker thread could not)
    import_pycolmap()
    from ..io.calibration import load_calibration

    if len(videos) < 2:
        raise InputError(f"need at least 2 videos to synchronize, got {len(videos)}")
    check_cue_config(cfg)
    sources, inputs, dropped = open_sources(videos, fps)
    grid = sync.offset_grid(list(inputs))
    if len(sources) < 2:
        why = "; ".join(f"{n}: {r}" for n, r in dropped.items())
        alone = {s.info.name: "the only readable video: there is no other video to synchronize it with"
                 for s in sources}
        stats = _no_cues({**dropped, **alone}, calibration is not None)
        raise NoUsableVideos(f"fewer than 2 readable videos ({why})", stats, inputs)
    calib = None
    if calibration is not None:
        calib = load_calibration(calibration, [s.info.name for s in sources])
    try:
        bundle, stats = extract_cues(sources, calib, cfg, sink=sink, progress=progress, engine=engine, grid=grid)
    except NoUsableVideos as exc:
        stats = dataclasses.replace(exc.stats, dropped={**dropped, **exc.stats.dropped})
        raise NoUsableVideos(str(exc), stats, inputs) from None
    stats = dataclasses.replace(stats, dropped={**dropped, **stats.dropped})
    return bundle, stats, inputs


def _no_cues(dropped: dict[str, str], calibrated: bool) -> CueStats:
    """Stage 0's record when it stopped before extracting any cue."""
    return CueStats("calibration" if calibrated else "estimated", 0, 0, 0, {}, {}, dict(dropped), {})
