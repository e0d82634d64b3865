"""People walking about, seen by static cameras as BlazePose would label them, with exact truth:
for the people cue's tests (the association, F and shift search; cameras from pairs).

Each person is BlazePose's 33 landmarks (geometry/skeleton.py) on a body that walks a smooth
path facing where it goes, swings its arms and now and then raises a hand to its face, each
person at their own pace, so that the landmarks' 3D positions at any moment are analytic. A
camera's view of a person is the projection of the landmarks (px, OpenCV), with pixel noise,
runs of frames where the person is not found, and optionally left and right swapped (a person
seen from behind labelled as if from the front). Pure numpy; world z up, metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry.epipolar import look_at, project
from ..geometry.skeleton import LANDMARK_NAMES, MIRROR, NUM_LANDMARKS
from ..people_types import VideoPeople

# body frame: x to the person's right, y forward, z up, origin between the feet; metres
_RIGHT_TEMPLATE = {
    "eye_inner": (0.015, 0.085, 1.655), "eye": (0.035, 0.080, 1.655), "eye_outer": (0.05, 0.07, 1.655),
    "ear": (0.075, 0.0, 1.63), "mouth": (0.025, 0.085, 1.57), "shoulder": (0.19, 0.0, 1.42),
    "elbow": (0.22, 0.0, 1.15), "wrist": (0.24, 0.03, 0.90), "pinky": (0.25, 0.05, 0.82),
    "index": (0.24, 0.07, 0.81), "thumb": (0.22, 0.07, 0.85), "hip": (0.10, 0.0, 0.95),
    "knee": (0.10, 0.02, 0.52), "ankle": (0.10, -0.01, 0.09), "heel": (0.10, -0.06, 0.03),
    "foot_index": (0.10, 0.13, 0.02),
}
_ARM = ("elbow", "wrist", "pinky", "index", "thumb")
_LEG = ("knee", "ankle", "heel", "foot_index")


def _template() -> np.ndarray:
    """(33,3) the standing body, in the body frame."""
    out = np.zeros((NUM_LANDMARKS, 3))
    for i, n in enumerate(LANDMARK_NAMES):
        if n == "nose":
            out[i] = (0.0, 0.11, 1.61)
        elif n == "mouth_left" or n == "mouth_right":
            x, y, z = _RIGHT_TEMPLATE["mouth"]
            out[i] = (x if n == "mouth_right" else -x, y, z)
        else:
            side, part = n.split("_", 1)
            x, y, z = _RIGHT_TEMPLATE[part]
            out[i] = (x if side == "right" else -x, y, z)
    return out


TEMPLATE = _template()


@dataclass(frozen=True)
class Walker:
    """One person's motion: a loop on the floor and a gait, all analytic in global time."""

    centre: tuple[float, float]  # m, the middle of the loop
    radii: tuple[float, float]  # m
    loop_s: float  # one loop takes this long
    phase: float  # rad
    stride_hz: float  # arm and leg swing
    reach_hz: float  # how often the right hand comes up to the face
    height: float = 1.0  # scale of the body

    def landmarks(self, g: np.ndarray) -> np.ndarray:
        """(G,33,3) world positions of the 33 landmarks at global times g (G,) s."""
        g = np.asarray(g, dtype=np.float64)
        w = 2 * np.pi / self.loop_s
        a = w * g + self.phase
        pos = np.c_[self.centre[0] + self.radii[0] * np.cos(a), self.centre[1] + self.radii[1] * np.sin(a)]
        vel = np.c_[-self.radii[0] * np.sin(a), self.radii[1] * np.cos(a)]
        heading = np.arctan2(vel[:, 1], vel[:, 0]) - np.pi / 2  # body y along the velocity
        body = np.broadcast_to(TEMPLATE * self.height, (len(g), NUM_LANDMARKS, 3)).copy()
        swing = 0.5 * np.sin(2 * np.pi * self.stride_hz * g)
        reach = np.clip(np.sin(2 * np.pi * self.reach_hz * g + self.phase), 0, None) ** 2  # 0..1
        for side, sign in (("left", -1.0), ("right", 1.0)):
            shoulder = body[:, LANDMARK_NAMES.index(f"{side}_shoulder")]
            hip = body[:, LANDMARK_NAMES.index(f"{side}_hip")]
            arm_angle = sign * swing + (1.9 * reach if side == "right" else 0.0)
            leg_angle = -sign * 0.6 * swing
            for part, pivot, angle in [(p, shoulder, arm_angle) for p in _ARM] + [(p, hip, leg_angle) for p in _LEG]:
                k = LANDMARK_NAMES.index(f"{side}_{part}")
                body[:, k] = pivot + _rotate_x(body[:, k] - pivot, angle)
        c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
        world = np.empty_like(body)
        world[..., 0] = c * body[..., 0] - s * body[..., 1] + pos[:, :1]
        world[..., 1] = s * body[..., 0] + c * body[..., 1] + pos[:, 1:]
        world[..., 2] = body[..., 2]
        return world


def _rotate_x(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(G,3) vectors rotated about the body's x axis (a swing forward for positive angles)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.c_[v[:, 0], c * v[:, 1] - s * v[:, 2], s * v[:, 1] + c * v[:, 2]]


@dataclass(frozen=True)
class PeopleCamera:
    """A static camera of the scene."""

    name: str
    K: np.ndarray  # (3,3) px
    cam_from_world: np.ndarray  # (4,4)
    width: int  # px
    height: int  # px
    fps: float
    num_frames: int
    offset_s: float  # DESIGN.md: the global time of its local time 0


def ring_camera(name: str, angle_deg: float, K: np.ndarray, distance: float = 6.0, height: float = 3.0,
                target: tuple[float, float, float] = (0.0, 0.0, 0.9), roll_deg: float = 0.0,
                size: tuple[int, int] = (960, 540), fps: float = 10.0, num_frames: int = 120,
                offset_s: float = 0.0) -> PeopleCamera:
    """A camera on a circle around the scene, looking at target, turned roll_deg about its axis."""
    a = np.deg2rad(angle_deg)
    centre = np.array([distance * np.cos(a), distance * np.sin(a), height])
    T = look_at(centre, np.asarray(target, np.float64))
    r = np.deg2rad(roll_deg)
    roll = np.array([[np.cos(r), -np.sin(r), 0], [np.sin(r), np.cos(r), 0], [0, 0, 1.0]])
    T[:3] = roll @ T[:3]
    return PeopleCamera(name, np.asarray(K, np.float64), T, size[0], size[1], fps, num_frames, offset_s)


@dataclass(frozen=True)
class ViewOptions:
    """How one camera's person detector sees the people."""

    noise_px: float = 1.0
    missing_runs: int = 3  # runs of frames where a person is not found, per person
    mirrored: tuple[int, ...] = ()  # people labelled left/right swapped in this view
    clutter: int = 1  # false people: landmarks of a random pose wandering about the image
    seed: int = 0


@dataclass(frozen=True)
class PeopleScene:
    """Cameras, walkers and each camera's view of them, with the truth."""

    cameras: tuple[PeopleCamera, ...]
    walkers: tuple[Walker, ...]
    views: dict[str, VideoPeople] = field(default_factory=dict)
    person_of_track: dict[str, np.ndarray] = field(default_factory=dict)  # (P,) walker index of each track (-1: clutter)

    @property
    def offsets_s(self) -> dict[str, float]:
        return {c.name: c.offset_s for c in self.cameras}


def view_people(camera: PeopleCamera, walkers: tuple[Walker, ...], opts: ViewOptions) -> tuple[VideoPeople, np.ndarray]:
    """(the camera's VideoPeople, (P,) walker index of each track, -1 for clutter)."""
    rng = np.random.default_rng(opts.seed)
    T = camera.num_frames
    tau = np.arange(T) / camera.fps
    g = tau + camera.offset_s
    tracks, truth = [], []
    for w_i, walker in enumerate(walkers):
        X = walker.landmarks(g)  # (T,33,3)
        xy = project(camera.K, camera.cam_from_world, X.reshape(-1, 3)).reshape(T, NUM_LANDMARKS, 2)
        xy = xy + rng.normal(0, opts.noise_px, xy.shape)
        inside = (xy[..., 0] >= 0) & (xy[..., 0] < camera.width) & (xy[..., 1] >= 0) & (xy[..., 1] < camera.height)
        vis = np.where(inside, 0.95, 0.05)
        lm = np.concatenate([xy, vis[..., None]], -1)
        for _ in range(opts.missing_runs):
            start = int(rng.integers(0, T))
            lm[start:start + int(rng.integers(2, 8))] = np.nan
        if w_i in opts.mirrored:
            lm = lm[:, MIRROR]
        tracks.append(lm)
        truth.append(w_i)
    for _ in range(opts.clutter):
        centre = rng.uniform([0.2 * camera.width, 0.2 * camera.height], [0.8 * camera.width, 0.8 * camera.height])
        walk = np.cumsum(rng.normal(0, 3.0, (T, 2)), axis=0) + centre
        shape = rng.normal(0, 0.06 * camera.height, (NUM_LANDMARKS, 2))
        xy = walk[:, None, :] + shape[None] + rng.normal(0, 2.0, (T, NUM_LANDMARKS, 2))
        tracks.append(np.concatenate([xy, np.full((T, NUM_LANDMARKS, 1), 0.9)], -1))
        truth.append(-1)
    return VideoPeople(camera.name, np.stack(tracks), tau), np.array(truth)


def people_scene(cameras: tuple[PeopleCamera, ...], walkers: tuple[Walker, ...],
                 options: dict[str, ViewOptions] | None = None) -> PeopleScene:
    """Every camera's view of the walkers (options per camera name; default ViewOptions with the
    camera's index as seed)."""
    views, truth = {}, {}
    for i, cam in enumerate(cameras):
        opts = (options or {}).get(cam.name, ViewOptions(seed=i))
        views[cam.name], truth[cam.name] = view_people(cam, walkers, opts)
    return PeopleScene(cameras, walkers, views, truth)


def default_walkers() -> tuple[Walker, ...]:
    """Three people at their own paces, on loops that cross the middle of the scene."""
    return (Walker((0.0, 0.0), (1.6, 1.0), 9.0, 0.0, 0.9, 0.23),
            Walker((0.6, -0.4), (1.0, 1.5), 7.0, 2.0, 1.1, 0.31, 0.95),
            Walker((-0.5, 0.5), (1.2, 0.8), 11.0, 4.0, 0.8, 0.17, 1.05))
