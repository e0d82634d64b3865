"""Stage 1 with clock drift: a pair's energy over (Δ, rate) around its 1-D minimum.

Time map of a pair (sync.posefree's convention): τ_a = Δ + rate · τ_b, rate = (1 + drift_b) /
(1 + drift_a). Reading b at rate · τ_b is the same energy with b's frame times scaled by the rate,
so the residuals, kernels and camera sampling of sync.landscape are used unchanged. The rows of
the search turn about a pivot p, b's local time in the middle of the overlap: a column is
c = τ_a - τ_b at τ_b = p, so Δ = c - (rate - 1) · p, and c and the rate are nearly uncorrelated
(which is what Stage 2 is given).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..result_types import RateLandscape
from ..types import TrackPairs, VideoInfo
from .config import DriftConfig, LandscapeConfig

RATE_HALF_WIDTH_PPM = 1000.0  # the (Δ, rate) search spans the pair's rate ± this (pose-free: the rate its tracks gave)
RATE_STEP_PPM = 100.0  # its rows (the rate is then refined continuously)
OFFSET_HALF_WIDTH_FRAMES = 4.0  # its columns: the 1-D minimum ± this many frames of the finer video...
OFFSET_COLUMNS = 17  # ...in this many columns
FIT_ROWS = 3  # the rate: the vertex of a parabola through the row minima within this many rows of the lowest
from .landscape import PairEnergy, PairInput


def scaled_video(v: VideoInfo, rate: float) -> VideoInfo:
    """v with its local times multiplied by rate (b's times in a's clock, up to the offset)."""
    return VideoInfo(v.name, v.width, v.height, v.num_frames, v.timestamps_s * rate,
                     None if v.fps is None else v.fps / rate)


def overlap_pivot_s(va: VideoInfo, vb: VideoInfo, offset_s: float, rate: float) -> float:
    """b's local time in the middle of the common span under τ_a = offset_s + rate · τ_b."""
    lo = max(vb.timestamps_s[0], (va.timestamps_s[0] - offset_s) / rate)
    hi = min(vb.timestamps_s[-1], (va.timestamps_s[-1] - offset_s) / rate)
    return float(0.5 * (lo + hi)) if hi > lo else float(0.5 * (vb.timestamps_s[0] + vb.timestamps_s[-1]))


@dataclass(frozen=True)
class RateFit:
    offset_s: float  # Δ_ab at τ_b = 0 (τ_a = offset_s + rate · τ_b)
    rate: float  # (1 + drift_b) / (1 + drift_a)
    pivot_s: float  # b's local time of the pivot
    pivot_offset_s: float  # τ_a - τ_b at τ_b = pivot_s
    pivot_offset_std_s: float  # 1-sigma (curvature of the energy), NaN when not positive definite
    log_rate_std: float  # 1-sigma of log(rate)
    energy: float  # at the solution
    landscape: RateLandscape


def _energy_row(a: PairInput, b: PairInput, pairs: TrackPairs, cfg: LandscapeConfig, pivot_s: float,
                scale: float, cols_s: np.ndarray, rate: float) -> np.ndarray:
    """E(c, rate) over the pivot offsets cols_s at one rate: b's clock scaled by it (each row of
    the grid has its own rate, so nothing is worth keeping between rows)."""
    b = dataclasses.replace(b, video=scaled_video(b.video, rate))
    e, _ = PairEnergy(a, b, pairs, cfg).energy(cols_s - (rate - 1.0) * pivot_s, scale)
    return e


def rate_landscape(a: PairInput, b: PairInput, pairs: TrackPairs, cfg: LandscapeConfig, drift: DriftConfig,
                   offset_s: float, rate0: float, robust_scale: float) -> RateLandscape | None:
    """The pair's energy over (pivot offset, rate) around (offset_s, rate0): columns the 1-D
    minimum ± offset_half_width_frames at the overlap's middle, rows rate0 ± rate_half_width_ppm;
    None when the grid has no energy (no overlap). What fit_rate searches, and the recording's image."""
    scale = robust_scale if math.isfinite(robust_scale) else 0.0
    step = min(a.video.frame_interval_s, b.video.frame_interval_s * rate0)
    pivot = overlap_pivot_s(a.video, b.video, offset_s, rate0)
    c0 = offset_s + (rate0 - 1.0) * pivot
    cols = c0 + np.linspace(-OFFSET_HALF_WIDTH_FRAMES * step, OFFSET_HALF_WIDTH_FRAMES * step,
                            OFFSET_COLUMNS)
    ppm0 = (rate0 - 1.0) * 1e6
    rates_ppm = ppm0 + np.arange(-RATE_HALF_WIDTH_PPM, RATE_HALF_WIDTH_PPM + 1e-9, RATE_STEP_PPM)
    img = np.stack([_energy_row(a, b, pairs, cfg, pivot, scale, cols, 1.0 + r * 1e-6) for r in rates_ppm])
    if not np.isfinite(img).any():
        return None
    return RateLandscape(pivot, cols, rates_ppm, img)


def fit_rate(a: PairInput, b: PairInput, pairs: TrackPairs, cfg: LandscapeConfig, drift: DriftConfig,
             offset_s: float, rate0: float, robust_scale: float, num_track_pairs: int) -> RateFit | None:
    """(Δ, rate) of the pair near (offset_s, rate0) on the pair's energy; None when the grid
    around it has no energy (no overlap).

    The grid of rate_landscape; sub-cell minima from parabolas (see below). The
    uncertainties are the landscape-curvature figure of sync.landscape.curvature_uncertainty
    per axis (var = E* / (n a), n track pairs: rough; NaN when the energy is flat there)."""
    land = rate_landscape(a, b, pairs, cfg, drift, offset_s, rate0, robust_scale)
    if land is None:
        return None
    pivot, cols, rates_ppm, img = land.pivot_s, land.offsets_s, land.rates_ppm, land.energy
    # per row the sub-column minimum (parabola through its lowest cell and the two beside it);
    # then a parabola over the rows near the lowest: the energy is a mean over terms that enter
    # and leave as the rate turns the time map, so it is noisy cell to cell and flat in the rate
    # over a short overlap; a fit over several rows averages that, and a flat fit says so
    row_c = np.full(len(rates_ppm), np.nan)
    row_e = np.full(len(rates_ppm), np.nan)
    row_a = np.full(len(rates_ppm), np.nan)
    for r, row in enumerate(img):
        if not np.isfinite(row).any():
            continue
        j = int(np.nanargmin(row))
        row_c[r], row_e[r] = cols[j], row[j]
        if 0 < j < len(cols) - 1 and np.isfinite(row[j - 1:j + 2]).all():
            x, e, a2 = _parabola(cols[j - 1:j + 2], row[j - 1:j + 2])
            if a2 > 0 and abs(x - cols[j]) <= cols[1] - cols[0]:
                row_c[r], row_e[r], row_a[r] = x, e, a2
    i = int(np.nanargmin(row_e))
    near = [k for k in range(i - FIT_ROWS, i + FIT_ROWS + 1)
            if 0 <= k < len(rates_ppm) and np.isfinite(row_e[k])]
    u_std = float("nan")
    ppm = float(rates_ppm[i])
    if len(near) >= 3:
        A = np.vander(rates_ppm[near] - rates_ppm[i], 3)
        q, *_ = np.linalg.lstsq(A, row_e[near], rcond=None)
        if q[0] > 0:
            # clipped to the rows fitted: beyond them the parabola is extrapolation
            ppm = float(np.clip(rates_ppm[i] - q[1] / (2 * q[0]),
                                rates_ppm[near[0]], rates_ppm[near[-1]]))
            e_min = max(float(np.polyval(q, ppm - rates_ppm[i])), 1e-12)
            u_std = math.sqrt(e_min / (max(num_track_pairs, 1) * q[0])) * 1e-6
    # the pivot offset at that rate: between the two nearest rows' minima
    ok = np.isfinite(row_c)
    c = float(np.interp(ppm, rates_ppm[ok], row_c[ok]))
    e_best = float(np.interp(ppm, rates_ppm[ok], row_e[ok]))
    a_c = row_a[i]
    c_std = (math.sqrt(max(e_best, 1e-12) / (max(num_track_pairs, 1) * a_c))
             if math.isfinite(a_c) and a_c > 0 else float("nan"))
    rate = 1.0 + ppm * 1e-6
    return RateFit(float(c - (rate - 1.0) * pivot), rate, pivot, float(c), c_std, u_std, e_best, land)


def _parabola(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """(vertex x, vertex y, a) of y = a (x - x0)² + y0 through three points."""
    q = np.polyfit(x - x[1], y, 2)
    if q[0] <= 0:
        return float(x[1]), float(y[1]), float(q[0])
    x0 = -q[1] / (2 * q[0])
    return float(x[1] + x0), float(np.polyval(q, x0)), float(q[0])
