"""Stage 1 (pair landscapes and decisions) and Stage 2 (global solve): the steps, as pure
functions; vs_inspect.pipeline.stage12 runs them over a cue bundle."""

from .config import DecisionConfig, LandscapeConfig, PairSelection, SolveConfig, SyncConfig

__all__ = ["DecisionConfig", "LandscapeConfig", "PairSelection", "SolveConfig", "SyncConfig"]
