"""Bijective ZoomOut on a Laplace-Beltrami basis: the refinement of a dense map.

ZoomOut (Melzi et al., *ZoomOut: Spectral Upsampling for Efficient Shape Correspondence*, 2019)
alternates between functional maps fitted to the current vertex maps and vertex maps read from
the functional maps by nearest neighbours, growing the basis each step; here with the
bijectivity and orthogonality terms of Ren et al. (*Discrete Optimization for Shape Matching*,
2021), a Laplacian commutativity term in the fits and other coordinates beside the spectral ones
(:func:`map_embeddings`). It iterates on random surface samples (:func:`zoomout_samples`); the
final map is read out for every source vertex (:func:`read_out_map`). The basis: cotangent
stiffness, mixed Voronoi mass (or the intrinsic Delaunay Laplacian's, ``DenseConfig.basis_laplacian``),
``scipy.sparse.linalg.eigsh`` (:func:`dense_spectrum`; on a decimated proxy of a large mesh,
interpolated).

Memory stays O(V): the functional maps are (k + margin) x k, nearest neighbours are searched
by blocks of source rows (:class:`MapSearch`), and on a large target near each image's nearest
ZoomOut sample (:func:`darcyan.geometry.knn.nearest_rows_near`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..geometry.knn import nearest_rows, nearest_rows_near
from ..geometry.sampling import farthest_point_vertices, sample_vertices
from ..parallel import own_threads, side_by_side
from .config import DenseConfig

# Shift of the shift-invert eigen solver (just below the zero eigenvalue of the Laplacian).
EIGSH_SHIFT = -1e-8
# Eigenvalues below this share of the largest are the constant functions' 0 (rounding aside).
ZERO_EIGENVALUE = 1e-9


# ----------------------------------------------------------------------------------------------
# Samples and basis


def zoomout_sample(shape, config: DenseConfig, member: int = 0) -> np.ndarray:
    """``(zoomout_samples,)`` the vertices ZoomOut iterates on, in their order of priority (the
    seeds' short ZoomOuts take a spread subset, :func:`seed_subset`). The first ZoomOut's, with
    ``config.sampling`` ``"farthest"``: in farthest-point order
    (:func:`~darcyan.geometry.sampling.farthest_point_vertices`) from the vertex farthest from
    the area centroid (the origin of the prepared mesh). Otherwise (``"random"``, or another member of the ensemble,
    ``config.ensemble``, which needs samples of its own): drawn by area with seed ``config.seed``
    (``(config.seed, member)`` for the other members), sorted."""
    if config.sampling == "random" or member > 0:
        rng = np.random.default_rng(config.seed if member == 0 else (config.seed, member))
        return np.sort(sample_vertices(shape.mesh.n_vertices, config.zoomout_samples, rng, shape.vertex_areas))

    def farthest():
        positions = shape.mesh.vertices  # centred on the area centroid by the preparation
        start = int(np.argmax((positions**2).sum(axis=1)))
        return farthest_point_vertices(positions, config.zoomout_samples, start)

    return shape.derived(("zoomout_sample", config.zoomout_samples), farthest)


def seed_subset(shape, sample: np.ndarray, count: int, config: DenseConfig) -> np.ndarray:
    """``(min(count, s),)`` vertices of ``shape`` that the seeds' short ZoomOuts run on, given its
    ZoomOut sample ``(s,)``: of a sorted random sample, every so many; of a farthest-point sample,
    its first ``count`` (a farthest-point sample of its own), and, when ZoomOut runs on every
    vertex, ``count`` farthest points of the shape."""
    count = min(count, len(sample))
    if config.sampling == "random":
        return sample[np.linspace(0, len(sample) - 1, count).astype(np.int64)]
    if len(sample) == shape.mesh.n_vertices:  # every vertex, in index order: not spread
        return zoomout_sample(shape, dataclasses.replace(config, zoomout_samples=count))
    return sample[:count]


def zoomout_samples(shape_1, shape_2, config: DenseConfig, member: int = 0) -> tuple:
    """``(sample_1, sample_2)``: both shapes' :func:`zoomout_sample` for ``member``, or every vertex
    of both when ``config.zoomout_samples`` is 0 or covers the larger mesh."""
    if 0 < config.zoomout_samples < max(shape_1.mesh.n_vertices, shape_2.mesh.n_vertices):
        return zoomout_sample(shape_1, config, member), zoomout_sample(shape_2, config, member)
    return np.arange(shape_1.mesh.n_vertices), np.arange(shape_2.mesh.n_vertices)


def fit_width(k: int, config: DenseConfig, columns: int | None = None) -> int:
    """How many eigenfunctions of the shape a functional map of size k maps from: k +
    ``config.basis_margin`` from the size ``config.margin_from`` on, else k (at most ``columns``,
    the bases' columns, when given)."""
    p = k + config.basis_margin if k >= config.margin_from else k
    return p if columns is None else min(p, columns)


def dense_spectrum(shape, config: DenseConfig):
    """The shape's ``fit_width(basis_size)`` first Laplace-Beltrami eigenpairs (a
    :class:`~darcyan.geometry.spectral.Spectrum`, built once per shape; on the coarse proxy of a
    large mesh, see ``DenseConfig.basis_proxy_vertices``), the shift-invert steps solved by
    Cholesky: 130 eigenpairs take some 450 of them."""
    size = fit_width(config.basis_size, config)
    return shape.smooth_spectrum(min(size, shape.mesh.n_vertices - 1), config.basis_proxy_vertices,
                                 tol=config.basis_tolerance, shift=EIGSH_SHIFT, lanczos=config.basis_lanczos,
                                 cholesky=True, laplacian=config.basis_laplacian)


def dense_basis(shape, config: DenseConfig) -> np.ndarray:
    """``(n, fit_width(basis_size))`` the eigenvectors of :func:`dense_spectrum`."""
    return dense_spectrum(shape, config).vectors


def dense_eigenvalues(shape, config: DenseConfig) -> np.ndarray:
    """``(fit_width(basis_size),)`` the eigenvalues of :func:`dense_spectrum` (ascending; the
    coarse proxy's where the basis comes from it)."""
    return dense_spectrum(shape, config).values


# ----------------------------------------------------------------------------------------------
# The iterations


def commutativity_shrinkage(values_a: np.ndarray, values_b: np.ndarray, p: int, k: int, weight: float) -> np.ndarray:
    """``(p, k)`` the factor ``1 / (1 + weight r_ij^2)``, ``r_ij = (l_i - l_j) / (l_i + l_j)``
    (0 where both are 0), by which ZoomOut shrinks each entry ``C[i, j]`` of its least-squares
    functional map from b's first k eigenfunctions (eigenvalues ``l_j`` of ``values_b``) to
    a's first p (``l_i``). On samples of an orthonormal basis (``B^T B = s I``, which samples
    drawn by area approach) this is the exact minimizer of the fit's squared residual plus the
    Laplacian commutativity term ``s * weight * sum(r_ij^2 C_ij^2)``, at no cost beyond the
    fit. The relative gap, not the absolute one: between two bodies of unlike proportions the
    eigenvalues differ by a share, and an absolute penalty would leave the low frequencies free
    and pin the high ones. Eigenvalues below ``ZERO_EIGENVALUE`` times the largest count as 0: the
    constant functions' eigenvalue is 0 only up to rounding (0 on one shape, 2e-14 on another),
    and its relative gap must not be read as 1."""
    a, b = np.abs(values_a[:p]), np.abs(values_b[:k])
    floor = ZERO_EIGENVALUE * max(a.max(initial=0.0), b.max(initial=0.0))
    a, b = np.where(a > floor, a, 0.0)[:, None], np.where(b > floor, b, 0.0)[None, :]
    total = a + b
    relative = np.divide(a - b, total, out=np.zeros_like(total), where=total > 0)
    return 1.0 / (1.0 + weight * relative**2)


class _Fitter:
    """Least-squares functional maps on the leading columns of one basis ``(s, K)``: its QR
    factorization once, whose leading k columns factor the first k basis columns (and the
    leading block of R's inverse inverts theirs), so that each ZoomOut step's fit
    ``basis[:, :k] @ C ~ Y`` is two small products, not a new least squares."""

    def __init__(self, basis: np.ndarray):
        self.basis = basis
        self.q = self.r_inverse = None
        if basis.shape[0] >= basis.shape[1]:  # fewer samples than columns: least squares each time
            self.q, r = np.linalg.qr(basis)
            self.r_inverse = np.linalg.inv(r)

    def fit(self, mapped: np.ndarray, p: int | None = None) -> np.ndarray:
        """``(p, k)`` ``C`` with ``basis[:, :p] @ C ~ mapped`` (``mapped (s, k)``; ``p``, at most
        the basis's columns, defaults to k)."""
        p = mapped.shape[1] if p is None else p
        if self.q is None:
            return np.linalg.lstsq(self.basis[:, :p], mapped, rcond=None)[0]
        return self.r_inverse[:p, :p] @ (self.q[:, :p].T @ mapped)


@dataclass(frozen=True, eq=False)
class MapSearch:
    """A vertex map a -> b as a nearest-row search in inner-product form: query ``i``'s image is
    the reference row ``j`` minimizing ``offsets[j] - 2 queries[i] . references[j]``
    (:func:`~darcyan.geometry.knn.nearest_rows` with offsets; :meth:`nearest`).

    Attributes:
        queries: ``(n_a, d)`` a row per point of shape a.
        references: ``(n_b, d)`` a row per point of shape b.
        offsets: ``(n_b,)`` float64, what each reference row adds to every score.
    """

    queries: np.ndarray
    references: np.ndarray
    offsets: np.ndarray

    def nearest(self) -> np.ndarray:
        """``(n_a,) int64`` the vertex map: each query's reference row."""
        return nearest_rows(self.references, self.queries, self.offsets)


def map_embeddings(b_a: np.ndarray, b_b: np.ndarray, c_ab: np.ndarray, c_ba: np.ndarray,
                   config: "DenseConfig", f_a: np.ndarray | None = None, f_b: np.ndarray | None = None,
                   g_a: np.ndarray | None = None, g_b: np.ndarray | None = None,
                   dtype=np.float64) -> MapSearch:
    """The :class:`MapSearch` whose nearest rows give the map a -> b minimizing coupling,
    bijectivity and orthogonality residuals (and, with ``f_a (s_a, c)``, ``f_b (s_b, c)`` the
    landmark coordinates, their difference weighed by ``config.landmark_weight``; with ``g_a
    (s_a, d)``, ``g_b (s_b, d)``, those coordinates as they are). ``dtype``: of the rows returned
    (each term computed in double precision, then converted; the offsets stay double).

    ``c_ab (p, k)`` (p >= k: see ``DenseConfig.basis_margin``) pulls b's first k coefficients
    back to a's first p (``b_a[:, :p] C_ab ~ b_b[map, :k]``), ``c_ba (p, k)`` the reverse; the
    bases ``b_a``, ``b_b`` have at least p columns. Coupling: ``b_b[j, :k] ~ b_a[i, :p] C_ab``;
    bijectivity (the map b -> a undoes a -> b): ``b_b[j, :p] C_ba ~ b_a[i, :k]``; orthogonality
    (area preservation, ``C C^T ~ I`` for a square map): ``b_b[j, :k] C_ab[:k]^T ~ b_a[i, :k]``,
    on the square k x k block alone, leaving a's columns beyond k out of this term (a choice that
    holds near isometry, where that block carries the map, not an exact condition).

    The map is the Euclidean nearest row of embeddings that stack these terms: query ``[a C_ab,
    sqrt(w) a_k, 0, l f_a, g_a]`` against reference ``[b_k, sqrt(w) m_j, s_j, l f_b, g_b]`` (``w``
    the bijectivity and orthogonality weights summed, ``m_j`` the weighted mean of the rows
    they compare ``a_k`` with, ``s_j`` what is left of them, a number; ``l`` the landmark
    weight). Every product of a query with a reference is linear in ``a = b_a[i, :p]``, so the
    search reads queries ``[a, l f_a, g_a]`` against references ``[C_ab b_k + w m_j (padded to
    p columns), l f_b, g_b]`` with the squared length of the stacked reference row as its offset
    (each query's own squared length is the same for every ``j`` and left out): p + c + d
    columns instead of 2k + 1 + c + d, the same map up to rounding.
    """
    p, k = c_ab.shape
    w1, w2 = config.bijectivity ** 2, config.orthogonality ** 2
    total = w1 + w2
    landmarks = config.landmark_weight > 0 and f_a is not None

    def query_rows(rows: slice) -> tuple:
        parts = [b_a[rows, :p]]  # read once: a basis interpolated from a proxy is interpolated as it is read
        if landmarks:
            parts.append(config.landmark_weight * f_a[rows])
        if g_a is not None:
            parts.append(g_a[rows])
        return parts, None

    def reference_rows(rows: slice) -> tuple:
        b = b_b[rows, :p] if total > 0 else b_b[rows, :k]  # read once (an interpolated basis is interpolated as read)
        folded = b[:, :k] @ c_ab.T  # (a C_ab) . b_k = a . (C_ab b_k)
        offsets = np.einsum("ij,ij->i", b[:, :k], b[:, :k])
        if total > 0:
            # Both terms compare b_a[i] with a row of b: w1 |a - x_j|^2 + w2 |a - y_j|^2 equals
            # (w1 + w2) |a - m_j|^2 + w1 w2 / (w1 + w2) |x_j - y_j|^2 with m_j their weighted mean.
            # y = b_k C_ab[:k]^T is the fold's first k columns (read before they are added to)
            x, y = b @ c_ba, folded[:, :k]
            pulled = w1 * x + w2 * y  # (w1 + w2) m_j
            offsets += (np.einsum("ij,ij->i", pulled, pulled) + w1 * w2 * np.einsum("ij,ij->i", x - y, x - y)) / total
            folded[:, :k] += pulled
        parts = [folded]
        for extra in ((config.landmark_weight * f_b[rows]) if landmarks else None,
                      None if g_b is None else g_b[rows]):
            if extra is not None:
                parts.append(extra)
                offsets += np.einsum("ij,ij->i", extra, extra)
        return parts, offsets

    queries, _ = _rows_by_blocks(query_rows, len(b_a), dtype)
    references, offsets = _rows_by_blocks(reference_rows, len(b_b), dtype)
    return MapSearch(queries, references, offsets)


# Rows of an embedding computed at once: the double-precision terms of a block, not of a whole
# large mesh, are held beside the result (on a 210k-vertex mesh, 1 GB less at the peak).
EMBEDDING_BLOCK_ROWS = 16384


def _rows_by_blocks(parts_of, n: int, dtype) -> tuple:
    """``(rows (n, d) of dtype, values (n,) or None)``: the columns ``parts_of(rows)`` gives for
    each block of rows (each term computed in double precision, then converted), side by side,
    and the block's values (``(parts, values or None)`` from ``parts_of``), end to end."""
    out = values = None
    for first in range(0, max(n, 1), EMBEDDING_BLOCK_ROWS):
        rows = slice(first, min(first + EMBEDDING_BLOCK_ROWS, n))
        parts, block_values = parts_of(rows)
        if out is None:
            out = np.empty((n, sum(part.shape[1] for part in parts)), dtype)
            values = None if block_values is None else np.empty(n)
        column = 0
        for part in parts:
            out[rows, column:column + part.shape[1]] = part
            column += part.shape[1]
        if values is not None:
            values[rows] = block_values
    return out, values


def zoomout(basis_1: np.ndarray, basis_2: np.ndarray, map_12: np.ndarray, map_21: np.ndarray,
            config: "DenseConfig", coords_1: np.ndarray | None = None,
            coords_2: np.ndarray | None = None, coarse_1: np.ndarray | None = None,
            coarse_2: np.ndarray | None = None, steady_1: np.ndarray | None = None,
            steady_2: np.ndarray | None = None, values_1: np.ndarray | None = None,
            values_2: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bijective ZoomOut on (sampled) vertices.

    ``basis_i (s_i, K)``: Laplace-Beltrami eigenfunctions at the vertices taking part (K up to
    ``config.basis_size + config.basis_margin``);
    ``map_12 (s_1,)`` indices of rows of ``basis_2`` (the current map 1 -> 2) and ``map_21
    (s_2,)`` the reverse. For k from ``config.basis_start`` to ``config.basis_size`` by
    ``config.basis_step``: fit the functional maps of both directions to the current
    vertex maps (least squares, each entry shrunk by :func:`commutativity_shrinkage` when the
    eigenvalues are given), then update both vertex maps by nearest neighbours of the
    embeddings of :func:`map_embeddings` (ZoomOut, Melzi et al. 2019, with the bijectivity and
    orthogonality terms of Ren et al., *Discrete Optimization for Shape Matching*, 2021); each
    map is :func:`fit_width` x k (rectangular from ``config.margin_from`` on). ``coords_i (s_i,
    c)``: the landmark coordinates, weighed by ``config.landmark_weight`` in every step (see
    :func:`map_embeddings`); ``coarse_i (s_i, c)``: coordinates that join the embeddings, as they are, in the steps of size at most
    ``config.signature_until`` only (the weighted point signatures); ``steady_i (s_i, t)``:
    coordinates that join them in every step (the weighted signature turns); ``values_i (K,)``:
    the bases' eigenvalues, for the commutativity term of the fits (``config.commutativity``;
    without them, plain least-squares fits).

    Returns ``c_12, c_21`` (``(p, k)``: the last size k and its p columns, as above; see
    :func:`map_embeddings`): ``basis_1[:, :p] @ c_12 ~ basis_2[map_12, :k]``.
    """
    largest = min(config.basis_size, basis_1.shape[1], basis_2.shape[1])
    sizes = list(range(min(config.basis_start, largest), largest + 1, config.basis_step))
    if sizes[-1] != largest:
        sizes.append(largest)
    columns = min(basis_1.shape[1], basis_2.shape[1])
    widest = fit_width(largest, config, columns)
    fit_1, fit_2 = _Fitter(basis_1[:, :widest]), _Fitter(basis_2[:, :widest])
    for i, k in enumerate(sizes):
        p = fit_width(k, config, columns)
        b1, b2 = basis_1[:, :p], basis_2[:, :p]
        c_12, c_21 = fit_1.fit(b2[map_12, :k], p), fit_2.fit(b1[map_21, :k], p)
        if config.commutativity > 0 and values_1 is not None and values_2 is not None:
            c_12 = c_12 * commutativity_shrinkage(values_1, values_2, p, k, config.commutativity)
            c_21 = c_21 * commutativity_shrinkage(values_2, values_1, p, k, config.commutativity)
        if i < len(sizes) - 1:
            g_1, g_2 = (coarse_1, coarse_2) if k <= config.signature_until else (None, None)
            g_1, g_2 = _joined(g_1, steady_1), _joined(g_2, steady_2)
            # the two directions side by side: each search alone is too small to split well
            map_12, map_21 = side_by_side([
                partial(_nearest_map, b1, b2, c_12, c_21, config, coords_1, coords_2, g_1, g_2),
                partial(_nearest_map, b2, b1, c_21, c_12, config, coords_2, coords_1, g_2, g_1)])
    return c_12, c_21


def _nearest_map(*embedding) -> np.ndarray:
    """The vertex map of :func:`map_embeddings` ``(*embedding)``."""
    return map_embeddings(*embedding).nearest()


def _joined(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
    """Columns of ``a`` beside those of ``b``, either of which may be ``None``."""
    return b if a is None else a if b is None else np.hstack([a, b])


def read_out_map(shape_2, basis_1: np.ndarray, basis_2: np.ndarray, c_12: np.ndarray, c_21: np.ndarray,
                 config: DenseConfig, coords_1: np.ndarray, coords_2: np.ndarray,
                 sample_2: np.ndarray, steady_1: np.ndarray | None = None,
                 steady_2: np.ndarray | None = None, sample_1: np.ndarray | None = None,
                 positions_1: np.ndarray | None = None) -> np.ndarray:
    """``(n1,)`` for every source vertex a target vertex (prepared numbering): the nearest rows of
    the :func:`map_embeddings` of functional maps ``c_12, c_21 (p, k)`` on the bases ``(n_i,
    >= p)``, the landmark coordinates ``(n_i, c)`` and, as they are, ``steady_i (n_i, t)`` (the
    weighted signature turns, when given); a target mesh of more than
    ``config.local_search_above`` vertices is searched near each image's nearest ZoomOut sample
    (``sample_2``, see :func:`darcyan.geometry.knn.nearest_rows_near`); with the source's
    ZoomOut samples ``sample_1`` and vertex positions ``positions_1 (n1, 3)``, that sample is
    sought near the image of the source sample nearest each vertex."""
    # Single precision, as the search reads them (half the memory of a large mesh's).
    search = map_embeddings(basis_1, basis_2, c_12, c_21, config, coords_1, coords_2, steady_1, steady_2,
                            dtype=np.float32)
    q, r = search.queries, search.references
    mesh_2 = shape_2.mesh
    if mesh_2.n_vertices > config.local_search_above and len(sample_2) < mesh_2.n_vertices:
        # The search's cells: as many as ZoomOut's samples, drawn over the vertices (not the
        # area), so that each holds as many vertices: cells of equal area hold many more where a
        # mesh is dense (hands, faces), and dense regions map onto dense regions, so the search's
        # cost grew with the square of the density (6 s of 7 on a 210k mesh of TOSCA's david).
        cells = np.sort(sample_vertices(mesh_2.n_vertices, len(sample_2), np.random.default_rng(config.seed)))
        guess = None
        if sample_1 is not None:
            # Each vertex's image is sought near that of the source sample nearest to it (the
            # samples' own map: a search among the samples alone), not among all cells.
            from scipy.spatial import cKDTree

            images = nearest_rows(r[cells], q[sample_1], search.offsets[cells])
            guess = images[cKDTree(positions_1[sample_1]).query(positions_1, workers=own_threads())[1]]
        return nearest_rows_near(r, q, mesh_2.vertices, cells, config.local_search_reach, guess,
                                 config.local_search_guess * config.local_search_reach, search.offsets)
    return search.nearest()


def consensus_map(positions: np.ndarray, maps: list) -> np.ndarray:
    """``(n1,)`` per source vertex the medoid of its images under ``maps`` (each ``(n1,)``, rows of
    ``positions (n2, 3)``): the image with the least sum of distances to the others (the first
    such, in the order of ``maps``). ZoomOut from different samples settles in different local
    optima, each right over most of the body and wrong, if anywhere, in a region of its own; where
    two of three agree, the medoid keeps them."""
    if len(maps) < 3:
        return maps[0]
    images = np.stack([positions[m] for m in maps])  # (K, n1, 3)
    spread = np.zeros((len(maps), images.shape[1]))
    for i, j in zip(*np.triu_indices(len(maps), k=1)):
        gap = np.linalg.norm(images[i] - images[j], axis=1)
        spread[i] += gap
        spread[j] += gap
    return np.stack(maps)[np.argmin(spread, axis=0), np.arange(images.shape[1])]
