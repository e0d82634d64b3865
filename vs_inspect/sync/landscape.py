"""Stage 1: the energy landscape E_ab(Δ) of one pair of videos, its refinement and uncertainty.

Δ_ab = offset_s[b] - offset_s[a]: x_a(t + Δ) and x_b(t) show the same moment (DESIGN.md).
The video with the lower frame rate is read at its own frames and the other is interpolated,
which keeps interpolation error small. A moving camera contributes its pose at its own moment.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numba
import numpy as np
from scipy.optimize import minimize_scalar

from ..geometry.epipolar import epipolar_residual, fundamental_from_cameras
from ..geometry.offsets import OffsetGrid, span_of
from ..geometry.sampling import camera_at_frames, camera_between_frames, tracks_between_frames
from ..geometry.timing import frame_brackets
from ..types import CameraTrack, TrackPairs, Tracks, VideoInfo
from . import kernels
from .config import LandscapeConfig

log = logging.getLogger(__name__)

MIN_TERMS = 30  # an offset with fewer (track pair, frame) terms gets no energy (NaN)


@dataclass(frozen=True)
class PairInput:
    """One side of a pair: a video with its camera and tracks."""

    video: VideoInfo
    camera: CameraTrack
    tracks: Tracks


@dataclass(frozen=True)
class RawLandscape:
    offsets_s: np.ndarray  # (D,) Δ_ab candidates, seconds
    energy: np.ndarray  # (D,) normalized energy, NaN where support < MIN_TERMS
    support: np.ndarray  # (D,) int, number of terms
    robust_scale: float  # truncation level used (residual units), NaN for the plain mean


def landscape_step_s(va: VideoInfo, vb: VideoInfo, cfg: LandscapeConfig) -> float:
    """The grid step of a pair's landscape: --step-s, else the finer of the two frame intervals."""
    return cfg.step_s or min(va.frame_interval_s, vb.frame_interval_s)


def search_offsets(va: VideoInfo, vb: VideoInfo, cfg: LandscapeConfig,
                   grid: OffsetGrid | None = None) -> np.ndarray:
    """Candidate Δ_ab on a grid through 0, leaving >= min_overlap_s of common time, within
    --range-s. The --around windows do not crop it: the energy's statistics (its median, the
    rivals' prominence) are read over the whole range, and the decision takes its minimum within
    the window only (grid.within_window; grid: the run's, with its reference)."""
    grid = cfg.offset_grid() if grid is None else grid
    return grid.pair_offsets(va.name, span_of(va.timestamps_s), vb.name, span_of(vb.timestamps_s),
                             landscape_step_s(va, vb, cfg), window=False)


class PairEnergy:
    """Evaluates E_ab(Δ) for any set of offsets; holds the prepared arrays of one pair."""

    def __init__(self, a: PairInput, b: PairInput, pairs: TrackPairs, cfg: LandscapeConfig):
        self.cfg = cfg
        # Sample the coarser video at its frames; interpolate the finer one.
        self.sample_is_a = a.video.frame_interval_s > b.video.frame_interval_s
        s, i = (a, b) if self.sample_is_a else (b, a)
        self.s, self.i = s, i
        idx = pairs.index
        # writable C arrays always: read-only ones (a Ray task's inputs) would make numba compile
        # and cache a second specialization of the kernels for the same work
        def own(x, dtype=None):
            return np.require(x, dtype=dtype, requirements=("C", "W"))
        self.pair_s = own(idx[:, 0] if self.sample_is_a else idx[:, 1])
        self.pair_i = own(idx[:, 1] if self.sample_is_a else idx[:, 0])
        self.weight = (np.ones(len(idx)) if pairs.weight is None else own(pairs.weight, np.float64))
        self.xs = own(s.tracks.xy, np.float64)
        self.xi = own(i.tracks.xy, np.float64)
        # τ_i = t_s + sign·Δ_ab (a's time is b's time + Δ).
        self.sign = -1.0 if self.sample_is_a else 1.0
        self.moving = a.camera.is_moving or b.camera.is_moving
        self.threads = cfg.threads or numba.get_num_threads()
        if not self.moving:
            F_ab = fundamental_from_cameras(a.camera.K, a.camera.cam_from_world,
                                            b.camera.K, b.camera.cam_from_world)
            self.G_static = own(F_ab if self.sample_is_a else F_ab.T)

    def _brackets(self, offsets_s: np.ndarray):
        q = self.s.video.timestamps_s[None, :] + self.sign * offsets_s[:, None]
        return frame_brackets(self.i.video.timestamps_s, q)

    def _G_moving(self, k: np.ndarray, w: np.ndarray) -> np.ndarray:
        """(D,Ts,3,3) G between s at its frame j and i at its interpolated moment."""
        D, Ts = k.shape
        cam_s = camera_at_frames(self.s.camera, np.broadcast_to(np.arange(Ts), (D, Ts)))
        cam_i = camera_between_frames(self.i.camera, k, w)
        invalid = ~(cam_s.valid & cam_i.valid)
        # K is inverted: a placeholder keeps the batched inverse finite (NaN poses just give NaN);
        # the G of invalid terms is discarded below
        K_s, T_s, T_i = cam_s.K, cam_s.cam_from_world, cam_i.cam_from_world
        K_i = np.where(invalid[..., None, None], np.eye(3), cam_i.K)
        if not cam_s.valid.all():
            K_s = np.where(invalid[..., None, None], np.eye(3), K_s)
        with np.errstate(invalid="ignore", divide="ignore"):
            G = fundamental_from_cameras(K_s, T_s, K_i, T_i)
        G[invalid] = np.nan
        return np.ascontiguousarray(G)

    def sums(self, offsets_s: np.ndarray, loss: str, scale: float):
        """(loss sum, weight sum, term count) per offset, from the compiled kernel."""
        offsets_s = np.asarray(offsets_s, dtype=np.float64)
        k, w = self._brackets(offsets_s)
        k = np.ascontiguousarray(k)
        w = np.ascontiguousarray(w)
        args = (self.xs, self.xi, self.pair_s, self.pair_i, self.weight)
        code = kernels.RESIDUAL_CODE[self.cfg.residual]
        lcode = kernels.LOSS_CODE[loss]
        if self.moving:
            G = self._G_moving(k, w)
            return kernels.landscape_moving(*args, G, k, w, code, lcode, float(scale), self.threads)
        return kernels.landscape_static(*args, self.G_static, k, w, code, lcode, float(scale),
                                        self.threads)

    def energy(self, offsets_s: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
        acc, wsum, cnt = self.sums(offsets_s, self.cfg.loss, scale)
        with np.errstate(invalid="ignore", divide="ignore"):
            e = acc / wsum
        e[cnt < MIN_TERMS] = np.nan
        return e, cnt

    def residuals(self, offset_s: float, max_pairs: int | None = None,
                  kind: str | None = None) -> np.ndarray:
        """(P',Ts) residuals of every term at one offset (NaN where undefined); for scale and plots.

        kind overrides the configured residual (e.g. Sampson for the inlier check)."""
        sel = np.arange(len(self.pair_s))
        if max_pairs is not None and len(sel) > max_pairs:
            sel = np.linspace(0, len(sel) - 1, max_pairs).round().astype(int)
        k, w = self._brackets(np.array([offset_s]))
        k, w = k[0], w[0]
        y = tracks_between_frames(self.xi, k, w, self.pair_i[sel])
        x = self.xs[self.pair_s[sel]]
        if self.moving:
            G = self._G_moving(k[None], w[None])[0]
        else:
            G = self.G_static
        with np.errstate(invalid="ignore", divide="ignore"):
            return epipolar_residual(G, x, y, kind or self.cfg.residual)

    def auto_scale(self, offsets_s: np.ndarray) -> float:
        """Truncation level: 9 x the smallest per-offset median residual, on a subsample.

        The median ignores up to half wrong track pairs; the best offset's median measures the
        noise of right pairs, in whatever units the residual has.
        """
        coarse = offsets_s[:: max(1, len(offsets_s) // 60)]
        best = np.inf
        for d in coarse:
            r = self.residuals(float(d), max_pairs=300)
            r = r[np.isfinite(r)]
            if r.size >= MIN_TERMS:
                best = min(best, float(np.median(r)))
        if not np.isfinite(best) or best <= 0:
            return np.inf
        return 9.0 * best


def compute_landscape(a: PairInput, b: PairInput, pairs: TrackPairs, cfg: LandscapeConfig,
                      offsets_s: np.ndarray | None = None,
                      grid: OffsetGrid | None = None) -> tuple[RawLandscape, PairEnergy]:
    """The discrete landscape over the pair's search grid (search_offsets with grid), or over
    offsets_s (D,) seconds when given (a pose-free pair's window around the offset its tracks gave)."""
    offsets = search_offsets(a.video, b.video, cfg, grid) if offsets_s is None else np.asarray(offsets_s, float)
    pe = PairEnergy(a, b, pairs, cfg)
    if len(offsets) == 0 or len(pairs.index) == 0:
        nan = np.full(len(offsets), np.nan)
        return RawLandscape(offsets, nan, np.zeros(len(offsets), dtype=np.int64), np.nan), pe
    if cfg.loss == "mean":
        scale = np.nan
    else:  # the truncation level: 9 x the median residual at the best coarse offset
        scale = pe.auto_scale(offsets)
    energy, support = pe.energy(offsets, scale if np.isfinite(scale) else 0.0)
    return RawLandscape(offsets, energy, support, scale), pe


def refine_minimum(pe: PairEnergy, raw: RawLandscape, best_idx: int) -> tuple[float, float]:
    """Sub-grid refinement of the minimum at best_idx: (offset_s, energy)."""
    off = raw.offsets_s
    step = off[1] - off[0] if len(off) > 1 else 0.0
    if not pe.cfg.refine or step == 0:
        return float(off[best_idx]), float(raw.energy[best_idx])
    scale = raw.robust_scale if np.isfinite(raw.robust_scale) else 0.0

    def f(x: float) -> float:
        e, _ = pe.energy(np.array([x]), scale)
        return float(e[0]) if np.isfinite(e[0]) else float(np.nanmax(raw.energy))

    lo, hi = off[best_idx] - step, off[best_idx] + step
    res = minimize_scalar(f, bounds=(lo, hi), method="bounded",
                          options={"xatol": min(1e-4, step / 100)})
    x, e = float(res.x), float(res.fun)
    if e > raw.energy[best_idx]:
        return float(off[best_idx]), float(raw.energy[best_idx])
    return x, e


def curvature_uncertainty(raw: RawLandscape, best_idx: int, best_energy: float,
                          num_track_pairs: int) -> float:
    """1-sigma of Δ from a parabola through the minimum: var ≈ E* / (n · a) for E ≈ a(Δ-Δ*)² + E*.

    n is the number of track pairs (not terms: terms of one track are correlated), so this is a
    conservative, rough figure; NaN when the neighbours are missing.
    """
    e, off = raw.energy, raw.offsets_s
    if best_idx <= 0 or best_idx >= len(e) - 1:
        return float("nan")
    lo, mid, hi = e[best_idx - 1], e[best_idx], e[best_idx + 1]
    step = off[1] - off[0]
    a = (lo + hi - 2 * mid) / (2 * step * step)
    if not (np.isfinite(a) and a > 0) or num_track_pairs < 1:
        return float("nan")
    return float(math.sqrt(max(best_energy, 1e-12) / (num_track_pairs * a)))
