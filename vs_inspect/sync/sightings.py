"""Stage 1 for a pair with a worn camera: its wearer seen by the other camera.

When camera b moves (worn on a head) and camera a's person detector found a head in its frames
(CueBundle.heads), the heads that sit on b's camera centre projected at b's time t − Δ count for
Δ (geometry/sightings.py); both directions of a pair add up. The pair's energy is 1 − (heads at
Δ) / (heads at the peak), 0 at the peak, and its decision asks for a single clear peak: at least
MIN_SIGHTINGS heads, and no offset farther than RIVAL_FRAMES from it with more than
MAX_RIVAL_RATIO of them. The result is a PairLandscape like any other pair's
(residual "sighting", no track pairs), so Stage 2, result.json and the recording take it as they
take the epipolar ones. It is used for a pair whose track pairs gave no accepted offset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..geometry.offsets import grid_around
from ..geometry.sightings import (SightingLandscape, SightingShiftFit, sighting_landscape, sighting_peak,
                                  sighting_shift_fit)
from ..result_types import PairDecision, PairLandscape
from ..types import CueBundle
from .config import SyncConfig
from .landscape import search_offsets

RESIDUAL = "sighting"
RADIUS_FRACTION = 0.015  # a head is on the worn camera's centre within this share of the viewer's diagonal
MIN_SIGHTINGS = 8  # the peak needs this many heads there (both directions of the pair together)
MAX_RIVAL_RATIO = 0.34  # refused when an offset beyond RIVAL_FRAMES has more than this share of its heads
RIVAL_FRAMES = 3.0  # frames of the coarser video beyond which another offset rivals the peak
REFINE_FRAMES = 2.0  # an accepted peak's Δ fitted again within this many frames (one constant shift head-centre)


def sighting_directions(bundle: CueBundle, a: str, b: str) -> list[tuple[str, str]]:
    """(viewer, worn) of the pair that can be measured: the worn camera moves (its per-frame
    centres), the viewer has heads, both have real poses in one world (not pose-free)."""
    out = []
    for viewer, worn in ((a, b), (b, a)):
        if (viewer in bundle.heads and bundle.cameras[worn].is_moving
                and not {viewer, worn} & bundle.pose_free
                and np.isfinite(bundle.heads[viewer][:, 0]).any()):
            out.append((viewer, worn))
    return out


def _direction_inputs(bundle: CueBundle, viewer: str, worn: str) -> tuple:
    """The arguments of geometry.sighting_landscape before the offsets (the viewer's heads; a
    static viewer's one pose for every frame; absent valid masks: every pose valid)."""
    cv, cw = bundle.cameras[viewer], bundle.cameras[worn]
    v_info, w_info = bundle.video(viewer), bundle.video(worn)
    K = cv.K if cv.K.ndim == 2 else cv.K[0]
    pose_v = cv.cam_from_world if cv.is_moving else np.broadcast_to(cv.cam_from_world, (v_info.num_frames, 4, 4))
    valid_v = cv.valid if cv.valid is not None else np.ones(v_info.num_frames, bool)
    valid_w = cw.valid if cw.valid is not None else np.ones(w_info.num_frames, bool)
    return (bundle.heads[viewer], v_info.timestamps_s, K, pose_v, valid_v, w_info.timestamps_s,
            cw.cam_from_world, valid_w)


def direction_landscape(bundle: CueBundle, viewer: str, worn: str, offsets_s: np.ndarray,
                        radius_px: float) -> SightingLandscape:
    """geometry.sighting_landscape of the worn camera's wearer seen by the viewer, over candidate
    Δ = offset_s[worn] − offset_s[viewer]."""
    return sighting_landscape(*_direction_inputs(bundle, viewer, worn), offsets_s, radius_px)


def direction_shift_fit(bundle: CueBundle, viewer: str, worn: str, peak_s: float, offsets_s: np.ndarray,
                        radius_px: float) -> SightingShiftFit:
    """geometry.sighting_shift_fit of the viewer's heads within 2 × radius_px of the worn camera's
    centre at Δ = peak_s (a head a few px to the side of the centre still counts), over
    candidate Δ = offset_s[worn] − offset_s[viewer]."""
    return sighting_shift_fit(*_direction_inputs(bundle, viewer, worn), offsets_s, peak_s, 2.0 * radius_px)


def sighting_pair(bundle: CueBundle, a: str, b: str, cfg: SyncConfig) -> PairLandscape | None:
    """The pair's sighting landscape and decision (None: no direction can be measured)."""
    directions = sighting_directions(bundle, a, b)
    va, vb = bundle.video(a), bundle.video(b)
    grid = cfg.offset_grid(bundle.names)
    offsets = search_offsets(va, vb, cfg.landscape, grid)
    offsets = offsets[grid.within_window(a, b, offsets)]  # the peak and its rivals within --around's window
    if not directions or len(offsets) == 0:
        return None
    near = np.zeros(len(offsets), int)
    moments = np.zeros(len(offsets), int)
    radius = {}
    for viewer, worn in directions:
        v_info = bundle.video(viewer)
        radius[viewer] = RADIUS_FRACTION * math.hypot(v_info.width, v_info.height)
        # Δ of (viewer, worn) is Δ_ab when the viewer is a, -Δ_ab when it is b
        sign = 1.0 if viewer == a else -1.0
        land = direction_landscape(bundle, viewer, worn, sign * offsets, radius[viewer])
        near += land.near
        moments += land.moments
    coarse_s = max(va.frame_interval_s, vb.frame_interval_s)
    land = _decided(a, b, offsets, near, moments, coarse_s, directions, radius)
    if not land.decision.accepted or REFINE_FRAMES <= 0:
        return land
    peak = refine_peak(bundle, a, directions, land.best_offset_s, coarse_s, radius, REFINE_FRAMES,
                       (float(offsets[0]), float(offsets[-1])))
    best = int(np.argmin(np.abs(offsets - peak.offset_s)))
    decision = replace(land.decision, reason=f"{land.decision.reason}; {peak.note()}")
    return replace(land, best_offset_s=peak.offset_s, minima_idx=np.array([best]), decision=decision)


@dataclass(frozen=True)
class RefinedPeak:
    """A sighting peak fitted again with one constant shift between heads and camera (refine_peak)."""

    offset_s: float  # Δ_ab, s; the peak as counted when not refined
    refined: bool  # False: the fit's best Δ lay on the window's border, or too few heads stayed posed
    shift_px: dict[str, np.ndarray]  # {viewer: (2,) mean head − worn camera's centre at offset_s, px}
    rms_px: float  # rms distance of the heads from centre + shift at offset_s, px (NaN: not refined)
    window_frames: float  # the fit's half window, frames of the coarser video

    def note(self) -> str:
        """One clause for the pair's reason."""
        if not self.refined:
            return (f"not refined by a constant head-to-centre shift (the fit's best Δ lies on the border of "
                    f"±{self.window_frames:g} frames, or too few heads stay posed)")
        said = ", ".join(f"{v}: ({s[0]:+.1f}, {s[1]:+.1f}) px" for v, s in self.shift_px.items())
        return (f"refined to Δ={self.offset_s:+.3f} s by a constant shift between the heads and the camera's "
                f"centre ({said}; rms {self.rms_px:.1f} px)")


def refine_peak(bundle: CueBundle, a: str, directions, peak_s: float, coarse_s: float, radius: dict[str, float],
                window_frames: float, bounds_s: tuple[float, float] = (-math.inf, math.inf)) -> RefinedPeak:
    """The peak's Δ_ab fitted again with one constant image shift per direction between its heads
    and the worn camera's centre (geometry.sighting_shift_fit, the heads within twice the radius at
    the peak), on a tenth-of-a-frame grid within window_frames of the peak. The peak as it was
    when the fit's minimum lies on the window's border or no Δ keeps 80 % of a direction's heads
    posed. bounds_s: the pair's search range, which the grid stays in."""
    fine = grid_around(peak_s, window_frames * coarse_s, 0.1 * coarse_s, bounds_s)
    sum_sq = np.zeros(len(fine))
    moments = np.zeros(len(fine), int)
    enough = np.ones(len(fine), bool)
    shifts = {}
    for viewer, worn in directions:
        sign = 1.0 if viewer == a else -1.0  # the viewer's Δ is Δ_ab when it is a, -Δ_ab when it is b
        fit = direction_shift_fit(bundle, viewer, worn, sign * peak_s, sign * fine, radius[viewer])
        enough &= fit.moments >= 0.8 * fit.chosen.sum()
        sum_sq += np.nan_to_num(fit.sum_sq_px2)
        moments += fit.moments
        if fit.chosen.any():  # a direction whose heads are never near the centre has no shift
            shifts[viewer] = fit.shift_px
    with np.errstate(all="ignore"):
        cost = np.where(enough & (moments > 0), sum_sq / moments, np.inf)
    i = int(np.argmin(cost))
    if not np.isfinite(cost[i]) or i in (0, len(fine) - 1):
        return RefinedPeak(float(peak_s), False, {}, float("nan"), window_frames)
    return RefinedPeak(float(fine[i]), True, {v: s[i] for v, s in shifts.items()}, math.sqrt(cost[i]), window_frames)


def _decided(a, b, offsets, near, moments, coarse_s, directions, radius) -> PairLandscape:
    top = int(near.max())
    energy = 1.0 - near / max(top, 1)
    energy = np.where(moments > 0, energy, np.nan)
    best_s, lo, hi, rival = sighting_peak(offsets, near, RIVAL_FRAMES * coarse_s)
    best = int(np.argmin(np.abs(offsets - best_s)))
    # the half-height width over √(heads) (heads scatter about the peak like samples of it), at
    # least a frame of the coarser video: a counted peak can be a frame or more late, as the head is
    # not the camera (refine_frames fits that shift out, but not all of it)
    half = offsets[near >= 0.5 * top] if top else offsets[:0]
    uncertainty = coarse_s
    if top and len(half):
        uncertainty = float(max(uncertainty, (half.max() - half.min()) / (2.0 * math.sqrt(top))))
    edge = lo == 0 or hi == len(near) - 1
    who = "; ".join(f"{v} sees the person carrying {w}" for v, w in directions)
    if top < MIN_SIGHTINGS:
        ok, why = False, (f"sightings of a camera's carrier: {top} heads at most on the camera's centre ({who}), "
                          f"need {MIN_SIGHTINGS}")
    elif rival > MAX_RIVAL_RATIO * top:
        ok, why = False, (f"sightings of a camera's carrier ambiguous: {top} heads at Δ={best_s:+.3f} s, {rival} at "
                          f"an offset more than {RIVAL_FRAMES:g} frames away ({who})")
    elif edge:
        ok, why = False, f"sightings of a camera's carrier peak on the border of the search range ({who})"
    else:
        ok, why = True, (f"sightings of a camera's carrier: {top} heads within "
                         f"{', '.join(sorted({f'{r:.1f} px' for r in radius.values()}))} of the camera's centre at "
                         f"Δ={best_s:+.3f} s, {rival} at any other offset ({who})")
    decision = PairDecision(accepted=ok, reason=why, contrast=1.0 - rival / max(top, 1),
                            second_depth_ratio=rival / max(top, 1), num_minima=1 + int(rival > 0),
                            num_pareto_minima=1, at_range_edge=edge, support_fraction=float(top / max(moments[best], 1)))
    return PairLandscape(a, b, offsets, energy, moments, np.array([best]), best_s, 0.0, uncertainty,
                         0, decision, residual=RESIDUAL)


def with_sightings(bundle: CueBundle, lands: list[PairLandscape], cfg: SyncConfig) -> list[PairLandscape]:
    """lands, where a worn camera's sightings (sync/sightings.py) time a pair whose track pairs gave
    no accepted offset: an accepted sighting landscape takes the pair's place (its reason says
    what the track pairs gave); a rejected one is kept for a pair that had no landscape, and
    otherwise adds its reason to the pair's."""
    out = list(lands)
    names = bundle.names
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            mine = [k for k, p in enumerate(out) if {p.a, p.b} == {a, b}]
            if any(out[k].decision.accepted for k in mine):
                continue
            land = sighting_pair(bundle, a, b, cfg)
            if land is None:
                continue
            if mine and land.decision.accepted:
                land = replace(land, decision=replace(
                    land.decision, reason=f"{land.decision.reason}; its track pairs: {out[mine[0]].decision.reason}"))
                out[mine[0]] = land
            elif not mine:
                out.append(land)
            else:  # both refused: the pair's reason gives both
                old = out[mine[0]]
                out[mine[0]] = replace(old, decision=replace(
                    old.decision, reason=f"{old.decision.reason}; {land.decision.reason}"))
    return out
