"""Stage 1 (pair landscapes and decisions) and Stage 2 (global solve): the steps, as pure
functions; vs_inspect.pipeline.stage12 runs them over a cue bundle.

pairs        which pairs of videos are evaluated
landscape    one pair's energy over candidate offsets (kernels: the compiled sums)
decision     the spurious-pair decision on a landscape and the checks at its minimum
pair         Stage 1 for one pair: landscape, decision, refinement, drift (rate), pose-free pairs
posefree     F, shift and rate of a pair from its tracks alone
sightings    a worn camera's pairs timed by its wearer seen in the other camera
solve        the robust least squares over accepted pairs (drift: with a rate per video)
stage2       per-video offsets from the accepted pairs, each null with its reason
"""

from .config import DecisionConfig, LandscapeConfig, PairSelection, SolveConfig, SyncConfig

__all__ = ["DecisionConfig", "LandscapeConfig", "PairSelection", "SolveConfig", "SyncConfig"]
