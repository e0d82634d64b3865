"""How the people of two videos give their association, F and time shift (sync/people_pairs.py):
the settings, one docstring per field."""

from __future__ import annotations

from dataclasses import dataclass

from ..geometry.skeleton import GEOMETRY_LANDMARKS, subset_mirror


@dataclass(frozen=True)
class PeoplePairConfig:
    """How the people of two videos give their association, F and time shift."""

    landmarks: tuple[int, ...] = GEOMETRY_LANDMARKS
    """BlazePose landmarks used (indices; closed under the left/right mirror)."""
    noise_share: float = 0.025
    """A landmark's position noise as a share of the person's size in the image (the diagonal of
    the box around its landmarks); a correspondence is an inlier within this many of those."""
    min_noise_px: float = 1.5
    """The noise unit is at least this many px (very small people)."""
    search_step_s: float = 0.2
    """The search tries the candidate shifts this far apart (at least every candidate)..."""
    search_noise: float = 2.0
    """...measuring distances in this many noise units, so that a shift half a step from the
    right one still shows its association."""
    search_frames: int = 24
    """Frames of the overlap (evenly spread) the search scores at each shift."""
    sample_points: int = 200
    """Correspondences (evenly spread in time) each RANSAC sees."""
    max_hypotheses: int = 8
    """Person pairings (with the most correspondences) that propose an F at each shift, each as
    labelled and mirrored."""
    min_pair_points: int = 40
    """A person pairing proposes an F, or is associated, from this many correspondences on."""
    min_pair_inlier_share: float = 0.35
    """An associated person pairing has at least this share of its correspondences as inliers."""
    distinct_s: float = 0.5
    """Two shifts closer than this are one valley of the landscape."""
    min_inliers: int = 150
    """A pair is refused with fewer inlier correspondences at its best shift."""
    min_support_fraction: float = 0.4
    """Shifts with fewer common frames than this share of the median shift's are neither chosen
    nor rivals (a fit over few frames is good by chance)."""
    min_contrast: float = 0.3
    """The best shift's mean cost must lie this share below the landscape's median, else the
    landscape is flat (people who hardly move fit one geometry at every shift)."""
    max_uncertainty_frames: float = 1.0
    """Refused when shifts more than this many frames (of the slower video) from the best fit
    about as well (their per-frame costs not worse by t_min)."""
    t_min: float = 2.0
    """A shift fits worse than the best when the paired difference of their per-frame costs has a
    t-statistic of at least this."""
    min_margin: float = 1.5
    """The best peak of evidence must be this many times as prominent as the next distinct one
    (and as high as another candidate's of other people at another shift), else refused."""
    candidates: int = 12
    """Associations (of the search's best distinct shifts) whose landscapes are sketched (at every
    sketch_every-th shift)..."""
    sketch_every: int = 4
    full_landscapes: int = 2
    """...and the ones of these whose sketch has the most evidence, computed at every shift."""
    irls_iterations: int = 4
    """Reweighting steps of each F fitted on the landscape."""
    fresh_every: int = 4
    """On the landscape, a fresh RANSAC start at every this many shifts (the neighbour's F at all)."""
    refine_loss_scale: float = 0.5
    """soft L1 scale of the continuous refinement, in noise units."""
    refine_max_points: int = 1500
    """Inlier correspondences (evenly spread) the continuous refinement uses."""
    seed: int = 0
    """Seed of OpenCV's random generator for this pair's RANSAC fits."""

    def __post_init__(self) -> None:
        subset_mirror(self.landmarks)  # ValueError when not closed under the mirror
        if self.sketch_every < 1 or self.full_landscapes < 1 or self.noise_share <= 0 or self.search_frames < 8 or self.search_step_s <= 0 or self.search_noise < 1 or self.sample_points < 8 \
                or self.min_pair_points < 8 or self.min_margin < 1 or self.fresh_every < 1:
            raise ValueError(f"PeoplePairConfig out of range: {self}")
