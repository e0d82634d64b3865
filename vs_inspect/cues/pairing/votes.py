"""Cross-view track pairs from known epipolar geometry, without descriptors.

Between two static cameras whose cameras are known (imported or estimated), a track of a and a
track of b are the same physical point only if, at some offset Δ, b's point lies on the
epipolar line of a's point at (nearly) every common moment. Descriptors rarely match small
moving objects across wide baselines; a trajectory that crosses the epipolar lines of many
frames is a much stronger signature. So every candidate (i, j) is checked at every offset on a
half-frame grid:

- consistent at Δ: at least `min_frames` common moments, at least `min_inlier_share` of them
  with a Sampson distance below tau, and the fitting moments spread across the epipolar lines
  (a point moving along its line fits any offset); six probe moments are tried first, so a
  wrong candidate costs a few evaluations per offset;
- informative: consistent at only a narrow band of offsets (points moving along the epipolar
  lines fit every Δ and say nothing);
- each informative pair votes for its best offset; the few highest peaks of the vote histogram
  are kept (not only the highest: Stage 1 compares them with all their supporters), and at each
  peak a track keeps one partner (greedily by lowest residual).

Stage 1 then searches the offset again with these pairs and the descriptor pairs together; a
peak with few supporters becomes a rival minimum, which the decision stage weighs honestly.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ...geometry.epipolar import epipolar_residual, fundamental_from_cameras
from ...geometry.offsets import OffsetGrid, span_of
from ...geometry.sampling import camera_at_frames, camera_between_frames, tracks_between_frames
from ...geometry.timing import frame_brackets
from ...types import CameraTrack, TrackPairs, VideoInfo
from .vote_kernels import _consistency


@dataclass(frozen=True)
class VoteParams:
    """The epipolar vote's own parameters (not user settings: measured defaults, BENCHMARKS.md)."""

    tau_diag: float = 0.004  # Sampson distance (share of the image diagonal, at least 2 px) below which a moment fits
    min_frames: int = 8  # common moments a candidate needs at an offset
    min_inlier_share: float = 0.8  # share of those moments that must fit
    max_band_share: float = 0.08  # a pair consistent at more than this share of the offsets is uninformative
    min_sweep_tau: float = 4.0  # a track must sweep this many tau across the epipolar lines (along them fits any offset)
    epipole_margin_tau: float = 10.0  # a moment within this many tau of an epipole does not count (0: every moment)
    max_tracks: int = 300  # longest tracks per video taken as candidates (cost grows with the product)
    max_rate_hz: float = 30.0  # b's frames read at about this rate at most (every 2nd at 60 fps); 0: all
    peaks: int = 3  # vote-histogram peaks whose supporters are kept
    peak_halfwidth: int = 2  # grid steps either side of a peak that count as supporting it


VOTE = VoteParams()


@dataclass(frozen=True)
class GeometricPairStats:
    candidates: int  # track pairs checked
    informative: int  # consistent at a narrow band of offsets
    kept: int  # pairs output
    peaks_s: tuple[float, ...]  # Δ_ab of the kept peaks, seconds
    peak_votes: tuple[int, ...]  # informative pairs voting for each kept peak
    pair_peak: np.ndarray | None = None  # (P,) int, which kept peak each output pair supports
    # the evidence behind the peaks, for the joint choice over all camera pairs (joint_offsets)
    vote_offsets_s: np.ndarray | None = None  # (D,) Δ_ab grid, seconds, increasing
    votes: np.ndarray | None = None  # (D,) informative candidates whose best offset is there
    halfwidth_s: float = 0.0  # a candidate supports Δ when its best offset is this close, seconds
    cand_index: np.ndarray | None = None  # (M,2) informative candidates (track of a, track of b)
    cand_offset_s: np.ndarray | None = None  # (M,) their best Δ_ab, seconds
    cand_res: np.ndarray | None = None  # (M,) their mean Sampson distance² there, px²
    window_s: tuple[float, float] | None = None  # (lo, hi) of Δ_ab a peak may be at (--around), s

    def swapped(self) -> GeometricPairStats:
        """The same evidence for the pair taken the other way round (Δ_ba = -Δ_ab)."""
        flip = None if self.vote_offsets_s is None else -self.vote_offsets_s[::-1]
        return GeometricPairStats(
            self.candidates, self.informative, self.kept, tuple(-p for p in self.peaks_s),
            self.peak_votes, self.pair_peak, flip,
            None if self.votes is None else self.votes[::-1].copy(), self.halfwidth_s,
            None if self.cand_index is None else self.cand_index[:, ::-1].copy(),
            None if self.cand_offset_s is None else -self.cand_offset_s, self.cand_res,
            None if self.window_s is None else (-self.window_s[1], -self.window_s[0]))

    def allows(self, delta_s: np.ndarray) -> np.ndarray:
        """(...) bool: whether a peak may be at Δ_ab = delta_s (inside the --around window)."""
        d = np.asarray(delta_s, np.float64)
        if self.window_s is None:
            return np.ones(d.shape, bool)
        return (d >= self.window_s[0] - 1e-9) & (d <= self.window_s[1] + 1e-9)


def epipolar_extent(xy: np.ndarray, epipole: np.ndarray) -> np.ndarray:
    """(N,) px: extent of each track across the epipolar lines (perpendicular to the line through
    its median position and the epipole). xy (N,T,2); epipole (3,) homogeneous (may be at infinity)."""
    with warnings.catch_warnings():  # tracks never seen give NaN, on purpose
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(xy, axis=1)  # (N,2)
    line = np.cross(np.concatenate([med, np.ones((len(med), 1))], 1), epipole[None, :])
    line /= np.maximum(np.linalg.norm(line[:, :2], axis=1, keepdims=True), 1e-12)
    dist = np.einsum("ntk,nk->nt", xy, line[:, :2]) + line[:, 2:3]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nan_to_num(np.nanmax(dist, 1) - np.nanmin(dist, 1), nan=0.0)


def _candidates(xy: np.ndarray, max_tracks: int, min_frames: int, sweep: np.ndarray,
                min_sweep: float) -> np.ndarray:
    """Indices of the longest tracks seen at least min_frames that sweep across the lines."""
    length = np.isfinite(xy[..., 0]).sum(1)
    idx = np.nonzero((length >= min_frames) & (sweep >= min_sweep))[0]
    if len(idx) > max_tracks:
        idx = idx[np.argsort(-length[idx], kind="stable")[:max_tracks]]
    return np.sort(idx)


def _peaks(votes: np.ndarray, count: int, halfwidth: int, allowed: np.ndarray | None = None) -> list[int]:
    """Indices of the highest peaks of a vote histogram, at least 2*halfwidth+1 apart (and where
    allowed (D,) bool, when given)."""
    smooth = np.convolve(votes, np.ones(2 * halfwidth + 1), mode="same")
    out: list[int] = []
    for d in np.argsort(-smooth, kind="stable"):
        if smooth[d] <= 0 or len(out) >= count:
            break
        if allowed is not None and not allowed[d]:
            continue
        if all(abs(int(d) - p) > 2 * halfwidth for p in out):
            out.append(int(d))
    return out


def _per_frame_fundamentals(cam_a: CameraTrack, cam_b: CameraTrack, Tb: int) -> np.ndarray:
    """(Tb,3,3) G with x_aᵀ G[q] x_b = 0 at b's frame q (a static); NaN where b has no pose."""
    if cam_b.num_pose_frames not in (1, Tb):
        raise ValueError(f"camera b has {cam_b.num_pose_frames} poses for {Tb} frames")
    b = camera_at_frames(cam_b, np.arange(Tb))  # NaN where b has no pose, and so is G
    return fundamental_from_cameras(cam_a.K, cam_a.cam_from_world, b.K, b.cam_from_world)


def _moving_fundamentals(cam_a: CameraTrack, cam_b: CameraTrack, k: np.ndarray,
                         w: np.ndarray) -> np.ndarray:
    """(D,Tb,3,3) G with x_aᵀ G[d, q] x_b = 0 between a at brackets (k, w) (D,Tb) (its pose
    interpolated as its track points are) and b at its frame q; NaN where either pose is unknown.
    The same cameras as the energy landscape's (sync/landscape.py, PairEnergy._G_moving)."""
    D, Tb = k.shape
    cam_b_at = camera_at_frames(cam_b, np.broadcast_to(np.arange(Tb), (D, Tb)))
    cam_a_at = camera_between_frames(cam_a, k, w)
    invalid = ~(cam_a_at.valid & cam_b_at.valid)
    # K is inverted: a placeholder keeps the batched inverse finite; invalid G are NaN below
    K_a = np.where(invalid[..., None, None], np.eye(3), cam_a_at.K)
    K_b = np.where(invalid[..., None, None], np.eye(3), cam_b_at.K)
    with np.errstate(invalid="ignore", divide="ignore"):
        G = fundamental_from_cameras(K_a, cam_a_at.cam_from_world, K_b, cam_b_at.cam_from_world)
    G[invalid] = np.nan
    return np.ascontiguousarray(G)


def _one_to_one(cand_a: np.ndarray, cand_b: np.ndarray, res: np.ndarray) -> np.ndarray:
    """Indices into the candidates: a one-to-one choice of least total residual (Hungarian)."""
    ua, ra = np.unique(cand_a, return_inverse=True)
    ub, rb = np.unique(cand_b, return_inverse=True)
    big = 1e9
    cost = np.full((len(ua), len(ub)), big)
    which = np.full((len(ua), len(ub)), -1, np.int64)
    order = np.argsort(-res, kind="stable")  # the least residual of a repeated cell wins
    cost[ra[order], rb[order]] = res[order]
    which[ra[order], rb[order]] = order
    rows, cols = linear_sum_assignment(cost)
    ok = cost[rows, cols] < big
    return np.sort(which[rows[ok], cols[ok]])


def _peak_supporters(peaks: list[int], informative: np.ndarray, best: np.ndarray, cand_a: np.ndarray,
                     cand_b: np.ndarray, res: np.ndarray, halfwidth: int) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(index (P,2) of the track pairs kept, (P,) which peak each supports, votes per peak): at each
    peak one partner per track, the one-to-one choice of least total residual; a track pair
    supporting two peaks is kept once, with the first (highest)."""
    keep_a, keep_b, keep_p, peak_votes = [], [], [], []
    for pi, p in enumerate(peaks):
        near = informative & (np.abs(best - p) <= halfwidth)
        peak_votes.append(int(near.sum()))
        sel = np.nonzero(near)[0]
        if not len(sel):
            continue
        sel = sel[_one_to_one(cand_a[sel], cand_b[sel], res[sel])]
        keep_a += cand_a[sel].tolist()
        keep_b += cand_b[sel].tolist()
        keep_p += [pi] * len(sel)
    index = np.stack([np.array(keep_a, np.int64), np.array(keep_b, np.int64)], 1) \
        if keep_a else np.zeros((0, 2), np.int64)
    index, first = np.unique(index, axis=0, return_index=True)
    return index, np.array(keep_p, np.int64)[first], peak_votes


def geometric_pairs(a: str, b: str, info_a: VideoInfo, info_b: VideoInfo, cam_a: CameraTrack,
                    cam_b: CameraTrack, xy_a: np.ndarray, xy_b: np.ndarray,
                    params: VoteParams = VOTE, grid: OffsetGrid = OffsetGrid()
                    ) -> tuple[TrackPairs, GeometricPairStats]:
    """Track pairs between cameras a and b from epipolar consistency over time.

    Either camera may move (per-frame poses): with one moving, its epipolar geometry is taken per
    frame; with both, per frame of b and per offset (a's pose at the moment b's frame meets,
    interpolated between its frames as its track points are). xy_a (Na,Ta,2), xy_b (Nb,Tb,2):
    undistorted px in the cameras' pinhole models. grid: the limits of the offsets voted for
    (overlap, range), on a half-frame step of the finer video; its --around window holds the
    peaks only, so that the votes' statistics (vote_z) stay the whole range's.
    """
    if cam_a.is_moving and not cam_b.is_moving:  # a moving camera is b inside: Δ_ba = -Δ_ab
        tp, st = geometric_pairs(b, a, info_b, info_a, cam_b, cam_a, xy_b, xy_a, params, grid)
        return TrackPairs(a, b, tp.index[:, ::-1].copy(), tp.weight), st.swapped()
    empty = TrackPairs(a, b, np.zeros((0, 2), np.int64), np.zeros(0))
    Tb = xy_b.shape[1]
    step = 0.5 * min(info_a.frame_interval_s, info_b.frame_interval_s)
    ta, tb = info_a.timestamps_s, info_b.timestamps_s
    offsets = grid.pair_offsets(a, span_of(ta), b, span_of(tb), step, window=False)
    allowed = grid.within_window(a, b, offsets)
    if not len(offsets):
        return empty, GeometricPairStats(0, 0, 0, (), ())
    k, w = frame_brackets(ta, tb[None, :] + offsets[:, None])
    # (Dg,Tb,3,3): one row of G when a is static, one per offset when both move
    G = _moving_fundamentals(cam_a, cam_b, k, w) if cam_a.is_moving else \
        _per_frame_fundamentals(cam_a, cam_b, Tb)[None]
    posed = np.isfinite(G[..., 0, 0])  # (Dg,Tb)
    if not posed.any():
        return empty, GeometricPairStats(0, 0, 0, (), ())
    diag = float(np.hypot(info_b.width, info_b.height))
    tau = max(2.0, params.tau_diag * diag)
    u, _, vt = np.linalg.svd(np.where(posed[..., None, None], G, np.eye(3)))
    e_a, e_b = u[..., -1], vt[..., -1, :]  # (Dg,Tb,3) unit null vectors: Gᵀ e_a = 0, G e_b = 0
    # a moving camera's extent is judged at a middle pose (both moving: the offset nearest 0
    # that has one)
    rows = np.nonzero(posed.any(1))[0]
    g_mid = rows[np.argmin(np.abs(offsets[rows]))] if len(G) > 1 else 0
    mid = np.nonzero(posed[g_mid])[0][posed[g_mid].sum() // 2]
    ia = _candidates(xy_a, params.max_tracks, params.min_frames, epipolar_extent(xy_a, e_a[g_mid, mid]),
                     params.min_sweep_tau * tau)
    ib = _candidates(xy_b, params.max_tracks, params.min_frames, epipolar_extent(xy_b, e_b[g_mid, mid]),
                     params.min_sweep_tau * tau)
    if not len(ia) or not len(ib):
        return empty, GeometricPairStats(0, 0, 0, (), ())
    qstep = max(1, int(1.0 / (info_b.frame_interval_s * params.max_rate_hz))) if params.max_rate_hz > 0 else 1
    cand_a = np.repeat(ia, len(ib))
    cand_b = np.tile(ib, len(ia))
    _, best, res = _consistency(np.ascontiguousarray(xy_a, np.float64),
                                np.ascontiguousarray(xy_b, np.float64), cand_a, cand_b,
                                np.ascontiguousarray(G), np.ascontiguousarray(e_a),
                                np.ascontiguousarray(e_b),
                                np.ascontiguousarray(k), np.ascontiguousarray(w), tau * tau,
                                params.min_frames, params.min_inlier_share,
                                max(1, int(params.max_band_share * len(offsets))),
                                params.min_sweep_tau * tau, qstep, (params.epipole_margin_tau * tau) ** 2)
    informative = best >= 0
    votes = np.bincount(best[informative], minlength=len(offsets)).astype(float)
    peaks = _peaks(votes, params.peaks, params.peak_halfwidth, None if allowed.all() else allowed)
    index, pair_peak, peak_votes = _peak_supporters(peaks, informative, best, cand_a, cand_b, res, params.peak_halfwidth)
    coarser = max(info_a.frame_interval_s, info_b.frame_interval_s)
    inf = np.nonzero(informative)[0]
    stats = GeometricPairStats(len(cand_a), int(informative.sum()), len(index),
                               tuple(float(offsets[p]) for p in peaks), tuple(peak_votes),
                               pair_peak, offsets, votes,
                               max(step * params.peak_halfwidth, 0.5 * coarser),
                               np.stack([cand_a[inf], cand_b[inf]], 1), offsets[best[inf]], res[inf],
                               grid.pair_window(a, b))
    return TrackPairs(a, b, index, np.ones(len(index))), stats


def vote_z(st: GeometricPairStats) -> tuple[np.ndarray, np.ndarray]:
    """(offsets_s (D,), z (D,)): the vote histogram summed over ±halfwidth_s, as robust z-scores
    (median and MAD over all offsets: most offsets get only chance votes)."""
    offs, v = st.vote_offsets_s, st.votes
    step = float(np.median(np.diff(offs))) if len(offs) > 1 else 1.0
    hw = max(1, round(st.halfwidth_s / step))
    sm = np.convolve(v, np.ones(2 * hw + 1), mode="same")
    med = np.median(sm)
    mad = 1.4826 * np.median(np.abs(sm - med))
    return offs, (sm - med) / max(mad, 1.0)


def _voting_for(st: GeometricPairStats, delta_s: float) -> np.ndarray:
    """(M,) bool: the informative candidates whose best offset lies within halfwidth_s of delta_s."""
    if st.cand_offset_s is None:
        return np.zeros(0, bool)
    return np.abs(st.cand_offset_s - delta_s) <= st.halfwidth_s + 1e-9


def votes_at(st: GeometricPairStats, delta_s: float) -> int:
    """The pair's votes at Δ_ab = delta_s: informative candidates whose best offset is that close."""
    return int(_voting_for(st, delta_s).sum())


def supporters(st: GeometricPairStats, delta_s: float) -> np.ndarray:
    """(P,2) track pairs whose best offset lies within halfwidth_s of delta_s, one partner per
    track (the one-to-one choice of least total residual)."""
    if st.cand_index is None or not len(st.cand_index):
        return np.zeros((0, 2), np.int64)
    sel = np.nonzero(_voting_for(st, delta_s))[0]
    if not len(sel):
        return np.zeros((0, 2), np.int64)
    sel = sel[_one_to_one(st.cand_index[sel, 0], st.cand_index[sel, 1], st.cand_res[sel])]
    return st.cand_index[sel].astype(np.int64)


def consistent_at(info_a: VideoInfo, info_b: VideoInfo, cam_a: CameraTrack, cam_b: CameraTrack,
                  xy_a: np.ndarray, xy_b: np.ndarray, index: np.ndarray, delta_s: float,
                  tau_px: float, min_share: float, min_frames: int) -> np.ndarray:
    """(P,) bool: the track pairs index (P,2) whose points lie within tau_px (Sampson) of each
    other's epipolar lines at Δ_ab = delta_s in at least min_share of at least min_frames common
    moments. Either camera may move (both: a's pose interpolated at b's frames' moments)."""
    if cam_a.is_moving and not cam_b.is_moving:
        return consistent_at(info_b, info_a, cam_b, cam_a, xy_b, xy_a, index[:, ::-1], -delta_s,
                             tau_px, min_share, min_frames)
    if not len(index):
        return np.zeros(0, bool)
    k, w = frame_brackets(info_a.timestamps_s, info_b.timestamps_s + delta_s)
    G = _moving_fundamentals(cam_a, cam_b, k[None], w[None])[0] if cam_a.is_moving else \
        _per_frame_fundamentals(cam_a, cam_b, xy_b.shape[1])  # (Tb,3,3)
    xa = tracks_between_frames(xy_a, k, w, rows=index[:, 0])  # (P,Tb,2) a at b's moments
    with np.errstate(invalid="ignore", divide="ignore"):
        r = epipolar_residual(G, xa, xy_b[index[:, 1]], "sampson")  # (P,Tb) px², NaN: not both seen
        n = np.isfinite(r).sum(1)
        fit = (r < tau_px * tau_px).sum(1)
    return (n >= min_frames) & (fit >= min_share * np.maximum(n, 1))
