"""Which pairs of videos to evaluate: all, a random fraction, or a random spanning tree."""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree

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


def select_pairs(names: list[str], has_matches: set[tuple[str, str]],
                 sel: PairSelection) -> list[tuple[str, str]]:
    """Ordered (a, b) pairs with a before b in the video order.

    Pairs without any track pairs are kept in 'all' (so they show up as rejected with a reason)
    but never spent on in 'rst' or 'fraction'.
    """
    every = list(itertools.combinations(names, 2))
    if sel.mode == "all":
        return every
    rng = np.random.default_rng(sel.seed)
    matched = [p for p in every if p in has_matches or p[::-1] in has_matches]
    tree = random_spanning_forest(names, matched, rng)
    if sel.mode == "rst":
        return tree
    want = max(len(tree), math.ceil(sel.fraction * len(every)))
    rest = [p for p in matched if p not in tree]
    extra = [rest[i] for i in rng.permutation(len(rest))[: max(0, want - len(tree))]]
    chosen = set(tree) | set(extra)
    return [p for p in every if p in chosen]
