"""Dense correspondence: a target vertex for every source vertex, seeded by the sparse matches.

The sparse matches (feature point -> feature point) become *landmarks*. Each vertex is described
by its fast-marching geodesic distances to the k landmarks of its shape (an ``(n, k)`` embedding,
O(V k) memory): a near-isometry keeps these coordinates, so the nearest vertex of the other shape
in that space gives first maps in both directions. They are refined by a bijective ZoomOut (Melzi
et al., *ZoomOut: Spectral Upsampling for Efficient Shape Correspondence*, 2019, with the
bijectivity and orthogonality terms of Ren et al., *Discrete Optimization for Shape Matching*,
2021) on a Laplace-Beltrami basis (cotangent stiffness, mixed Voronoi mass,
``scipy.sparse.linalg.eigsh``), iterated on random surface samples; the final map is computed
for every source vertex. Plain ZoomOut drifts on the less isometric TOSCA pairs (cat); the
bijectivity term holds it.

Sparse matches may be wrong (symmetric flips, wrong extremities): by default only the largest
set of matches whose pairwise geodesic distances agree on both shapes is used (see
:func:`consistent_landmarks`), and the sparse matching competes with the alternatives the
sparse stage weighed (``Correspondence.alternatives``): each seeds a short ZoomOut, and the one
whose map best keeps a curvature signature seeds the dense map (a mirrored seed keeps every
distance and, with the orientation coordinates, turns the body round: front onto back, which
the curvature of a face or a chest shows). ``DenseMap.check`` says which seed was used and
whether the map is trusted. Beside the spectral terms, ZoomOut's steps carry the landmark
coordinates (distances and their turns), the curvature signature in the coarse steps, and the
turns from the landmark directions to the signature's (:func:`signature_turn_coordinates`).

Large meshes: the basis is computed on a decimated proxy and interpolated, and the final map
searches each image near its nearest ZoomOut sample (:func:`darcyan.geometry.knn.nearest_rows_near`).

Memory stays O(V): the functional maps are (k + margin) x k, nearest neighbours are searched
with a k-d tree (few dimensions) or by blocks of source rows (spectral dimensions).

:func:`evaluate_dense` scores a dense map against ground truth on a fixed random sample of
source vertices with the standard geodesic error (see :mod:`darcyan.eval.metrics`);
:func:`pyfm_own_map` is pyFM's own pipeline without darcyan's landmarks, the baseline of
``darcyan bench --dense``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError, DarcyanError
from ..geometry.knn import nearest_rows, nearest_rows_near
from ..geometry.mesh import Mesh
from ..geometry.sampling import farthest_point_vertices, sample_vertices
from .pyfm import DENSE_PIPELINE, pyfm_point_map

LANDMARK_MODES = ("consistent", "all")
METHODS = ("zoomout", "pyfm")
SAMPLINGS = ("farthest", "random")  # DenseConfig.sampling
UNMAPPED = -1  # source vertices the analysis left out (outside the largest component)
# Shift of the shift-invert eigen solver (just below the zero eigenvalue of the Laplacian).
EIGSH_SHIFT = -1e-8
MIN_LANDMARKS = 3
# What a dense map may raise on a pair it cannot map (too few consistent landmarks, an eigensolver
# that does not converge): callers report it and go on (the bench records the pair as failed).
DENSE_FAILURES = (DarcyanError, ArithmeticError, ValueError, RuntimeError, np.linalg.LinAlgError)
# Consistent landmark sets: exact maximum-clique search up to this many matches, greedy above.
MAX_EXHAUSTIVE_LANDMARKS = 24
# Weight of the (normalized) descriptor distances when breaking ties between landmark sets.
TIE_BREAK_WEIGHT = 1e-3
# Eigenvalues below this share of the largest are the constant functions' 0 (rounding aside).
ZERO_EIGENVALUE = 1e-9


@dataclass(frozen=True)
class DenseConfig:
    """Parameters of :func:`dense_map`.

    Attributes:
        method: ``"zoomout"``: geodesic landmark coordinates, then the bijective ZoomOut below;
            ``"pyfm"``: pyFM's functional map with the landmarks as descriptors, then its ZoomOut
            (``pip install 'darcyan[pyfm]'``; slower, the ``basis_*``, ``margin_from``,
            ``zoomout_samples``, ``sampling``, ``bijectivity``, ``orthogonality``,
            ``signature_weight``, ``signature_until``, ``commutativity`` and ``ensemble`` fields do
            not apply).
        landmarks: ``"consistent"``: keep the largest set of matches whose pairwise geodesic
            distances agree on both shapes (see ``consistency``); ``"all"``: every match.
        consistency: two matches agree when their geodesic distances on the two shapes differ by
            at most this fraction of the larger one (plus ``consistency_floor``).
        consistency_floor: absolute slack of that test, in sqrt(area) units.
        basis_start: size of the first functional map of ZoomOut.
        basis_size: size of the last one (Laplace-Beltrami eigenfunctions computed per shape:
            this many plus ``basis_margin``).
        basis_step: growth of the basis per ZoomOut iteration.
        basis_margin: from ZoomOut's size ``margin_from`` on, the step of size k fits each
            functional map from k + ``basis_margin`` eigenfunctions of the shape it maps from to
            the k first of the other (a rectangular map), in the steps and in the final map.
            Between two bodies that are not isometric the eigenfunctions do not pair up index
            by index: near the cut at k, one shape's k-th is a mix of the other's on either side
            of it, which a square map must drop (``docs/parameters.md``). The short ZoomOuts that
            score the seeds keep square maps.
        margin_from: the smallest size of ZoomOut that gets the margin (from the first size on,
            three FAUST maps of 40 lost 2-6 points).
        zoomout_samples: ZoomOut iterates on this many surface samples of each shape (0 = on
            all vertices); the final map is always computed for every source vertex.
        ensemble: ZoomOut runs from this many different samples (the first as ``sampling``
            says, the others independent random draws, from ``seed``), combined by
            :func:`consensus_map` (per source vertex the medoid of the images; 1 or 2: one run, a
            medoid needs three).
        bijectivity, orthogonality: scales of the bijectivity (the map b -> a undoes a -> b)
            and orthogonality (area preservation) terms beside the coupling term in ZoomOut's
            nearest-neighbour searches: each term's coordinates are multiplied by its scale, so
            its squared residual weighs the square (bijectivity 2: 4; ``docs/parameters.md``).
            0 and 0 = plain ZoomOut.
        landmark_weight: weight of the landmark coordinates (geodesic distances to the landmarks
            and, with ``orientation_weight``, their turns) beside the spectral terms in every
            ZoomOut step and in the final map: the landmarks hold the map throughout, not only
            at its start (3: ``docs/parameters.md``).
        orientation_weight: weight of the :func:`orientation_coordinates` beside the geodesic
            distances to the landmarks in the first map and in the landmark term (0: distances
            only). Distances to five extremities of a human cannot tell its front from its back:
            on FAUST, maps without them were flipped over a third of the body in 12 of 40 pairs.
        basis_tolerance: relative accuracy of the eigenvalues asked of the eigensolver (its
            start vector is seeded); at 1e-3 the eigenvectors of FAUST shapes equal those at
            machine precision to 1e-14, in half the time.
        basis_proxy_vertices: the basis of a mesh with more than twice this many vertices is
            computed on a decimated copy of about this many and interpolated
            (:meth:`darcyan.geometry.shape.Shape.smooth_basis`); 0: always on the mesh itself.
        candidates: the sparse matching and its first ``candidates - 1`` alternatives
            (``Correspondence.alternatives``) are each turned into a first map; the one whose
            map best keeps the :func:`point_signature` seeds the dense map (1: the sparse
            matching alone). A seed of mirrored landmarks otherwise ruins a whole map.
        seed_basis, seed_samples: size of the short ZoomOut that scores each seed, and the
            samples it runs on.
        signature_lengths: diffusion lengths (sqrt(area)) of the mean curvature in that signature.
        signature_weight: weight of the :func:`point_signature` (each length divided by its
            standard deviation over both shapes) beside the other terms of the chosen seed's
            ZoomOut steps up to ``signature_until`` eigenfunctions (0: never). At the coarse sizes
            the landmark coordinates cannot tell which way an arm or a chest is turned, and a
            map locks in a wrong turn there; the curvature of a face, a chest or an elbow can.
            At the fine sizes the signature (which changes with the pose) would bias the map,
            so it is dropped (``docs/parameters.md``).
        signature_until: the largest basis size whose ZoomOut step uses the signature.
        signature_turns: weight of the :func:`signature_turn_coordinates` (at each vertex, the
            turn from the gradient of the distance to each landmark to the gradient of each
            length of the point signature) beside the other terms of every ZoomOut step of the
            chosen seed and of the final read-out (0: never). Along a limb the distances to all
            the landmarks grow alike on all its sides; the turn from that direction to the one in
            which the curvature changes differs from one side to another (``docs/parameters.md``).
        seed_margin: an alternative replaces the sparse matching only when its score is lower
            by at least this share; the map is ``trusted`` (``DenseMap.check``) only when no
            other seed scores within this share of its own.
        trust_orientation: ... and when its orientation agreement is at least this (a map
            flipped against its landmarks scores -0.5 to -0.7, a right one 0.6 to 0.9).
        local_search_above: a target mesh with more vertices than this is searched coarse to
            fine for the final map (:func:`darcyan.geometry.knn.nearest_rows_near`: near the
            image's nearest ZoomOut sample) instead of over all its vertices: O(V) instead of
            O(V^2) work.
        local_search_reach: the coarse-to-fine search looks at the cells of this many samples
            around the nearest one.
        commutativity: weight of a Laplacian commutativity term in the functional maps of the
            chosen seed's ZoomOut (its steps and final map): each entry ``C[i, j]`` of a
            least-squares fit is shrunk by ``1 / (1 + commutativity ((l_i - l_j) / (l_i +
            l_j))^2)`` (``l`` the eigenvalues; :func:`commutativity_shrinkage`), so a map mixes
            eigenfunctions of unlike frequencies only where the point map insists. Between two
            bodies a point map's noise spreads over all the entries, and a plain fit carries it
            into the next step. 0: plain ZoomOut fits. The short ZoomOuts that score the seeds
            fit without it (``docs/parameters.md``).
        seed: seed of the random surface samples (``sampling`` ``"random"``, and the other
            members of an ensemble).
        sampling: how the ``zoomout_samples`` are chosen: ``"random"``, drawn by area with
            ``seed``; ``"farthest"``, farthest-point samples (spread evenly, and the same whatever
            the vertices' numbering: a renumbered or re-welded file gets the same map; the other
            members of an ensemble still draw at random). Farthest points gained a little on
            FAUST but lost one tosca-hires map (michael0 -> 10: 99.0% -> 88.8% within 0.05), so
            random stays the default (``docs/parameters.md``).
    """

    method: str = "zoomout"
    landmarks: str = "consistent"
    consistency: float = 0.3
    consistency_floor: float = 0.02
    basis_start: int = 10
    basis_size: int = 120
    basis_step: int = 4
    basis_margin: int = 10
    margin_from: int = 40
    zoomout_samples: int = 2000
    ensemble: int = 1
    bijectivity: float = 2.0
    orthogonality: float = 1.0
    landmark_weight: float = 3.0
    orientation_weight: float = 1.0
    basis_proxy_vertices: int = 6000
    basis_tolerance: float = 1e-3
    candidates: int = 4
    seed_basis: int = 30
    seed_samples: int = 1000
    signature_lengths: tuple = (0.02, 0.05, 0.1)
    signature_weight: float = 3.0
    signature_until: int = 70
    signature_turns: float = 2.0
    seed_margin: float = 0.04
    trust_orientation: float = 0.3
    local_search_above: int = 20000
    local_search_reach: int = 16
    commutativity: float = 3.0
    seed: int = 0
    sampling: str = "random"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"dense: method must be one of {METHODS}, got {self.method!r}")
        if self.sampling not in SAMPLINGS:
            raise ConfigError(f"dense: sampling must be one of {SAMPLINGS}, got {self.sampling!r}")
        if self.landmarks not in LANDMARK_MODES:
            raise ConfigError(f"dense: landmarks must be one of {LANDMARK_MODES}, got {self.landmarks!r}")
        for name in ("basis_start", "basis_size", "basis_step", "local_search_reach", "candidates", "seed_basis",
                     "seed_samples", "ensemble"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"dense: {name} must be a positive integer, got {value!r}")
        if self.basis_start > self.basis_size:
            raise ConfigError(f"dense: basis_start ({self.basis_start}) exceeds basis_size ({self.basis_size})")
        for name in ("zoomout_samples", "local_search_above", "basis_proxy_vertices", "signature_until",
                     "basis_margin", "margin_from"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise ConfigError(f"dense: {name} must be a non-negative integer, got {value!r}")
        lengths = self.signature_lengths
        if (not isinstance(lengths, (list, tuple)) or not lengths
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0 for x in lengths)):
            raise ConfigError(f"dense: signature_lengths must be a list of positive lengths, got {lengths!r}")
        object.__setattr__(self, "signature_lengths", tuple(float(x) for x in lengths))
        if not (isinstance(self.seed_margin, (int, float)) and 0 <= self.seed_margin < 1):
            raise ConfigError(f"dense: seed_margin must be in [0, 1), got {self.seed_margin!r}")
        if not (isinstance(self.trust_orientation, (int, float)) and -1 <= self.trust_orientation <= 1):
            raise ConfigError(f"dense: trust_orientation must be in [-1, 1], got {self.trust_orientation!r}")
        for name in ("consistency", "consistency_floor", "bijectivity", "orthogonality", "landmark_weight",
                     "orientation_weight", "basis_tolerance", "signature_weight", "signature_turns",
                     "commutativity"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0
                    and np.isfinite(value)):
                raise ConfigError(f"dense: {name} must be non-negative, got {value!r}")


@dataclass
class DenseMap:
    """A dense map and how it was made.

    Attributes:
        target: ``(n1,) int64``, for each source vertex (input numbering) a target vertex (input
            numbering), :data:`UNMAPPED` for source vertices outside the analysed mesh.
        landmarks: ``(k, 2) int64`` (source, target) landmark pairs used, input numbering.
        timings: seconds per stage.
        check: what :func:`map_check` says of the map (``orientation`` in [-1, 1], ``distortion``),
            which seed was used (``seed``: 0 the sparse matching, i its i-th alternative, of
            ``seeds`` usable, distinct ones), its ``signature`` score, the ``runner_up``'s and every
            seed's (``signatures``: rank -> score), whether no other seed came within the
            margin (``clear``) and whether the map is ``trusted`` (see :class:`DenseConfig`).
    """

    target: np.ndarray
    landmarks: np.ndarray
    timings: dict = field(default_factory=dict)
    check: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------------------------
# Landmarks


def consistent_landmarks(dist_1: np.ndarray, dist_2: np.ndarray, relative: float, floor: float,
                         cost: np.ndarray | None = None) -> np.ndarray:
    """The largest set of matches whose pairwise geodesic distances agree on both shapes.

    Args:
        dist_1, dist_2: ``(k, k)`` geodesic distances between the matched points on each shape
            (match i is source point i -> target point i), sqrt(area) units.
        relative, floor: matches i, j agree when ``|dist_1[i,j] - dist_2[i,j]| <= relative *
            max(dist_1[i,j], dist_2[i,j]) + floor``.
        cost: ``(k,)`` tie-break among sets of equal size (e.g. descriptor distances): the set
            with the least total distortion plus cost wins.

    Returns:
        ``(m,) int64`` indices of the kept matches: a maximum clique of the agreement graph
        (exhaustive search up to :data:`MAX_EXHAUSTIVE_LANDMARKS` matches; above, the match
        with the most disagreements is dropped until all agree).
    """
    k = len(dist_1)
    if k == 0:
        return np.zeros(0, np.int64)
    distortion = np.abs(dist_1 - dist_2)
    agree = distortion <= relative * np.maximum(dist_1, dist_2) + floor
    np.fill_diagonal(agree, True)
    if k > MAX_EXHAUSTIVE_LANDMARKS:
        kept = np.arange(k)
        while not agree[np.ix_(kept, kept)].all():
            kept = np.delete(kept, np.argmax((~agree[np.ix_(kept, kept)]).sum(axis=1)))
        return kept.astype(np.int64)
    cost = np.zeros(k) if cost is None else np.asarray(cost, dtype=np.float64)
    best: list = [[], np.inf]

    def score(members):
        idx = np.array(members)
        return distortion[np.ix_(idx, idx)].sum() / 2 + cost[idx].sum()

    def grow(members, candidates):
        if len(members) + len(candidates) < len(best[0]):
            return
        if not candidates:
            if len(members) > len(best[0]) or (len(members) == len(best[0]) and score(members) < best[1]):
                best[0], best[1] = list(members), score(members)
            return
        first, rest = candidates[0], candidates[1:]
        grow(members + [first], [c for c in rest if agree[first, c]])
        grow(members, rest)

    grow([], list(range(k)))
    return np.array(sorted(best[0]), dtype=np.int64)


# ----------------------------------------------------------------------------------------------
# Spectral basis and nearest neighbours


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
    large mesh, see ``DenseConfig.basis_proxy_vertices``)."""
    size = fit_width(config.basis_size, config)
    return shape.smooth_spectrum(min(size, shape.mesh.n_vertices - 1), config.basis_proxy_vertices,
                                 tol=config.basis_tolerance, shift=EIGSH_SHIFT)


def dense_basis(shape, config: DenseConfig) -> np.ndarray:
    """``(n, fit_width(basis_size))`` the eigenvectors of :func:`dense_spectrum`."""
    return dense_spectrum(shape, config).vectors


def dense_eigenvalues(shape, config: DenseConfig) -> np.ndarray:
    """``(fit_width(basis_size),)`` the eigenvalues of :func:`dense_spectrum` (ascending; the
    coarse proxy's where the basis comes from it)."""
    return dense_spectrum(shape, config).values


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


# ----------------------------------------------------------------------------------------------
# The dense map


def _landmark_pairs(shape_1, shape_2, correspondence, config: DenseConfig, fields: tuple | None = None):
    """Landmark pairs in local numbering and their distance fields ``(n, k)`` on both shapes
    (``fields``: one ``{vertex: (n,) distance}`` per shape, read and filled in)."""
    fields = ({}, {}) if fields is None else fields
    src = shape_1.mesh_index(correspondence.source_vertex)
    tgt = shape_2.mesh_index(correspondence.target_vertex)
    cost = np.asarray(getattr(correspondence, "distance", np.zeros(len(src))), dtype=np.float64)
    ok = (src >= 0) & (tgt >= 0)
    src, tgt, cost = src[ok], tgt[ok], cost[ok]

    def distances(shape, known, vertices):
        for v in vertices:
            if int(v) not in known:
                known[int(v)] = shape.solver.distance(int(v))
        return np.stack([known[int(v)] for v in vertices], axis=1) if len(vertices) else np.zeros((shape.mesh.n_vertices, 0))

    fields_1, fields_2 = distances(shape_1, fields[0], src), distances(shape_2, fields[1], tgt)
    if config.landmarks == "consistent" and len(src):
        finite = np.where(np.isfinite(cost), cost, 0.0)
        scale = finite.max() if finite.max() > 0 else 1.0
        keep = consistent_landmarks(fields_1[src], fields_2[tgt], config.consistency, config.consistency_floor,
                                    cost=finite / scale * TIE_BREAK_WEIGHT)
        src, tgt, fields_1, fields_2 = src[keep], tgt[keep], fields_1[:, keep], fields_2[:, keep]
    return src, tgt, fields_1, fields_2


def orientation_coordinates(shape, fields: np.ndarray, others: np.ndarray | None = None) -> np.ndarray:
    """``(n, k (k - 1) / 2)``: at each vertex, for each two landmarks a < b, the sine of the turn
    from the gradient of the distance to a to that of the distance to b, about the outward normal
    (``fields (n, k)``: the distances). Distances to a few extremities cannot tell the front of a
    body from its back, nor left from right where the extremities sit symmetrically; these
    signs can: a reflection flips every one of them, an isometry keeps them. Averaged by area
    from the faces to the vertices. With ``others (n, j)``: ``(n, k j)``, the turn from each
    field's gradient to each of the others' instead (column ``a j + b``: field a to other b)."""
    from ..geometry.operators import face_gradients

    mesh = shape.mesh
    k = fields.shape[1]
    if others is None:
        a, b = np.triu_indices(k, k=1)
    else:
        a, b = np.repeat(np.arange(k), others.shape[1]), k + np.tile(np.arange(others.shape[1]), k)
        fields = np.hstack([fields, others])
    grads = face_gradients(mesh, fields, getattr(shape, "gradient", None))  # (m, 3, k [+ j])
    unit, corners, weight = _face_frame(shape)
    norm = np.linalg.norm(grads, axis=1)  # (m, k)
    ga, gb = [grads[:, i, a] for i in range(3)], [grads[:, i, b] for i in range(3)]  # (m, pairs) each
    # The cross product of each pair, with numpy.cross's operations in its order (the same bits,
    # without its copies of the (m, 3, pairs) operands: 40% of this function's time at 52k).
    c0 = ga[1] * gb[2]
    c0 -= ga[2] * gb[1]
    c1 = ga[2] * gb[0]
    c1 -= ga[0] * gb[2]
    c2 = ga[0] * gb[1]
    c2 -= ga[1] * gb[0]
    cross = np.stack([c0, c1, c2], axis=1)  # (m, 3, pairs)
    sine = np.einsum("mi,mip->mp", unit, cross) / np.maximum(norm[:, a] * norm[:, b], 1e-12)
    return (corners @ sine) / np.maximum(weight, 1e-300)[:, None]


def _face_frame(shape) -> tuple:
    """``(unit normals (m, 3), corners (n, m), weight (n,))`` of the shape's faces: the (n, m)
    matrix of face areas at the faces' corners (one product sums a face field per vertex) and
    its row sums; once per shape (:meth:`Shape.derived`) when the shape keeps derived results."""

    def compute():
        import scipy.sparse as sp

        mesh = shape.mesh
        v, f = mesh.vertices, mesh.faces
        normal = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        area = np.linalg.norm(normal, axis=1)
        unit = normal / np.maximum(area, 1e-300)[:, None]
        corners = sp.csr_matrix((np.repeat(area, 3), (f.ravel(), np.repeat(np.arange(len(f)), 3))),
                                shape=(mesh.n_vertices, len(f)))
        return unit, corners, np.asarray(corners.sum(axis=1)).ravel()

    derived = getattr(shape, "derived", None)
    return compute() if derived is None else derived(("face frame",), compute)


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


def map_embeddings(b_a: np.ndarray, b_b: np.ndarray, c_ab: np.ndarray, c_ba: np.ndarray,
                   config: "DenseConfig", f_a: np.ndarray | None = None, f_b: np.ndarray | None = None,
                   g_a: np.ndarray | None = None, g_b: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Query rows on shape a and reference rows on shape b whose nearest neighbours give the map
    a -> b minimizing coupling, bijectivity and orthogonality residuals (and, with ``f_a (s_a,
    c)``, ``f_b (s_b, c)`` the landmark coordinates, their difference weighed by
    ``config.landmark_weight``; with ``g_a (s_a, d)``, ``g_b (s_b, d)``, those coordinates as they
    are): ``nearest_rows(references, queries)`` is the vertex map.

    ``c_ab (p, k)`` (p >= k: see ``DenseConfig.basis_margin``) pulls b's first k coefficients
    back to a's first p (``b_a[:, :p] C_ab ~ b_b[map, :k]``), ``c_ba (p, k)`` the reverse; the
    bases ``b_a``, ``b_b`` have at least p columns. Coupling: ``b_b[j, :k] ~ b_a[i, :p] C_ab``;
    bijectivity (the map b -> a undoes a -> b): ``b_b[j, :p] C_ba ~ b_a[i, :k]``; orthogonality
    (area preservation, ``C C^T ~ I`` for a square map): ``b_b[j, :k] C_ab[:k]^T ~ b_a[i, :k]``,
    on the square k x k block alone, leaving a's columns beyond k out of this term (a choice that
    holds near isometry, where that block carries the map, not an exact condition).
    """
    p, k = c_ab.shape
    queries, references = [b_a[:, :p] @ c_ab], [b_b[:, :k]]
    w1, w2 = config.bijectivity ** 2, config.orthogonality ** 2
    if w1 + w2 > 0:
        # Both terms compare b_a[i] with a row of b: w1 |a - x_j|^2 + w2 |a - y_j|^2 equals
        # (w1 + w2) |a - m_j|^2 + w1 w2 / (w1 + w2) |x_j - y_j|^2 with m_j their weighted mean:
        # one block of k columns and one column carrying the j-only part, not two blocks.
        x, y = b_b[:, :p] @ c_ba, b_b[:, :k] @ c_ab[:k].T
        total = w1 + w2
        queries += [np.sqrt(total) * b_a[:, :k], np.zeros((len(b_a), 1))]
        references += [(w1 * x + w2 * y) / np.sqrt(total),
                       np.sqrt(w1 * w2 / total) * np.linalg.norm(x - y, axis=1)[:, None]]
    if config.landmark_weight > 0 and f_a is not None:
        queries.append(config.landmark_weight * f_a)
        references.append(config.landmark_weight * f_b)
    if g_a is not None:
        queries.append(g_a)
        references.append(g_b)
    return np.hstack(queries), np.hstack(references)


def zoomout(basis_1: np.ndarray, basis_2: np.ndarray, map_12: np.ndarray, map_21: np.ndarray,
            config: "DenseConfig", fields_1: np.ndarray | None = None,
            fields_2: np.ndarray | None = None, coarse_1: np.ndarray | None = None,
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
    map is :func:`fit_width` x k (rectangular from ``config.margin_from`` on). ``coarse_i (s_i,
    c)``: coordinates that join the embeddings, as they are, in the steps of size at most
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
            q, r = map_embeddings(b1, b2, c_12, c_21, config, fields_1, fields_2, g_1, g_2)
            map_12 = nearest_rows(r, q)
            q, r = map_embeddings(b2, b1, c_21, c_12, config, fields_2, fields_1, g_2, g_1)
            map_21 = nearest_rows(r, q)
    return c_12, c_21


def _joined(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
    """Columns of ``a`` beside those of ``b``, either of which may be ``None``."""
    return b if a is None else a if b is None else np.hstack([a, b])


def pyfm_own_map(mesh_1: Mesh, mesh_2: Mesh, n_input_vertices: int | None = None) -> DenseMap:
    """pyFM's own dense pipeline between two analysed meshes, *without* darcyan's landmarks (the
    baseline of ``darcyan bench --dense``): :func:`darcyan.dense.pyfm.pyfm_point_map` with no landmarks.

    ``mesh_i``: prepared, area-1 meshes (``ShapeDescription.mesh``); ``n_input_vertices``: of
    the source file (default: from ``mesh_1.input_index``). Returns a :class:`DenseMap` in input
    numbering like :func:`dense_map` (no landmarks; ``timings["pyfm"]``: the whole pipeline)."""
    t = time.perf_counter()
    local = pyfm_point_map(mesh_1, mesh_2, DENSE_PIPELINE)
    n_input = int(mesh_1.input_index.max()) + 1 if n_input_vertices is None else n_input_vertices
    target = np.full(n_input, UNMAPPED, dtype=np.int64)
    target[mesh_1.input_index] = mesh_2.input_index[local]
    return DenseMap(target, np.zeros((0, 2), dtype=np.int64), {"pyfm": time.perf_counter() - t})


def dense_map(shape_1, shape_2, correspondence, config: DenseConfig = DenseConfig(),
              progress=None) -> DenseMap:
    """A target vertex for every source vertex, seeded by sparse ``correspondence``.

    Args:
        shape_1, shape_2: the prepared shapes (:class:`~darcyan.geometry.shape.Shape`, or a
            :class:`~darcyan.method.pipeline.ShapeAnalysis`, whose shape is used): their area-1
            meshes, geodesic solvers and spectra.
        correspondence: anything with ``source_vertex (k,)`` and ``target_vertex (k,)`` in input
            numbering (a :class:`~darcyan.method.pipeline.Correspondence`; ``distance (k,)``
            breaks ties between landmark sets).
        config: see :class:`DenseConfig`.

    Returns:
        a :class:`DenseMap`; ``.target`` is ``(n_input_vertices of shape_1,) int64`` in the input
        numbering of shape 2 (:data:`UNMAPPED` for vertices outside the analysed mesh).

    Raises:
        DarcyanError: when a shape is a description only, or no seed (the correspondence or
            one of its alternatives) has :data:`MIN_LANDMARKS` consistent landmark pairs. A
            correspondence with fewer leaves the map to the best usable alternative.
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    say = progress or (lambda stage: None)
    timings: dict = {}
    choice = _choose_seed(shape_1, shape_2, correspondence, config, say, timings)
    seed, seeds, (sample_1, sample_2), (basis_1, basis_2) = choice
    mesh_1, mesh_2 = shape_1.mesh, shape_2.mesh
    src, tgt, fields_1, fields_2 = seed.source, seed.target, seed.fields_1, seed.fields_2
    turns_1, turns_2, coords_1, coords_2 = seed.turns_1, seed.turns_2, seed.coords_1, seed.coords_2
    t = time.perf_counter()
    if config.method == "pyfm":
        say("pyfm")
        local = pyfm_point_map(mesh_1, mesh_2, DENSE_PIPELINE, src, tgt)
        timings["pyfm"] = time.perf_counter() - t
    else:
        say("zoomout")
        # A medoid needs three runs; on every vertex (no draw of samples) the runs would be one map.
        every_vertex = len(sample_1) == mesh_1.n_vertices and len(sample_2) == mesh_2.n_vertices
        runs = config.ensemble if config.ensemble >= 3 and not every_vertex else 1
        everywhere = np.arange(mesh_1.n_vertices), np.arange(mesh_2.n_vertices)
        signature_1, signature_2 = signature_coordinates(shape_1, shape_2, config, *everywhere)
        steady_1, steady_2 = signature_turn_coordinates(shape_1, shape_2, config, fields_1, fields_2)
        values = (None, None)  # the commutativity term's eigenvalues
        if config.commutativity > 0:
            values = dense_eigenvalues(shape_1, config), dense_eigenvalues(shape_2, config)
        maps = []
        for member in range(runs):
            if member > 0:
                sample_1, sample_2 = zoomout_samples(shape_1, shape_2, config, member)
            first_12 = nearest_rows(coords_2[sample_2], coords_1[sample_1])  # first maps by the landmark coordinates
            first_21 = nearest_rows(coords_1[sample_1], coords_2[sample_2])
            coarse_1, coarse_2 = (None, None) if signature_1 is None else (signature_1[sample_1], signature_2[sample_2])
            turns = (None, None) if steady_1 is None else (steady_1[sample_1], steady_2[sample_2])
            c_12, c_21 = zoomout(basis_1[sample_1], basis_2[sample_2], first_12, first_21, config,
                                 coords_1[sample_1], coords_2[sample_2], coarse_1, coarse_2, *turns, *values)
            maps.append(read_out_map(shape_2, basis_1, basis_2, c_12, c_21, config, coords_1, coords_2, sample_2,
                                     steady_1, steady_2))
        local = consensus_map(mesh_2.vertices, maps)
        timings["zoomout"] = time.perf_counter() - t
    target = input_map(shape_1, shape_2, local)
    landmarks = np.stack([mesh_1.input_index[src], mesh_2.input_index[tgt]], axis=1)
    check = map_check(shape_1, local, fields_1, fields_2, turns_1, turns_2)
    check.update(_seed_check(seed, seeds, config.seed_margin))
    check["trusted"] = bool(check["orientation"] >= config.trust_orientation and check["clear"])
    return DenseMap(target, landmarks, timings, check)


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


def read_out_map(shape_2, basis_1: np.ndarray, basis_2: np.ndarray, c_12: np.ndarray, c_21: np.ndarray,
                 config: DenseConfig, coords_1: np.ndarray, coords_2: np.ndarray,
                 sample_2: np.ndarray, steady_1: np.ndarray | None = None,
                 steady_2: np.ndarray | None = None) -> np.ndarray:
    """``(n1,)`` for every source vertex a target vertex (prepared numbering): the nearest rows of
    the :func:`map_embeddings` of functional maps ``c_12, c_21 (p, k)`` on the bases ``(n_i,
    >= p)``, the landmark coordinates ``(n_i, c)`` and, as they are, ``steady_i (n_i, t)`` (the
    weighted signature turns, when given); a target mesh of more than
    ``config.local_search_above`` vertices is searched near each image's nearest ZoomOut sample
    (``sample_2``, see :func:`darcyan.geometry.knn.nearest_rows_near`)."""
    q, r = map_embeddings(basis_1, basis_2, c_12, c_21, config, coords_1, coords_2, steady_1, steady_2)
    mesh_2 = shape_2.mesh
    if mesh_2.n_vertices > config.local_search_above and len(sample_2) < mesh_2.n_vertices:
        return nearest_rows_near(r, q, mesh_2.vertices, sample_2, config.local_search_reach)
    return nearest_rows(r, q)


def input_map(shape_1, shape_2, local: np.ndarray) -> np.ndarray:
    """``(n_input_vertices of shape_1,) int64``: a map ``local (n1,)`` between the prepared meshes
    in the input numbering of both shapes (welded copies of a vertex mapped like it,
    :data:`UNMAPPED` for vertices outside the analysed mesh)."""
    target = np.full(shape_1.n_input_vertices, UNMAPPED, dtype=np.int64)
    on_mesh = shape_1.mesh_index(np.arange(shape_1.n_input_vertices))
    target[on_mesh >= 0] = shape_2.mesh.input_index[local[on_mesh[on_mesh >= 0]]]
    return target


def verified_matches(shape_1, shape_2, correspondence, config: DenseConfig = DenseConfig(),
                     full_basis: bool = False):
    """The matching a dense map would be seeded by: ``correspondence`` itself, or the alternative
    (``correspondence.alternatives``) whose short ZoomOut map keeps the curvature signature
    clearly better (see :class:`DenseConfig`: ``candidates``, ``seed_margin``). Scored on a
    spectrum of the short ZoomOuts' size (:func:`seed_scoring_config`), where :func:`dense_map`
    scores on its full basis: the same seed on every pair compared (``docs/parameters.md``), not
    by construction. Costs the two shapes' 30 first eigenfunctions and a short ZoomOut per
    candidate (choosing the seed of a 5k pair: 0.45 s, against 1.34 s on the full basis).
    ``full_basis``: score on the dense map's full basis instead, exactly as :func:`dense_map`
    does (when a dense map follows, which then reuses that basis).

    Returns ``(matches, about)``: a correspondence of the same kind as ``correspondence`` (its
    ``alternatives`` the others, the sparse matching first among them), and what
    :attr:`DenseMap.check` says of seeds (``seed``, ``signatures``, ``clear``: no other
    candidate within the margin).

    Raises:
        DarcyanError: when no candidate has :data:`MIN_LANDMARKS` consistent matches.
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    scoring = config if full_basis else seed_scoring_config(config)
    seed, seeds, _, _ = _choose_seed(shape_1, shape_2, correspondence, scoring, lambda stage: None, {})
    return matching_of_seed(correspondence, seed.rank), _seed_check(seed, seeds, config.seed_margin)


def seed_scoring_config(config: DenseConfig) -> DenseConfig:
    """``config`` with the basis cut to what scoring the seeds uses (``seed_basis``
    eigenfunctions, no margin): without a dense map to follow, a spectrum of that size is enough
    (choosing the seed of a 5k pair takes a third of the time). Its vectors are those of the full spectrum's first columns
    up to sign (which the short ZoomOuts' maps do not depend on), but for the last few, mixed
    with their neighbours beyond the cut: the seeds' scores move by up to 0.4% on the 5k sets'
    300 test pairs and 1.2% on 7 tosca-hires pairs, and the chosen seed is the same on all of
    them (``docs/parameters.md``)."""
    short = min(config.seed_basis, config.basis_size)
    return dataclasses.replace(config, basis_size=short, basis_start=min(config.basis_start, short), basis_margin=0)


def matching_of_seed(correspondence, rank: int):
    """The matching of seed ``rank`` (0: ``correspondence`` itself; 1, 2, ...: its
    ``alternatives``), the others (the sparse matching first) as its alternatives."""
    matchings = [correspondence] + list(getattr(correspondence, "alternatives", ()))
    if not 0 <= rank < len(matchings):
        raise DarcyanError(f"seed {rank}: the matching has {len(matchings) - 1} alternatives")
    chosen = matchings[rank]
    if rank > 0:
        chosen = dataclasses.replace(chosen, alternatives=tuple(m for m in matchings if m is not chosen))
    return chosen


def seed_scores(shape_1, shape_2, correspondence, config: DenseConfig = DenseConfig()) -> dict:
    """``{rank: score}``: the signature score of each usable seed (0: ``correspondence`` itself,
    1, 2, ...: its alternatives), lower is better; the scores :func:`dense_map` chooses its seed
    by (see :func:`chosen_seed`), without making the map. Raises DarcyanError like it."""
    return verified_matches(shape_1, shape_2, correspondence, config, full_basis=True)[1]["signatures"]


def seed_check(rank: int, signatures: dict, margin: float) -> dict:
    """What :attr:`DenseMap.check` says of the seeds, from the chosen seed's ``rank`` and every
    usable seed's score (``signatures``: rank -> score): ``clear`` when no other seed scores
    within ``margin`` (relative) of it."""
    others = sorted(score for r, score in signatures.items() if r != rank)
    return {"seed": rank, "seeds": len(signatures), "signature": signatures[rank],
            "runner_up": others[0] if others else None, "signatures": dict(signatures),
            "clear": bool(not others or signatures[rank] <= (1.0 - margin) * others[0])}


def _seed_check(seed, seeds: list, margin: float) -> dict:
    return seed_check(seed.rank, {s.rank: s.signature for s in seeds}, margin)


def _choose_seed(shape_1, shape_2, correspondence, config: DenseConfig, say, timings: dict) -> tuple:
    """``(seed, seeds, samples, bases)``: the ZoomOut samples and bases of both shapes, the
    usable seeds and the one chosen (see :func:`_chosen_seed`)."""
    for shape in (shape_1, shape_2):
        if not hasattr(shape, "mesh_index"):
            raise DarcyanError(f"{shape.name}: a dense map works on prepared shapes, not on a description "
                               f"(darcyan.load_shape(path) or darcyan.prepare_shape(mesh) gives one)")
    t = time.perf_counter()
    samples = zoomout_samples(shape_1, shape_2, config)
    bases = (None, None)
    if config.method == "zoomout" or config.candidates > 1:
        say("basis")
        bases = dense_basis(shape_1, config), dense_basis(shape_2, config)
    timings["basis"] = time.perf_counter() - t
    t = time.perf_counter()
    say("landmarks")
    seeds = _seeds(shape_1, shape_2, correspondence, config, samples, bases)
    if not seeds:
        raise DarcyanError(f"{shape_1.name} -> {shape_2.name}: fewer than {MIN_LANDMARKS} consistent landmark "
                           f"matches, a dense map needs at least {MIN_LANDMARKS}")
    timings["landmarks"] = time.perf_counter() - t
    return _chosen_seed(seeds, config.seed_margin), seeds, samples, bases


@dataclass(frozen=True)
class _Seed:
    """One candidate matching turned into landmarks and their coordinates on both shapes
    (``(n, c)``), with the mean difference of the point signatures between source points and
    their images under a short ZoomOut from it (``signature``, lower is better; 0 when the
    matching has no alternatives)."""

    rank: int
    source: np.ndarray
    target: np.ndarray
    fields_1: np.ndarray
    fields_2: np.ndarray
    turns_1: np.ndarray
    turns_2: np.ndarray
    coords_1: np.ndarray
    coords_2: np.ndarray
    signature: float


def _chosen_seed(seeds: list, margin: float) -> _Seed:
    """The seed :func:`chosen_seed` picks by the seeds' signature scores."""
    return seeds[chosen_seed([s.signature for s in seeds], margin)]


def chosen_seed(scores: list, margin: float) -> int:
    """Index of the seed that seeds the map, given each usable seed's signature score (the
    sparse matching's first, when usable): the lowest score, unless it beats the first by less
    than ``margin`` (relative): then the first."""
    best = min(range(len(scores)), key=lambda i: scores[i])
    return best if scores[best] < (1.0 - margin) * scores[0] else 0


def _seeds(shape_1, shape_2, correspondence, config: DenseConfig, samples: tuple, bases: tuple) -> list:
    """The usable seeds among the correspondence and its first ``config.candidates - 1``
    alternatives (``correspondence.alternatives``, the other matchings the sparse stage
    weighed). With several, each seeds a short ZoomOut (``config.seed_basis`` eigenfunctions,
    ``config.seed_samples`` of the samples) scored by how well its map keeps the shapes'
    :func:`point_signature`: a seed of mirrored landmarks yields a map that keeps their
    orientation only by turning the body round (front onto back), which no landmark coordinate
    sees and the curvature of a face or a chest does. A matching whose consistent landmarks are
    those of an earlier one is left out."""
    matchings = [correspondence] + list(getattr(correspondence, "alternatives", ()))[:max(config.candidates - 1, 0)]
    fields = ({}, {})
    seeds = []
    seen = set()
    scoring = None
    for rank, matching in enumerate(matchings):
        landmarks = _landmarks(shape_1, shape_2, matching, config, fields)
        if landmarks is None:
            continue
        # Matchings that differ only in matches the consistency test drops are one seed (the
        # same map): counted twice, a seed would be its own runner-up and never "clear".
        pairs = tuple(sorted(zip(landmarks[0].tolist(), landmarks[1].tolist())))
        if pairs in seen:
            continue
        seen.add(pairs)
        coords_1, coords_2 = landmarks[-2:]
        score = 0.0
        if len(matchings) > 1:
            if scoring is None:
                scoring = _SeedScoring(shape_1, shape_2, config, samples, bases)
            score = scoring.score(coords_1, coords_2)
        seeds.append(_Seed(rank, *landmarks, score))
    return seeds


def _landmarks(shape_1, shape_2, matching, config: DenseConfig, fields: tuple) -> tuple | None:
    """``(source, target, fields_1, fields_2, turns_1, turns_2, coords_1, coords_2)`` of one
    matching's consistent landmarks (``None`` below :data:`MIN_LANDMARKS`): their pairs, the
    distances to them ``(n, k)``, their :func:`orientation_coordinates` and the landmark
    coordinates, the distances beside the turns weighed by ``orientation_weight``."""
    src, tgt, fields_1, fields_2 = _landmark_pairs(shape_1, shape_2, matching, config, fields)
    if len(src) < MIN_LANDMARKS:
        return None
    turns_1, turns_2 = orientation_coordinates(shape_1, fields_1), orientation_coordinates(shape_2, fields_2)
    coords_1, coords_2 = fields_1, fields_2
    if config.orientation_weight > 0:
        coords_1 = np.hstack([fields_1, config.orientation_weight * turns_1])
        coords_2 = np.hstack([fields_2, config.orientation_weight * turns_2])
    return src, tgt, fields_1, fields_2, turns_1, turns_2, coords_1, coords_2


def landmark_coordinates(shape_1, shape_2, matching, config: DenseConfig = DenseConfig()) -> tuple:
    """``(coords_1 (n1, c), coords_2 (n2, c))``: the landmark coordinates that a dense map seeded
    by ``matching`` (source_vertex, target_vertex in input numbering) uses beside the spectral
    terms (see :func:`map_embeddings`), in prepared numbering.

    Raises:
        DarcyanError: when ``matching`` has fewer than :data:`MIN_LANDMARKS` consistent matches.
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    landmarks = _landmarks(shape_1, shape_2, matching, config, ({}, {}))
    if landmarks is None:
        raise DarcyanError(f"{shape_1.name} -> {shape_2.name}: fewer than {MIN_LANDMARKS} consistent landmark "
                           f"matches")
    return landmarks[-2:]


class _SeedScoring:
    """What scoring a seed needs, built once per pair: ``seed_samples`` of the ZoomOut samples
    (:func:`seed_subset`), the bases there and the point signatures."""

    def __init__(self, shape_1, shape_2, config: DenseConfig, samples: tuple, bases: tuple):
        size = min(config.seed_basis, config.basis_size)
        self.config = dataclasses.replace(config, basis_size=size, basis_start=min(config.basis_start, size),
                                          basis_margin=0)
        self.points = []
        for shape, sample in zip((shape_1, shape_2), samples):
            self.points.append(seed_subset(shape, sample, config.seed_samples, config))
        self.bases = [basis[points, :self.config.basis_size] for basis, points in zip(bases, self.points)]
        self.signatures = [point_signature(shape, config)[points] for shape, points in zip((shape_1, shape_2),
                                                                                          self.points)]

    def score(self, coords_1: np.ndarray, coords_2: np.ndarray) -> float:
        (p_1, p_2), (b_1, b_2) = self.points, self.bases
        f_1, f_2 = coords_1[p_1], coords_2[p_2]
        c_12, c_21 = zoomout(b_1, b_2, nearest_rows(f_2, f_1), nearest_rows(f_1, f_2), self.config, f_1, f_2)
        q, r = map_embeddings(b_1, b_2, c_12, c_21, self.config, f_1, f_2)
        return float(np.abs(self.signatures[0] - self.signatures[1][nearest_rows(r, q)]).mean())


def point_signature(shape, config: DenseConfig) -> np.ndarray:
    """``(n, len(config.signature_lengths))`` the shape's mean curvature diffused over each of
    ``config.signature_lengths`` (:func:`darcyan.method.symmetry.curvature_signature`: intrinsic
    enough to survive a change of pose, different on the front and the back of a body), on the
    coarse proxy of a large mesh."""
    from ..config import DarcyanConfig
    from ..method.symmetry import shape_signature

    describe = DarcyanConfig()  # the describe stage's curvature smoothing and diffusion steps

    def compute():
        proxy = shape.proxy(config.basis_proxy_vertices) if config.basis_proxy_vertices > 0 else None
        return shape_signature(shape, proxy, config.signature_lengths, describe.heat.diffusion_steps,
                               describe.curvature_smoothing)

    # once per shape: --verify and the dense map, or several dense variants, score seeds alike
    return shape.derived(("point signature", config.signature_lengths, config.basis_proxy_vertices), compute)


def signature_coordinates(shape_1, shape_2, config: DenseConfig, sample_1: np.ndarray,
                          sample_2: np.ndarray) -> tuple:
    """``(coarse_1 (s_1, c), coarse_2 (s_2, c))``: the :func:`point_signature` at the samples,
    each length divided by its standard deviation over both shapes' vertices and weighed by
    ``config.signature_weight`` (``(None, None)`` at weight 0): the coordinates that join the
    coarse ZoomOut steps (:func:`zoomout`)."""
    if config.signature_weight <= 0:
        return None, None
    s_1, s_2 = point_signature(shape_1, config), point_signature(shape_2, config)
    scale = np.concatenate([s_1, s_2]).std(axis=0)
    scale[scale == 0] = 1.0  # a constant signature (a sphere) tells nothing: left as it is
    weight = config.signature_weight / scale
    return weight * s_1[sample_1], weight * s_2[sample_2]


def signature_turn_coordinates(shape_1, shape_2, config: DenseConfig, fields_1: np.ndarray,
                               fields_2: np.ndarray) -> tuple:
    """``(turns_1 (n1, k l), turns_2 (n2, k l))``: at every vertex, the sine of the turn from the
    gradient of the distance to each of the k landmarks (``fields_i (n_i, k)``) to the gradient
    of each of the l lengths of the :func:`point_signature`, about the outward normal
    (:func:`orientation_coordinates`), times ``config.signature_turns`` (``(None, None)`` at
    weight 0). An isometry keeps them and a reflection flips them, like the turns between
    landmarks; unlike those, they do not vanish along a limb, where the directions to all the
    landmarks run along it and only the curvature tells one side of it from another."""
    if config.signature_turns <= 0:
        return None, None
    return tuple(config.signature_turns * orientation_coordinates(shape, fields, point_signature(shape, config))
                 for shape, fields in ((shape_1, fields_1), (shape_2, fields_2)))


def map_check(shape_1, local: np.ndarray, distances_1, distances_2, turns_1, turns_2) -> dict:
    """How far a map ``local (n1,)`` (prepared numbering) keeps what its landmarks say:
    ``orientation``, the area-weighted correlation of the :func:`orientation_coordinates` at each
    source vertex and at its image (1: kept everywhere, -1: a mirror image); ``distortion``, the
    area-weighted mean change of the geodesic distances to the landmarks from a vertex to its
    image (sqrt(area) units)."""
    area = shape_1.vertex_areas / shape_1.vertex_areas.sum()
    a, b = turns_1, turns_2[local]
    a, b = a - area @ a, b - area @ b
    covariance = (area @ (a * b)).sum()
    scale = np.sqrt((area @ (a * a)).sum() * (area @ (b * b)).sum())
    orientation = float(covariance / scale) if scale > 0 else 0.0
    distortion = float(area @ np.abs(distances_1 - distances_2[local]).mean(axis=1))
    return {"orientation": orientation, "distortion": distortion}


def dense_map_to_csv(target: np.ndarray) -> str:
    """CSV ``source_vertex,target_vertex``, one row per source vertex (0-based, input numbering)."""
    lines = ["source_vertex,target_vertex"] + [f"{s},{t}" for s, t in enumerate(np.asarray(target).tolist())]
    return "\n".join(lines) + "\n"
