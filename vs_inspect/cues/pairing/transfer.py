"""A camera's offset from the 3D trajectories of cameras already synchronized (point transfer).

The epipolar cue says only that a point lies on a line; once two or more cameras are
synchronized, their track pairs triangulate into 3D trajectories X(t) on the global clock, and a
third camera c must see those points at their projections, not just somewhere on a line. So for
every candidate offset_s of c, each triangulated sample X(t) is projected into c at its local
time τ = t − offset_s and compared with c's tracks there (interpolated between the frames around
τ, as everywhere): a trajectory supports the offset when one and the same track of c follows its
projection at several moments. The support summed over trajectories, per sample inside c's
video, forms a landscape over c's offset whose peak is far sharper than an epipolar vote's (a
point, not a line).

Pure functions of arrays: no I/O, no logging.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ...cue_stats import ThreeViewSummary, TransferSummary
from ...geometry.epipolar import project
from ...geometry.offsets import OffsetGrid, span_of
from ...geometry.sampling import camera_at_frames
from ...geometry.timing import frame_brackets
from ...geometry.triangulate import triangulate_over_time
from ...types import CameraTrack, TrackPairs, VideoInfo

_BLOCK_ELEMENTS = 4_000_000  # (offset, sample) brackets held at once
MIN_OVERLAP_SHARE = 0.25  # offsets with less overlap than this share of the largest are not candidates
MAX_BRACKETS = 30_000_000  # (offset, sample) brackets evaluated at most (about 12 s of compute)


@dataclass(frozen=True)
class Trajectories:
    """Triangulated samples of the track pairs of synchronized cameras, on the global clock."""

    points_world: np.ndarray  # (S,3) world units
    time_s: np.ndarray  # (S,) global time of each sample, seconds
    trajectory: np.ndarray  # (S,) int, which trajectory (row of source) each sample belongs to
    source: np.ndarray  # (K,4) int: per trajectory (pair number, track of a, track of b, samples)
    pairs: tuple[tuple[str, str], ...]  # the camera pairs that the pair numbers of source index

    @property
    def num_trajectories(self) -> int:
        return len(self.source)


def triangulate_pairs(infos: Mapping[str, VideoInfo], cameras: Mapping[str, CameraTrack],
                      tracks_xy: Mapping[str, np.ndarray],
                      pairs: Mapping[tuple[str, str], TrackPairs],
                      offsets_s: Mapping[str, float], min_samples: int = 8,
                      max_per_pair: int = 300, max_samples: int = 60) -> Trajectories:
    """Every track pair of two cameras with an offset, triangulated at b's frames (a read at the
    same global moments); a trajectory keeps the samples that pass geometry.triangulate's filter
    and is kept when at least min_samples do. At most max_per_pair track pairs per camera pair
    and max_samples samples per trajectory (each evenly spread), so that a moving camera's
    projections of every sample at every frame stay small."""
    pts, times, traj, source, used = [], [], [], [], []
    for (a, b), tp in sorted(pairs.items()):
        if a not in offsets_s or b not in offsets_s or tp is None or not len(tp.index):
            continue
        idx = tp.index
        if len(idx) > max_per_pair:
            idx = idx[np.linspace(0, len(idx) - 1, max_per_pair).round().astype(int)]
        tri, g = triangulate_over_time(infos[a].timestamps_s, cameras[a], tracks_xy[a], offsets_s[a],
                                       infos[b].timestamps_s, cameras[b], tracks_xy[b], offsets_s[b],
                                       idx, at="b")  # g: global time of b's frames
        n = tri.kept.sum(1)
        pair_no = len(used)
        used.append((a, b))
        for p in np.nonzero(n >= min_samples)[0]:
            ks = np.nonzero(tri.kept[p])[0]
            if len(ks) > max_samples:
                ks = ks[np.linspace(0, len(ks) - 1, max_samples).round().astype(int)]
            pts.append(tri.points_world[p, ks])
            times.append(g[ks])
            traj.append(np.full(len(ks), len(source)))
            source.append((pair_no, int(idx[p, 0]), int(idx[p, 1]), len(ks)))
    if not source:
        return Trajectories(np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64),
                            np.zeros((0, 4), np.int64), tuple(used))
    return Trajectories(np.concatenate(pts), np.concatenate(times), np.concatenate(traj),
                        np.array(source, np.int64), tuple(used))


@dataclass(frozen=True)
class TransferLandscape:
    """Support of camera c's candidate offsets by the projected trajectories."""

    offsets_s: np.ndarray  # (D,) candidate offset_s of c (global time of its local time 0), increasing
    support: np.ndarray  # (D,) Σ over trajectories of the moments its best track of c follows it
    overlap: np.ndarray  # (D,) samples whose moment falls inside c's video (and pose)
    supporters: np.ndarray  # (D,) trajectories followed by one track at >= min_hits moments
    best: int  # index of the highest share (support / overlap) among offsets with enough overlap, -1 if none
    z: float  # robust z-score of that share over all offsets with enough overlap
    matches: np.ndarray  # (M,2) int (trajectory, track of c) at the best offset, one-to-one

    @property
    def offset_s(self) -> float | None:
        return float(self.offsets_s[self.best]) if self.best >= 0 else None

    @property
    def share(self) -> np.ndarray:
        """(D,) support per sample inside c's video: the score the peak is chosen by."""
        return self.support / np.maximum(self.overlap, 1)


def transfer_landscape(traj: Trajectories, info_c: VideoInfo, camera_c: CameraTrack,
                       xy_c: np.ndarray, offsets_s: np.ndarray, radius_px: float,
                       min_hits: int = 5, min_overlap_share: float = MIN_OVERLAP_SHARE,
                       neighbours: int = 4, allowed: np.ndarray | None = None) -> TransferLandscape:
    """The support of each candidate offset of camera c (offsets_s (D,), increasing), and the
    offset whose share (support per sample inside c's video) is highest.

    A sample X(t) hits track j of c at offset o when j's point at τ = t − o (linear between the
    frames around τ) lies within radius_px of X's projection there (the camera's pose read the
    same way). A trajectory's support at o is the number of hits of its most-hit track, counted
    when at least min_hits. Offsets whose overlap (samples inside c's video) is below
    min_overlap_share of the largest overlap are not candidates: a peak resting on a few samples
    at the edge of the range says little. xy_c (N,T,2): c's tracks, undistorted px. Beyond
    MAX_BRACKETS (offsets × samples), the samples are thinned evenly. allowed (D,) bool: the
    offsets the best may be at (an --around window); the z-score's median and spread stay those
    of every candidate.
    """
    offsets_s = np.asarray(offsets_s, np.float64)
    stride = -(-len(offsets_s) * len(traj.time_s) // MAX_BRACKETS)
    if stride > 1:  # long videos: every stride-th sample (each trajectory's samples are consecutive)
        traj = Trajectories(traj.points_world[::stride], traj.time_s[::stride],
                            traj.trajectory[::stride], traj.source, traj.pairs)
    D, S, K = len(offsets_s), len(traj.time_s), traj.num_trajectories
    Nc, Tc = xy_c.shape[:2]
    empty = TransferLandscape(offsets_s, np.zeros(D), np.zeros(D, np.int64), np.zeros(D, np.int64),
                              -1, 0.0, np.zeros((0, 2), np.int64))
    if D == 0 or S == 0 or Tc < 2:
        return empty
    hits, overlap = _hits(traj, info_c, camera_c, xy_c, offsets_s, radius_px, neighbours)
    if not len(hits):  # no sample within the radius of a track (tracks within reach are not hits)
        return empty
    return _best_offset(hits, overlap, offsets_s, K, Nc, min_hits, min_overlap_share, allowed)


def _hits(traj: Trajectories, info_c: VideoInfo, camera_c: CameraTrack, xy_c: np.ndarray, offsets_s: np.ndarray,
          radius_px: float, neighbours: int) -> tuple[np.ndarray, np.ndarray]:
    """(hits as numbers (offset d * K + trajectory) * N + track j, one per sample that lands on
    track j of c at offset d; overlap (D,) samples inside c's video at each offset)."""
    D, S, K = len(offsets_s), len(traj.time_s), traj.num_trajectories
    Nc, Tc = xy_c.shape[:2]
    at_c = camera_at_frames(camera_c, np.arange(Tc))
    X = traj.points_world
    fixed = None if camera_c.is_moving else project(at_c.K[0], at_c.cam_from_world[0], X)  # (S,2)

    def projected(f: int, rows: np.ndarray) -> np.ndarray:
        """(Q,2) samples `rows` projected with frame f's pose (a moving camera: computed here,
        so that no (frames, samples) array is held)."""
        return fixed[rows] if fixed is not None else project(at_c.K[f], at_c.cam_from_world[f], X[rows])
    seen = np.isfinite(xy_c[..., 0])  # (N,T)
    both = [np.nonzero(seen[:, f] & seen[:, f + 1])[0] for f in range(Tc - 1)]
    trees = [cKDTree(xy_c[b, f]) if len(b) else None for f, b in enumerate(both)]
    steps = np.linalg.norm(np.diff(xy_c, axis=1), axis=-1)
    max_step = float(np.nanmax(steps)) if np.isfinite(steps).any() else 0.0
    reach = radius_px + max_step  # a track within radius at τ is this close at the frame before
    overlap = np.zeros(D, np.int64)
    keys = []  # hits as (offset d, trajectory, track j) numbers
    block = max(1, _BLOCK_ELEMENTS // S)  # offsets per block: bounded memory for long videos
    for d0 in range(0, D, block):
        k, w = frame_brackets(info_c.timestamps_s, traj.time_s[None, :] - offsets_s[d0:d0 + block, None])
        inside = (k >= 0) & at_c.valid[np.clip(k, 0, Tc - 2)] & at_c.valid[np.clip(k + 1, 0, Tc - 1)]
        overlap[d0:d0 + len(k)] = inside.sum(1)
        flat = np.flatnonzero(inside)
        flat = flat[np.argsort(k.ravel()[flat], kind="stable")]
        bounds = np.searchsorted(k.ravel()[flat], np.arange(Tc))
        for f in range(Tc - 1):
            d_idx, s_idx = np.divmod(flat[bounds[f]:bounds[f + 1]], S)
            if not len(d_idx) or trees[f] is None:
                continue
            ww = w[d_idx, s_idx][:, None]
            p = (1 - ww) * projected(f, s_idx) + ww * projected(f + 1, s_idx)  # (Q,2) at τ
            good = np.isfinite(p).all(1)
            d_idx, s_idx, p, ww = d_idx[good], s_idx[good], p[good], ww[good]
            if not len(p):
                continue
            nn = min(neighbours, len(both[f]))
            dist, cand = trees[f].query(p, k=nn, distance_upper_bound=reach)
            dist, cand = dist.reshape(len(p), nn), cand.reshape(len(p), nn)
            for col in range(nn):
                has = np.isfinite(dist[:, col])
                if not has.any():
                    continue
                j = both[f][cand[has, col]]
                xj = (1 - ww[has]) * xy_c[j, f] + ww[has] * xy_c[j, f + 1]  # the track at τ
                hit = np.linalg.norm(xj - p[has], axis=1) <= radius_px
                dd, ss = d0 + d_idx[has][hit], s_idx[has][hit]
                keys.append((dd.astype(np.int64) * K + traj.trajectory[ss]) * Nc + j[hit])
    return (np.concatenate(keys) if keys else np.zeros(0, np.int64)), overlap


def _best_offset(hits: np.ndarray, overlap: np.ndarray, offsets_s: np.ndarray, K: int, Nc: int, min_hits: int,
                 min_overlap_share: float, allowed: np.ndarray | None) -> TransferLandscape:
    """The landscape of the hits (_hits): each trajectory's most-hit track counted at min_hits,
    the best candidate offset by share, its robust z-score and matches."""
    D = len(offsets_s)
    u, count = np.unique(hits, return_counts=True)
    dk, jj = u // Nc, u % Nc  # (offset, trajectory) and track
    # each (offset, trajectory)'s most-hit track
    order = np.lexsort((-count, dk))
    first = np.r_[True, dk[order][1:] != dk[order][:-1]]
    top_dk, top_j, top_n = dk[order][first], jj[order][first], count[order][first]
    counted = top_n >= min_hits
    support = np.bincount(top_dk[counted] // K, weights=top_n[counted], minlength=D)
    supporters = np.bincount(top_dk[counted] // K, minlength=D)
    share = support / np.maximum(overlap, 1)  # as TransferLandscape.share
    candidates = overlap >= min_overlap_share * overlap.max()
    if not candidates.any() or support[candidates].max() <= 0:
        return TransferLandscape(offsets_s, support, overlap, supporters, -1, 0.0,
                                 np.zeros((0, 2), np.int64))
    vals = share[candidates]
    pick = candidates if allowed is None else candidates & np.asarray(allowed, bool)
    if not pick.any() or support[pick].max() <= 0:
        return TransferLandscape(offsets_s, support, overlap, supporters, -1, 0.0,
                                 np.zeros((0, 2), np.int64))
    best = int(np.flatnonzero(pick)[np.argmax(share[pick])])
    med = float(np.median(vals))
    mad = 1.4826 * float(np.median(np.abs(vals - med)))
    z = (share[best] - med) / max(mad, 1e-3)
    # the matches at the best offset: each trajectory's most-hit track, one trajectory per track
    at = counted & (top_dk // K == best)
    t_traj, t_j, t_n = top_dk[at] % K, top_j[at], top_n[at]
    order = np.argsort(-t_n, kind="stable")
    _, keep = np.unique(t_j[order], return_index=True)
    keep = order[keep]
    matches = np.stack([t_traj[keep], t_j[keep]], 1).astype(np.int64)
    return TransferLandscape(offsets_s, support, overlap, supporters, best, float(z),
                             matches[np.argsort(matches[:, 0])])


def candidate_offsets(traj: Trajectories, info_c: VideoInfo, step_s: float, grid: OffsetGrid = OffsetGrid(),
                      origin: str | None = None) -> np.ndarray:
    """Candidate offsets of c (multiples of step_s) at which c's video shares enough time with
    the samples (grid's min_overlap_s), within grid's range: the samples' times are global times
    whose 0 is origin's local time 0 (the joint vote's first camera). The --around window is not
    cropped here (it holds the choice: grid.within_window(origin, c, offsets))."""
    if not len(traj.time_s):
        return np.zeros(0)
    span = (float(traj.time_s.min()), float(traj.time_s.max()))
    return grid.pair_offsets(origin or "", span, info_c.name, span_of(info_c.timestamps_s), step_s, window=False)


@dataclass(frozen=True)
class TransferCheck:
    """Whether point transfer confirms the offset the joint vote chose for an unsure camera."""

    camera: str
    joint_offset_s: float  # the joint vote's offset_s of the camera
    landscape: TransferLandscape
    confirmed: bool
    reason: str  # why (or why not), one line

    def summary(self, trajectories: int) -> TransferSummary:
        """The record result.json's cues.geometric_joint.transfer keeps, the landscape included
        (trajectories: how many were projected)."""
        land = self.landscape
        return TransferSummary(round(self.joint_offset_s, 4), None if land.offset_s is None else round(land.offset_s, 4),
                               round(land.z, 2), int(trajectories),
                               int(land.supporters[land.best]) if land.best >= 0 else 0,
                               int(len(land.matches)), self.confirmed, self.reason,
                               tuple(round(float(o), 4) for o in land.offsets_s),
                               tuple(round(float(v), 4) for v in land.share))


def confirm_offset(camera: str, joint_offset_s: float, landscape: TransferLandscape,
                   frame_s: float, agree_frames: float, min_z: float,
                   min_supporters: int) -> TransferCheck:
    """The joint vote's offset of `camera` is confirmed when the transfer landscape's own peak
    lies within agree_frames frames (frame_s each) of it, stands min_z robust z-scores above the
    landscape and rests on at least min_supporters trajectories. Two different cues (a point on a
    line for the vote, a point on a point here) rarely agree on the same wrong offset."""
    o = landscape.offset_s
    if o is None:
        return TransferCheck(camera, joint_offset_s, landscape, False,
                             "no trajectory of the synchronized cameras is followed by a track of it")
    n = int(landscape.supporters[landscape.best])
    gap = abs(o - joint_offset_s) / frame_s
    what = (f"point transfer puts it at {o:+.3f} s ({n} trajectories, z {landscape.z:.1f}), the "
            f"joint vote at {joint_offset_s:+.3f} s ({gap:.1f} frames apart)")
    if gap > agree_frames:
        return TransferCheck(camera, joint_offset_s, landscape, False, f"{what}: they disagree")
    if landscape.z < min_z:
        return TransferCheck(camera, joint_offset_s, landscape, False, f"{what}: its peak is not clear (z < {min_z:g})")
    if n < min_supporters:
        return TransferCheck(camera, joint_offset_s, landscape, False, f"{what}: too few trajectories (< {min_supporters})")
    return TransferCheck(camera, joint_offset_s, landscape, True, f"{what}: confirmed")


@dataclass(frozen=True)
class ThreeViewCheck:
    """Whether a camera the joint vote is sure of sees, at its joint offset, the points that the
    other sure cameras' track pairs triangulate to (a check of its camera and offset in three
    views: the epipolar vote tests a point against a line, two views at a time)."""

    camera: str
    joint_offset_s: float  # the joint vote's offset_s of the camera
    trajectories: int  # triangulated from the other sure cameras' track pairs
    supporters: int  # of those, followed by one track of the camera at joint_offset_s
    best_supporters: int  # the most followed at any candidate offset
    best_offset_s: float | None  # where (None: no trajectory followed anywhere)
    needed: float  # supporters it needed: min_supporters, or the share of best_supporters if more
    passed: bool
    reason: str  # why (or why not), one line
    landscape: TransferLandscape  # over the camera's candidate offsets, the joint offset among them

    def summary(self) -> ThreeViewSummary:
        """The record result.json's cues.geometric_joint.three_view keeps."""
        return ThreeViewSummary(round(self.joint_offset_s, 4), self.trajectories, self.supporters,
                                self.best_supporters,
                                None if self.best_offset_s is None else round(self.best_offset_s, 4),
                                round(self.needed, 2), self.passed, self.reason,
                                tuple(round(float(o), 4) for o in self.landscape.offsets_s),
                                tuple(int(n) for n in self.landscape.supporters))


def check_in_three_views(camera: str, joint_offset_s: float, traj: Trajectories, info_c: VideoInfo,
                         camera_c: CameraTrack, xy_c: np.ndarray, radius_px: float, min_hits: int,
                         min_supporters: int, min_share_of_best: float, grid: OffsetGrid = OffsetGrid(),
                         origin: str | None = None) -> ThreeViewCheck:
    """The camera passes when at least min_supporters of traj (the other sure cameras'
    trajectories) are followed by one of its tracks (xy_c (N,T,2), undistorted px) at its joint
    offset, each at min_hits moments within radius_px of the projection, and at least
    min_share_of_best as many as at the offset (half-frame grid) where most are: a wrong camera
    leaves few followed anywhere, a wrong offset far fewer than the right one. grid, origin: as
    candidate_offsets takes them."""
    offsets = np.union1d(candidate_offsets(traj, info_c, 0.5 * info_c.frame_interval_s, grid, origin),
                         [joint_offset_s])
    allowed = grid.within_window(origin or "", camera, offsets)
    land = transfer_landscape(traj, info_c, camera_c, xy_c, offsets, radius_px, min_hits, allowed=allowed)
    n = int(land.supporters[np.searchsorted(offsets, joint_offset_s)])
    # the grid holds the joint offset at least
    enough = (land.overlap >= MIN_OVERLAP_SHARE * land.overlap.max()) & allowed
    best = int(np.argmax(np.where(enough, land.supporters, -1)))
    n_best = int(land.supporters[best])
    at_best = float(offsets[best]) if n_best > 0 else None
    what = (f"{n} of the {traj.num_trajectories} trajectories the other sure cameras triangulate are "
            f"followed by a track of it at its joint offset {joint_offset_s:+.3f} s"
            + (f", {n_best} at {at_best:+.3f} s" if at_best is not None and n_best > n else ""))
    bar = max(float(min_supporters), min_share_of_best * n_best)
    if n < bar:
        return ThreeViewCheck(camera, joint_offset_s, traj.num_trajectories, n, n_best, at_best, bar, False,
                              f"{what}; fewer than {bar:.3g}: its camera or offset disagrees in three views", land)
    return ThreeViewCheck(camera, joint_offset_s, traj.num_trajectories, n, n_best, at_best, bar, True,
                          f"{what}: agrees in three views", land)
