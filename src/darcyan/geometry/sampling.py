"""Samples of a surface's vertices: random (seeded by the caller) or farthest-point."""

from __future__ import annotations

import numpy as np

from ..errors import DarcyanError


def sample_vertices(n: int, count: int, rng: np.random.Generator, areas: np.ndarray | None = None) -> np.ndarray:
    """``(min(count, n),)`` distinct vertices of ``n`` drawn with probability proportional to
    ``areas (n,)`` (vertex areas: a uniform sample of the surface), or uniformly over the
    vertices without them."""
    p = None
    if areas is not None:
        p = np.asarray(areas, dtype=np.float64)
        p = p / p.sum()
    return rng.choice(n, size=min(count, n), replace=False, p=p)


def farthest_point_vertices(positions: np.ndarray, count: int, start: int) -> np.ndarray:
    """``(min(count, n),) int64`` vertices of ``positions (n, 3)`` in farthest-point order: first
    ``start``, then each time the vertex farthest (in space) from those taken (ties: the smallest
    index, the one way the numbering can matter; vertices at one spot, once every other spot is
    taken, in index order). Any prefix is itself spread evenly over the surface, and the set
    depends on where the vertices are, not on their numbering (unlike a random draw). Memory
    O(n); each pick updates only the vertices within the current largest gap of it (a k-d tree
    finds them), so a few thousand picks among 50k vertices take a fraction of a second."""
    from scipy.spatial import cKDTree

    positions = np.ascontiguousarray(positions, dtype=np.float64)
    if not 0 <= int(start) < len(positions):
        raise DarcyanError(f"farthest points: start vertex {start} is not one of the {len(positions)} vertices")
    count = min(int(count), len(positions))
    out = np.empty(count, dtype=np.int64)
    nearest = np.full(len(positions), np.inf)  # squared distance to the nearest pick
    tree = None
    current = int(start)
    for i in range(count):
        if i and nearest[current] == 0:  # every spot taken; the rest are copies of taken vertices
            rest = np.setdiff1d(np.arange(len(positions)), out[:i])
            out[i:] = rest[:count - i]
            break
        out[i] = current
        if i == 0:
            near = np.arange(len(positions))
        else:  # farther than the largest gap, no vertex can come nearer: left as it is
            tree = cKDTree(positions) if tree is None else tree
            reach = np.sqrt(nearest[current]) * (1 + 1e-9)  # the largest gap: current is the farthest
            near = np.asarray(tree.query_ball_point(positions[current], reach), dtype=np.int64)
        nearest[near] = np.minimum(nearest[near], ((positions[near] - positions[current]) ** 2).sum(axis=1))
        current = int(np.argmax(nearest))
    return out
