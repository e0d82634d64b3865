"""Rendered scenes whose cameras share a view (an arc of 30-90°), through the whole pipeline with
estimated cameras: a safety benchmark (no offset should be reported resolved with an error over
2 frames), counted per offset.

A scene is named a<arc>_c<cameras>m<hand-held>_s<seed>, e.g. a60_c4m1_s12: 60° arc, 4 cameras of
which 1 hand-held, seed 12, rendered as `vs-inspect synth-video --arc-deg 60 --cameras 4
--moving 1 --seed 12 --seconds 6` would render it (640×480, 30 fps). The suffix _mixed (e.g.
a60_c4m1_s70_mixed) draws each camera's frame rate from 24, 25, 30, 50 and 60 fps instead
(`--fps 0`), as phones and action cameras filming one event record.
"""

from __future__ import annotations

import itertools
import re
import statistics
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

SCENE_SECONDS = 6.0
SCENE_FPS = 30.0  # every camera's, unless the scene's rates are mixed
_NAME = re.compile(r"a(\d+)_c(\d+)m(\d+)_s(\d+)(_mixed)?")

# Each set below draws its scenes from its own seeds; every set but the first mixes arcs, camera
# counts and hand-held cameras the same way.
# seeds 0-9: arcs of 30-90°, 3-5 cameras
SEEDS_0_9_SCENES = ("a30_c4m1_s9", "a45_c4m1_s4", "a45_c4m1_s5", "a60_c3m0_s0", "a60_c3m0_s1",
                    "a60_c4m1_s0", "a60_c4m1_s1", "a60_c4m1_s2", "a60_c4m1_s3", "a60_c4m1_s8",
                    "a60_c5m2_s7", "a90_c4m0_s3", "a90_c4m1_s2", "a90_c4m1_s6")
# seeds 10-21 (the default set)
SEEDS_10_21_SCENES = ("a30_c4m1_s10", "a45_c4m1_s11", "a60_c4m1_s12", "a60_c4m1_s13", "a90_c4m1_s14",
                      "a60_c3m0_s15", "a45_c5m2_s16", "a30_c3m1_s17", "a60_c4m1_s18", "a90_c4m0_s19",
                      "a45_c4m1_s20", "a60_c5m2_s21")
SEEDS_22_33_SCENES = ("a30_c4m1_s22", "a45_c4m1_s23", "a60_c4m1_s24", "a60_c4m1_s25", "a90_c4m1_s26",
                      "a60_c3m0_s27", "a45_c5m2_s28", "a30_c3m1_s29", "a60_c4m1_s30", "a90_c4m0_s31",
                      "a45_c4m1_s32", "a60_c5m2_s33")
SEEDS_34_45_SCENES = ("a30_c4m1_s34", "a45_c4m1_s35", "a60_c4m1_s36", "a60_c4m1_s37", "a90_c4m1_s38",
                      "a60_c3m0_s39", "a45_c5m2_s40", "a30_c3m1_s41", "a60_c4m1_s42", "a90_c4m0_s43",
                      "a45_c4m1_s44", "a60_c5m2_s45")
SEEDS_46_57_SCENES = ("a30_c4m1_s46", "a45_c4m1_s47", "a60_c4m1_s48", "a60_c4m1_s49", "a90_c4m1_s50",
                      "a60_c3m0_s51", "a45_c5m2_s52", "a30_c3m1_s53", "a60_c4m1_s54", "a90_c4m0_s55",
                      "a45_c4m1_s56", "a60_c5m2_s57")
SEEDS_58_69_SCENES = ("a30_c4m1_s58", "a45_c4m1_s59", "a60_c4m1_s60", "a60_c4m1_s61", "a90_c4m1_s62",
                      "a60_c3m0_s63", "a45_c5m2_s64", "a30_c3m1_s65", "a60_c4m1_s66", "a90_c4m0_s67",
                      "a45_c4m1_s68", "a60_c5m2_s69")
# seeds 70-81, the same mix with each camera's frame rate drawn from 24-60 fps: tolerances counted
# in frames of the coarsest video meet cameras of different rates
MIXED_RATE_SCENES = tuple(f"{n}_mixed" for n in (
    "a30_c4m1_s70", "a45_c4m1_s71", "a60_c4m1_s72", "a60_c4m1_s73", "a90_c4m1_s74", "a60_c3m0_s75",
    "a45_c5m2_s76", "a30_c3m1_s77", "a60_c4m1_s78", "a90_c4m0_s79", "a45_c4m1_s80", "a60_c5m2_s81"))
SCENE_SETS = {"seeds-0-9": SEEDS_0_9_SCENES, "seeds-10-21": SEEDS_10_21_SCENES,
              "seeds-22-33": SEEDS_22_33_SCENES, "seeds-34-45": SEEDS_34_45_SCENES,
              "seeds-46-57": SEEDS_46_57_SCENES, "seeds-58-69": SEEDS_58_69_SCENES,
              "mixed-rates": MIXED_RATE_SCENES}
DEFAULT_SET = "seeds-10-21"


@dataclass(frozen=True)
class ArcScene:
    name: str
    arc_deg: float  # cameras spread over this arc (degrees)
    cameras: int
    moving: int  # how many of the cameras are hand-held
    seed: int
    mixed_rates: bool = False  # each camera's frame rate drawn from 24-60 fps (else SCENE_FPS)

    def scene_config(self):
        from ..synth.world import SceneConfig

        return SceneConfig(cameras=self.cameras, moving=self.moving, seconds=SCENE_SECONDS,
                           fps=None if self.mixed_rates else SCENE_FPS, arc_deg=self.arc_deg, seed=self.seed)


def parse_scene(name: str) -> ArcScene:
    """ArcScene from a name a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed]; ValueError names what is wrong."""
    m = _NAME.fullmatch(name)
    if not m:
        raise ValueError(f"{name!r}: not a scene name a<arc>_c<cameras>m<hand-held>_s<seed>[_mixed] "
                         "(e.g. a60_c4m1_s12)")
    arc, cams, moving, seed = (int(g) for g in m.groups()[:4])
    if not 0 < arc <= 360:
        raise ValueError(f"{name!r}: arc {arc}° is outside 1-360")
    if cams < 2 or moving > cams - 1:
        raise ValueError(f"{name!r}: needs at least 2 cameras and one of them static (got {cams}, {moving} hand-held)")
    return ArcScene(name, float(arc), cams, moving, seed, m.group(5) is not None)


def frame_errors(reference: str, offsets_s: dict[str, float | None], truth_s: dict[str, float],
                 fps: float | dict[str, float]) -> dict[str, float | None]:
    """Signed error of every non-reference video's offset in frames (None: unresolved).

    fps: every video's frame rate, or each video's ({video: fps}); then an error is in frames of
    the slower of the video and the reference (a 24 fps video against a 60 fps reference: 1/24 s)."""
    out: dict[str, float | None] = {}
    ref_s = offsets_s.get(reference)
    for v, t in truth_s.items():
        if v == reference:
            continue
        est = offsets_s.get(v)
        rate = min(fps[v], fps[reference]) if isinstance(fps, dict) else fps
        out[v] = None if est is None or ref_s is None else rate * ((est - ref_s) - (t - truth_s[reference]))
    return out


@dataclass(frozen=True)
class ArcSummary:
    offsets: int  # non-reference videos over all scenes
    resolved: int
    within_1: int  # |error| <= 1 frame
    from_1_to_2: int  # 1 < |error| <= 2 frames
    over_2: int  # |error| > 2 frames: the safety target says 0
    median_abs_frames: float | None  # over the resolved offsets
    max_abs_frames: float | None


def summarize(errors: list[float | None]) -> ArcSummary:
    got = [abs(e) for e in errors if e is not None]
    return ArcSummary(offsets=len(errors), resolved=len(got),
                      within_1=sum(e <= 1 for e in got), from_1_to_2=sum(1 < e <= 2 for e in got),
                      over_2=sum(e > 2 for e in got),
                      median_abs_frames=statistics.median(got) if got else None,
                      max_abs_frames=max(got) if got else None)


def _pose_at(T: np.ndarray, k: int) -> np.ndarray:
    return T if T.ndim == 2 else T[k]


def camera_errors_px(estimated: dict, truth: dict, timestamps_s: dict[str, np.ndarray],
                     offsets_s: dict[str, float], times_global_s: np.ndarray, points_world: np.ndarray,
                     undistort: dict[str, Callable[[np.ndarray], np.ndarray]] | None = None,
                     every: int = 3) -> dict[tuple[str, str], float]:
    """How well estimated cameras explain a scene's true moving points: {(a, b): median over the
    points of their mean distance (px) from each other's epipolar line}, for every pair of videos
    that both have an estimated camera. Stage 1's cue is exactly these distances, so they say
    how much of an offset's error the cameras can account for.

    estimated: name -> types.CameraTrack (pinhole; per frame for a moving camera, whose frames
    outside its valid ones are skipped); truth: name -> io.calibration.CameraCalibration;
    timestamps_s: name -> (T,) local frame times; offsets_s: the true offsets (DESIGN.md);
    times_global_s (G,), points_world (M,G,3): the scene's points over time (trajectories.npz).
    At every `every`-th frame of b, the points at that moment are projected with the true
    cameras (at a's frame nearest to it, and with the true lens), kept where both images see
    them, and undistorted like the tracks (undistort: name -> function of (N,2) px; none: as
    they are)."""
    import cv2

    from ..geometry.epipolar import epipolar_lines, fundamental_from_cameras, line_distance

    def seen(name: str, k: int, X: np.ndarray) -> np.ndarray:
        cal = truth[name]
        T = _pose_at(np.asarray(cal.cam_from_world, np.float64), k)
        rvec, _ = cv2.Rodrigues(T[:3, :3])
        xy, _ = cv2.projectPoints(X.reshape(-1, 1, 3), rvec, T[:3, 3], np.asarray(cal.K, np.float64),
                                  np.asarray(cal.dist, np.float64))
        xy = xy.reshape(-1, 2)
        depth = X @ T[2, :3] + T[2, 3]
        w, h = cal.size if cal.size is not None else (np.inf, np.inf)
        inside = (depth > 0) & (xy[:, 0] >= 0) & (xy[:, 1] >= 0) & (xy[:, 0] < w) & (xy[:, 1] < h)
        return np.where(inside[:, None], xy, np.nan)

    out = {}
    names = [n for n in estimated if n in truth and n in timestamps_s and n in offsets_s]
    for a, b in itertools.combinations(sorted(names), 2):
        ea, eb = estimated[a], estimated[b]
        ga = np.asarray(timestamps_s[a], np.float64) + offsets_s[a]  # a's frames on the global clock
        gb = np.asarray(timestamps_s[b], np.float64) + offsets_s[b]
        half = 0.5 * (ga[1] - ga[0]) if len(ga) > 1 else 0.0
        dist = []
        for kb in range(0, len(gb), max(1, every)):
            g = gb[kb]
            if not times_global_s[0] <= g <= times_global_s[-1]:
                continue
            ka = int(np.argmin(np.abs(ga - g)))
            if abs(ga[ka] - g) > half + 1e-9:
                continue  # a was not recording then
            if any(e.valid is not None and not e.valid[k] for e, k in ((ea, ka), (eb, kb))):
                continue
            i = int(np.clip(np.searchsorted(times_global_s, g), 1, len(times_global_s) - 1))
            w = (g - times_global_s[i - 1]) / (times_global_s[i] - times_global_s[i - 1])
            X = (1.0 - w) * points_world[:, i - 1] + w * points_world[:, i]  # (M,3) at g
            xa, xb = seen(a, ka, X), seen(b, kb, X)
            ok = np.isfinite(xa).all(1) & np.isfinite(xb).all(1)
            if not ok.any():
                continue
            xa, xb = xa[ok], xb[ok]
            if undistort:
                xa = undistort[a](xa) if a in undistort else xa
                xb = undistort[b](xb) if b in undistort else xb
            Ka = ea.K if ea.K.ndim == 2 else ea.K[ka]
            Kb = eb.K if eb.K.ndim == 2 else eb.K[kb]
            F = fundamental_from_cameras(Ka, _pose_at(ea.cam_from_world, ka), Kb, _pose_at(eb.cam_from_world, kb))
            d_a = line_distance(epipolar_lines(F, xb), xa)
            d_b = line_distance(epipolar_lines(np.swapaxes(F, -1, -2), xa), xb)
            dist.append(0.5 * (d_a + d_b))
        if dist:
            out[(a, b)] = float(np.median(np.concatenate(dist)))
    return out


@dataclass(frozen=True)
class BodyPointFit:
    """Which rigid moving body point each track of one video follows (the scene's truth)."""

    body: np.ndarray  # (N,) int index into the bodies given, -1: no body point within fit_px
    point_body: np.ndarray  # (N,3) m, the point in its body's frame (NaN where body is -1)
    residual_px: np.ndarray  # (N,) median distance of the track from that point's projection (inf: too short)


def fit_body_points(xy: np.ndarray, global_times_s: np.ndarray, K: np.ndarray, cam_from_world: np.ndarray,
                    bodies: list[Callable[[np.ndarray], np.ndarray]], fit_px: float = 1.5,
                    min_frames: int = 8) -> BodyPointFit:
    """For every track of xy (N,T,2 px, undistorted, NaN where unseen): the body point whose
    projection it follows best. bodies: world_from_body(global times (G,)) -> (G,4,4) of each
    moving body; global_times_s (T,): the true global time of each frame; cam_from_world (4,4)
    or (T,4,4): the true camera. As the body moves against the camera, the track's frames see
    one body point from many places, so the point is triangulated in the body's frame (linear,
    least squares) and judged by its reprojection. A track on an occluding edge, or one that
    slid from one point to another, follows none."""
    N, T = xy.shape[:2]
    cams = np.broadcast_to(np.asarray(cam_from_world, np.float64), (T, 4, 4))
    P = np.einsum("ij,tjk->tik", np.asarray(K, np.float64), cams[:, :3])  # (T,3,4)
    poses = [np.asarray(f(np.asarray(global_times_s, np.float64))) for f in bodies]  # each (T,4,4)
    body = np.full(N, -1)
    point = np.full((N, 3), np.nan)
    residual = np.full(N, np.inf)
    for n in range(N):
        seen = np.isfinite(xy[n]).all(1)
        if seen.sum() < min_frames:
            continue
        x = xy[n, seen].astype(np.float64)
        for bi, W in enumerate(poses):
            M = np.einsum("tij,tjk->tik", P[seen], W[seen])  # (F,3,4) image from body
            A = np.concatenate([x[:, :1] * M[:, 2] - M[:, 0], x[:, 1:] * M[:, 2] - M[:, 1]])
            X, *_ = np.linalg.lstsq(A[:, :3], -A[:, 3], rcond=None)
            p = M @ np.append(X, 1.0)
            if (p[:, 2] <= 0).any():
                continue
            r = float(np.median(np.linalg.norm(p[:, :2] / p[:, 2:] - x, axis=1)))
            if r < residual[n]:
                residual[n], body[n], point[n] = r, bi, X
    body[residual > fit_px] = -1
    point[body < 0] = np.nan
    return BodyPointFit(body, point, residual)


@dataclass(frozen=True)
class PairTruth:
    """Cross-view track pairs judged against the scene's true motion."""

    same_point: int  # both tracks follow one body point (within same_point_m)
    other_point: int  # both follow a body point, but not the same one
    not_rigid: int  # a track of the pair follows no body point (BodyPointFit.body -1)

    @property
    def total(self) -> int:
        return self.same_point + self.other_point + self.not_rigid


def judge_pairs(index: np.ndarray, fit_a: BodyPointFit, fit_b: BodyPointFit,
                same_point_m: float = 0.05) -> PairTruth:
    """Track pairs index (P,2) (track of a, track of b) counted by what their tracks follow
    (fit_body_points of each video): one point of one body (the two points within same_point_m
    metres in the body's frame), two different points, or, for at least one track, none."""
    ia, ib = np.asarray(index, np.int64).reshape(-1, 2).T
    rigid = (fit_a.body[ia] >= 0) & (fit_b.body[ib] >= 0)
    near = np.linalg.norm(fit_a.point_body[ia] - fit_b.point_body[ib], axis=1) <= same_point_m
    same = rigid & (fit_a.body[ia] == fit_b.body[ib]) & near
    return PairTruth(int(same.sum()), int((rigid & ~same).sum()), int((~rigid).sum()))
