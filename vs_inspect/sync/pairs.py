"""Which pairs of videos to evaluate: all, a random fraction, a random spanning tree, or each
camera's k nearest cameras by viewing direction (for large rigs: about N*k pairs, not N^2/2)."""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree

from ..types import CameraTrack
from .config import PairSelection


def random_spanning_forest(names: list[str], candidates: list[tuple[str, str]],
                           rng: np.random.Generator) -> list[tuple[str, str]]:
    """A spanning tree of each connected component, with uniform random edge weights."""
    if not candidates:
        return []
    pos = {n: i for i, n in enumerate(names)}
    rows = [pos[a] for a, _ in candidates]
    cols = [pos[b] for _, b in candidates]
    weights = rng.uniform(1.0, 2.0, size=len(candidates))
    graph = coo_matrix((weights, (rows, cols)), shape=(len(names), len(names))).tocsr()
    tree = minimum_spanning_tree(graph).tocoo()
    chosen = {(min(r, c), max(r, c)) for r, c in zip(tree.row, tree.col)}
    return [p for p in candidates if (min(pos[p[0]], pos[p[1]]), max(pos[p[0]], pos[p[1]])) in chosen]


def viewing_direction(cam: CameraTrack) -> np.ndarray:
    """(3,) unit optical axis in world coordinates (the mean over frames for a moving camera)."""
    R = np.asarray(cam.cam_from_world)[..., :3, :3]
    axis = R[..., 2, :]  # the world direction of the camera's +z: third row of cam_from_world's R
    axis = axis.reshape(-1, 3).mean(axis=0)
    return axis / max(float(np.linalg.norm(axis)), 1e-12)


def nearest_camera_pairs(names: list[str], candidates: list[tuple[str, str]],
                         cameras: dict[str, CameraTrack], k: int) -> list[tuple[str, str]]:
    """Each camera with its k candidate partners of the smallest angle between viewing
    directions (ties: the closer camera centre), plus the minimum spanning tree of those angles
    over the candidates, so that every connected group of videos stays connected. At most
    N*k + N - 1 pairs."""
    if not candidates:
        return []
    pos = {n: i for i, n in enumerate(names)}
    axes = np.stack([viewing_direction(cameras[n]) for n in names])
    centres = np.stack([_centre(cameras[n]) for n in names])
    angle = np.arccos(np.clip(axes @ axes.T, -1.0, 1.0))  # (N,N) rad
    dist = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
    partners: dict[int, list[tuple[float, float, int]]] = {i: [] for i in range(len(names))}
    for a, b in candidates:
        i, j = pos[a], pos[b]
        partners[i].append((angle[i, j], dist[i, j], j))
        partners[j].append((angle[i, j], dist[i, j], i))
    chosen = set()
    for i, near in partners.items():
        for _, _, j in sorted(near)[:k]:
            chosen.add((min(i, j), max(i, j)))
    rows = [pos[a] for a, _ in candidates]
    cols = [pos[b] for _, b in candidates]
    weights = 1.0 + np.array([angle[r, c] for r, c in zip(rows, cols)])  # > 0: 0 means "no edge"
    graph = coo_matrix((weights, (rows, cols)), shape=(len(names), len(names))).tocsr()
    tree = minimum_spanning_tree(graph).tocoo()
    chosen |= {(min(r, c), max(r, c)) for r, c in zip(tree.row, tree.col)}
    return [p for p in candidates if (min(pos[p[0]], pos[p[1]]), max(pos[p[0]], pos[p[1]])) in chosen]


def _centre(cam: CameraTrack) -> np.ndarray:
    """(3,) camera centre in world coordinates (the mean over frames for a moving camera)."""
    return cam.centers().mean(axis=0)


def select_pairs(names: list[str], has_matches: set[tuple[str, str]],
                 sel: PairSelection, cameras: dict[str, CameraTrack] | None = None
                 ) -> list[tuple[str, str]]:
    """Ordered (a, b) pairs with a before b in the video order.

    Pairs without any track pairs are kept in 'all' (so they show up as rejected with a reason)
    but never spent on in 'rst', 'fraction' or 'knn'. 'knn' needs the cameras.
    """
    every = list(itertools.combinations(names, 2))
    if sel.mode == "all":
        return every
    rng = np.random.default_rng(sel.seed)
    matched = [p for p in every if p in has_matches or p[::-1] in has_matches]
    if sel.mode == "knn":
        if cameras is None:
            raise ValueError("pair selection knn needs the cameras of the videos")
        return nearest_camera_pairs(names, matched, cameras, sel.k)
    tree = random_spanning_forest(names, matched, rng)
    if sel.mode == "rst":
        return tree
    want = max(len(tree), math.ceil(sel.fraction * len(every)))
    rest = [p for p in matched if p not in tree]
    extra = [rest[i] for i in rng.permutation(len(rest))[: max(0, want - len(tree))]]
    chosen = set(tree) | set(extra)
    return [p for p in every if p in chosen]
