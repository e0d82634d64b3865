"""How right Stage 0's cross-view track pairs are, measured against known cameras and offsets.

A track pair (i of a, j of b) is "right" when the two tracks are projections of one physical
point: at the true offset, b's point lies on the epipolar line of a's point (Sampson distance
below tol_px) at most of their common moments (median below tol_px, at least min_common of them),
with the true cameras. A wrong pair can pass by staying on the same epipolar lines by chance;
that needs a point moving along its line, rare over many frames, so the counts are a close upper
bound.

Recall is against every right pair that exists among the tracks: how many tracks of a (and of b)
have at least one right partner, the smaller of the two being the most one-to-one pairs there
can be.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.epipolar import fundamental_from_cameras
from ..geometry.timing import frame_brackets
from ..types import CameraTrack, CueBundle


@dataclass(frozen=True)
class PairTruth:
    pairs: int  # track pairs output by Stage 0
    right: int  # of them, right (one physical point)
    judged: int  # of them, with at least min_common common moments (others cannot be judged)
    possible: int  # most one-to-one right pairs among all tracks (recall's denominator)

    @property
    def precision(self) -> float:
        return self.right / self.judged if self.judged else float("nan")

    @property
    def recall(self) -> float:
        return self.right / self.possible if self.possible else float("nan")


def _same_moment(bundle: CueBundle, cams: dict[str, CameraTrack], a: str, b: str, delta_ab_s: float):
    """Per frame q of b: a's tracks interpolated at the same moment, and F_ab of that moment.

    Returns xa (Na,Tb,2) (NaN where a is not seen then), xb (Nb,Tb,2), F (Tb,3,3) (NaN where a
    camera has no pose)."""
    ia, ib = bundle.video(a), bundle.video(b)
    k, w = frame_brackets(ia.timestamps_s, ib.timestamps_s + delta_ab_s)  # (Tb,)
    xya = bundle.tracks[a].xy
    kc = np.clip(k, 0, max(0, ia.num_frames - 2))
    if ia.num_frames >= 2:
        xa = xya[:, kc] + w[None, :, None] * (xya[:, kc + 1] - xya[:, kc])
    else:
        xa = xya[:, kc]
    xa[:, k < 0] = np.nan
    near = np.where(w < 0.5, kc, np.minimum(kc + 1, ia.num_frames - 1))  # a's pose frame
    ca, cb = cams[a], cams[b]
    q = np.arange(ib.num_frames)
    pa = ca.pose_at(near) if ca.is_moving else np.broadcast_to(ca.cam_from_world, (len(q), 4, 4))
    pb = cb.pose_at(q) if cb.is_moving else np.broadcast_to(cb.cam_from_world, (len(q), 4, 4))
    Ka = ca.K_at(near) if ca.is_moving else ca.K
    Kb = cb.K_at(q) if cb.is_moving else cb.K
    if np.ndim(Ka) == 3 or np.ndim(Kb) == 3:
        Ka = np.broadcast_to(Ka, (len(q), 3, 3))
        Kb = np.broadcast_to(Kb, (len(q), 3, 3))
        F = np.stack([fundamental_from_cameras(Ka[t], pa[t], Kb[t], pb[t]) for t in q])
    else:
        F = fundamental_from_cameras(Ka, pa, Kb, pb)
    bad = k < 0
    if ca.is_moving and ca.valid is not None:
        bad |= ~ca.valid[near]
    if cb.is_moving and cb.valid is not None:
        bad |= ~cb.valid[q]
    F = np.array(F, dtype=np.float64)
    F[bad] = np.nan
    return xa, bundle.tracks[b].xy, F


def _sampson_px(xa: np.ndarray, xb: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Sampson distance (px) of xa (...,2) and xb (...,2) with x_aᵀ F x_b = 0, F (...,3,3)."""
    ha = np.concatenate([xa, np.ones(xa.shape[:-1] + (1,))], -1)
    hb = np.concatenate([xb, np.ones(xb.shape[:-1] + (1,))], -1)
    lb = np.einsum("...ij,...j->...i", F, hb)  # line in a
    la = np.einsum("...ji,...j->...i", F, ha)  # line in b
    num = np.einsum("...i,...i->...", ha, lb)
    den = lb[..., 0] ** 2 + lb[..., 1] ** 2 + la[..., 0] ** 2 + la[..., 1] ** 2
    return np.abs(num) / np.sqrt(den)


def pair_truth(bundle: CueBundle, cams: dict[str, CameraTrack], offsets_s: dict[str, float],
               a: str, b: str, tol_px: float = 2.0, min_common: int = 5) -> PairTruth:
    """Precision and recall of bundle.pairs[(a, b)] under cams and the true offsets_s."""
    xa, xb, F = _same_moment(bundle, cams, a, b, offsets_s[b] - offsets_s[a])
    tp = bundle.pair(a, b)
    index = np.zeros((0, 2), np.int64) if tp is None else tp.index
    d = _sampson_px(xa[index[:, 0]], xb[index[:, 1]], F[None])  # (P,Tb), NaN where not both seen
    common = np.isfinite(d).sum(1)
    hits = (d < tol_px).sum(1)
    judged = common >= min_common
    right = judged & (2 * hits > common)
    # every right pair among all tracks: per frame of b, the points within tol of each other's line
    keys = []
    for q in range(xb.shape[1]):
        if not np.all(np.isfinite(F[q])):
            continue
        sa = np.nonzero(np.isfinite(xa[:, q, 0]))[0]
        sb = np.nonzero(np.isfinite(xb[:, q, 0]))[0]
        if not len(sa) or not len(sb):
            continue
        dq = _sampson_px(xa[sa, q][:, None], xb[sb, q][None, :], F[q])
        i, j = np.nonzero(dq < tol_px)
        keys.append(sa[i].astype(np.int64) * xb.shape[0] + sb[j])
    possible = 0
    if keys:
        key, n_hit = np.unique(np.concatenate(keys), return_counts=True)
        ci, cj = key // xb.shape[0], key % xb.shape[0]
        n_common = (np.isfinite(xa[ci, :, 0]) & np.isfinite(xb[cj, :, 0]) &
                    np.isfinite(F[None, :, 0, 0])).sum(1)
        ok = (n_common >= min_common) & (2 * n_hit > n_common)
        possible = int(min(len(np.unique(ci[ok])), len(np.unique(cj[ok]))))
    return PairTruth(len(index), int(right.sum()), int(judged.sum()), possible)


def bundle_pair_truth(bundle: CueBundle, cams: dict[str, CameraTrack], offsets_s: dict[str, float],
                      tol_px: float = 2.0) -> dict[tuple[str, str], PairTruth]:
    """pair_truth of every pair of the bundle whose two cameras are in cams."""
    return {k: pair_truth(bundle, cams, offsets_s, k[0], k[1], tol_px)
            for k in bundle.pairs if k[0] in cams and k[1] in cams}
