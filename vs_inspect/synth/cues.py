"""Cue-level synthetic scenes: moving 3D points seen by static and moving cameras, written as a
cue bundle with the true offsets. Everything that makes real cues hard is a knob: pixel noise,
fragmented tracks, wrong track pairs, pose errors, mixed and variable frame rates, pairs with no
matches and a pair whose matches are all wrong. Deterministic from the seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..geometry.epipolar import look_at, project
from ..types import CameraTrack, CueBundle, TrackPairs, Tracks, VideoInfo


@dataclass(frozen=True)
class CueSceneConfig:
    cameras: int = 7
    """Number of cameras (videos)."""
    moving: int = 2
    """How many of them are hand-held (moving, with shake)."""
    variable_rate: int = 1
    """How many videos have a variable frame rate (per-frame timestamps)."""
    seconds: float = 8.0
    """Typical video length; each video gets 0.8-1.0 of it."""
    max_offset_s: float = 2.5
    """Start offsets are drawn in ±max_offset_s around the reference (video 0)."""
    noise_px: float = 0.8
    """Gaussian pixel noise of every track point (1-sigma, per coordinate)."""
    wrong_fraction: float = 0.25
    """Share of track pairs that join two different physical points."""
    pose_error_deg: float = 0.5
    """Rotation error of every written camera pose (and 1% of the distance in translation)."""
    track_life_s: tuple[float, float] = (1.0, 4.0)
    """A track lives this long before the tracker loses it and a new track starts."""
    points_per_object: int = 40
    """Surface points tracked on each moving object."""
    pairs_per_view_pair: int = 400
    """Track pairs written for each pair of views (fewer if fewer exist)."""
    no_match_pairs: int = 1
    """Pairs of views that get no track pairs at all."""
    all_wrong_pair: bool = True
    """One pair of views whose track pairs are all wrong (it must be rejected)."""
    fps_choices: tuple[float, ...] = (24.0, 25.0, 30.0, 50.0, 60.0)
    """Frame rates drawn for the videos."""
    seed: int = 0
    """Seed of everything random."""
    drift_ppm: float = 0.0
    """Clock drift of every non-reference video, ± this (random sign, ppm): its frames show the
    moments offset_s + (1 + drift) * t_local (0: the constant-offset world of the paper)."""


@dataclass(frozen=True)
class CueScene:
    bundle: CueBundle  # with gt_offsets_s set; cameras carry the pose errors
    true_cameras: dict[str, CameraTrack]  # exact cameras
    points_world: np.ndarray  # (M, G, 3) m, true 3D points on the global time grid
    times_global_s: np.ndarray  # (G,) s
    all_wrong_pair: tuple[str, str] | None
    no_match_pairs: tuple[tuple[str, str], ...]


# ---- the moving world: analytic trajectories, so any time can be sampled exactly ------------


def object_points(g: np.ndarray, rng: np.random.Generator, per_object: int) -> np.ndarray:
    """(M, len(g), 3) positions of all tracked points at global times g (seconds)."""
    g = np.asarray(g, dtype=np.float64)
    objs = []
    # 1. a walking figure: centre on a circle, limbs swinging at the step rate.
    local = rng.uniform([-0.2, -0.15, 0.0], [0.2, 0.15, 1.8], size=(per_object, 3))
    heading = 0.4 * g + 0.3
    cx, cy = 2.0 * np.cos(heading), 2.0 * np.sin(heading)
    swing = 0.35 * np.sin(2 * np.pi * 1.6 * g)[None, :] * (1.0 - local[:, 2:3] / 1.8) ** 2
    fwd = np.stack([-np.sin(heading), np.cos(heading)])  # direction of travel
    side = np.stack([np.cos(heading), np.sin(heading)])
    px = cx[None] + local[:, 0:1] * side[0][None] + (local[:, 1:2] + swing) * fwd[0][None]
    py = cy[None] + local[:, 0:1] * side[1][None] + (local[:, 1:2] + swing) * fwd[1][None]
    pz = np.broadcast_to(local[:, 2:3] + 0.05 * np.abs(np.sin(2 * np.pi * 1.6 * g))[None], px.shape)
    objs.append(np.stack([px, py, pz], -1))
    # 2. a bouncing ball that drifts across and spins.
    dirs = rng.normal(size=(per_object, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    centre = np.stack([-2.5 + 0.45 * np.mod(g + 3.0, 11.0), 1.0 * np.sin(0.3 * g),
                       0.25 + 1.4 * np.abs(np.sin(np.pi * g / 1.3))], -1)
    spin = Rotation.from_rotvec(np.outer(3.0 * g, [0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2]))
    rot_dirs = np.einsum("gij,mj->mgi", spin.as_matrix(), dirs)
    objs.append(centre[None] + 0.25 * rot_dirs)
    # 3. a rotating box moving slowly along a line.
    face = rng.integers(0, 3, per_object)
    box = rng.uniform(-1, 1, size=(per_object, 3))
    box[np.arange(per_object), face] = np.sign(box[np.arange(per_object), face])
    box *= [0.4, 0.3, 0.25]
    rot = Rotation.from_rotvec(np.outer(2 * np.pi * g / 3.0, [0.2, 0.3, 1.0]) / np.linalg.norm([0.2, 0.3, 1.0]))
    bc = np.stack([0.5 + 0.15 * g, -1.5 + 0.05 * g, 0.9 + 0.2 * np.sin(0.9 * g)], -1)
    objs.append(bc[None] + np.einsum("gij,mj->mgi", rot.as_matrix(), box))
    # 4. a drifting blob on a Lissajous path (e.g. a bird or a drone).
    blob = rng.normal(scale=0.15, size=(per_object, 3))
    path = np.stack([1.8 * np.sin(0.7 * g + 1.0), 1.5 * np.sin(1.1 * g), 2.2 + 0.6 * np.sin(0.5 * g)], -1)
    objs.append(path[None] + blob[:, None, :])
    return np.concatenate(objs, axis=0)


def _rand_rotation(rng: np.random.Generator, deg: float) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return Rotation.from_rotvec(np.deg2rad(deg) * axis).as_matrix()


def make_cue_scene(cfg: CueSceneConfig = CueSceneConfig()) -> CueScene:
    """The scene of cfg (deterministic from cfg.seed): its videos' clocks, true and written
    cameras, fragmented tracks and track pairs (some wrong) as a cue bundle with the true offsets."""
    rng = np.random.default_rng(cfg.seed)
    n = cfg.cameras
    if n < 2:
        raise ValueError(f"a scene needs at least 2 cameras, got {n}")
    names = [f"cam{i}" for i in range(n)]
    offsets = {names[0]: 0.0}
    for v in names[1:]:
        offsets[v] = float(np.round(rng.uniform(-cfg.max_offset_s, cfg.max_offset_s), 4))
    # signs from their own stream: a scene without drift is the same scene as before
    signs = np.random.default_rng(cfg.seed + 104729).choice([-1.0, 1.0], size=n)
    drift = {v: (0.0 if i == 0 else float(signs[i] * cfg.drift_ppm)) for i, v in enumerate(names)}
    moving = set(names[n - cfg.moving:]) if cfg.moving else set()
    vfr = set(names[1:1 + cfg.variable_rate]) - moving if cfg.variable_rate else set()
    resolutions = [(1280, 720), (1920, 1080), (640, 480), (1024, 768), (960, 540)]

    videos, true_cams, cams, tracks = [], {}, {}, {}
    per_video_obs = {}
    for ci, v in enumerate(names):
        video, g = _scene_video(v, ci, resolutions, vfr, offsets, drift, cfg, rng)
        videos.append(video)
        K, T_true, radius = _scene_camera(v, ci, n, video, g, moving, rng)
        true_cams[v] = CameraTrack(K, T_true)
        cams[v] = CameraTrack(K, _written_pose(T_true, radius, cfg, rng))
        per_video_obs[v] = _observed(g, K, T_true, video, cfg, rng)

    M = per_video_obs[names[0]].shape[0]
    inst_of_point = np.repeat(np.arange(M // cfg.points_per_object), cfg.points_per_object)
    seg_point: dict[str, np.ndarray] = {}
    for video in videos:
        v = video.name
        tracks[v], seg_point[v] = _fragmented_tracks(video, per_video_obs[v], M, inst_of_point, cfg, rng)

    pairs, no_match, all_wrong = _scene_pairs(names, n, seg_point, inst_of_point, cfg, rng)

    g_grid = np.linspace(-cfg.max_offset_s, cfg.seconds + cfg.max_offset_s, 200)
    pts = object_points(g_grid, np.random.default_rng(cfg.seed + 7919), cfg.points_per_object)
    bundle = CueBundle(tuple(videos), cams, tracks, pairs, offsets,
                       gt_drift_ppm=drift if cfg.drift_ppm else None)
    return CueScene(bundle, true_cams, pts, g_grid, all_wrong, no_match)


def _scene_video(v: str, ci: int, resolutions: list[tuple[int, int]], vfr: set[str], offsets: dict[str, float],
                 drift: dict[str, float], cfg: CueSceneConfig, rng: np.random.Generator
                 ) -> tuple[VideoInfo, np.ndarray]:
    """(video v's clock and size, the global time (T,) s of each of its frames): a frame rate of
    cfg.fps_choices, 0.8-1.0 of cfg.seconds long, a variable rate when v is in vfr."""
    W, H = resolutions[ci % len(resolutions)]
    fps = float(rng.choice(cfg.fps_choices))
    dur = cfg.seconds * rng.uniform(0.8, 1.0)
    T = int(dur * fps)
    if v in vfr:
        dt = (1.0 / fps) * rng.uniform(0.7, 1.3, size=T - 1)
        ts = np.concatenate([[0.0], np.cumsum(dt)])
        video = VideoInfo(v, W, H, T, ts, None)
    else:
        video = VideoInfo.constant_rate(v, W, H, T, fps)
    g = video.timestamps_s + offsets[v] if not cfg.drift_ppm else \
        offsets[v] + (1.0 + drift[v] * 1e-6) * video.timestamps_s
    return video, g


def _scene_camera(v: str, ci: int, n: int, video: VideoInfo, g: np.ndarray, moving: set[str],
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """(K (3,3), true cam_from_world (4,4), or (T,4,4) for a moving camera, its distance from the
    scene's centre): camera ci of n on a ring around the scene, looking at its middle; a moving
    one walks along the ring while panning, with shake."""
    W, H, T = video.width, video.height, video.num_frames
    fx = W * rng.uniform(0.8, 1.1)
    K = np.array([[fx, 0, W / 2 + rng.uniform(-10, 10)],
                  [0, fx * rng.uniform(0.97, 1.03), H / 2 + rng.uniform(-10, 10)], [0, 0, 1]])
    angle = 2 * np.pi * ci / n + rng.uniform(-0.2, 0.2)
    radius = rng.uniform(8.0, 10.0)
    height = rng.uniform(1.2, 3.0)
    target = np.array([0.0, 0.0, 1.0]) + rng.uniform(-0.3, 0.3, 3)
    if v in moving:
        # hand-held: walks along an arc while panning, plus shake at 2-5 Hz.
        ang = angle + 0.06 * (g - g[0])
        shake = sum(rng.uniform(0.005, 0.02) * np.sin(2 * np.pi * f * g + rng.uniform(0, 6))[:, None]
                    * rng.normal(size=3)[None] for f in (2.1, 3.3, 4.7))
        C = np.stack([radius * np.cos(ang), radius * np.sin(ang), np.full_like(g, height)], -1) + shake
        aim = target[None] + 0.3 * np.stack([np.sin(0.5 * g), np.cos(0.4 * g), 0.2 * np.sin(0.7 * g)], -1)
        T_true = np.stack([look_at(C[k], aim[k]) for k in range(T)])
    else:
        C = np.array([radius * np.cos(angle), radius * np.sin(angle), height])
        T_true = look_at(C, target)
    return K, T_true, radius


def _written_pose(T_true: np.ndarray, radius: float, cfg: CueSceneConfig, rng: np.random.Generator) -> np.ndarray:
    """T_true as the bundle writes it: rotated by cfg.pose_error_deg about a random axis and moved
    by 1% of radius."""
    # written pose: rotation error pose_error_deg, translation error 1% of the distance.
    R_err = _rand_rotation(rng, cfg.pose_error_deg)
    t_err = rng.normal(size=3)
    t_err *= 0.01 * radius / np.linalg.norm(t_err) if cfg.pose_error_deg > 0 else 0.0
    T_noisy = np.array(T_true, copy=True)
    T_noisy[..., :3, :3] = R_err @ T_true[..., :3, :3]
    T_noisy[..., :3, 3] = (R_err @ T_true[..., :3, 3].T).T + t_err if T_true.ndim == 3 else \
        R_err @ T_true[:3, 3] + t_err
    return T_noisy


def _observed(g: np.ndarray, K: np.ndarray, T_true: np.ndarray, video: VideoInfo, cfg: CueSceneConfig,
              rng: np.random.Generator) -> np.ndarray:
    """(M,T,2) px of every moving point in every frame (global times g), with cfg.noise_px of
    noise; NaN outside the image."""
    W, H, T = video.width, video.height, video.num_frames
    # observations of every point at every frame
    X = object_points(g, np.random.default_rng(cfg.seed + 7919), cfg.points_per_object)
    Tm = T_true if T_true.ndim == 3 else np.broadcast_to(T_true, (T, 4, 4))
    xy = project(K[None, None], Tm[None], X)
    inside = (xy[..., 0] >= 0) & (xy[..., 0] <= W - 1) & (xy[..., 1] >= 0) & (xy[..., 1] <= H - 1)
    xy[~inside] = np.nan
    xy += rng.normal(scale=cfg.noise_px, size=xy.shape) if cfg.noise_px > 0 else 0.0
    return xy


def _fragmented_tracks(video: VideoInfo, obs: np.ndarray, M: int, inst_of_point: np.ndarray, cfg: CueSceneConfig,
                       rng: np.random.Generator) -> tuple[Tracks, np.ndarray]:
    """(the video's tracks, the point (M) each follows): each point's observations obs (M,T,2) cut
    into tracks that live cfg.track_life_s, with short gaps before the tracker seeds again."""
    T = video.num_frames
    rows, owners = [], []
    for m in range(M):
        seen = np.isfinite(obs[m, :, 0])
        k = 0
        while k < T:
            if not seen[k]:
                k += 1
                continue
            life = rng.uniform(*cfg.track_life_s)
            end = k
            while end < T and seen[end] and video.timestamps_s[end] - video.timestamps_s[k] < life:
                end += 1
            if end - k >= 3:
                row = np.full((T, 2), np.nan)
                row[k:end] = obs[m, k:end]
                rows.append(row)
                owners.append(m)
            k = end + int(rng.integers(0, 3))  # a short gap before the tracker re-seeds
    xy = np.stack(rows) if rows else np.zeros((0, T, 2))
    return Tracks(xy.astype(np.float32), inst_of_point[np.asarray(owners, dtype=int)]), np.asarray(owners, dtype=int)


def _scene_pairs(names: list[str], n: int, seg_point: dict[str, np.ndarray], inst_of_point: np.ndarray,
                 cfg: CueSceneConfig, rng: np.random.Generator
                 ) -> tuple[dict[tuple[str, str], TrackPairs], tuple[tuple[str, str], ...], tuple[str, str] | None]:
    """(track pairs of every pair of views, the pairs of views given none, the pair whose pairs
    are all wrong or None): up to cfg.pairs_per_view_pair tracks of the same point, a
    cfg.wrong_fraction of them joined to another point instead (half on the same object)."""
    all_pairs = [(names[i], names[j]) for i in range(n) for j in range(i + 1, n)]
    order = rng.permutation(len(all_pairs))
    no_match = tuple(all_pairs[i] for i in order[: cfg.no_match_pairs])
    all_wrong = all_pairs[order[cfg.no_match_pairs]] if cfg.all_wrong_pair and len(all_pairs) > cfg.no_match_pairs else None
    pairs: dict[tuple[str, str], TrackPairs] = {}
    for a, b in all_pairs:
        if (a, b) in no_match:
            continue
        pa, pb = seg_point[a], seg_point[b]
        same = [(i, j) for i in range(len(pa)) for j in np.flatnonzero(pb == pa[i])]
        if not same:
            continue
        same = np.array(same)
        take = same[rng.permutation(len(same))[: cfg.pairs_per_view_pair]]
        n_wrong = len(take) if (a, b) == all_wrong else int(round(cfg.wrong_fraction * len(take)))
        wrong_rows = rng.permutation(len(take))[:n_wrong]
        for r in wrong_rows:
            i = take[r, 0]
            # half the wrong matches land on the same object (the hard kind), half anywhere
            same_obj = np.flatnonzero((inst_of_point[pb] == inst_of_point[pa[i]]) & (pb != pa[i]))
            pool = same_obj if (rng.random() < 0.5 and len(same_obj)) else np.flatnonzero(pb != pa[i])
            take[r, 1] = rng.choice(pool)
        pairs[(a, b)] = TrackPairs(a, b, take)
    return pairs, no_match, all_wrong
