"""The synthetic world's rigid bodies: the static set (ground, walls, crates) and the moving
objects (a walking figure of rigid parts, a bouncing ball, a thrown ball, a spinning box), each
pose an analytic function of global time."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from .meshes import Mesh, box_mesh, plane_mesh, sphere_mesh
from .textures import ball_texture, cloth_texture, crate_texture, ground_texture, wall_texture

PoseFn = Callable[[np.ndarray], np.ndarray]  # (G,) global times s -> (G,4,4) world_from_body


@dataclass(frozen=True)
class Body:
    """One rigid piece of the world, drawn with its texture at its pose."""

    name: str
    mesh: Mesh
    texture: np.ndarray  # (h,w,3) uint8 RGB, row 0 = top
    id_rgb: tuple[int, int, int]  # flat colour of this body in a segmentation render
    instance: int  # moving object the body belongs to (figure parts share one); -1 = static
    pose: PoseFn | None = None  # world_from_body at global times; None = static at identity

    @property
    def moving(self) -> bool:
        return self.pose is not None

    def world_from_body(self, g: np.ndarray) -> np.ndarray:
        """(G,4,4) poses at global times g (s)."""
        g = np.atleast_1d(np.asarray(g, dtype=np.float64))
        if self.pose is None:
            return np.broadcast_to(np.eye(4), (len(g), 4, 4)).copy()
        return self.pose(g)


def _rigid(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(G,3,3), (G,3) -> (G,4,4)."""
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def _rot(axis, angle: np.ndarray) -> np.ndarray:
    """(G,3,3) rotations by angle (G,) rad about a fixed axis."""
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    return Rotation.from_rotvec(np.asarray(angle)[:, None] * axis[None]).as_matrix()


def _smooth_path(rng: np.random.Generator, radius: float, speed: float):
    """A smooth closed 2-D path (random harmonics) walked at about `speed` m/s: returns
    f(g) -> ((G,2) position, (G,) heading rad)."""
    k = np.arange(1, 4)
    ax, ay = rng.normal(0, 1, 3) / k ** 1.5, rng.normal(0, 1, 3) / k ** 1.5
    ax[0], ay[0] = 1.0, 0.8
    px, py = rng.uniform(0, 2 * np.pi, 3), rng.uniform(0, 2 * np.pi, 3)
    s = np.linspace(0, 2 * np.pi, 2001)
    xy = np.stack([(ax[:, None] * np.cos(k[:, None] * s + px[:, None])).sum(0),
                   (ay[:, None] * np.sin(k[:, None] * s + py[:, None])).sum(0)], -1)
    scale = radius / np.abs(xy).max()
    length = scale * np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()
    omega = 2 * np.pi * speed / length
    phase0 = rng.uniform(0, 2 * np.pi)

    def f(g: np.ndarray):
        s = omega * g + phase0
        x = scale * (ax[:, None] * np.cos(k[:, None] * s + px[:, None])).sum(0)
        y = scale * (ay[:, None] * np.sin(k[:, None] * s + py[:, None])).sum(0)
        dx = scale * (-ax[:, None] * k[:, None] * np.sin(k[:, None] * s + px[:, None])).sum(0)
        dy = scale * (ay[:, None] * k[:, None] * np.cos(k[:, None] * s + py[:, None])).sum(0)
        return np.stack([x, y], -1), np.arctan2(dy, dx)
    return f


def walking_figure(rng: np.random.Generator, instance: int, center=(0.0, 0.0)) -> list[Body]:
    """An articulated figure (torso, head, two arms, two legs) walking a smooth loop."""
    path = _smooth_path(rng, radius=2.6, speed=1.0)
    step_hz = 0.9  # gait cycles per second
    swing = np.deg2rad(28.0)
    phase = rng.uniform(0, 2 * np.pi)
    center = np.asarray(center, dtype=np.float64)
    shirt = cloth_texture(rng, (170, 20, 25), (245, 235, 220), stripes=6)
    trousers = cloth_texture(rng, (20, 40, 120), (90, 150, 230), stripes=10)
    skin = cloth_texture(rng, (150, 100, 70), (235, 190, 150), stripes=3)
    face = ball_texture(rng, [(235, 190, 150), (90, 50, 30), (235, 190, 150), (235, 190, 150)], 256)

    def figure_pose(g):
        xy, heading = path(g)
        cyc = 2 * np.pi * step_hz * g + phase
        z = 0.03 * np.abs(np.sin(cyc))
        t = np.concatenate([xy + center, z[:, None]], -1)
        return _rigid(_rot((0, 0, 1), heading), t), cyc

    def part(offset, joint, sign, amp):
        offset, joint = np.asarray(offset, float), np.asarray(joint, float)

        def pose(g):
            W, cyc = figure_pose(g)
            ang = sign * amp * np.sin(cyc)
            R = _rot((0, 1, 0), ang)
            # rotate about the joint: x_fig = joint + R (x_local - joint) + offset - joint + joint
            t = joint[None] + np.einsum("gij,j->gi", R, offset - joint)
            return W @ _rigid(R, t)
        return pose

    I = instance
    bodies = [
        Body("figure_torso", box_mesh((0.26, 0.42, 0.62)), crate_like_atlas(shirt), (230, 30, 30), I,
             lambda g: figure_pose(g)[0] @ _rigid(np.eye(3)[None].repeat(len(g), 0), np.tile([0, 0, 1.22], (len(g), 1)))),
        Body("figure_head", sphere_mesh(0.14, 16, 32), face, (250, 160, 120), I,
             lambda g: figure_pose(g)[0] @ _rigid(_rot((0, 0, 1), 0.3 * np.sin(0.7 * g)), np.tile([0, 0, 1.70], (len(g), 1)))),
    ]
    for side, y in (("left", 0.11), ("right", -0.11)):
        s = 1 if side == "left" else -1
        bodies.append(Body(f"figure_leg_{side}", box_mesh((0.15, 0.15, 0.9), (0, 0, -0.45)),
                           crate_like_atlas(trousers), (30, 60 + 40 * (s > 0), 200), I,
                           part((0, y, 0.9), (0, y, 0.9), s, swing)))
    for side, y in (("left", 0.28), ("right", -0.28)):
        s = -1 if side == "left" else 1
        bodies.append(Body(f"figure_arm_{side}", box_mesh((0.1, 0.1, 0.62), (0, 0, -0.31)),
                           crate_like_atlas(skin), (240, 200 + 40 * (s > 0), 60), I,
                           part((0, y, 1.5), (0, y, 1.5), s, 0.8 * swing)))
    return bodies


def crate_like_atlas(tile: np.ndarray) -> np.ndarray:
    """A 3x2 atlas from one tile (every face of a box shows the same pattern)."""
    return np.ascontiguousarray(np.tile(tile, (2, 3, 1)))


def bouncing_ball(rng: np.random.Generator, instance: int) -> Body:
    """A ball rolling across the ground and bouncing, spinning as it rolls."""
    r = 0.32
    x0, y0 = rng.uniform(-2.0, 0.0), rng.uniform(-1.5, 1.5)
    vx, vy = 0.55, rng.uniform(-0.2, 0.2)
    bounce_T = rng.uniform(1.1, 1.4)
    h = 0.9

    def pose(g):
        # travel back and forth on a triangle wave so the ball stays near the middle
        span = 4.0
        u = np.mod(vx * g + x0 + span / 2, 2 * span)
        x = np.where(u < span, u, 2 * span - u) - span / 2
        y = y0 + vy * np.sin(0.4 * g)
        ph = np.mod(g / bounce_T, 1.0)
        z = r + 4 * h * ph * (1 - ph)
        R = _rot((0.0, 1.0, 0.15), x / r) @ _rot((0, 0, 1), 0.3 * g)  # rolls with its travel
        return _rigid(R, np.stack([x, y, z], -1))
    tex = ball_texture(rng, [(230, 30, 30), (250, 220, 30), (30, 140, 230), (40, 190, 60), (250, 250, 250), (160, 40, 200)])
    return Body("bouncing_ball", sphere_mesh(r), tex, (40, 200, 40), instance, pose)


def thrown_ball(rng: np.random.Generator, instance: int) -> Body:
    """A small ball thrown back and forth between two points, on true ballistic arcs."""
    r = 0.13
    A = np.array([rng.uniform(-2.5, -1.5), rng.uniform(1.0, 2.0), 1.3])
    B = np.array([rng.uniform(1.5, 2.5), rng.uniform(-2.0, -0.5), 1.3])
    flight = rng.uniform(1.2, 1.4)
    gacc = 9.81
    v0 = gacc * flight / 2
    t0 = rng.uniform(0, flight)

    def pose(g):
        k = np.floor((g + t0) / flight)
        s = (g + t0) - k * flight  # time since this throw
        fwd = np.mod(k, 2) == 0
        start = np.where(fwd[:, None], A, B)
        end = np.where(fwd[:, None], B, A)
        p = start + (end - start) * (s / flight)[:, None]
        p[:, 2] = start[:, 2] + v0 * s - 0.5 * gacc * s * s
        return _rigid(_rot((1.0, 0.3, 0.5), 9.0 * g), p)
    tex = cloth_texture(rng, (250, 120, 0), (20, 20, 20), size=256, stripes=4)
    return Body("thrown_ball", sphere_mesh(r, 16, 32), tex, (255, 140, 0), instance, pose)


def spinning_box(rng: np.random.Generator, instance: int) -> Body:
    """A box spinning about a tilted axis while floating on a slow Lissajous path."""
    axis = np.array([0.3, 0.5, 1.0])
    spin = 2 * np.pi * rng.uniform(0.25, 0.4)
    a, b = rng.uniform(0.4, 0.6), rng.uniform(0.7, 0.9)
    c = rng.uniform(-1.0, 1.0, 2)

    def pose(g):
        t = np.stack([c[0] + 1.6 * np.sin(a * g + 1.0), c[1] + 1.3 * np.sin(b * g),
                      1.4 + 0.35 * np.sin(1.3 * g)], -1)
        return _rigid(_rot(axis, spin * g) @ _rot((1, 0, 0), 0.4 * np.sin(0.9 * g)), t)
    tex = crate_texture(rng, "B", (60, 170, 200), size=256)
    return Body("spinning_box", box_mesh((0.55, 0.55, 0.55)), tex, (200, 40, 220), instance, pose)


def static_set(rng: np.random.Generator, half_size: float = 12.0, wall_height: float = 4.0) -> list[Body]:
    """Ground, four walls and a few crates (all static)."""
    L = half_size
    bodies = [Body("ground", plane_mesh((-L, -L, 0), (2 * L, 0, 0), (0, 2 * L, 0)),
                   ground_texture(rng), (128, 128, 128), -1)]
    colours = [(150, 60, 45), (90, 110, 140), (120, 130, 70), (160, 140, 100)]
    corners = [((-L, -L, 0), (2 * L, 0, 0)), ((L, -L, 0), (0, 2 * L, 0)),
               ((L, L, 0), (-2 * L, 0, 0)), ((-L, L, 0), (0, -2 * L, 0))]
    for i, (c0, u) in enumerate(corners):  # faces point inward: u x up points to the centre
        bodies.append(Body(f"wall{i}", plane_mesh(c0, u, (0, 0, wall_height)),
                           wall_texture(rng, 2048, 384, colours[i]), (100 + 30 * i, 90, 80), -1))
    for i in range(5):
        ang = 2 * np.pi * i / 5 + rng.uniform(-0.3, 0.3)
        rad = rng.uniform(4.2, 6.0)
        s = rng.uniform(0.6, 1.1)
        size = (s * rng.uniform(0.8, 1.5), s * rng.uniform(0.8, 1.5), s)
        mesh = box_mesh(size, (0, 0, size[2] / 2))
        R = _rot((0, 0, 1), np.array([rng.uniform(0, np.pi)]))[0]
        pts = mesh.points @ R.T + [rad * np.cos(ang), rad * np.sin(ang), 0]
        mesh = Mesh(pts, mesh.faces, mesh.uv, mesh.normals @ R.T)
        col = tuple(int(v) for v in rng.integers(80, 220, 3))
        bodies.append(Body(f"crate{i}", mesh, crate_texture(rng, "ABCDE"[i], col), (60, 60, 60 + 20 * i), -1))
    return bodies

