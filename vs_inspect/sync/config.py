"""Settings of Stage 1 and Stage 2, one docstring per field. A field whose metadata names a "flag"
is a command-line option (pipeline.config generates it, with the docstring as help). The
measurements behind the defaults are in BENCHMARKS.md ("Measurements behind defaults")."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

from ..errors import InputError, check_fields
from ..geometry.epipolar import RESIDUALS
from ..geometry.offsets import OffsetGrid


@dataclass(frozen=True)
class LandscapeConfig:
    residual: str = field(default="sampson", metadata={"flag": "--energy", "choices": RESIDUALS})
    """Epipolar residual: sampson (default), symmetric, cosine or algebraic (the paper's ablation)."""
    loss: str = field(default="truncated", metadata={"flag": "--loss", "choices": ("truncated", "mean")})
    """Aggregation over (track pair, frame) terms: truncated (robust, default) or mean (the paper's plain mean)."""
    min_overlap_s: float = field(default=1.0, metadata={"flag": "--min-overlap-s"})
    """Only offsets that leave at least this much common time of the two videos are searched."""
    range_s: float | None = field(default=None, metadata={"flag": "--range-s"})
    """Search only |Δ| <= range_s (seconds); None = every offset with enough overlap."""
    step_s: float | None = field(default=None, metadata={"flag": "--step-s"})
    """Grid step of the discrete search; None = the finer of the two frame intervals."""
    around: dict[str, tuple[float, float]] = field(default_factory=dict, metadata={
        "flag": "--around", "append": True, "metavar": "NAME=OFFSET±WINDOW",
        "help": "search that video's offset only within OFFSET±WINDOW seconds of the reference's time "
                "(also NAME=OFFSET+-WINDOW or NAME=OFFSET:WINDOW; repeatable)",
        "apply": lambda items, land: replace(land, around={**land.around, **parse_around(items)})})
    """Per-video search window: name -> (offset_s, half width s); its pairs search only the Δ these windows allow."""
    refine: bool = True
    """Refine the best discrete offset below the grid step (bounded 1-D search on the continuous energy)."""
    threads: int = 0
    """Worker threads of the compiled kernel; 0 = numba's default (all cores)."""

    def __post_init__(self) -> None:
        if self.residual not in RESIDUALS:
            raise ValueError(f"unknown residual {self.residual!r}; choose one of {RESIDUALS}")
        if self.loss not in ("truncated", "mean"):
            raise ValueError(f"unknown loss {self.loss!r}; choose truncated or mean")
        check_fields(self, positive=("range_s", "step_s"),
                     nonnegative=("min_overlap_s", "threads"))
        for name, (offset_s, half_s) in self.around.items():
            if not (math.isfinite(offset_s) and math.isfinite(half_s) and half_s >= 0):
                raise ValueError(f"--around {name}: the offset must be a number and the window a number "
                                 f">= 0, got {offset_s}±{half_s}")
            if self.range_s is not None and abs(offset_s) - half_s > self.range_s:
                raise ValueError(f"--around {name}={offset_s:g}±{half_s:g} lies outside --range-s "
                                 f"{self.range_s:g} (|offset| - window > range)")

    def offset_grid(self, reference: str | None = None) -> OffsetGrid:
        """The limits of every pair's candidate offsets: --min-overlap-s, --range-s and the
        --around windows, whose origin is the reference video (offset 0)."""
        return OffsetGrid(self.min_overlap_s, self.range_s,
                          tuple((n, o - w, o + w) for n, (o, w) in sorted(self.around.items())), reference)


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_AROUND = re.compile(rf"^(?P<name>[^=]+)=\s*(?P<offset>{_NUMBER})\s*(?:±|\+-|:)\s*(?P<window>{_NUMBER})$")


def parse_around(items: list[str]) -> dict[str, tuple[float, float]]:
    """NAME=OFFSET±WINDOW items (--around; ± may be written +- or :) as {name: (offset_s, window_s)}."""
    out: dict[str, tuple[float, float]] = {}
    for item in items:
        m = _AROUND.match(item.strip())
        if m is None:
            raise ValueError(f"--around must be NAME=OFFSET±WINDOW in seconds (or NAME=OFFSET+-WINDOW, "
                             f"NAME=OFFSET:WINDOW), for example cam1=1.5±0.5; got {item!r}")
        window = float(m["window"])
        if window < 0:
            raise ValueError(f"--around {item!r}: the window must be >= 0")
        out[m["name"].strip()] = (float(m["offset"]), window)
    return out


@dataclass(frozen=True)
class DecisionConfig:
    enabled: bool = field(default=True, metadata={
        "flag": "--no-spurious-filter", "negate": True,
        "help": "turn off the spurious-pair filter: accept every pair with a minimum, ambiguous "
                "or not (the paper's ablation)"})
    """Refuse pairs whose landscape is flat, ambiguous or too weak (off: every pair with a minimum counts)."""
    min_track_pairs: int = 8
    """A pair with fewer cross-view track pairs (or fewer seen at its minimum) is refused."""
    max_uncertainty_frames: float = 1.0
    """A minimum whose 1-sigma is wider than this many frames of the coarser video is refused; 0: no check."""
    unchecked_agree_frames: float = 2.0
    """A pair with unchecked track pairs (two static cameras no third one checks) is accepted only if its descriptor pairs alone give an accepted minimum within this many frames; 0 = no check."""
    chosen_agree_frames: float = 2.0
    """Reject when the best minimum lies more than this many frames of the coarser video from the Δ at which Stage 0 kept the pair's track pairs (the joint vote's); 0 = no check."""

    def __post_init__(self) -> None:
        check_fields(self, nonnegative=("min_track_pairs", "unchecked_agree_frames", "chosen_agree_frames",
                                        "max_uncertainty_frames"))


@dataclass(frozen=True)
class SolveConfig:
    solver: str = field(default="irls", metadata={"flag": "--solver", "choices": ("irls", "ls")})
    """irls (Huber-loss iteratively reweighted least squares, default) or ls (plain least squares)."""
    huber_delta_s: float | None = field(default=None, metadata={"flag": "--huber-delta-s"})
    """Huber threshold in seconds; None = half the coarsest frame interval of the videos."""
    max_iterations: int = 50
    """IRLS iterations at most."""
    reference: str | None = field(default=None, metadata={"flag": "--reference", "metavar": "NAME"})
    """Video whose offset is 0; None = the first video."""

    def __post_init__(self) -> None:
        if self.solver not in ("irls", "ls"):
            raise ValueError(f"unknown solver {self.solver!r}; choose irls or ls")
        check_fields(self, positive=("huber_delta_s", "max_iterations"))


@dataclass(frozen=True)
class PairSelection:
    mode: str = field(default="all", metadata={
        "flag": "--pairs", "type": str, "metavar": "{all,FRACTION,rst,knn:K}",
        "apply": lambda text, sel: PairSelection.parse(text, sel.seed)})
    """Pairs of videos to evaluate: all, a random FRACTION (keeping every video connected), rst (a random spanning tree) or knn:K (each camera with the K nearest in viewing direction)."""
    fraction: float = 1.0
    """Share of pairs for mode 'fraction'."""
    seed: int = field(default=0, metadata={"flag": "--seed"})
    """Seed of random pair selection."""
    k: int = 4
    """Nearest cameras per camera for mode 'knn'."""

    def __post_init__(self) -> None:
        check_fields(self, nonnegative=("seed",), positive=("k",))
        if self.mode not in ("all", "rst", "fraction", "knn"):
            raise ValueError(f"unknown pair selection {self.mode!r}; choose all, rst, fraction or knn")
        if not 0 < self.fraction <= 1:
            raise ValueError(f"--pairs fraction must be in (0,1], got {self.fraction}")

    @staticmethod
    def parse(text: str, seed: int = 0) -> PairSelection:
        """'all' | 'rst' | a fraction in (0,1] such as '0.5' | 'knn:K' with K >= 1 such as 'knn:4'."""
        if text in ("all", "rst"):
            return PairSelection(text, 1.0, seed)
        if text.startswith("knn:"):
            k = text.removeprefix("knn:")
            if not k.isdigit() or int(k) < 1:
                raise ValueError(f"--pairs knn:K needs a whole number K >= 1, got {text!r}")
            return PairSelection("knn", 1.0, seed, int(k))
        try:
            frac = float(text)
        except ValueError:
            raise ValueError(f"--pairs must be all, rst, knn:K or a fraction in (0,1], got {text!r}") from None
        if not 0 < frac <= 1:
            raise ValueError(f"--pairs fraction must be in (0,1], got {frac}")
        return PairSelection("fraction", frac, seed)


@dataclass(frozen=True)
class DriftConfig:
    enabled: bool = field(default=False, metadata={"flag": "--drift", "enable": True})
    """Solve each clock's drift too (t_global = offset_s + (1 + drift) t_local); off: one constant offset."""
    prior_ppm: float = 1000.0
    """Each drift's zero-mean prior (1-sigma, ppm), so that pairs too short to tell it leave it near 0."""

    def __post_init__(self) -> None:
        check_fields(self, positive=("prior_ppm",))


@dataclass(frozen=True)
class SightingConfig:
    enabled: bool = field(default=True, metadata={
        "flag": "--no-sightings", "negate": True,
        "help": "do not time pairs with a worn camera by its wearer seen by the other camera "
                "(the bundle's heads)"})
    """Time a worn camera's pair its track pairs leave open by its wearer seen in the other camera."""
    max_chain: int = 1
    """Sighting pairs a video's offset may rest on in a chain from the reference (their errors add up)."""

    def __post_init__(self) -> None:
        check_fields(self, nonnegative=("max_chain",))


@dataclass(frozen=True)
class SyncConfig:
    landscape: LandscapeConfig = LandscapeConfig()
    decision: DecisionConfig = DecisionConfig()
    solve: SolveConfig = SolveConfig()
    pairs: PairSelection = PairSelection()
    drift: DriftConfig = DriftConfig()
    sightings: SightingConfig = SightingConfig()

    def offset_grid(self, names: list[str]) -> OffsetGrid:
        """The limits of every pair's candidate offsets among the videos names (--min-overlap-s,
        --range-s, --around about the reference: --reference or the first name). InputError for a
        window of no video of names, or a window of the reference that leaves out 0."""
        reference = self.solve.reference or names[0]
        check_windows(self.landscape, list(names), reference)
        return self.landscape.offset_grid(reference)


def check_windows(cfg: LandscapeConfig, names: list[str], reference: str) -> None:
    """InputError for an --around window of no video of names, or of the reference outside 0."""
    for name, (offset_s, half_s) in cfg.around.items():
        if name not in names:
            raise InputError(f"--around {name}: no video is named {name!r}; known: {', '.join(names)}")
        if name == reference and abs(offset_s) > half_s:
            raise InputError(f"--around {name}={offset_s:g}±{half_s:g}: {name} is the reference, whose "
                             f"offset is 0 by definition, outside the window")
