"""What a recording shows beyond the stages' own results, computed before it reaches the sink.

A stage builds these views only for a sink that records (sink.options is not None) and hands them
to it; RerunSink then logs them as they are. Numbers only: no rerun here.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from ..eval.metrics import offset_errors_ms
from .diagnose import loop_closures
from .epipolar_sweep import EpipolarSweep, epipolar_sweep
from .trajectories import PairTrajectories, run_trajectories
from .record_options import RecordOptions
from ..result_types import PairLandscape, RateLandscape, SyncResult
from ..types import CueBundle, VideoInfo

GRAPH_RADIUS_PX = 300.0  # video nodes sit on a circle of this radius in the pair graph view
GRAPH_PAIR_AT = 0.35  # a pair's node sits this far along the chord from a to b (not halfway:
# the chords of opposite videos all cross at the centre, and their labels would overlap there)


@dataclass(frozen=True)
class PairRecordView:
    """One pair as the recording shows it, besides its PairLandscape."""

    true_offset_s: float | None  # Δ_ab from the truth, seconds (None: unknown)
    true_energy: float | None  # landscape energy interpolated at true_offset_s (None: unknown or no finite energy)
    sweep: EpipolarSweep | None  # epipolar lines at the offsets chosen for the view (None: none shown)
    sweep_median_px: np.ndarray  # (D,) px, median point-line distance at each sweep offset, NaN where none
    rate_image: np.ndarray | None = None  # (H,W,3) uint8 RGB, the (Δ, rate) energy (drift model; rate_landscape_image)


@dataclass(frozen=True)
class VideoTracksView:
    """The tracks of one video that the recording shows."""

    xy: np.ndarray  # (N,T,2) px, NaN where unseen (the chosen rows of the video's tracks)
    instance: np.ndarray  # (N,) int, moving-object instance of each (-1 unknown)


@dataclass(frozen=True)
class TriangleResidual:
    """Loop closure of three pairs: offsets are differences, so Δ_ab + Δ_bc − Δ_ac = 0 when all
    three pairs are right; a large residual names a triangle with at least one wrong pair."""

    a: str
    b: str
    c: str
    residual_ms: float  # Δ_ab + Δ_bc − Δ_ac of the pairs' chosen offsets, ms
    accepted: int  # how many of the three pairs were accepted (0-3)
    tolerance_ms: float  # diagnose's loop tolerance (2 frames of the slowest video, or 3σ)

    @property
    def closes(self) -> bool:
        return abs(self.residual_ms) <= self.tolerance_ms


@dataclass(frozen=True)
class RunRecordView:
    """Stage 2's result as the recording shows it, besides the SyncResult."""

    graph_xy: dict[str, tuple[float, float]]  # node -> position in the pair graph, px; nodes are
    # video names and "a__b" for each evaluated pair (its midpoint)
    true_offsets_s: dict[str, float | None]  # video -> true offset relative to the reference's, s
    errors_ms: dict[str, float | None]  # video -> |error| against the truth, ms (offset_errors_ms)
    tracks: dict[str, VideoTracksView]  # video -> its tracks to log (only videos with tracks)
    trajectories: tuple[PairTrajectories, ...]  # accepted pairs triangulated at the solved offsets
    triangles: tuple[TriangleResidual, ...] = ()  # every triangle of evaluated pairs, largest |residual| first


def record_frame(image_bgr: np.ndarray, options: RecordOptions) -> np.ndarray:
    """(h,w,3) uint8 BGR: the frame as the recording keeps it, at most options.max_image_width_px
    wide (area-averaged; 0 = full resolution)."""
    import cv2
    img = np.asarray(image_bgr)
    h, w = img.shape[:2]
    mw = options.max_image_width_px
    if mw and w > mw:
        img = cv2.resize(img, (mw, max(1, round(h * mw / w))), interpolation=cv2.INTER_AREA)
    return img


def record_mask(instances: np.ndarray, options: RecordOptions) -> np.ndarray:
    """(h,w) uint8 (uint16 beyond 255 instances) instance ids as the recording keeps them, at most
    options.max_mask_width_px wide (nearest neighbour, so that ids stay ids; 0 = full resolution)."""
    import cv2
    m = np.asarray(instances)
    h, w = m.shape[:2]
    m = m.astype(np.uint16 if m.max(initial=0) > 255 else np.uint8)
    mw = options.max_mask_width_px
    if mw and w > mw:
        m = cv2.resize(m, (mw, max(1, round(h * mw / w))), interpolation=cv2.INTER_NEAREST)
    return m


def over_range(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """values (D,) mapped linearly onto the finite range of reference, so that two energies of
    different robust scales share one plot (NaN kept); unchanged when either has no finite value."""
    v = np.asarray(values, dtype=np.float64)
    ok, ref = np.isfinite(v), np.asarray(reference, dtype=np.float64)
    ref = ref[np.isfinite(ref)]
    if not ok.any() or not len(ref):
        return v
    span = float(np.ptp(v[ok]))
    return ref.min() + (v - v[ok].min()) / (span if span > 0 else 1.0) * float(np.ptp(ref))


def sweep_offsets(land: PairLandscape, max_offsets: int) -> np.ndarray:
    """(D,) candidate offsets of the pair's epipolar view: all when max_offsets < 0 or enough,
    else an even spread, the best minima and a dense run around the chosen Δ (plus the chosen Δ)."""
    off = np.asarray(land.offsets_s)
    n = max_offsets
    if n < 0 or len(off) <= n:
        return off
    pick = set(np.linspace(0, len(off) - 1, max(2, n // 2)).round().astype(int).tolist())
    pick |= {int(i) for i in land.minima_idx[:5]}
    if math.isfinite(land.best_offset_s):
        c = int(np.argmin(np.abs(off - land.best_offset_s)))
        half = max(1, (n - len(pick)) // 2)
        pick |= set(range(max(0, c - half), min(len(off), c + half + 1)))
    out = off[sorted(pick)]
    if math.isfinite(land.best_offset_s):
        out = np.unique(np.concatenate([out, [land.best_offset_s]]))
    return out


def pair_record_view(bundle: CueBundle, land: PairLandscape, options: RecordOptions,
                     image_frames: Collection[int] | None = None) -> PairRecordView:
    """The view of one pair. image_frames: frames of video a the sink holds an image of (the
    epipolar view prefers one of them, so that the lines are drawn over the frame)."""
    gt = bundle.gt_offsets_s
    true = (gt[land.b] - gt[land.a]) if gt and land.a in gt and land.b in gt else None
    e = np.asarray(land.energy, dtype=np.float64)
    ok = np.isfinite(e)
    e_true = float(np.interp(true, np.asarray(land.offsets_s)[ok], e[ok])) \
        if true is not None and ok.any() else None
    sweep = None
    med = np.zeros(0)
    # a pose-free pair's cameras are placeholders: no epipolar lines to draw from them
    if options.epipolar_offsets and not land.pose_free:
        sweep = epipolar_sweep(bundle, land.a, land.b, sweep_offsets(land, options.epipolar_offsets),
                               land.best_offset_s, options.epipolar_lines,
                               prefer_frames=set(image_frames) if image_frames is not None else None)
    if sweep is not None:
        med = np.full(len(sweep.offsets_s), np.nan)
        for d in range(len(med)):
            if np.isfinite(sweep.distance_px[d]).any():
                med[d] = float(np.nanmedian(sweep.distance_px[d]))
    image = None
    if land.rate_landscape is not None:
        truth = None
        gd = bundle.gt_drift_ppm
        if true is not None and gd and land.a in gd and land.b in gd:
            da, db = gd[land.a] * 1e-6, gd[land.b] * 1e-6
            rate = (1 + db) / (1 + da)
            truth = (true / (1 + da) + (rate - 1) * land.rate_landscape.pivot_s, (rate - 1) * 1e6)
        elif true is not None:
            truth = (true, 0.0)
        image = rate_landscape_image(land.rate_landscape, (land.pivot_offset_s, (land.rate - 1) * 1e6), truth)
    return PairRecordView(true, e_true, sweep, med, image)


RATE_IMAGE_CELL_PX = 16  # each (offset, rate) cell is drawn as a square of this many pixels


def rate_landscape_image(rl: RateLandscape, chosen: tuple[float, float] | None = None,
                         truth: tuple[float, float] | None = None) -> np.ndarray:
    """(V·c, U·c, 3) uint8 RGB of the energy over (offset at the pivot: columns, left to right;
    rate: rows, lowest ppm at the top), c = RATE_IMAGE_CELL_PX: viridis from the lowest energy
    (dark) to the highest (bright), grey where there is none; a white ring at the chosen
    (pivot offset s, ppm), an orange cross at the truth when known."""
    from matplotlib import colormaps

    e = np.asarray(rl.energy, dtype=np.float64)
    ok = np.isfinite(e)
    lo, hi = (float(e[ok].min()), float(e[ok].max())) if ok.any() else (0.0, 1.0)
    z = np.where(ok, (e - lo) / (hi - lo if hi > lo else 1.0), 0.0)
    rgb = (colormaps["viridis"](z)[..., :3] * 255).round().astype(np.uint8)
    rgb[~ok] = 128
    c = RATE_IMAGE_CELL_PX
    img = np.ascontiguousarray(np.repeat(np.repeat(rgb, c, axis=0), c, axis=1))

    def pixel(off_s: float, ppm: float) -> tuple[int, int] | None:
        cols, rows = np.asarray(rl.offsets_s), np.asarray(rl.rates_ppm)
        if not (math.isfinite(off_s) and math.isfinite(ppm)) or len(cols) < 2 or len(rows) < 1:
            return None
        x = (off_s - cols[0]) / (cols[1] - cols[0])
        y = (ppm - rows[0]) / (rows[1] - rows[0]) if len(rows) > 1 else 0.0
        if not (-0.5 <= x <= len(cols) - 0.5 and -0.5 <= y <= len(rows) - 0.5):
            return None
        return int(round((y + 0.5) * c)), int(round((x + 0.5) * c))

    h, w = img.shape[:2]
    if truth is not None and (p := pixel(*truth)) is not None:
        r0, c0 = p
        for d in range(-c // 2, c // 2 + 1):
            for dy, dx in ((d, d), (d, -d)):
                if 0 <= r0 + dy < h and 0 <= c0 + dx < w:
                    img[r0 + dy, c0 + dx] = (255, 140, 0)
    if chosen is not None and (p := pixel(*chosen)) is not None:
        r0, c0 = p
        yy, xx = np.mgrid[0:h, 0:w]
        ring = np.abs(np.hypot(yy - r0, xx - c0) - c * 0.45) < 1.0
        img[ring] = 255
    return img


def graph_layout(result: SyncResult) -> dict[str, tuple[float, float]]:
    """Videos evenly on a circle, each pair's node on the chord from a to b, GRAPH_PAIR_AT of the
    way from a."""
    names = list(result.offsets_s)
    ang = 2 * np.pi * np.arange(len(names)) / max(len(names), 1)
    pos = {v: (GRAPH_RADIUS_PX * math.cos(a), GRAPH_RADIUS_PX * math.sin(a)) for v, a in zip(names, ang)}
    out = dict(pos)
    t = GRAPH_PAIR_AT
    for p in result.pairs:
        pa, pb = pos.get(p.a, (0, 0)), pos.get(p.b, (0, 0))
        out[f"{p.a}__{p.b}"] = (pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]))
    return out


def triangle_residuals(result: SyncResult, videos: Collection[VideoInfo] = ()) -> tuple[TriangleResidual, ...]:
    """diagnose.loop_closures (Δ_ab + Δ_bc − Δ_ac per triangle of pairs with a chosen offset, and
    its tolerance) with how many of its pairs were accepted, largest |residual| first."""
    accepted = {frozenset((p.a, p.b)) for p in result.pairs if p.decision.accepted}
    out = [TriangleResidual(*lp.videos, lp.residual_ms, sum(k in accepted for k in lp.pairs()), lp.tolerance_ms)
           for lp in loop_closures(result, videos)]
    return tuple(sorted(out, key=lambda t: -abs(t.residual_ms)))


def track_rows(bundle: CueBundle, name: str, max_tracks: int, seed: int = 0) -> np.ndarray:
    """(N,) sorted rows of the video's tracks to show: all when max_tracks < 0 or enough, else a
    random choice of max_tracks with the tracks used by track pairs first."""
    n = bundle.tracks[name].num_tracks
    rows = np.arange(n)
    if max_tracks < 0 or n <= max_tracks:
        return rows
    used = np.zeros(n, bool)
    for (a, b), tp in bundle.pairs.items():
        if a == name:
            used[tp.index[:, 0]] = True
        elif b == name:
            used[tp.index[:, 1]] = True
    rng = np.random.default_rng(seed)
    pick = rng.permutation(np.flatnonzero(used))[:max_tracks]
    if len(pick) < max_tracks:
        pick = np.concatenate([pick, rng.permutation(np.flatnonzero(~used))[: max_tracks - len(pick)]])
    return np.sort(pick)


def run_record_view(bundle: CueBundle, result: SyncResult, options: RecordOptions) -> RunRecordView:
    """The view of Stage 2's result: graph layout, the truth and errors, tracks, trajectories."""
    gt = bundle.gt_offsets_s
    ref_true = gt.get(result.reference, 0.0) if gt else 0.0
    true = {v: (gt[v] - ref_true) if gt and v in gt else None for v in result.offsets_s}
    errors = offset_errors_ms(result.offsets_s, gt, result.reference) if gt else {}
    tracks: dict[str, VideoTracksView] = {}
    if options.max_tracks_per_video != 0:
        for v in bundle.videos:
            tr = bundle.tracks.get(v.name)
            if tr is None or tr.num_tracks == 0:
                continue
            rows = track_rows(bundle, v.name, options.max_tracks_per_video)
            inst = tr.instance[rows] if tr.instance is not None else np.full(len(rows), -1)
            tracks[v.name] = VideoTracksView(tr.xy[rows], inst)
    trajs: tuple[PairTrajectories, ...] = ()
    if options.trajectories:
        accepted = [(p.a, p.b, p.decision.contrast) for p in result.pairs if p.decision.accepted]
        trajs = run_trajectories(bundle, accepted, result.offsets_s, options.max_trajectory_video_pairs,
                                 options.max_trajectory_pairs)
    return RunRecordView(graph_layout(result), true, {v: errors.get(v) for v in result.offsets_s},
                         tracks, trajs, triangle_residuals(result, bundle.videos))
