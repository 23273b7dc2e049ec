"""Nearest-neighbour searches, exact, in memory O(queries x block) or O(points).

- :func:`nearest_points`: numpy only (a cached match imports no scipy), float64, exact with
  ties broken by the smallest index; for the few thousand points of the mirror test, and a
  small mesh's searches in few dimensions; :class:`NearestPoints`, the same search prepared once
  for several sets of queries (the mirror test's rounds).
- :func:`nearest_neighbours`: each point's k nearest others among a few hundred points.
- :func:`nearest_rows`: any size; in few dimensions :func:`nearest_points` for small sets, else a
  k-d tree (scipy); blocked single-precision brute force in many (spectral embeddings of dense
  maps), also in inner-product form (rows whose norms were folded into offsets);
  :func:`nearest_rows_near`, the same searched coarse to fine over a surface (large dense maps;
  nearly exact, see there).
"""

from __future__ import annotations

import threading

import numpy as np

# Nearest rows: a k-d tree up to this dimension, blocked brute force above it (in 15 dimensions
# scipy's k-d tree took 9 s for 3000 queries among 50k rows, brute force 0.3 s).
KDTREE_MAX_DIM = 6
# ... and the tree only when the points or the queries are more than this: up to it, the exact
# numpy search (nearest_points: 0.04 s for 5k x 5k in 6 dimensions, the tree 0.03 s; its block of
# 64 x 7k distances 3.6 MB) costs less than importing scipy.spatial (0.05 s on an idle machine,
# 0.3-0.7 s beside a busy core; scipy.special and scipy.constants come with it) for a 5k dense map.
NUMPY_SEARCH_MAX_POINTS = 7000
# Queries per block of the brute force: a (256, n) block stays in cache (3x faster than one big block).
NN_BLOCK_ROWS = 256

# Nearest-neighbour searches in numpy, not scipy.spatial: importing that costs more (0.3 s) than
# a cached match's whole work, and the sets here are small (800 queries, <= 10k points).
QUERY_BLOCK = 64  # queries per block: a (64, 10k) block of distances, 5 MB, reused
# Queries x points below which nearest_points runs in this thread: the mirror test's rounds (a few
# hundred queries among 2,000) take less than starting the thread pool would (and its import, in a
# cached match that needs none).
THREADED_SEARCH_MIN = 4_000_000
# Multiple of the float64 unit roundoff that bounds the error of the screened distances (their
# exact bound is a few units times (d + 3)); any point within it of the minimum is measured again.
SCREEN_SLACK = 64


def nearest_points(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """``(q,)`` index of the point of ``points`` ``(n, d)`` nearest to each row of ``queries``
    ``(q, d)`` in Euclidean distance, exactly (ties: the smallest index).

    Squared distances are screened as ``|p|^2 - 2 q.p`` (one matrix product per block of
    queries, about 2x a k-d tree's time here); a query whose runner-up lies within the product's
    rounding of its minimum is settled by measuring ``|p - q|^2`` directly. The blocks of a large
    search (``THREADED_SEARCH_MIN``) run on :func:`~darcyan.parallel.own_threads` threads.
    Several searches among the same points: :class:`NearestPoints`.
    """
    return NearestPoints(points)(queries)


class NearestPoints:
    """:func:`nearest_points` among one set of ``points`` ``(n, d)``, prepared once (centred,
    their squared norms folded into the product's right factor) for several sets of queries:
    the same indices as :func:`nearest_points` of each, by the same arithmetic. A float64
    ``points`` array is kept, not copied: changed afterwards, it no longer matches what was
    prepared."""

    def __init__(self, points: np.ndarray):
        self.points = np.asarray(points, dtype=np.float64)
        self.centre = self.points.mean(axis=0)  # centred, the products' rounding is smaller
        p = self.points - self.centre
        p_sq = np.einsum("ij,ij->i", p, p)
        self.right = np.vstack([p.T, p_sq])  # (d + 1, n): [-2 q, 1] @ right = |p|^2 - 2 q.p
        self.reach = float(np.sqrt(p_sq.max(initial=0.0)))
        self.unit = SCREEN_SLACK * (self.points.shape[1] + 3) * float(np.finfo(np.float64).eps)

    def __call__(self, queries: np.ndarray) -> np.ndarray:
        """``(q,)`` index of the nearest point to each row of ``queries`` ``(q, d)``."""
        from ..parallel import map_blocks

        points, centre, right, reach, unit = self.points, self.centre, self.right, self.reach, self.unit
        queries = np.asarray(queries, dtype=np.float64)
        out = np.empty(len(queries), np.int64)
        scratch = threading.local()  # each thread's block of distances, reused: no fresh pages per block

        def search(start: int) -> None:  # the same blocks whatever the threads: the same bits
            q = queries[start:start + QUERY_BLOCK]
            if getattr(scratch, "block", None) is None:
                scratch.block = np.empty((min(QUERY_BLOCK, len(queries)), len(points)))
            qc = q - centre
            rows = np.arange(len(q))
            screened = np.matmul(np.hstack([-2.0 * qc, np.ones((len(q), 1))]), right, out=scratch.block[:len(q)])
            best = screened.argmin(axis=1)
            low = screened[rows, best].copy()
            tolerance = unit * (np.linalg.norm(qc, axis=1) + reach) ** 2
            screened[rows, best] = np.inf
            unsure = np.flatnonzero(screened.min(axis=1) <= low + tolerance)
            screened[rows, best] = low
            out[start:start + len(q)] = best
            if len(unsure):
                r, c = np.nonzero(screened[unsure] <= (low + tolerance)[unsure, None])
                exact = ((q[unsure[r]] - points[c]) ** 2).sum(axis=1)
                order = np.lexsort((c, exact, r))  # per query: smallest distance, then smallest index
                first = order[np.r_[True, r[order][1:] != r[order][:-1]]]
                out[start + unsure[r[first]]] = c[first]

        blocks = list(range(0, len(queries), QUERY_BLOCK))
        if len(queries) * len(points) < THREADED_SEARCH_MIN:
            for start in blocks:
                search(start)
        else:
            map_blocks(search, blocks)
        return out


def nearest_neighbours(points: np.ndarray, k: int) -> np.ndarray:
    """``(n, k)`` indices of each point's ``k`` nearest other points of ``points`` ``(n, d)``,
    nearest first (exact; for the few hundred points of the mirror test)."""
    # Column by column, in the order a sum over the last axis adds them (the same bits), without
    # the (n, n, d) array of differences.
    squared = np.subtract.outer(points[:, 0], points[:, 0]) ** 2
    for column in range(1, points.shape[1]):
        squared += np.subtract.outer(points[:, column], points[:, column]) ** 2
    np.fill_diagonal(squared, -1.0)  # each point first, then dropped
    near = np.argpartition(squared, k, axis=1)[:, :k + 1]
    order = np.argsort(np.take_along_axis(squared, near, axis=1), axis=1, kind="stable")
    return np.take_along_axis(near, order, axis=1)[:, 1:]


def nearest_rows(reference: np.ndarray, queries: np.ndarray, offsets: np.ndarray | None = None) -> np.ndarray:
    """``(q,) int64``: for each row of ``queries (q, d)``, the nearest row of ``reference (n, d)``;
    with ``offsets (n,)``, the row ``j`` minimizing ``offsets[j] - 2 q . reference[j]`` instead
    (``offsets`` ``|reference[j]|^2`` is the nearest row: the inner-product form lets a caller
    fold parts of its rows into the offsets, see :class:`~darcyan.dense.zoomout.MapSearch`).

    In few dimensions (at most ``KDTREE_MAX_DIM``), in double precision: without offsets exact,
    by :func:`nearest_points` when neither the rows nor the queries are more than
    ``NUMPY_SEARCH_MAX_POINTS``, else by a k-d tree; with offsets by brute force. In many, brute
    force in single precision. The brute force runs by blocks of queries (memory ``block x n``
    per thread beside the converted copies, never ``q x n``; inputs already of its precision are
    not copied), the blocks on :func:`~darcyan.parallel.own_threads` threads.

    Raises:
        ValueError: for coordinates or offsets that are not finite (no row is nearest then).
    """
    from ..parallel import map_blocks, own_threads

    few = np.shape(reference)[1] <= KDTREE_MAX_DIM
    dtype = np.float64 if few else np.float32
    reference = np.ascontiguousarray(reference, dtype=dtype)
    queries = np.ascontiguousarray(queries, dtype=dtype)
    if not all(_finite(a) for a in (reference, queries, offsets)):
        raise ValueError("nearest rows: coordinates that are not finite (NaN or infinite)")
    if offsets is None and few:
        if max(len(reference), len(queries)) <= NUMPY_SEARCH_MAX_POINTS:
            return nearest_points(reference, queries)
        from scipy.spatial import cKDTree

        return cKDTree(reference).query(queries, workers=own_threads())[1].astype(np.int64)
    # One matrix product per block gives |r|^2 - 2 q.r directly: [-2 q, 1] @ [r, |r|^2]^T.
    if offsets is None:
        offsets = np.einsum("ij,ij->i", reference, reference)
    right = np.vstack([reference.T, np.asarray(offsets, dtype=dtype)[None]])
    out = np.empty(len(queries), dtype=np.int64)

    def search(start: int) -> None:  # the same blocks whatever the threads: the same bits
        rows = queries[start:start + NN_BLOCK_ROWS]
        left = np.hstack([-2.0 * rows, np.ones((len(rows), 1), dtype)])
        out[start:start + len(rows)] = np.matmul(left, right).argmin(axis=1)

    map_blocks(search, list(range(0, len(queries), NN_BLOCK_ROWS)))
    return out


def _finite(values: np.ndarray | None) -> bool:
    """Whether every entry of ``values`` is finite (``None``: yes), in one pass without a mask as
    large as the array: a NaN or an infinity makes the double-precision sum non-finite."""
    return values is None or bool(np.isfinite(np.sum(values, dtype=np.float64)))


def nearest_rows_near(reference: np.ndarray, queries: np.ndarray, positions: np.ndarray, coarse: np.ndarray,
                      reach: int, guess: np.ndarray | None = None, guess_reach: int | None = None,
                      offsets: np.ndarray | None = None) -> np.ndarray:
    """``(q,) int64``: for each row of ``queries (q, d)``, the nearest row of ``reference (n, d)``
    among those lying near its nearest *coarse* row: a coarse-to-fine :func:`nearest_rows` for
    embeddings of surface points, in ``O(q (m + reach n / m) d)`` instead of ``O(q n d)``.

    ``positions (n, 3)``: where each reference row lies on its surface; ``coarse (m,)``: indices
    of a sample of the reference rows spread over it. Each reference row belongs to the cell of
    its nearest sample (in space); a query is compared with the rows of the cells of the
    ``reach`` samples nearest (in space) to its nearest sample (in the embedding). Not exact: on
    a smooth embedding of a sphere with 16 cells it finds the row of the full search for 99.8%
    of the queries, and on a 52k-vertex dense map the map's error is that of the full search to
    within 2% (``docs/decisions/``).

    ``guess (q,)``, when given: for each query, the index into ``coarse`` of a sample it is
    expected to lie near (e.g. the image of the source sample nearest to it in space). Its
    nearest sample is then sought only among the ``guess_reach`` (default ``reach``) samples
    nearest the guess (in space), not among all m: ``O(q guess_reach d)`` instead of
    ``O(q m d)``, the larger cost on a large mesh.

    ``offsets (n,)``, when given: "nearest" in :func:`nearest_rows`'s inner-product form.
    """
    from scipy.spatial import cKDTree

    from ..parallel import map_blocks

    reference = np.ascontiguousarray(reference, dtype=np.float32)
    queries = np.ascontiguousarray(queries, dtype=np.float32)
    coarse = np.asarray(coarse, dtype=np.int64)
    tree = cKDTree(positions[coarse])
    cell = tree.query(positions)[1]  # (n,) the sample each reference row belongs to
    around = tree.query(positions[coarse], k=min(reach, len(coarse)))[1].reshape(len(coarse), -1)
    by_cell = np.argsort(cell, kind="stable")
    bounds = np.searchsorted(cell[by_cell], np.arange(len(coarse) + 1))
    if guess is not None and len(guess) and (np.min(guess) < 0 or np.max(guess) >= len(coarse)):
        raise ValueError(f"nearest_rows_near: a guess outside the {len(coarse)} coarse samples")
    ref_sq = np.einsum("ij,ij->i", reference, reference) if offsets is None else np.asarray(offsets, np.float32)
    nearest_sample = nearest_rows(reference[coarse], queries, ref_sq[coarse]) if guess is None else \
        _nearest_around(reference[coarse], queries, np.asarray(guess, dtype=np.int64),
                        tree.query(positions[coarse], k=min(guess_reach or reach, len(coarse)))[1].reshape(len(coarse), -1),
                        ref_sq[coarse])
    out = np.empty(len(queries), dtype=np.int64)
    by_query = np.argsort(nearest_sample, kind="stable")
    starts = np.searchsorted(nearest_sample[by_query], np.arange(len(coarse) + 1))
    def search(s: int) -> None:  # the queries nearest sample s; cells apart, on any thread
        members = by_query[starts[s]:starts[s + 1]]
        candidates = np.concatenate([by_cell[bounds[c]:bounds[c + 1]] for c in around[s]])
        near, near_sq = reference[candidates], ref_sq[candidates]
        # By blocks of queries: on a large mesh one sample can be the nearest of tens of thousands.
        # Never a block of one row of several (a one-row product is BLAS's gemv, whose last bits differ).
        firsts = list(range(0, len(members), NN_BLOCK_ROWS))
        if len(firsts) > 1 and len(members) - firsts[-1] == 1:
            firsts.pop()
        for start, end in zip(firsts, firsts[1:] + [len(members)]):
            rows = members[start:end]
            scores = near_sq[None, :] - 2.0 * (queries[rows] @ near.T)
            out[rows] = candidates[np.argmin(scores, axis=1)]

    map_blocks(search, np.flatnonzero(np.diff(starts)).tolist())
    return out


def _nearest_around(samples: np.ndarray, queries: np.ndarray, guess: np.ndarray, around: np.ndarray,
                    offsets: np.ndarray) -> np.ndarray:
    """``(q,)`` for each query the nearest of the rows of ``samples (m, d)`` listed in
    ``around[guess[i]]`` (``around (m, r)``: each sample's neighbours, itself first), by groups of
    queries sharing a guess; nearest in :func:`nearest_rows`'s inner-product form with
    ``offsets (m,)``."""
    from ..parallel import map_blocks

    out = np.empty(len(queries), dtype=np.int64)
    order = np.argsort(guess, kind="stable")
    starts = np.searchsorted(guess[order], np.arange(len(samples) + 1))

    def search(g: int) -> None:
        members = order[starts[g]:starts[g + 1]]
        near = around[g]
        scores = offsets[near][None, :] - 2.0 * (queries[members] @ samples[near].T)
        out[members] = near[np.argmin(scores, axis=1)]

    map_blocks(search, np.flatnonzero(np.diff(starts)).tolist())
    return out
