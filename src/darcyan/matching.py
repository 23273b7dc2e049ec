"""Matching feature points by the L2 distance between their descriptors (the paper's section 3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from .errors import ConfigError


@dataclass(frozen=True)
class Matches:
    """``source (k,)`` and ``target (k,)`` indices into the two feature sets; ``distance (k,)``."""

    source: np.ndarray
    target: np.ndarray
    distance: np.ndarray

    def __len__(self) -> int:
        return len(self.source)


def descriptor_distances(desc_1: np.ndarray, desc_2: np.ndarray) -> np.ndarray:
    """``(k1, k2)`` L2 distances between rows of ``desc_1 (k1, d)`` and ``desc_2 (k2, d)``.

    Entries NaN in either descriptor (levels off the surface) are left out, and the sum over the
    remaining ones is rescaled to the full length, so partial grids stay comparable. Pairs with no
    common entry are infinitely far apart.
    """
    a = np.asarray(desc_1, dtype=np.float64)[:, None, :]
    b = np.asarray(desc_2, dtype=np.float64)[None, :, :]
    both = np.isfinite(a) & np.isfinite(b)
    sq = np.where(both, (a - b) ** 2, 0.0).sum(axis=2)
    count = both.sum(axis=2)
    dim = a.shape[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.sqrt(sq * dim / count)
    return np.where(count > 0, dist, np.inf)


def match_descriptors(desc_1: np.ndarray, desc_2: np.ndarray, mode: str = "nearest") -> Matches:
    """Match each row of ``desc_1`` to a row of ``desc_2``.

    Args:
        mode: ``"nearest"``: every source point takes the target with the smallest distance (the
            paper; several sources may share a target). ``"one-to-one"``: the assignment with the
            least total distance, each target used at most once (min(k1, k2) matches).
    """
    dist = descriptor_distances(desc_1, desc_2)
    if dist.size == 0:
        empty = np.zeros(0, np.int64)
        return Matches(empty, empty, np.zeros(0))
    if mode == "nearest":
        src = np.flatnonzero(np.isfinite(dist).any(axis=1))
        tgt = np.argmin(dist[src], axis=1)
    elif mode == "one-to-one":
        finite = np.where(np.isfinite(dist), dist, 1e12)
        src, tgt = linear_sum_assignment(finite)
        keep = np.isfinite(dist[src, tgt])
        src, tgt = src[keep], tgt[keep]
    else:
        raise ConfigError(f"matching mode must be 'nearest' or 'one-to-one', got {mode!r}")
    return Matches(src.astype(np.int64), tgt.astype(np.int64), dist[src, tgt])
