"""Speed of the Stage 1 landscape: compiled kernel vs the straightforward reference, same process.

Workload: 5,000 track pairs x 300 frames x 201 candidate offsets, for a static pair and
for a pair with a moving camera. Tracks are full length (the worst case: no NaN to skip).
"""

from __future__ import annotations

import resource
import time
from dataclasses import dataclass

import numba
import numpy as np

from ..geometry.epipolar import look_at, project
from ..geometry.offsets import grid_between
from ..sync.config import LandscapeConfig
from ..sync.landscape import PairEnergy, PairInput
from ..sync.reference import reference_energy
from ..types import CameraTrack, TrackPairs, Tracks, VideoInfo


@dataclass(frozen=True)
class EnergyBenchRow:
    case: str
    implementation: str
    seconds: float  # median of repeats
    peak_rss_mb: float  # process peak resident memory after this measurement
    max_abs_diff: float  # max |E_fast - E_ref| over offsets (0 for the reference row)


def _workload(moving: bool, pairs: int = 5000, frames: int = 300, seed: int = 0):
    rng = np.random.default_rng(seed)
    fps = 30.0
    t = np.arange(frames) / fps
    X = rng.uniform(-1, 1, size=(pairs, 1, 3)) + np.stack(
        [np.sin(1.3 * t), np.cos(0.7 * t), 0.3 * np.sin(2.1 * t)], -1)[None] + [0, 0, 1]
    K_a = np.array([[900.0, 0, 640], [0, 880, 360], [0, 0, 1]])
    K_b = np.array([[700.0, 0, 630], [0, 710, 350], [0, 0, 1]])
    T_a = look_at([8, 1, 2], [0, 0, 1])
    if moving:
        T_b = np.stack([look_at([1 + 0.5 * np.sin(tt), 8, 2 + 0.1 * np.cos(3 * tt)], [0, 0, 1]) for tt in t])
    else:
        T_b = look_at([1, 8, 2], [0, 0, 1])
    offset = 0.4
    xa = project(K_a[None, None], T_a[None, None], X)
    Tb = T_b if moving else np.broadcast_to(T_b, (frames, 4, 4))
    # b sees the same trajectory shifted by the offset (τ_a = τ_b + Δ)
    Xb = np.concatenate([X[:, int(offset * fps):], np.repeat(X[:, -1:], int(offset * fps), 1)], 1)
    xb = project(K_b[None, None], Tb[None], Xb)
    xa += rng.normal(scale=0.5, size=xa.shape)
    xb += rng.normal(scale=0.5, size=xb.shape)
    va = VideoInfo.constant_rate("a", 1280, 720, frames, fps)
    vb = VideoInfo.constant_rate("b", 1280, 720, frames, fps)
    a = PairInput(va, CameraTrack(K_a, T_a), Tracks(xa))
    b = PairInput(vb, CameraTrack(K_b, T_b), Tracks(xb))
    idx = np.stack([np.arange(pairs), np.arange(pairs)], 1)
    return a, b, TrackPairs("a", "b", idx)


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run_energy_bench(repeats: int = 3, reference_offsets: int = 201) -> list[EnergyBenchRow]:
    rows = []
    offsets = grid_between(-100 / 30.0, 100 / 30.0, 1 / 30.0)  # 201 candidates at the frame step
    for case, moving in (("static pair", False), ("moving camera", True)):
        a, b, tp = _workload(moving)
        pe = PairEnergy(a, b, tp, LandscapeConfig())
        scale = 100.0
        pe.energy(offsets[:3], scale)  # compile (cached on disk after the first run)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            e_fast, _ = pe.energy(offsets, scale)
            times.append(time.perf_counter() - t0)
        rows.append(EnergyBenchRow(case, f"numba kernel ({numba.get_num_threads()} threads)",
                                   float(np.median(times)), _peak_mb(), 0.0))
        sub = offsets[:: max(1, len(offsets) // reference_offsets)]
        t0 = time.perf_counter()
        e_ref, _ = reference_energy(pe, sub, scale)
        t_ref = (time.perf_counter() - t0) * len(offsets) / len(sub)
        e_fast_sub, _ = pe.energy(sub, scale)
        diff = float(np.nanmax(np.abs(e_fast_sub - e_ref)))
        rows.append(EnergyBenchRow(case, "numpy reference (per offset F x)", t_ref, _peak_mb(), diff))
    return rows


def format_rows(rows: list[EnergyBenchRow]) -> str:
    out = [f"{'case':<15}{'implementation':<36}{'time_s':>9}{'speed-up':>10}{'peak_rss_MB':>13}{'max|ΔE|':>10}"]
    by_case: dict[str, float] = {}
    for r in rows:
        if r.implementation.startswith("numpy"):
            by_case[r.case] = r.seconds
    for r in rows:
        ratio = by_case[r.case] / r.seconds
        out.append(f"{r.case:<15}{r.implementation:<36}{r.seconds:>9.3f}{ratio:>9.1f}x{r.peak_rss_mb:>13.0f}"
                   f"{r.max_abs_diff:>10.2g}")
    return "\n".join(out)
