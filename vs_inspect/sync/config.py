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
    robust_scale: float | None = None
    """Truncation level of the robust loss in the residual's units (px² for sampson); None = 9 x the median residual at the best coarse offset."""
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
    min_terms: int = 30
    """An offset with fewer (track pair, frame) terms gets no energy (NaN)."""
    refine: bool = True
    """Refine the best discrete offset below the grid step (bounded 1-D search on the continuous energy)."""
    threads: int = 0
    """Worker threads of the compiled kernel; 0 = numba's default (all cores)."""

    def __post_init__(self) -> None:
        if self.residual not in RESIDUALS:
            raise ValueError(f"unknown residual {self.residual!r}; choose one of {RESIDUALS}")
        if self.loss not in ("truncated", "mean"):
            raise ValueError(f"unknown loss {self.loss!r}; choose truncated or mean")
        check_fields(self, positive=("robust_scale", "range_s", "step_s", "min_terms"),
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
    """Reject pairs whose landscape is ambiguous (off = accept every pair with a minimum: the ablation)."""
    min_track_pairs: int = 8
    """A pair with fewer cross-view track pairs, or whose best offset is seen by fewer of them, is rejected: a few wrong matches can line up by chance at some offset."""
    min_support_fraction: float = 0.4
    """Reject when the best minimum rests on fewer (track pair, frame) terms than this fraction of the landscape's median count (a mean over few terms dips by chance)."""
    min_contrast: float = 0.3
    """Reject when the best energy is less than this fraction below the landscape's median (flat landscape)."""
    max_second_ratio: float = 0.7
    """Reject when another minimum (with comparable overlap) is at least this prominent relative to the best."""
    max_minima: int = 2
    """Reject when more local minima than this are at least half as prominent as the best (the paper uses 2)."""
    min_rival_support: float = 0.5
    """Another minimum competes with the best only if its overlap (term count) is at least this fraction of the best's."""
    min_prominence: float = 0.1
    """A local minimum counts only with a prominence of this fraction of the best depth."""
    min_inlier_fraction: float = 0.45
    """Reject when fewer observations than this lie within inlier_px_fraction of the image diagonal of their epipolar line at the best offset (all-wrong matches, wrong poses)."""
    inlier_px_fraction: float = 0.01
    """Inlier distance for that check, as a fraction of the larger image diagonal (1 % = 14.7 px at 1280x720)."""
    reject_range_edge: bool = True
    """Reject when the best minimum lies on the border of the search range."""
    unchecked_agree_frames: float = 2.0
    """A pair with unchecked track pairs (two static cameras no third one checks) is accepted only if its descriptor pairs alone give an accepted minimum within this many frames; 0 = no check."""

    chosen_agree_frames: float = 2.0
    """Reject when the best minimum lies more than this many frames of the coarser video from the Δ at which Stage 0 kept the pair's track pairs (the joint vote's); 0 = no check."""
    max_uncertainty_frames: float = 1.0
    """Reject when the best minimum's 1-sigma (from its curvature and the number of track pairs) is wider than this many frames of the coarser video; 0 = no check."""

    def __post_init__(self) -> None:
        check_fields(self, nonnegative=("min_track_pairs", "unchecked_agree_frames", "chosen_agree_frames",
                                        "max_uncertainty_frames"),
                     positive=("max_minima",),
                     fraction=("min_contrast", "max_second_ratio", "min_rival_support", "min_prominence",
                               "min_inlier_fraction", "inlier_px_fraction", "min_support_fraction"))


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
    """Clock drift: solve a rate per video besides its offset (t_global = offset_s + (1 + drift) * t_local), each accepted pair refined around its minimum. Off: one constant offset."""
    rate_half_width_ppm: float = 1000.0
    """The (Δ, rate) search spans the pair's rate ± this many ppm (pose-free pairs: around the rate their tracks gave)."""
    rate_step_ppm: float = 100.0
    """Row spacing of that search (and of the recording's image); the minimum is then refined continuously."""
    offset_half_width_frames: float = 4.0
    """Its columns: the 1-D minimum ± this many frames of the finer video, at the overlap's middle."""
    offset_columns: int = 17
    """Number of columns."""
    fit_rows: int = 3
    """The rate is the vertex of a parabola through the row minima within this many rows of the lowest."""
    prior_ppm: float = 1000.0
    """Stage 2: each video's drift has a zero-mean prior of this 1-sigma (ppm), so that pairs too short to tell the rate leave it near 0 instead of at noise."""

    def __post_init__(self) -> None:
        check_fields(self, positive=("rate_half_width_ppm", "rate_step_ppm", "offset_half_width_frames",
                                     "offset_columns", "fit_rows", "prior_ppm"))


@dataclass(frozen=True)
class PoseFreeSyncConfig:
    window_s: float = 2.0
    """A pose-free pair's energy is searched over the offset its tracks gave ± this (seconds)."""

    def __post_init__(self) -> None:
        check_fields(self, positive=("window_s",))


@dataclass(frozen=True)
class SightingConfig:
    enabled: bool = field(default=True, metadata={
        "flag": "--no-sightings", "negate": True,
        "help": "do not time pairs with a worn camera by its wearer seen by the other camera "
                "(the bundle's heads)"})
    """Time a pair whose track pairs gave no accepted offset by a moving camera's wearer seen in the other camera (the bundle's heads: sync/sightings.py)."""
    radius_fraction: float = 0.015
    """A head counts as on the worn camera's centre within this fraction of the viewer's image diagonal (10.9 px at 512x512)."""
    min_sightings: int = 8
    """The peak needs at least this many heads on the centre (both directions of the pair together)."""
    max_rival_ratio: float = 0.34
    """Rejected when an offset farther than rival_frames from the peak has more than this fraction of its heads."""
    rival_frames: float = 3.0
    """Frames of the coarser video beyond which another offset is a rival of the peak."""
    refine_frames: float = 2.0
    """An accepted peak's Δ is fitted again within this many frames of the coarser video, with one constant image shift between the wearer's head and the camera's centre; 0: the peak as counted."""
    max_chain: int = 1
    """A video's offset may rest on at most this many sighting pairs in a chain from the reference (their errors add up; epipolar pairs do not count)."""

    def __post_init__(self) -> None:
        check_fields(self, nonnegative=("max_chain", "refine_frames"),
                     positive=("radius_fraction", "min_sightings", "rival_frames"), fraction=("max_rival_ratio",))


@dataclass(frozen=True)
class SyncConfig:
    landscape: LandscapeConfig = LandscapeConfig()
    decision: DecisionConfig = DecisionConfig()
    solve: SolveConfig = SolveConfig()
    pairs: PairSelection = PairSelection()
    drift: DriftConfig = DriftConfig()
    pose_free: PoseFreeSyncConfig = PoseFreeSyncConfig()
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
