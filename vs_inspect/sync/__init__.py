"""Stage 1 (pair landscapes and decisions) and Stage 2 (global solve)."""

from .config import DecisionConfig, LandscapeConfig, PairSelection, SolveConfig, SyncConfig
from .run import sync_bundle

__all__ = ["DecisionConfig", "LandscapeConfig", "PairSelection", "SolveConfig", "SyncConfig",
           "sync_bundle"]
