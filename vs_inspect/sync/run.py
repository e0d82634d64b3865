"""Moved to vs_inspect.pipeline.stage12 (kept so that older imports keep working)."""

from ..pipeline.stage12 import pair_landscape, solve_stage2, sync_bundle  # noqa: F401
