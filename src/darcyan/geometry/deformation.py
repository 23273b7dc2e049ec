"""As-rigid-as-possible deformation of a mesh towards soft targets (Sorkine and Alexa 2007).

The energy of positions ``y (n, 3)`` of a mesh at rest in ``x (n, 3)``, with targets ``t (n, 3)``::

    sum_ij w_ij |(y_i - y_j) - R_i (x_i - x_j)|^2  +  (2 / length^2) sum_i a_i |y_i - t_i|^2

(the first sum over ordered pairs of neighbours, so each edge twice; ``w`` the cotangent
weights, clamped at 0; ``R_i`` the best rotation of vertex i's one-ring, or with a ``stretch``
its best rotation times its best scale, held within ``1 / (1 + stretch)`` and ``1 + stretch``;
``a`` the vertex areas over the total area). The targets may also be given at points other than
the vertices (``sampling``): the pull is then ``(2 / length^2) sum_s a_s |(P y)_s - t_s|^2`` over
points ``P y``, each a barycentric combination of vertices, with areas ``a_s`` of their own. A
coarse copy of a large mesh deformed so that the full mesh's vertices, carried on it, meet their
targets: the same energy's data term with the copy's unknowns (a ninth of a 52k-vertex mesh's).
Both terms are areas times squared lengths, so the balance does not depend on the mesh's scale
or resolution: the mesh follows the targets on scales beyond about ``length`` (in sqrt(area)
units) and keeps its own shape below it, bends included, since each one-ring may turn. It is
minimized by local-global iterations: each one-ring's rotation from a 3x3 SVD (libigl), then
one sparse solve for the positions, whose matrix is factorized once.

libigl's ``arap`` holds chosen vertices fixed (hard constraints); a dense map's images are each
a vertex or two off, so here every vertex is pulled towards its target softly instead.
"""

from __future__ import annotations

import numpy as np

# The faint pull (per vertex, over the vertex count, against area shares that sum to 1) that
# keeps the system regular where a vertex has no pull of its own (no face of nonzero area, or no
# sample point on its faces): about a thousandth of an ordinary vertex's.
ISOLATED_PULL = 1e-3


class ArapDeformation:
    """A mesh's as-rigid-as-possible fit to soft targets; build once, :meth:`fit` many times.

    Args:
        vertices: ``(n, 3)`` the rest positions.
        laplacian: ``(n, n)`` its cotangent Laplacian (scipy sparse, negative semidefinite, as
            :attr:`darcyan.geometry.shape.Shape.laplacian`).
        areas: ``(n,)`` its vertex areas (any scale: they are divided by their sum).
        length: the scale (sqrt(area) units of the mesh) beyond which the fit follows the targets.
        sampling: ``(m, n)`` scipy sparse, each row the barycentric weights (summing to 1) of a
            point of the surface where a target is given; ``None``: the targets are at the
            vertices. With it, ``areas`` are the ``(m,)`` areas of those points.
        stretch: how much each one-ring may grow or shrink beside turning (0: as rigid as
            possible; above it, as similar as possible within that range).
    """

    def __init__(self, vertices: np.ndarray, laplacian, areas: np.ndarray, length: float, sampling=None,
                 stretch: float = 0.0):
        import scipy.sparse as sp  # lazily: a cached match imports no scipy
        from scipy.sparse.linalg import splu

        n = len(vertices)
        coo = laplacian.tocoo()
        coo.data = np.asarray(coo.data, dtype=np.float64)
        off = (coo.row != coo.col) & (coo.data > 0)  # obtuse pairs (negative weights) are left out
        if not off.any():
            raise ValueError("ARAP: the Laplacian has no positive off-diagonal weight (a negative "
                             "semidefinite cotangent Laplacian is expected)")
        if not (np.isfinite(length) and length > 0):
            raise ValueError(f"ARAP: length must be a positive number, got {length!r}")
        self._rows, cols, weights = coo.row[off], coo.col[off], coo.data[off]
        self._weights = sp.csr_matrix((weights, (self._rows, cols)), shape=(n, n))
        self._vertices = np.asarray(vertices, dtype=np.float64)
        # each directed edge (i, j), times its weight: x_i - x_j
        self._edges = weights[:, None] * (self._vertices[self._rows] - self._vertices[cols])
        self._cols = cols
        if not (np.isfinite(stretch) and stretch >= 0):
            raise ValueError(f"ARAP: stretch must be a number >= 0, got {stretch!r}")
        self._stretch = float(stretch)
        if self._stretch > 0:  # sum_j w_ij |x_i - x_j|^2: the rest one-ring's size, against which a scale is read
            self._rest_size = np.bincount(self._rows, np.einsum("ij,ij->i", self._edges, self._vertices[self._rows]
                                                                 - self._vertices[cols]), minlength=n)
        degree = np.asarray(self._weights.sum(axis=1)).ravel()
        # sum_j w_ij (x_i - x_j): the rest one-ring, rotated in each step
        self._spokes = degree[:, None] * self._vertices - self._weights @ self._vertices
        areas = np.asarray(areas, dtype=np.float64)
        self._sampling = None
        if sampling is None:
            # an isolated vertex (no face of nonzero area) still gets a pull, so the system stays regular
            areas = np.maximum(areas / areas.sum(), ISOLATED_PULL / n)
            self._pull = areas / length ** 2
            system = sp.diags(degree + self._pull) - self._weights
        else:
            sampling = sp.csr_matrix(sampling, dtype=np.float64)
            if sampling.shape != (len(areas), n):
                raise ValueError(f"ARAP: sampling must be ({len(areas)}, {n}) for {len(areas)} areas and {n} "
                                 f"vertices, got {sampling.shape}")
            self._sampling = sampling
            self._sample_pull = areas / areas.sum() / length ** 2
            pulled = sampling.T @ sp.diags(self._sample_pull) @ sampling
            # each vertex's share of the pull; a vertex that no point reaches is held, faintly
            # (the floor of the vertex case), so that the system stays regular
            self._reach = sampling.T @ self._sample_pull
            self._floor = np.where(self._reach > 0, 0.0, ISOLATED_PULL / n / length ** 2)
            system = sp.diags(degree + self._floor) - self._weights + pulled
        self._solve = splu(system.tocsc()).solve

    def fit(self, targets: np.ndarray, iterations: int, start: np.ndarray | None = None) -> np.ndarray:
        """``(n, 3)``: positions after ``iterations`` local-global steps towards ``targets (n, 3)``
        (``(m, 3)`` with a ``sampling``), starting from ``start (n, 3)`` (default: the targets;
        with a sampling, each vertex at the mean of the targets of the points it carries, by
        weight, or where none, at rest moved by the others' mean move). Time per step O(n)
        beside one solve with the factorization built at construction (its fill-in grows a
        little faster than n: about 0.2 s to build at 52k vertices)."""
        targets = np.asarray(targets, dtype=np.float64)
        if self._sampling is None:
            positions = targets.copy() if start is None else np.asarray(start, dtype=np.float64)
            pulled = self._pull[:, None] * targets
        else:
            pulled = self._sampling.T @ (self._sample_pull[:, None] * targets)
            reached = self._reach > 0
            mean = pulled / np.where(reached, self._reach, 1.0)[:, None]
            # a vertex no point reaches: at rest, moved as the reached ones moved on average (so
            # that where the targets lie does not matter)
            shift = (mean[reached] - self._vertices[reached]).mean(axis=0) if reached.any() else np.zeros(3)
            mean = np.where(reached[:, None], mean, self._vertices + shift)
            positions = mean if start is None else np.asarray(start, dtype=np.float64)
            pulled = pulled + self._floor[:, None] * mean
        for _ in range(iterations):
            covariances = self._covariances(positions)
            rotations = self._rotations_of(covariances)
            if self._stretch > 0:
                rotations = rotations * self._scales(covariances, rotations)[:, None, None]
            positions = self._solve(self._rotated_edges(rotations) + pulled)
        return positions

    def _scales(self, covariances: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """``(n,)`` each one-ring's best scale beside its rotation ``R_i``: ``trace(R_i S_i^T) /
        sum_j w_ij |x_i - x_j|^2`` for its covariance ``S_i`` (:meth:`_covariances`), held within
        ``1 / (1 + stretch)`` and ``1 + stretch`` (1 where a one-ring has no size)."""
        along = np.einsum("nab,bna->n", rotations, covariances)
        scale = np.divide(along, self._rest_size, out=np.ones_like(along), where=self._rest_size > 0)
        return np.clip(scale, 1.0 / (1.0 + self._stretch), 1.0 + self._stretch)

    def rotations(self, positions: np.ndarray) -> np.ndarray:
        """``(n, 3, 3)`` each one-ring's rotation best taking its rest edges to those of
        ``positions (n, 3)`` (what a local step computes)."""
        return self._rotations(np.asarray(positions, dtype=np.float64))

    def _rotations(self, positions: np.ndarray) -> np.ndarray:
        """``(n, 3, 3)`` the local step's rotations for ``positions (n, 3)`` (float64)."""
        return self._rotations_of(self._covariances(positions))

    def _covariances(self, positions: np.ndarray) -> np.ndarray:
        """``(3, n, 3)`` each one-ring's covariance ``S_i = sum_j w_ij (x_i - x_j) (y_i - y_j)^T``
        stacked as libigl reads them: ``[a, i, b]`` is entry ``(a, b)`` of ``S_i``."""
        n = len(positions)
        current = positions[self._rows] - positions[self._cols]
        stacked = np.empty((3, n, 3))
        for a in range(3):
            for b in range(3):
                stacked[a, :, b] = np.bincount(self._rows, self._edges[:, a] * current[:, b], minlength=n)
        return stacked

    @staticmethod
    def _rotations_of(covariances: np.ndarray) -> np.ndarray:
        """``(n, 3, 3)`` each one-ring's rotation best taking its rest edges to its current ones:
        ``R = V U^T`` for its covariance ``S = U D V^T`` (:meth:`_covariances`; a proper rotation:
        the sign of V's last column turned where that would be a reflection), by libigl's
        ``fit_rotations`` (a fixed-size 3x3 SVD; 2.5x numpy's batched SVD)."""
        import igl

        n = covariances.shape[1]
        # libigl gives the rotation nearest S (3 x 3n, one per column block); R is its transpose
        return igl.fit_rotations(covariances.reshape(3 * n, 3), False).reshape(3, n, 3).transpose(1, 0, 2)

    def _rotated_edges(self, rotations: np.ndarray) -> np.ndarray:
        """``(n, 3)``: ``sum_j w_ij (R_i + R_j) (x_i - x_j) / 2``, the global step's right side."""
        x, w = self._vertices, self._weights
        own = np.einsum("nab,nb->na", rotations, self._spokes)
        # sum_j w_ij R_j (x_i - x_j), column by column of the rotations
        others = np.zeros_like(x)
        for b in range(3):
            others += x[:, b, None] * (w @ rotations[:, :, b]) - w @ (rotations[:, :, b] * x[:, b, None])
        return 0.5 * (own + others)
