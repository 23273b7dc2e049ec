"""Random samples of a surface's vertices, seeded by the caller."""

from __future__ import annotations

import numpy as np


def sample_vertices(n: int, count: int, rng: np.random.Generator, areas: np.ndarray | None = None) -> np.ndarray:
    """``(min(count, n),)`` distinct vertices of ``n`` drawn with probability proportional to
    ``areas (n,)`` (vertex areas: a uniform sample of the surface), or uniformly over the
    vertices without them."""
    p = None
    if areas is not None:
        p = np.asarray(areas, dtype=np.float64)
        p = p / p.sum()
    return rng.choice(n, size=min(count, n), replace=False, p=p)
