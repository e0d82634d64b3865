"""A small dynamic 3D world with exact ground truth, seen by static and hand-held cameras.

Pure geometry and procedural textures (numpy + OpenCV drawing), no rendering and no I/O: the
renderer (render.py) draws what this module describes, and videos.py writes videos and truth.

- Static set: a large textured ground, textured walls around it and a few textured crates, so
  that camera poses can be estimated from the video.
- Moving bodies (every one rigid; the walking figure is articulated from rigid parts): a walking
  figure, a rolling and bouncing ball, a ball thrown back and forth, a spinning box on a floating
  path. Each body's pose is an analytic function of global time, so any moment is exact.
- Cameras: static cameras around the scene and hand-held ones (smooth walk plus shake), each with
  its own intrinsics (fx != fy, off-centre principal point), resolution, frame rate, start time
  (offset) and duration; options for motion blur, exposure differences, a camera that sees little
  of the motion, variable frame rate.

World frame: z up, metres. Camera frame: OpenCV (x right, y down, z forward), pixel coordinates
with integer values at pixel centres. Times: DESIGN.md convention, a frame at local time tau of
camera v shows the global moment g = tau + offset_s[v].

The meshes, textures and bodies are in meshes.py, textures.py and bodies.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from ..geometry.epipolar import camera_centers, look_at, project
from .bodies import (
    Body, PoseFn, _rot, bouncing_ball, spinning_box, static_set, thrown_ball, walking_figure,
)
from .meshes import sample_surface, triangle_areas
from .textures import add_marks


@dataclass(frozen=True)
class World:
    bodies: tuple[Body, ...]
    object_names: tuple[str, ...]  # name of each moving instance (index = Body.instance)
    track_points_body: np.ndarray  # (M,3) m, surface points in their body's frame
    track_normals_body: np.ndarray  # (M,3) unit normals in the body's frame
    track_body: np.ndarray  # (M,) int index into bodies

    @property
    def track_instance(self) -> np.ndarray:
        """(M,) moving-object instance of each surface point."""
        return np.array([self.bodies[b].instance for b in self.track_body], dtype=np.int64)

    def body_poses(self, g: np.ndarray) -> np.ndarray:
        """(B,G,4,4) world_from_body of every body at global times g."""
        return np.stack([b.world_from_body(g) for b in self.bodies])

    def points_at(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World positions and normals of the tracked surface points at times g:
        ((M,G,3) m, (M,G,3))."""
        g = np.atleast_1d(np.asarray(g, dtype=np.float64))
        M = len(self.track_body)
        X = np.zeros((M, len(g), 3))
        N = np.zeros((M, len(g), 3))
        for bi in np.unique(self.track_body):
            sel = self.track_body == bi
            T = self.bodies[bi].world_from_body(g)  # (G,4,4)
            X[sel] = np.einsum("gij,mj->mgi", T[:, :3, :3], self.track_points_body[sel]) + T[None, :, :3, 3]
            N[sel] = np.einsum("gij,mj->mgi", T[:, :3, :3], self.track_normals_body[sel])
        return X, N


@lru_cache(maxsize=4)
def make_world(seed: int = 0, points_per_object: int = 60) -> World:
    """The default world: static set plus four moving objects, deterministic from the seed.

    Cached (textures take a few seconds); the World is immutable by convention."""
    rng = np.random.default_rng(seed)
    bodies = static_set(rng)
    objects = ["walking_figure", "bouncing_ball", "thrown_ball", "spinning_box"]
    moving = walking_figure(rng, 0) + [bouncing_ball(rng, 1), thrown_ball(rng, 2), spinning_box(rng, 3)]
    for b in moving:  # unique marks on every moving body (its texture alone may repeat)
        area_px = b.texture.shape[0] * b.texture.shape[1]
        object.__setattr__(b, "texture", add_marks(b.texture, rng, max(40, area_px // 2500)))
    bodies += moving
    pts, nrm, owner = [], [], []
    for inst in range(len(objects)):
        idx = [i for i, b in enumerate(bodies) if b.instance == inst]
        area = np.array([triangle_areas(bodies[i].mesh).sum() for i in idx])
        counts = np.maximum(3, np.round(points_per_object * area / area.sum())).astype(int)
        for i, n in zip(idx, counts):
            p, q = sample_surface(bodies[i].mesh, int(n), rng)
            pts.append(p)
            nrm.append(q)
            owner += [i] * int(n)
    return World(tuple(bodies), tuple(objects), np.concatenate(pts), np.concatenate(nrm),
                 np.asarray(owner, dtype=np.int64))


# ---- cameras ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CameraSpec:
    """One camera: its image, clock, intrinsics, pose over time and its rendering look."""

    name: str
    width: int  # px
    height: int  # px
    K: np.ndarray  # (3,3) px, OpenCV pinhole (fx != fy allowed, principal point off-centre)
    timestamps_s: np.ndarray  # (T,) local time of each frame, s, starts at 0, strictly increasing
    offset_s: float  # global time of local time 0 (DESIGN.md)
    fps: float | None  # nominal rate; None for a variable frame rate video
    pose_fn: PoseFn  # global times (G,) -> (G,4,4) cam_from_world
    moving: bool
    exposure_gain: float = 1.0  # multiplies linear brightness of the rendered image
    white_balance: tuple[float, float, float] = (1.0, 1.0, 1.0)  # per-channel gain (R,G,B)
    motion_blur_frac: float = 0.0  # shutter open for this fraction of the frame interval (0 = none)
    role: str = "static"  # static | handheld | little_motion

    @property
    def num_frames(self) -> int:
        return len(self.timestamps_s)

    @property
    def global_times_s(self) -> np.ndarray:
        return self.timestamps_s + self.offset_s

    def cam_from_world(self) -> np.ndarray:
        """(T,4,4) for a moving camera, (4,4) for a static one."""
        T = self.pose_fn(self.global_times_s)
        return T if self.moving else T[0]


@dataclass(frozen=True)
class SceneConfig:
    cameras: int = 4
    """Number of cameras (videos)."""
    moving: int = 1
    """How many of them are hand-held (smooth walk plus shake)."""
    seconds: float = 8.0
    """Length of the reference video (cam0); the others get 0.75-1.0 of it (unless same_length)."""
    same_length: bool = False
    """Every camera records `seconds` (a fixed workload, e.g. for timing)."""
    width: int = 640
    """Image width of every camera (px)."""
    height: int = 480
    """Image height of every camera (px)."""
    fps: float | None = 30.0
    """Frame rate of every camera; None = drawn per camera from 24, 25, 30, 50, 60."""
    max_offset_s: float = 1.5
    """Start offsets are drawn in ±max_offset_s around the reference (cam0 = 0)."""
    variable_rate: int = 0
    """How many (static) cameras record at a variable frame rate (jittered timestamps)."""
    little_motion: int = 0
    """How many extra static cameras look mostly away from the action."""
    motion_blur: bool = False
    """Average several renders over an open shutter (half the frame interval)."""
    exposure: bool = False
    """Give the cameras different exposure and white balance."""
    points_per_object: int = 60
    """Surface points tracked on each moving object (the true cue bundle)."""
    arc_deg: float = 360.0
    """Cameras stand around the scene evenly (360) or spread over an arc of this many degrees."""
    seed: int = 0
    """Seed of everything random."""

    def __post_init__(self) -> None:
        if self.cameras < 2:
            raise ValueError(f"a scene needs at least 2 cameras, got {self.cameras}")
        if not 0 <= self.moving <= self.cameras:
            raise ValueError(f"moving must be in 0..{self.cameras}, got {self.moving}")
        if self.seconds <= 0:
            raise ValueError(f"seconds must be positive, got {self.seconds}")
        if self.width < 16 or self.height < 16:
            raise ValueError(f"image size must be at least 16x16, got {self.width}x{self.height}")
        if not 0 < self.arc_deg <= 360:
            raise ValueError(f"arc_deg must be in (0, 360], got {self.arc_deg}")
        if self.fps is not None and not 1 <= self.fps <= 240:
            raise ValueError(f"fps must be in [1, 240], got {self.fps}")


@dataclass(frozen=True)
class Scene:
    config: SceneConfig
    world: World
    cameras: tuple[CameraSpec, ...]

    @property
    def offsets_s(self) -> dict[str, float]:
        return {c.name: float(c.offset_s) for c in self.cameras}

    def global_span_s(self) -> tuple[float, float]:
        g0 = min(c.offset_s for c in self.cameras)
        g1 = max(c.offset_s + c.timestamps_s[-1] for c in self.cameras)
        return float(g0), float(g1)


def _intrinsics(rng: np.random.Generator, W: int, H: int) -> np.ndarray:
    fx = W * rng.uniform(0.85, 1.15)
    fy = fx * rng.uniform(0.96, 1.04)
    cx = (W - 1) / 2 + W * rng.uniform(-0.03, 0.03)
    cy = (H - 1) / 2 + H * rng.uniform(-0.03, 0.03)
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def _static_pose(center, target) -> PoseFn:
    T = look_at(np.asarray(center, float), np.asarray(target, float))
    return lambda g: np.broadcast_to(T, (len(np.atleast_1d(g)), 4, 4)).copy()


def _handheld_pose(rng: np.random.Generator, angle0: float, radius: float, height: float) -> PoseFn:
    """A person walking slowly on an arc around the scene, aiming at the action, with shake:
    body sway at the step rate and hand tremor (small rotations at 2-9 Hz)."""
    ang_speed = rng.choice([-1, 1]) * rng.uniform(0.06, 0.1)  # rad/s along the arc
    step_hz = rng.uniform(1.6, 2.0)
    aim = rng.uniform(-0.5, 0.5, 2)
    tremor = [(rng.uniform(2, 9), rng.uniform(0, 2 * np.pi), rng.normal(size=3)) for _ in range(4)]
    phases = rng.uniform(0, 2 * np.pi, 3)

    def pose(g):
        g = np.atleast_1d(np.asarray(g, dtype=np.float64))
        a = angle0 + ang_speed * g + 0.05 * np.sin(0.3 * g + phases[0])
        r = radius + 0.4 * np.sin(0.25 * g + phases[1])
        C = np.stack([r * np.cos(a), r * np.sin(a), height + 0.02 * np.sin(2 * np.pi * step_hz * g)], -1)
        C[:, :2] += 0.02 * np.stack([np.sin(np.pi * step_hz * g), np.cos(np.pi * step_hz * g)], -1)
        target = np.stack([aim[0] + 0.6 * np.sin(0.35 * g + phases[2]), aim[1] + 0.5 * np.sin(0.27 * g),
                           1.0 + 0.15 * np.sin(0.5 * g)], -1)
        T = np.stack([look_at(C[k], target[k]) for k in range(len(g))])
        rv = sum(np.deg2rad(0.25) * np.sin(2 * np.pi * f * g + p)[:, None] * d[None] for f, p, d in tremor)
        R_shake = Rotation.from_rotvec(rv).as_matrix()  # camera-frame rotation
        T[:, :3, :3] = R_shake @ T[:, :3, :3]
        T[:, :3, 3] = np.einsum("gij,gj->gi", R_shake, T[:, :3, 3])
        return T
    return pose


def _timestamps(rng: np.random.Generator, seconds: float, fps: float, variable: bool) -> np.ndarray:
    n = max(2, int(np.floor(seconds * fps)) + 1)
    if not variable:
        return np.arange(n) / fps
    dt = rng.uniform(0.75, 1.25, n - 1) / fps
    ts = np.concatenate([[0.0], np.cumsum(dt)])
    ts = np.round(ts, 4)  # representable in a 1/10000 s time base
    return ts[ts <= seconds + 1e-9]


def make_scene(cfg: SceneConfig = SceneConfig()) -> Scene:
    """World plus cameras, all from cfg.seed."""
    world = make_world(cfg.seed, cfg.points_per_object)
    rng = np.random.default_rng(cfg.seed + 1000)
    n = cfg.cameras + cfg.little_motion
    cams: list[CameraSpec] = []
    moving_idx = set(range(cfg.cameras - cfg.moving, cfg.cameras))
    static_idx = [i for i in range(cfg.cameras) if i not in moving_idx]
    vfr_idx = set(static_idx[1:1 + cfg.variable_rate])
    base_angle = rng.uniform(0, 2 * np.pi)
    for i in range(n):
        name = f"cam{i}"
        W, H = cfg.width, cfg.height
        fps = float(cfg.fps) if cfg.fps else float(rng.choice([24.0, 25.0, 30.0, 50.0, 60.0]))
        seconds = cfg.seconds if i == 0 else cfg.seconds * rng.uniform(0.75, 1.0)
        if cfg.same_length:  # drawn above all the same, so the rest of the scene does not change
            seconds = cfg.seconds
        offset = 0.0 if i == 0 else float(rng.uniform(-cfg.max_offset_s, cfg.max_offset_s))
        variable = i in vfr_idx
        ts = _timestamps(rng, seconds, fps, variable)
        K = _intrinsics(rng, W, H)
        if cfg.arc_deg >= 360:
            angle = base_angle + 2 * np.pi * i / max(1, cfg.cameras) + rng.uniform(-0.25, 0.25)
        else:  # cameras spread over an arc: narrower baselines, easier cross-view matching
            step = np.deg2rad(cfg.arc_deg) / max(1, cfg.cameras - 1)
            angle = base_angle + step * (i % cfg.cameras) + rng.uniform(-0.15, 0.15) * step
        if i >= cfg.cameras:  # little motion: the action sits at the image border
            role = "little_motion"
            C = np.array([9.0 * np.cos(angle), 9.0 * np.sin(angle), rng.uniform(1.5, 2.0)])
            to_action = np.array([0.0, 0.0, 1.0]) - C
            half_fov = np.arctan(W / 2 / K[0, 0])
            turn = rng.choice([-1, 1]) * 1.15 * half_fov  # centre of the action just off the image
            target = C + _rot((0, 0, 1), np.array([turn]))[0] @ to_action
            pose, moving = _static_pose(C, target), False
        elif i in moving_idx:
            role = "handheld"
            pose, moving = _handheld_pose(rng, angle, rng.uniform(7.5, 8.5), rng.uniform(1.5, 1.8)), True
        else:
            role = "static"
            radius, height = rng.uniform(7.0, 9.5), rng.uniform(1.6, 3.2)
            C = np.array([radius * np.cos(angle), radius * np.sin(angle), height])
            pose, moving = _static_pose(C, np.array([0.0, 0.0, 1.0]) + rng.uniform(-0.3, 0.3, 3)), False
        gain, wb = 1.0, (1.0, 1.0, 1.0)
        if cfg.exposure:
            gain = float(rng.uniform(0.6, 1.5))
            wb = tuple(float(v) for v in rng.uniform(0.88, 1.12, 3))
        cams.append(CameraSpec(name, W, H, K, ts, offset, None if variable else fps, pose, moving,
                               gain, wb, 0.5 if cfg.motion_blur else 0.0, role))
    return Scene(cfg, world, tuple(cams))


# ---- exact observations of the tracked points -------------------------------------------------


def observe_points(world: World, cam: CameraSpec, g: np.ndarray, cam_from_world: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Project the tracked surface points at global times g.

    Returns ((M,G,2) px with NaN outside the image, behind the camera or back-facing,
    (M,G) depth along the optical axis in m). Occlusion is not tested here (the caller compares
    the depth with a rendered depth map).
    """
    X, N = world.points_at(g)
    T = np.broadcast_to(cam_from_world, (len(np.atleast_1d(g)), 4, 4))
    xy = project(cam.K[None, None], T[None], X)
    Xc = np.einsum("gij,mgj->mgi", T[:, :3, :3], X) + T[None, :, :3, 3]
    depth = Xc[..., 2]
    facing = np.einsum("mgi,mgi->mg", N, camera_centers(T)[None] - X) > 0.0
    inside = (xy[..., 0] >= -0.5) & (xy[..., 0] <= cam.width - 0.5) & \
             (xy[..., 1] >= -0.5) & (xy[..., 1] <= cam.height - 0.5)
    ok = inside & facing & (depth > 0.05)
    xy[~ok] = np.nan
    return xy, depth
