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
from ..geometry.two_view import sampson_px
from ..geometry.sampling import (
    camera_at_frames,
    camera_between_frames,
    tracks_between_frames,
)
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
    """Per frame q of b: a's tracks and camera read at the same moment (geometry.sampling: linear
    between a's two frames around it, the camera slerped), and F_ab of that moment.

    Returns xa (Na,Tb,2) (NaN where a is not seen then), xb (Nb,Tb,2), F (Tb,3,3) (NaN where a
    camera has no pose)."""
    ia, ib = bundle.video(a), bundle.video(b)
    k, w = frame_brackets(ia.timestamps_s, ib.timestamps_s + delta_ab_s)  # (Tb,)
    xa = tracks_between_frames(bundle.tracks[a].xy, k, w)
    ca = camera_between_frames(cams[a], k, w)  # NaN outside a's video or where a has no pose
    cb = camera_at_frames(cams[b], np.arange(ib.num_frames))
    F = fundamental_from_cameras(ca.K, ca.cam_from_world, cb.K, cb.cam_from_world)
    return xa, bundle.tracks[b].xy, F


def pair_truth(bundle: CueBundle, cams: dict[str, CameraTrack], offsets_s: dict[str, float],
               a: str, b: str, tol_px: float = 2.0, min_common: int = 5) -> PairTruth:
    """Precision and recall of bundle.pairs[(a, b)] under cams and the true offsets_s."""
    xa, xb, F = _same_moment(bundle, cams, a, b, offsets_s[b] - offsets_s[a])
    tp = bundle.pair(a, b)
    index = np.zeros((0, 2), np.int64) if tp is None else tp.index
    d = sampson_px(F[None], xa[index[:, 0]], xb[index[:, 1]])  # (P,Tb), NaN where not both seen
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
        dq = sampson_px(F[q], xa[sa, q][:, None], xb[sb, q][None, :])
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
