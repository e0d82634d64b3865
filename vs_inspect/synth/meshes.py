"""Triangle meshes of the synthetic world's bodies (in their body's frame, with texture
coordinates) and points sampled on their surfaces."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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

