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
:func:`consistent_landmarks`).

Memory stays O(V): the functional maps are k x k, nearest neighbours are searched with a k-d
tree (few dimensions) or by chunks of source rows (spectral dimensions).

:func:`evaluate_dense` scores a dense map against ground truth on a fixed random sample of
source vertices with the standard geodesic error (see :mod:`darcyan.eval.metrics`);
:func:`pyfm_own_map` is pyFM's own pipeline without darcyan's landmarks, the baseline of
``darcyan bench --dense``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError, DarcyanError
from ..geometry.knn import nearest_rows
from ..geometry.mesh import Mesh
from ..geometry.sampling import sample_vertices
from .pyfm import DENSE_PIPELINE, pyfm_point_map

LANDMARK_MODES = ("consistent", "all")
METHODS = ("zoomout", "pyfm")
UNMAPPED = -1  # source vertices the analysis left out (outside the largest component)
# Shift of the shift-invert eigen solver (just below the zero eigenvalue of the Laplacian).
EIGSH_SHIFT = -1e-8
MIN_LANDMARKS = 3
# Consistent landmark sets: exact maximum-clique search up to this many matches, greedy above.
MAX_EXHAUSTIVE_LANDMARKS = 24
# Weight of the (normalized) descriptor distances when breaking ties between landmark sets.
TIE_BREAK_WEIGHT = 1e-3


@dataclass(frozen=True)
class DenseConfig:
    """Parameters of :func:`dense_map`.

    Attributes:
        method: ``"zoomout"``: geodesic landmark coordinates, then the bijective ZoomOut below;
            ``"pyfm"``: pyFM's functional map with the landmarks as descriptors, then its ZoomOut
            (``pip install 'darcyan[pyfm]'``; slower, the ``basis_*``, ``zoomout_samples``,
            ``bijectivity`` and ``orthogonality`` fields do not apply).
        landmarks: ``"consistent"``: keep the largest set of matches whose pairwise geodesic
            distances agree on both shapes (see ``consistency``); ``"all"``: every match.
        consistency: two matches agree when their geodesic distances on the two shapes differ by
            at most this fraction of the larger one (plus ``consistency_floor``).
        consistency_floor: absolute slack of that test, in sqrt(area) units.
        basis_start: size of the first functional map of ZoomOut.
        basis_size: size of the last one (Laplace-Beltrami eigenfunctions computed per shape).
        basis_step: growth of the basis per ZoomOut iteration.
        zoomout_samples: ZoomOut iterates on this many random surface samples of each shape
            (0 = on all vertices); the final map is always computed for every source vertex.
        bijectivity, orthogonality: weights of the bijectivity (``C_12 C_21 ~ I``) and
            orthogonality (area preservation) terms beside the coupling term in ZoomOut's
            nearest-neighbour searches (0 and 0 = plain ZoomOut).
        landmark_weight: weight of the landmark coordinates (geodesic distances to the landmarks
            and, with ``orientation_weight``, their turns) beside the spectral terms in every
            ZoomOut step and in the final map: the landmarks hold the map throughout, not only
            at its start (3: ``docs/parameters.md``).
        orientation_weight: weight of the :func:`orientation_coordinates` beside the geodesic
            distances to the landmarks in the first map and in the landmark term (0: distances
            only). Distances to five extremities of a human cannot tell its front from its back:
            on FAUST, maps without them were flipped over a third of the body in 12 of 40 pairs.
        seed: seed of the surface samples.
    """

    method: str = "zoomout"
    landmarks: str = "consistent"
    consistency: float = 0.3
    consistency_floor: float = 0.02
    basis_start: int = 10
    basis_size: int = 100
    basis_step: int = 4
    zoomout_samples: int = 3000
    bijectivity: float = 1.0
    orthogonality: float = 1.0
    landmark_weight: float = 3.0
    orientation_weight: float = 1.0
    seed: int = 0

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"dense: method must be one of {METHODS}, got {self.method!r}")
        if self.landmarks not in LANDMARK_MODES:
            raise ConfigError(f"dense: landmarks must be one of {LANDMARK_MODES}, got {self.landmarks!r}")
        for name in ("basis_start", "basis_size", "basis_step"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"dense: {name} must be a positive integer, got {value!r}")
        if self.basis_start > self.basis_size:
            raise ConfigError(f"dense: basis_start ({self.basis_start}) exceeds basis_size ({self.basis_size})")
        if not isinstance(self.zoomout_samples, int) or self.zoomout_samples < 0:
            raise ConfigError(f"dense: zoomout_samples must be a non-negative integer, got {self.zoomout_samples!r}")
        for name in ("consistency", "consistency_floor", "bijectivity", "orthogonality", "landmark_weight",
                     "orientation_weight"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value >= 0):
                raise ConfigError(f"dense: {name} must be non-negative, got {value!r}")


@dataclass
class DenseMap:
    """A dense map and how it was made.

    Attributes:
        target: ``(n1,) int64``, for each source vertex (input numbering) a target vertex (input
            numbering), :data:`UNMAPPED` for source vertices outside the analysed mesh.
        landmarks: ``(k, 2) int64`` (source, target) landmark pairs used, input numbering.
        timings: seconds per stage.
        check: what :func:`map_check` says of the map (``orientation`` in [-1, 1], ``distortion``).
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


def _surface_sample(shape, config: DenseConfig) -> np.ndarray:
    """``(zoomout_samples,)`` vertices drawn by area (seed ``config.seed``), sorted."""
    return np.sort(sample_vertices(shape.mesh.n_vertices, config.zoomout_samples, np.random.default_rng(config.seed),
                                   shape.vertex_areas))


def _basis(shape, size: int) -> np.ndarray:
    """``(n, size)`` the shape's Laplace-Beltrami eigenvectors (built once per shape)."""
    return shape.spectrum(min(size, shape.mesh.n_vertices - 1), shift=EIGSH_SHIFT).vectors


# ----------------------------------------------------------------------------------------------
# The dense map


def _landmark_pairs(shape_1, shape_2, correspondence, config: DenseConfig):
    """Landmark pairs in local numbering and their distance fields ``(n, k)`` on both shapes."""
    src = shape_1.mesh_index(correspondence.source_vertex)
    tgt = shape_2.mesh_index(correspondence.target_vertex)
    cost = np.asarray(getattr(correspondence, "distance", np.zeros(len(src))), dtype=np.float64)
    ok = (src >= 0) & (tgt >= 0)
    src, tgt, cost = src[ok], tgt[ok], cost[ok]
    fields_1 = np.stack([shape_1.solver.distance(int(v)) for v in src], axis=1) if len(src) else np.zeros((shape_1.mesh.n_vertices, 0))
    fields_2 = np.stack([shape_2.solver.distance(int(v)) for v in tgt], axis=1) if len(tgt) else np.zeros((shape_2.mesh.n_vertices, 0))
    if config.landmarks == "consistent" and len(src):
        finite = np.where(np.isfinite(cost), cost, 0.0)
        scale = finite.max() if finite.max() > 0 else 1.0
        keep = consistent_landmarks(fields_1[src], fields_2[tgt], config.consistency, config.consistency_floor,
                                    cost=finite / scale * TIE_BREAK_WEIGHT)
        src, tgt, fields_1, fields_2 = src[keep], tgt[keep], fields_1[:, keep], fields_2[:, keep]
    return src, tgt, fields_1, fields_2


def orientation_coordinates(shape, fields: np.ndarray) -> np.ndarray:
    """``(n, k (k - 1) / 2)``: at each vertex, for each two landmarks a < b, the sine of the turn
    from the gradient of the distance to a to that of the distance to b, about the outward normal
    (``fields (n, k)``: the distances). Distances to a few extremities cannot tell the front of a
    body from its back, nor left from right where the extremities sit symmetrically; these
    signs can: a reflection flips every one of them, an isometry keeps them. Averaged by area
    from the faces to the vertices."""
    from ..geometry.operators import face_gradients

    mesh = shape.mesh
    k = fields.shape[1]
    a, b = np.triu_indices(k, k=1)
    grads = face_gradients(mesh, fields)  # (m, 3, k)
    v, f = mesh.vertices, mesh.faces
    normal = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(normal, axis=1)
    unit = normal / np.maximum(area, 1e-300)[:, None]
    norm = np.linalg.norm(grads, axis=1)  # (m, k)
    cross = np.cross(grads[:, :, a], grads[:, :, b], axis=1)  # (m, 3, pairs)
    sine = np.einsum("mi,mip->mp", unit, cross) / np.maximum(norm[:, a] * norm[:, b], 1e-12)
    weight = np.zeros(mesh.n_vertices)
    out = np.zeros((mesh.n_vertices, len(a)))
    for corner in range(3):
        np.add.at(out, f[:, corner], sine * area[:, None])
        np.add.at(weight, f[:, corner], area)
    return out / np.maximum(weight, 1e-300)[:, None]


def _fit_map(basis_from: np.ndarray, basis_to_mapped: np.ndarray) -> np.ndarray:
    """``(k, k)`` least-squares ``C`` with ``basis_from @ C ~ basis_to_mapped`` (both ``(s, k)``)."""
    return np.linalg.lstsq(basis_from, basis_to_mapped, rcond=None)[0]


def _embeddings(b_a: np.ndarray, b_b: np.ndarray, c_ab: np.ndarray, c_ba: np.ndarray,
                config: "DenseConfig", f_a: np.ndarray | None = None,
                f_b: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Query rows on shape a and reference rows on shape b whose nearest neighbours give the map
    a -> b minimizing coupling, bijectivity and orthogonality residuals.

    ``c_ab (k, k)`` pulls b's coefficients back to a (``b_a C_ab ~ b_b[map]``), ``c_ba`` the
    reverse. Coupling: ``b_b[j] ~ b_a[i] C_ab``; bijectivity (``C_ab C_ba ~ I``):
    ``b_b[j] C_ba ~ b_a[i]``; orthogonality (``C_ab C_ab^T ~ I``): ``b_b[j] C_ab^T ~ b_a[i]``.
    """
    queries, references = [b_a @ c_ab], [b_b]
    if config.bijectivity > 0:
        queries.append(config.bijectivity * b_a)
        references.append(config.bijectivity * (b_b @ c_ba))
    if config.orthogonality > 0:
        queries.append(config.orthogonality * b_a)
        references.append(config.orthogonality * (b_b @ c_ab.T))
    if config.landmark_weight > 0 and f_a is not None:
        queries.append(config.landmark_weight * f_a)
        references.append(config.landmark_weight * f_b)
    return np.hstack(queries), np.hstack(references)


def zoomout(basis_1: np.ndarray, basis_2: np.ndarray, map_12: np.ndarray, map_21: np.ndarray,
            config: "DenseConfig", fields_1: np.ndarray | None = None,
            fields_2: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bijective ZoomOut on (sampled) vertices.

    ``basis_i (s_i, K)``: Laplace-Beltrami eigenfunctions at the vertices taking part;
    ``map_12 (s_1,)`` indices of rows of ``basis_2`` (the current map 1 -> 2) and ``map_21
    (s_2,)`` the reverse. For k from ``config.basis_start`` to ``config.basis_size`` by
    ``config.basis_step``: fit the k x k functional maps of both directions to the current
    vertex maps (least squares), then update both vertex maps by nearest neighbours of the
    embeddings of :func:`_embeddings` (ZoomOut, Melzi et al. 2019, with the bijectivity and
    orthogonality terms of Ren et al., *Discrete Optimization for Shape Matching*, 2021).

    Returns ``c_12, c_21`` (``(k, k)``, the last size): ``basis_1 @ c_12 ~ basis_2[map_12]``.
    """
    largest = min(config.basis_size, basis_1.shape[1], basis_2.shape[1])
    sizes = list(range(min(config.basis_start, largest), largest + 1, config.basis_step))
    if sizes[-1] != largest:
        sizes.append(largest)
    for i, k in enumerate(sizes):
        b1, b2 = basis_1[:, :k], basis_2[:, :k]
        c_12, c_21 = _fit_map(b1, b2[map_12]), _fit_map(b2, b1[map_21])
        if i < len(sizes) - 1:
            q, r = _embeddings(b1, b2, c_12, c_21, config, fields_1, fields_2)
            map_12 = nearest_rows(r, q)
            q, r = _embeddings(b2, b1, c_21, c_12, config, fields_2, fields_1)
            map_21 = nearest_rows(r, q)
    return c_12, c_21


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
        DarcyanError: when a shape is a description only, or fewer than :data:`MIN_LANDMARKS`
            usable landmark pairs remain.
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    for shape in (shape_1, shape_2):
        if not hasattr(shape, "mesh_index"):
            raise DarcyanError(f"{shape.name}: a dense map works on prepared shapes, not on a description "
                               f"(darcyan.load_shape(path) or darcyan.prepare_shape(mesh) gives one)")
    say = progress or (lambda stage: None)
    timings = {}
    t = time.perf_counter()
    say("landmarks")
    src, tgt, fields_1, fields_2 = _landmark_pairs(shape_1, shape_2, correspondence, config)
    if len(src) < MIN_LANDMARKS:
        raise DarcyanError(f"{shape_1.name} -> {shape_2.name}: only {len(src)} consistent landmark match(es), "
                           f"a dense map needs at least {MIN_LANDMARKS}")
    turns_1, turns_2 = orientation_coordinates(shape_1, fields_1), orientation_coordinates(shape_2, fields_2)
    # Landmark coordinates: the distances, and their turns unless weighed 0.
    coords_1, coords_2 = fields_1, fields_2
    if config.orientation_weight > 0:
        coords_1 = np.hstack([fields_1, config.orientation_weight * turns_1])
        coords_2 = np.hstack([fields_2, config.orientation_weight * turns_2])
    if config.method == "pyfm":
        timings["landmarks"] = time.perf_counter() - t
        t = time.perf_counter()
        say("pyfm")
        local = pyfm_point_map(shape_1.mesh, shape_2.mesh, DENSE_PIPELINE, src, tgt)
        timings["pyfm"] = time.perf_counter() - t
    else:
        map_12 = nearest_rows(coords_2, coords_1)  # (n1,) first maps by the landmark coordinates
        map_21 = nearest_rows(coords_1, coords_2)  # (n2,)
        timings["landmarks"] = time.perf_counter() - t
        t = time.perf_counter()
        say("basis")
        basis_1 = _basis(shape_1, config.basis_size)
        basis_2 = _basis(shape_2, config.basis_size)
        timings["basis"] = time.perf_counter() - t
        t = time.perf_counter()
        say("zoomout")
        mesh_1, mesh_2 = shape_1.mesh, shape_2.mesh
        if 0 < config.zoomout_samples < max(mesh_1.n_vertices, mesh_2.n_vertices):
            sample_1 = _surface_sample(shape_1, config)
            sample_2 = _surface_sample(shape_2, config)
            # The maps restricted to the samples: each image snapped to the nearest sample.
            sub_12 = nearest_rows(mesh_2.vertices[sample_2], mesh_2.vertices[map_12[sample_1]])
            sub_21 = nearest_rows(mesh_1.vertices[sample_1], mesh_1.vertices[map_21[sample_2]])
        else:
            sample_1, sample_2 = np.arange(mesh_1.n_vertices), np.arange(mesh_2.n_vertices)
            sub_12, sub_21 = map_12, map_21
        c_12, c_21 = zoomout(basis_1[sample_1], basis_2[sample_2], sub_12, sub_21, config,
                             coords_1[sample_1], coords_2[sample_2])
        k = len(c_12)
        q, r = _embeddings(basis_1[:, :k], basis_2[:, :k], c_12, c_21, config, coords_1, coords_2)
        local = nearest_rows(r, q)
        timings["zoomout"] = time.perf_counter() - t
    target = np.full(shape_1.n_input_vertices, UNMAPPED, dtype=np.int64)
    on_mesh = shape_1.mesh_index(np.arange(shape_1.n_input_vertices))  # welded copies included
    target[on_mesh >= 0] = shape_2.mesh.input_index[local[on_mesh[on_mesh >= 0]]]
    landmarks = np.stack([shape_1.mesh.input_index[src], shape_2.mesh.input_index[tgt]], axis=1)
    check = map_check(shape_1, local, fields_1, fields_2, turns_1, turns_2)
    return DenseMap(target, landmarks, timings, check)


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
