"""Matching feature points by the L2 distance between their descriptors (the paper's section 3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import Consistency
from ..errors import ConfigError


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
        from scipy.optimize import linear_sum_assignment  # lazily: importing it costs ~0.2 s of start-up

        finite = np.where(np.isfinite(dist), dist, 1e12)
        src, tgt = linear_sum_assignment(finite)
        keep = np.isfinite(dist[src, tgt])
        src, tgt = src[keep], tgt[keep]
    else:
        raise ConfigError(f"matching mode must be 'nearest' or 'one-to-one', got {mode!r}")
    return Matches(src.astype(np.int64), tgt.astype(np.int64), dist[src, tgt])


def median_distance(dist: np.ndarray) -> float:
    """Median of the finite entries of a :func:`descriptor_distances` table (NaN if none): the
    scale of descriptor similarity in :func:`consistent_candidates` and of :func:`drop_dissimilar`."""
    finite = dist[np.isfinite(dist)].ravel()
    if not len(finite):
        return float("nan")
    # np.median's value, without the import of numpy.ma that np.median costs a cached match
    half = len(finite) // 2
    if len(finite) % 2:
        return float(np.partition(finite, half)[half])
    return float(np.mean(np.partition(finite, [half - 1, half])[half - 1:half + 1]))


def drop_dissimilar(matches: Matches, desc_1: np.ndarray, desc_2: np.ndarray, limit: float,
                    median: float | None = None) -> Matches:
    """``matches`` without those whose descriptor distance exceeds ``limit`` times the median
    :func:`descriptor_distances` over all pairs of rows of ``desc_1`` and ``desc_2`` (0: all kept;
    ``median``: that median, if already known).

    A layout-keeping matching can pair a feature point that has no counterpart on the other
    shape (a cat's ear against its nose) with whatever fits the layout; the descriptors of such
    a pair differ more than those of most unrelated extremities (docs/decisions/).
    """
    if limit <= 0 or len(matches) == 0:
        return matches
    if median is None:
        median = median_distance(descriptor_distances(desc_1, desc_2))
    keep = matches.distance <= limit * median
    return Matches(matches.source[keep], matches.target[keep], matches.distance[keep])


def consistent_matching(desc_1: np.ndarray, desc_2: np.ndarray, geodesics_1: np.ndarray, geodesics_2: np.ndarray,
                        weights: Consistency = Consistency()) -> Matches:
    """The best of :func:`consistent_candidates`."""
    return consistent_candidates(desc_1, desc_2, geodesics_1, geodesics_2, weights)[0][1]


def consistent_candidates(desc_1: np.ndarray, desc_2: np.ndarray, geodesics_1: np.ndarray, geodesics_2: np.ndarray,
                          weights: Consistency = Consistency()) -> list[tuple[float, Matches]]:
    """One-to-one partial matchings that keep the shapes' layout, best first: ``(score, matches)``.

    Maximizes over assignments pi (each target used at most once; a source may stay unmatched)

        sum_i (1 - D(i, pi(i)) / median(D))                       descriptor similarity
      + w_g * sum_{i<j} kept(d1(i, j), d2(pi(i), pi(j)))            geodesic layout

    by beam search, where ``kept`` is +1 for a geodesic distance that changes by less than
    ``geodesic_tolerance`` relatively, falling smoothly to -1 beyond. This rejects assignments
    that break the metric (a left hand with a right foot). Unmatched sources contribute 0, so a
    point whose counterpart was not detected is left out rather than forced onto a wrong one. A
    mirror image keeps every distance: it scores like the true matching and is among the
    candidates; :func:`darcyan.method.symmetry.choose_orientation` tells them apart.

    Args:
        desc_1, desc_2: ``(k1, d)``, ``(k2, d)`` descriptors.
        geodesics_1, geodesics_2: ``(k1, k1)``, ``(k2, k2)`` geodesic distances between feature points.
    """
    k1, k2 = len(desc_1), len(desc_2)
    dist = descriptor_distances(desc_1, desc_2)
    if k1 == 0 or k2 == 0:
        empty = np.zeros(0, np.int64)
        return [(0.0, Matches(empty, empty, np.zeros(0)))]
    median = median_distance(dist)
    scale = median if median > 0 else 1.0  # NaN (no finite pair) fails the test too
    unary = np.where(np.isfinite(dist), 1.0 - dist / scale, -np.inf)

    # Sources with the most distinctive best match first: early choices steer the beam.
    ranked = np.sort(-unary, axis=1)
    margin = ranked[:, 1] - ranked[:, 0] if k2 > 1 else np.zeros(k1)
    order = np.argsort(-margin, kind="stable")
    beams = [(0.0, ())]  # (score, ((source, target or -1), ...))
    for i in order:
        candidates = []
        for score, assignment in beams:
            gain = unary[i].copy()  # (k2,) score of matching i to each target
            matched = [(s, t) for s, t in assignment if t >= 0]
            if matched:
                src = np.array([s for s, _ in matched], dtype=np.int64)
                tgt = np.array([t for _, t in matched], dtype=np.int64)
                g1 = geodesics_1[i, src][None, :]
                g2 = geodesics_2[:, tgt]
                change = np.abs(g1 - g2) / np.maximum(0.5 * (g1 + g2), 1e-12) / weights.geodesic_tolerance
                gain += weights.geodesic * (1.0 - 2.0 * np.minimum(change**2, 1.0)).sum(axis=1)
                gain[tgt] = -np.inf
            for t in np.flatnonzero(np.isfinite(gain)):
                candidates.append((score + gain[t], assignment + ((int(i), int(t)),)))
            candidates.append((score, assignment + ((int(i), -1),)))
        candidates.sort(key=lambda c: -c[0])
        beams = candidates[:weights.beam_width]
    out = []
    for score, assignment in beams:
        pairs = sorted((s, t) for s, t in assignment if t >= 0)
        src = np.array([s for s, _ in pairs], dtype=np.int64)
        tgt = np.array([t for _, t in pairs], dtype=np.int64)
        out.append((float(score), Matches(src, tgt, dist[src, tgt] if len(src) else np.zeros(0))))
    return out
