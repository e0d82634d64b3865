"""Triangulated 3D trajectories of a run: the track pairs of accepted video pairs, with b read at
a's moments through the solved offsets. Both the recording (world/trajectories) and the report's
3D scene draw these, so they show the same points. Numbers only (no rerun, no drawing).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..geometry.triangulate import triangulate_over_time
from ..types import CueBundle

MIN_SEGMENT_SAMPLES = 5  # shorter runs of a trajectory are dropped (too short to show motion)
MAX_STEP_RATIO = 8.0  # a run is cut where one step exceeds this x the track's median step
REGION_RADIUS_RATIO = 1.5  # points farther from the scene's middle than this x the cameras' spread are dropped


@dataclass(frozen=True)
class Segment:
    """One unbroken run of a triangulated track: row `track` of points_world, frames [start, stop)."""

    track: int
    start: int
    stop: int


@dataclass(frozen=True)
class PairTrajectories:
    """3D positions of paired tracks of one accepted pair, triangulated at the solved offsets."""

    a: str
    b: str
    track_pairs: np.ndarray  # (P,2) int, the rows of the pair's TrackPairs.index triangulated
    points_world: np.ndarray  # (P,Ta,3) world units, NaN where not triangulated, rejected or in no segment
    time_s: np.ndarray  # (Ta,) global time of a's frames (τ_a + offset_s[a]), seconds
    instance: np.ndarray  # (P,) int (-1 unknown)
    segments: tuple[Segment, ...]  # runs to draw as lines; every finite point lies in one
    reprojection_px: float  # median reprojection error (larger of the two views) of the kept points


def triangulate_pair(bundle: CueBundle, a: str, b: str, offset_a_s: float, offset_b_s: float,
                     max_tracks: int) -> PairTrajectories | None:
    """Track pairs of (a, b) triangulated at a's frames, b read at the same global moment.

    At most max_tracks track pairs, evenly spread over the pair's list. Points pass the filter of
    geometry.triangulate.triangulate_track_pair; then each track is cut into segments (see
    split_segments). No region filter here (see run_trajectories).
    """
    tp = bundle.pair(a, b)
    if tp is None or len(tp.index) == 0:
        return None
    idx = tp.index
    if len(idx) > max_tracks:
        idx = idx[np.linspace(0, len(idx) - 1, max_tracks).round().astype(int)]
    va, vb = bundle.video(a), bundle.video(b)
    tri, g = triangulate_over_time(va.timestamps_s, bundle.cameras[a], bundle.tracks[a].xy, offset_a_s,
                                   vb.timestamps_s, bundle.cameras[b], bundle.tracks[b].xy, offset_b_s,
                                   idx, at="a")
    err = tri.reprojection_px[tri.kept]
    inst = bundle.tracks[a].instance
    inst = inst[idx[:, 0]] if inst is not None else np.full(len(idx), -1)
    X, segs = split_segments(tri.points_world)
    return PairTrajectories(a, b, idx, X, g, np.asarray(inst), segs,
                            float(np.median(err)) if err.size else float("nan"))


def split_segments(points_world: np.ndarray) -> tuple[np.ndarray, tuple[Segment, ...]]:
    """(points (P,T,3) with samples outside every segment set NaN, segments) of (P,T,3) points.

    A segment is a run of consecutive finite samples, cut where one step is longer than
    MAX_STEP_RATIO x the track's median step (a wrong match or near-parallel rays make a jump);
    runs shorter than MIN_SEGMENT_SAMPLES are dropped.
    """
    X = np.array(points_world, dtype=np.float64)
    keep = np.zeros(X.shape[:2], bool)
    segs: list[Segment] = []
    for p in range(X.shape[0]):
        idx = np.flatnonzero(np.isfinite(X[p]).all(-1))
        if len(idx) < MIN_SEGMENT_SAMPLES:
            continue
        step = np.linalg.norm(np.diff(X[p, idx], axis=0), axis=1)
        cut = (np.diff(idx) > 1) | (step > MAX_STEP_RATIO * np.median(step) + 1e-12)
        for run in np.split(idx, np.flatnonzero(cut) + 1):
            if len(run) >= MIN_SEGMENT_SAMPLES:
                segs.append(Segment(p, int(run[0]), int(run[-1]) + 1))
                keep[p, run] = True
    X[~keep] = np.nan
    return X, tuple(segs)


def run_trajectories(bundle: CueBundle, accepted: Sequence[tuple[str, str, float]],
                     offsets_s: Mapping[str, float | None], max_video_pairs: int,
                     max_tracks: int) -> tuple[PairTrajectories, ...]:
    """The trajectories of a run: the accepted pairs (a, b, contrast) whose two videos have an
    offset, sharpest landscape first (then by name), at most max_video_pairs of them, each with at
    most max_tracks track pairs.

    Points farther from the scene's middle (median of all kept points) than REGION_RADIUS_RATIO x
    the spread of the camera centres are dropped: what no camera looks at is a wrong match.
    """
    ok = [(a, b, c) for a, b, c in accepted
          if offsets_s.get(a) is not None and offsets_s.get(b) is not None]
    ok.sort(key=lambda p: (-p[2], f"{p[0]}__{p[1]}"))
    out = []
    for a, b, _ in ok[:max(0, max_video_pairs)]:
        tj = triangulate_pair(bundle, a, b, float(offsets_s[a]), float(offsets_s[b]), max_tracks)
        if tj is not None and tj.segments:
            out.append(tj)
    if not out:
        return ()
    pts = np.concatenate([t.points_world.reshape(-1, 3) for t in out])
    pts = pts[np.isfinite(pts).all(1)]
    mid = np.median(pts, axis=0)
    centers = np.concatenate([_valid_centers(bundle, n) for n in bundle.names])
    if len(centers) > 1:
        radius = REGION_RADIUS_RATIO * np.max(np.linalg.norm(centers - centers.mean(0), axis=1))
    else:  # one camera position: judge by the points' own spread
        radius = 5.0 * np.median(np.linalg.norm(pts - mid, axis=1))
    kept = []
    for t in out:
        X = t.points_world.copy()
        with np.errstate(invalid="ignore"):
            X[~(np.linalg.norm(X - mid, axis=-1) < radius)] = np.nan
        X, segs = split_segments(X)
        if segs:
            kept.append(PairTrajectories(t.a, t.b, t.track_pairs, X, t.time_s, t.instance, segs,
                                         t.reprojection_px))
    return tuple(kept)


def _valid_centers(bundle: CueBundle, name: str) -> np.ndarray:
    cam = bundle.cameras[name]
    C = cam.centers()
    if cam.valid is not None and len(C) == len(cam.valid) and len(C) > 1:
        C = C[cam.valid]
    return C
