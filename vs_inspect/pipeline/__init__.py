"""The pipeline layer: run(inputs, config, sink) -> RunResult, and the stages it sequences.

    from vs_inspect.pipeline import run
    result = run(["cam0.mp4", "cam1.mp4", "cam2.mp4"], calibration="calibration.json")
    print(result.offsets_s)

Stage 0 (stage0.run_stage0): videos -> cue bundle. Stage 1 + 2 (stage12.sync_bundle): cue bundle
-> SyncResult, sequencing sync.pair.pair_landscape (one pair) and sync.stage2.solve_stage2 (the
global solve).
"""

from .config import RunConfig
from .run import run
from .stage0 import open_sources, run_stage0
from .stage12 import pair_landscape, solve_stage2, sync_bundle

__all__ = ["RunConfig", "open_sources", "pair_landscape", "run", "run_stage0", "solve_stage2",
           "sync_bundle"]
