"""A straightforward reference implementation of the landscape, for the speed benchmark and tests.

Per candidate offset: interpolate the other video's points, build F for every frame, compute
F x for every point with numpy, and average the robust loss. No compiled code, no reuse across
offsets.
"""

from __future__ import annotations

import numpy as np

from ..geometry.epipolar import epipolar_residual
from ..geometry.sampling import tracks_between_frames
from .landscape import MIN_TERMS, PairEnergy


def reference_energy(pe: PairEnergy, offsets_s: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    out = np.full(len(offsets_s), np.nan)
    support = np.zeros(len(offsets_s), dtype=np.int64)
    xs = pe.xs[pe.pair_s]  # (P,Ts,2)
    for d, off in enumerate(offsets_s):
        k, w = pe._brackets(np.array([off]))
        k, w = k[0], w[0]
        y = tracks_between_frames(pe.xi, k, w, pe.pair_i)  # (P,Ts,2)
        G = pe._G_moving(k[None], w[None])[0] if pe.moving else pe.G_static
        with np.errstate(invalid="ignore", divide="ignore"):
            r = epipolar_residual(G, xs, y, pe.cfg.residual)
        valid = np.isfinite(r)
        if pe.cfg.loss == "truncated":
            r = np.minimum(r, scale)
        wgt = pe.weight[:, None] * valid
        support[d] = int(valid.sum())
        if support[d] >= MIN_TERMS:
            out[d] = float(np.sum(np.where(valid, r, 0.0) * wgt) / wgt.sum())
    return out, support
