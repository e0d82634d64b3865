"""Stage 1 for one pair of videos: its energy landscape over candidate offsets, the decision on
it, the checks at its refined minimum, and with the drift model its (Δ, rate) refinement. A pair
whose cameras give no F (pose-free) is searched around the shift its tracks gave (sync.posefree).
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from ..geometry.offsets import OffsetGrid, grid_between, span_of
from ..result_types import PairDecision, PairLandscape
from ..types import CameraTrack, CueBundle, TrackPairs
from .config import SyncConfig
from .decision import INLIER_PX_FRACTION, check_chosen_offset, check_inliers, check_track_pairs_at_best, check_uncertainty, decide
from .landscape import (PairEnergy, PairInput, RawLandscape, compute_landscape, curvature_uncertainty,
                        landscape_step_s, refine_minimum)
from .posefree import PoseFreeConfig, PoseFreePair
from .rate import fit_rate, rate_landscape, scaled_video


def pair_landscape(bundle: CueBundle, a: str, b: str, cfg: SyncConfig,
                   pose_free: PoseFreePair | None = None, pose_free_pair: bool = False):
    """Stage 1 for one ordered pair: (PairLandscape, PairEnergy or None).

    pose_free_pair: the pair has no usable cameras; pose_free is then what its tracks gave
    (sync.posefree: F, shift, rate), the energy uses the cameras of that F and is searched in a
    window around that shift (None: the pair is rejected with the reason). With the drift model
    (cfg.drift.enabled) the 1-D minimum is refined over (Δ, rate) (sync.rate)."""
    tp = bundle.pair(a, b) or TrackPairs(a, b, np.zeros((0, 2), dtype=np.int64))
    side = {n: PairInput(bundle.video(n), bundle.cameras[n], bundle.tracks[n]) for n in (a, b)}
    grid = cfg.offset_grid(bundle.names)
    window = grid.pair_window(a, b)
    offsets, rate0, decision_cfg = None, 1.0, cfg.decision
    if pose_free_pair:
        if pose_free is None or pose_free.b_from_a is None or pose_free.inlier_share < MIN_POSE_FREE_INLIERS:
            return dataclasses.replace(_pose_free_rejected(bundle, a, b, tp, cfg, pose_free), window_s=window), None
        side, offsets, rate0 = _pose_free_inputs(bundle, a, b, side, cfg, pose_free, grid)
        # one track followed by both cameras is the evidence here (its F explains most matches)
        decision_cfg = dataclasses.replace(cfg.decision, min_track_pairs=min(cfg.decision.min_track_pairs, 1))
    raw, pe, minima, decision, best, best_e, sigma = _decided_landscape(side[a], side[b], tp, cfg, decision_cfg,
                                                                        offsets, grid)
    decision, confirm = _check_stage0_choice(side[a], side[b], tp, cfg, decision_cfg, offsets, decision, best, grid)
    if len(tp.index) == 0 and not decision.accepted:
        decision = PairDecision(False, "no cross-view track pairs (no matched motion, or Stage 0 kept none)",
                                0.0, 0.0, 0, 0, False)
    land = PairLandscape(a, b, raw.offsets_s, raw.energy, raw.support, minima, best, best_e, sigma,
                         len(tp.index), decision, cfg.landscape.residual, raw.robust_scale,
                         confirm_energy=None if confirm is None else confirm.raw.energy,
                         confirm_offset_s=confirm.best_s if confirm is not None and confirm.decision.accepted
                         else float("nan"), window_s=window)
    if pose_free_pair:
        land = dataclasses.replace(land, rate=rate0, pose_free=True)
    if cfg.drift.enabled and math.isfinite(best):
        # b unscaled: the grid starts from (best, rate0) in the pair's own clocks
        side_b = dataclasses.replace(side[b], video=bundle.video(b))
        if pose_free_pair:
            # the rate its tracks gave (a continuous fit on every detection) is sharper than the
            # energy's over a single track, whose terms enter and leave as the rate turns: the
            # pair keeps it, with the energy's minimum at that rate; the energy's (Δ, rate) grid
            # is only the image shown, so it is not fitted
            img = rate_landscape(side[a], side_b, tp, cfg.landscape, cfg.drift, best, rate0, raw.robust_scale)
            if img is not None:
                land = dataclasses.replace(land, log_rate_std=pose_free.log_rate_std, pivot_s=img.pivot_s,
                                           pivot_offset_s=best + (rate0 - 1.0) * img.pivot_s,
                                           pivot_offset_std_s=sigma, rate_landscape=img)
        else:
            fit = fit_rate(side[a], side_b, tp, cfg.landscape, cfg.drift, best, rate0, raw.robust_scale,
                           max(len(tp.index), 1))
            if fit is not None:
                land = dataclasses.replace(land, best_offset_s=fit.offset_s, best_energy=fit.energy,
                                           rate=fit.rate, log_rate_std=fit.log_rate_std, pivot_s=fit.pivot_s,
                                           pivot_offset_s=fit.pivot_offset_s,
                                           pivot_offset_std_s=fit.pivot_offset_std_s,
                                           rate_landscape=fit.landscape)
    return land, pe


class _Decided(NamedTuple):
    """One set of track pairs' landscape, the decision on it and its refined minimum."""

    raw: RawLandscape
    energy_fn: PairEnergy
    minima: np.ndarray  # (M,) int, indices of significant minima, best first
    decision: PairDecision
    best_s: float  # refined best Δ_ab, s (NaN: no minimum)
    best_energy: float
    sigma_s: float  # its 1-sigma from the curvature


def _decided_landscape(a: PairInput, b: PairInput, tp: TrackPairs, cfg: SyncConfig, decision_cfg,
                       offsets: np.ndarray | None, grid: OffsetGrid | None = None) -> _Decided:
    """The landscape of one set of track pairs, the decision on it and the checks at its refined
    minimum."""
    raw, pe = compute_landscape(a, b, tp, cfg.landscape, offsets, grid)
    allowed = None if grid is None else grid.within_window(a.video.name, b.video.name, raw.offsets_s)
    decision, minima = decide(raw.energy, raw.support, raw.offsets_s, len(tp.index), decision_cfg,
                              None if allowed is None or allowed.all() else allowed)
    best, best_e, sigma = float("nan"), float("nan"), float("nan")
    if len(minima):
        best_idx = int(minima[0])
        best, best_e = refine_minimum(pe, raw, best_idx)
        sigma = curvature_uncertainty(raw, best_idx, best_e, len(tp.index))
        va, vb = a.video, b.video
        tau_px = INLIER_PX_FRACTION * max(np.hypot(va.width, va.height),
                                                       np.hypot(vb.width, vb.height))
        r = pe.residuals(best, kind="sampson")
        seen = int(np.isfinite(r).any(axis=1).sum()) if r.ndim == 2 else 0
        r = r[np.isfinite(r)]
        inliers = float(np.mean(np.sqrt(r) < tau_px)) if r.size else float("nan")
        decision = check_inliers(decision, inliers, tau_px, decision_cfg)
        decision = check_track_pairs_at_best(decision, seen, best, decision_cfg)
        frame_s = max(va.frame_interval_s, vb.frame_interval_s)
        decision = check_uncertainty(decision, sigma, best, frame_s, decision_cfg)
    return _Decided(raw, pe, minima, decision, best, best_e, sigma)


def _check_stage0_choice(a: PairInput, b: PairInput, tp: TrackPairs, cfg: SyncConfig, decision_cfg,
                         offsets: np.ndarray | None, decision: PairDecision, best: float,
                         grid: OffsetGrid | None = None) -> tuple[PairDecision, _Decided | None]:
    """(decision, the landscape of the track pairs found by appearance alone or None): the one
    place where Stage 1 looks at what Stage 0 decided about a pair's track pairs. Its minimum
    must lie near the Δ Stage 0 kept them at (TrackPairs.chosen_at_offset_s), and track pairs no
    triangle checked (TrackPairs.unchecked) must be confirmed by the others alone."""
    frame_s = max(a.video.frame_interval_s, b.video.frame_interval_s)
    decision = check_chosen_offset(decision, best, tp.chosen_at_offset_s, frame_s, decision_cfg)
    if decision.accepted and tp.unchecked is not None and tp.unchecked.any() and decision_cfg.enabled \
            and decision_cfg.unchecked_agree_frames > 0:
        return _confirm_without_unchecked(a, b, tp, cfg, decision_cfg, offsets, decision, best, grid)
    return decision, None


def _confirm_without_unchecked(a: PairInput, b: PairInput, tp: TrackPairs, cfg: SyncConfig, decision_cfg,
                               offsets: np.ndarray | None, decision: PairDecision, best: float,
                               grid: OffsetGrid | None = None) -> tuple[PairDecision, _Decided]:
    """(decision, the other track pairs' own landscape and decision): the accepted decision, or
    a rejection when the pair's other track pairs alone (found by
    appearance, without assuming an offset) give no accepted minimum within
    unchecked_agree_frames of the coarser video's frames of best: the unchecked rows were chosen
    by an epipolar vote at an offset no third camera checked, and two views cannot tell a wrong
    vote peak from a right one (a moving body's two sides fit a shifted offset)."""
    keep = ~tp.unchecked
    alone = TrackPairs(tp.a, tp.b, tp.index[keep], None if tp.weight is None else tp.weight[keep])
    confirm = _decided_landscape(a, b, alone, cfg, decision_cfg, offsets, grid)
    own, own_best = confirm.decision, confirm.best_s
    tol_s = decision_cfg.unchecked_agree_frames * max(a.video.frame_interval_s, b.video.frame_interval_s)
    head = (f"no third camera to check: {int(tp.unchecked.sum())} of the {len(tp.index)} track pairs "
            f"were chosen by an epipolar vote at an offset no triangle checked, and the "
            f"{len(alone.index)} found by appearance alone ")
    if not own.accepted:
        why = head + f"give no minimum of their own to confirm {best:+.3f} s ({own.reason})"
    elif abs(own_best - best) > tol_s:
        why = head + (f"put it at {own_best:+.3f} s, not {best:+.3f} s (more than "
                      f"{decision_cfg.unchecked_agree_frames:g} frames, {tol_s * 1000:.0f} ms, apart)")
    else:
        return dataclasses.replace(decision, reason=decision.reason + f"; confirmed by the {len(alone.index)} "
                                   f"track pairs found by appearance alone ({own_best:+.3f} s)"), confirm
    return dataclasses.replace(decision, accepted=False, reason=why), confirm


POSE_FREE_WINDOW_S = 2.0  # a pose-free pair's energy is searched over the shift its tracks gave ± this

MIN_POSE_FREE_INLIERS = 0.5
"""A pose-free pair whose refined F explains fewer of its matches than this has no geometry to
build the energy on (a wrong shift, or too little common motion)."""


def is_pose_free_pair(bundle: CueBundle, a: str, b: str) -> bool:
    """The pair's cameras cannot give F: either video is marked pose-free (K only), or both
    cameras are static at the same centre (no baseline, F = 0)."""
    if a in bundle.pose_free or b in bundle.pose_free:
        return True
    ca, cb = bundle.cameras[a], bundle.cameras[b]
    if ca.is_moving or cb.is_moving:
        return False
    centre = [c.centers()[0] for c in (ca, cb)]
    return bool(np.linalg.norm(centre[0] - centre[1]) < 1e-9)


def _pair_track_rows(bundle: CueBundle, a: str, b: str) -> tuple[int, int]:
    """The track pair seen in most frames by both sides: the one posefree estimates from."""
    tp = bundle.pair(a, b)
    seen = {n: np.isfinite(bundle.tracks[n].xy).all(axis=2).sum(axis=1) for n in (a, b)}
    counts = np.minimum(seen[a][tp.index[:, 0]], seen[b][tp.index[:, 1]])
    i = int(np.argmax(counts))
    return int(tp.index[i, 0]), int(tp.index[i, 1])


def _static_K(cam) -> np.ndarray:
    return cam.K if cam.K.ndim == 2 else cam.K[0]


def pose_free_job(bundle: CueBundle, a: str, b: str, cfg: SyncConfig) -> tuple:
    """The arguments of sync.posefree.estimate_pair for one pose-free pair."""
    ia, ib = _pair_track_rows(bundle, a, b)
    va, vb = bundle.video(a), bundle.video(b)
    pcfg = PoseFreeConfig(estimate_rate=cfg.drift.enabled)
    rng = cfg.offset_grid(bundle.names).pair_bounds(a, span_of(va.timestamps_s), b, span_of(vb.timestamps_s))
    return (va.timestamps_s, bundle.tracks[a].xy[ia], _static_K(bundle.cameras[a]),
            vb.timestamps_s, bundle.tracks[b].xy[ib], _static_K(bundle.cameras[b]), pcfg, rng)


def _pose_free_inputs(bundle: CueBundle, a: str, b: str, side: dict[str, PairInput], cfg: SyncConfig,
                      pf: PoseFreePair, grid: OffsetGrid):
    """(the pair's inputs with the cameras of pf's F, the window of offsets, the rate read at)."""
    cam_a = CameraTrack(_static_K(bundle.cameras[a]), np.eye(4))
    cam_b = CameraTrack(_static_K(bundle.cameras[b]), pf.b_from_a)
    rate0 = pf.rate if cfg.drift.enabled else 1.0
    vb = scaled_video(bundle.video(b), rate0)
    side = {a: dataclasses.replace(side[a], camera=cam_a),
            b: dataclasses.replace(side[b], camera=cam_b, video=vb)}
    step = landscape_step_s(side[a].video, vb, cfg.landscape)
    half = POSE_FREE_WINDOW_S
    lo, hi = grid.pair_bounds(a, span_of(side[a].video.timestamps_s), b, span_of(bundle.video(b).timestamps_s),
                              window=False)
    offsets = grid_between(max(pf.offset_s - half, lo), min(pf.offset_s + half, hi), step, grid.max_count,
                           f"{a!r} and {b!r}")
    return side, offsets, rate0


def _pose_free_rejected(bundle: CueBundle, a: str, b: str, tp: TrackPairs, cfg: SyncConfig,
                        pf: PoseFreePair | None) -> PairLandscape:
    why = ("pose-free pair: its tracks gave no time shift (too little common motion)" if pf is None else
           f"pose-free pair: the F of its best time shift explains {pf.inlier_share:.0%} of the matches "
           f"(< {MIN_POSE_FREE_INLIERS:.0%})")
    nan = float("nan")
    empty = np.zeros(0)
    return PairLandscape(a, b, empty, empty, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64),
                         nan, nan, nan, len(tp.index), PairDecision(False, why, 0.0, 0.0, 0, 0, False),
                         cfg.landscape.residual, nan, pose_free=True)
