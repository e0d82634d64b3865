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
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from ..geometry.epipolar import camera_centers, look_at, project

PoseFn = Callable[[np.ndarray], np.ndarray]  # (G,) global times s -> (G,4,4) world_from_body


# ---- meshes -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh in its body's local frame, with texture coordinates."""

    points: np.ndarray  # (V,3) float64 m, body frame
    faces: np.ndarray  # (F,3) int64 vertex indices, counter-clockwise seen from outside
    uv: np.ndarray  # (V,2) float64 texture coordinates in [0,1] (v = 0 at the image bottom)
    normals: np.ndarray  # (V,3) float64 unit outward normals

    def __post_init__(self) -> None:
        for name, shape in (("points", 3), ("faces", 3), ("uv", 2), ("normals", 3)):
            a = getattr(self, name)
            if a.ndim != 2 or a.shape[1] != shape:
                raise ValueError(f"Mesh.{name} must have shape (N,{shape}), got {a.shape}")


def box_mesh(size: tuple[float, float, float], center=(0.0, 0.0, 0.0)) -> Mesh:
    """A box whose six faces map to the six cells of a 3x2 texture atlas (face i -> cell i)."""
    sx, sy, sz = (s / 2 for s in size)
    c = np.asarray(center, dtype=np.float64)
    # (normal, u axis, v axis) of the six faces; u x v = normal so faces are counter-clockwise.
    axes = [((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, -1, 0), (0, 0, 1)),
            ((0, 1, 0), (-1, 0, 0), (0, 0, 1)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
            ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (1, 0, 0), (0, -1, 0))]
    half = np.array([sx, sy, sz])
    pts, uvs, nrm, faces = [], [], [], []
    m = 0.02  # margin inside each atlas cell
    for i, (n, u, v) in enumerate(axes):
        n, u, v = (np.array(a, dtype=np.float64) for a in (n, u, v))
        col, row = i % 3, i // 3
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pts.append(c + half * n + a * half * u + b * half * v)
            uvs.append(((col + m + (1 - 2 * m) * (a + 1) / 2) / 3,
                        (row + m + (1 - 2 * m) * (b + 1) / 2) / 2))
            nrm.append(n)
        k = 4 * i
        faces += [(k, k + 1, k + 2), (k, k + 2, k + 3)]
    return Mesh(np.array(pts), np.array(faces, dtype=np.int64), np.array(uvs), np.array(nrm))


def sphere_mesh(radius: float, n_lat: int = 24, n_lon: int = 48) -> Mesh:
    """A UV sphere (u = longitude, v = latitude), seam vertices duplicated."""
    lat = np.linspace(0.0, np.pi, n_lat + 1)
    lon = np.linspace(0.0, 2 * np.pi, n_lon + 1)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    n = np.stack([np.sin(la) * np.cos(lo), np.sin(la) * np.sin(lo), np.cos(la)], -1).reshape(-1, 3)
    uv = np.stack([lo / (2 * np.pi), 1.0 - la / np.pi], -1).reshape(-1, 2)
    faces = []
    W = n_lon + 1
    for i in range(n_lat):
        for j in range(n_lon):
            a, b, c, d = i * W + j, i * W + j + 1, (i + 1) * W + j + 1, (i + 1) * W + j
            if i > 0:
                faces.append((a, d, b))
            if i < n_lat - 1:
                faces.append((b, d, c))
    return Mesh(radius * n, np.array(faces, dtype=np.int64), uv, n)


def plane_mesh(corner: np.ndarray, u_vec: np.ndarray, v_vec: np.ndarray) -> Mesh:
    """A rectangle corner + a u_vec + b v_vec (a, b in [0,1]), facing u_vec x v_vec."""
    corner, u_vec, v_vec = (np.asarray(a, dtype=np.float64) for a in (corner, u_vec, v_vec))
    pts = np.array([corner, corner + u_vec, corner + u_vec + v_vec, corner + v_vec])
    n = np.cross(u_vec, v_vec)
    n /= np.linalg.norm(n)
    return Mesh(pts, np.array([(0, 1, 2), (0, 2, 3)], dtype=np.int64),
                np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=np.float64), np.tile(n, (4, 1)))


def triangle_areas(mesh: Mesh) -> np.ndarray:
    """(F,) area of each face, m²."""
    tri = mesh.points[mesh.faces]  # (F,3,3)
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def sample_surface(mesh: Mesh, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """n points uniformly by area on the mesh: ((n,3) body-frame points, (n,3) unit normals)."""
    tri = mesh.points[mesh.faces]  # (F,3,3)
    area = triangle_areas(mesh)
    f = rng.choice(len(area), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    w = np.stack([1 - s, s * (1 - r2), s * r2], -1)
    pts = np.einsum("nk,nkj->nj", w, tri[f])
    nrm = np.einsum("nk,nkj->nj", w, mesh.normals[mesh.faces[f]])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return pts, nrm


# ---- procedural textures (RGB uint8, row 0 = top of the image) --------------------------------


def value_noise(rng: np.random.Generator, h: int, w: int, octaves=(4, 16, 64, 256)) -> np.ndarray:
    """(h,w) float in about [-1,1]: smooth noise summed over grid sizes."""
    out = np.zeros((h, w), np.float32)
    amp = 1.0
    for cells in octaves:
        g = rng.standard_normal((max(2, cells * h // max(h, w)), max(2, cells * w // max(h, w))))
        out += amp * cv2.resize(g.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
        amp *= 0.6
    return out / (np.abs(out).max() + 1e-9)


def _tint(gray: np.ndarray, rgb_lo, rgb_hi) -> np.ndarray:
    t = np.clip(gray, 0, 1)[..., None]
    return (np.asarray(rgb_lo) * (1 - t) + np.asarray(rgb_hi) * t).astype(np.uint8)


def ground_texture(rng: np.random.Generator, size: int = 2048, tiles: int = 24) -> np.ndarray:
    """Paving: 1 m tiles of varying shade, joints, noise and scattered marks."""
    yy, xx = np.mgrid[0:size, 0:size]
    cell = size / tiles
    shade = rng.uniform(0.35, 0.75, size=(tiles, tiles))
    g = shade[(yy // cell).astype(int), (xx // cell).astype(int)]
    g = g + 0.18 * value_noise(rng, size, size)
    joint = (np.mod(xx, cell) < 3) | (np.mod(yy, cell) < 3)
    g[joint] = 0.15
    img = _tint(g, (70, 62, 50), (215, 205, 185))
    for _ in range(400):  # marks: stones, leaves, paint spots
        c = tuple(int(v) for v in rng.integers(0, size, 2))
        col = tuple(int(v) for v in rng.integers(20, 235, 3))
        if rng.random() < 0.5:
            cv2.circle(img, c, int(rng.integers(3, 14)), col, -1, cv2.LINE_AA)
        else:
            d = rng.integers(-25, 25, 2)
            cv2.line(img, c, (c[0] + int(d[0]), c[1] + int(d[1])), col, int(rng.integers(2, 6)), cv2.LINE_AA)
    return img


def wall_texture(rng: np.random.Generator, w: int, h: int, base_rgb) -> np.ndarray:
    """Bricks of varying colour with mortar, plus posters and graffiti-like strokes."""
    img = np.zeros((h, w, 3), np.uint8)
    img[:] = (200, 200, 195)
    bh = h // 16
    bw = 2 * bh
    base = np.asarray(base_rgb, dtype=np.float64)
    for r in range(0, h // bh + 1):
        shift = (r % 2) * bw // 2
        for c in range(-1, w // bw + 2):
            col = np.clip(base * rng.uniform(0.7, 1.2) + rng.normal(0, 12, 3), 0, 255)
            x0, y0 = c * bw + shift, r * bh
            cv2.rectangle(img, (x0 + 2, y0 + 2), (x0 + bw - 2, y0 + bh - 2), tuple(float(v) for v in col), -1)
    noise = value_noise(rng, h, w, octaves=(8, 32, 128))
    img = np.clip(img.astype(np.float32) * (1 + 0.15 * noise[..., None]), 0, 255).astype(np.uint8)
    for _ in range(6):  # posters
        x0, y0 = int(rng.integers(0, w - h // 3)), int(rng.integers(0, h // 2))
        pw, ph = int(rng.integers(h // 6, h // 3)), int(rng.integers(h // 5, h // 2.5))
        col = tuple(int(v) for v in rng.integers(30, 250, 3))
        cv2.rectangle(img, (x0, y0), (x0 + pw, y0 + ph), col, -1)
        for _ in range(5):
            c2 = tuple(int(v) for v in rng.integers(0, 255, 3))
            p = (x0 + int(rng.integers(0, pw)), y0 + int(rng.integers(0, ph)))
            cv2.circle(img, p, int(rng.integers(4, max(5, pw // 4))), c2, -1, cv2.LINE_AA)
    return img


def crate_texture(rng: np.random.Generator, label: str, rgb, size: int = 512) -> np.ndarray:
    """3x2 atlas for box_mesh: planks with a frame and a painted label on every face."""
    H, W = size * 2, size * 3
    g = 0.55 + 0.25 * value_noise(rng, H, W, octaves=(6, 24, 96))
    img = _tint(g, np.asarray(rgb) * 0.45, np.minimum(255, np.asarray(rgb) * 1.2))
    for i in range(6):
        col, row = i % 3, i // 3
        x0, y0 = col * size, (1 - row) * size  # image rows go down, atlas v goes up
        for k in range(1, 5):
            cv2.line(img, (x0, y0 + k * size // 5), (x0 + size, y0 + k * size // 5), (40, 30, 20), 4)
        cv2.rectangle(img, (x0 + 12, y0 + 12), (x0 + size - 12, y0 + size - 12), (30, 25, 15), 18)
        cv2.line(img, (x0 + 12, y0 + 12), (x0 + size - 12, y0 + size - 12), (30, 25, 15), 14)
        cv2.putText(img, f"{label}{i}", (x0 + size // 6, y0 + 2 * size // 3), cv2.FONT_HERSHEY_DUPLEX,
                    size / 170, (240, 240, 240), max(2, size // 60), cv2.LINE_AA)
    return img


def cloth_texture(rng: np.random.Generator, rgb_a, rgb_b, size: int = 256, stripes: int = 8) -> np.ndarray:
    """Bold stripes with a checker overlay and noise (a shirt, trousers, a box)."""
    yy, xx = np.mgrid[0:size, 0:size]
    s = ((yy * stripes) // size) % 2
    chk = (((xx * stripes * 2) // size + (yy * stripes * 2) // size) % 2) * 0.25
    t = np.clip(s * 0.8 + chk + 0.15 * value_noise(rng, size, size, octaves=(4, 16, 64)), 0, 1)
    return _tint(t, rgb_a, rgb_b)


def ball_texture(rng: np.random.Generator, colours, size: int = 512) -> np.ndarray:
    """Beach-ball segments in longitude, a band at the equator and dots."""
    h, w = size // 2, size
    yy, xx = np.mgrid[0:h, 0:w]
    seg = (xx * len(colours) // w) % len(colours)
    img = np.asarray(colours, dtype=np.uint8)[seg]
    band = np.abs(yy - h / 2) < h / 14
    img[band] = (250, 250, 250)
    for _ in range(30):
        c = (int(rng.integers(0, w)), int(rng.integers(h // 8, 7 * h // 8)))
        cv2.circle(img, c, int(rng.integers(4, 12)), tuple(int(v) for v in rng.integers(0, 255, 3)), -1, cv2.LINE_AA)
    return img


def add_marks(img: np.ndarray, rng: np.random.Generator, n: int) -> np.ndarray:
    """A copy of img with n random small dots, rings and strokes: unique local features, so that
    repeated patterns (stripes, the same tile on every face) still match unambiguously."""
    out = img.copy()
    h, w = out.shape[:2]
    r_max = max(3, min(h, w) // 24)
    for _ in range(n):
        c = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        col = tuple(int(v) for v in rng.integers(0, 256, 3))
        kind = rng.integers(0, 3)
        if kind == 0:
            cv2.circle(out, c, int(rng.integers(2, r_max)), col, -1, cv2.LINE_AA)
        elif kind == 1:
            cv2.circle(out, c, int(rng.integers(3, r_max + 2)), col, 2, cv2.LINE_AA)
        else:
            d = rng.integers(-r_max, r_max + 1, 2)
            cv2.line(out, c, (c[0] + int(d[0]), c[1] + int(d[1])), col, 2, cv2.LINE_AA)
    return out


# ---- bodies -----------------------------------------------------------------------------------


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
