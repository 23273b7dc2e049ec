"""Landmarks: the sparse matches a dense map keeps, and the coordinates they give every vertex.

Sparse matches may be wrong (symmetric flips, wrong extremities): by default only the largest
set of matches whose pairwise geodesic distances agree on both shapes is kept
(:func:`consistent_landmarks`). Each vertex is then described by its fast-marching distances to
the landmarks of its shape (``(n, k)``, O(V k) memory), which a near-isometry keeps, and by the
turns between those distances' gradients (:func:`orientation_coordinates`), which a reflection
flips: together the coordinates of the first maps and of the landmark term of every ZoomOut
step (:func:`landmark_coordinates`).
"""

from __future__ import annotations

import numpy as np

from ..errors import DarcyanError
from .config import DenseConfig

MIN_LANDMARKS = 3
# The default of consistent_landmarks' exhaustive limit (DenseConfig.exhaustive_landmarks).
MAX_EXHAUSTIVE_LANDMARKS = DenseConfig().exhaustive_landmarks
FACE_BLOCK = 32768  # faces per block of the orientation coordinates' products (memory, not results)


def consistent_landmarks(dist_1: np.ndarray, dist_2: np.ndarray, relative: float, floor: float,
                         cost: np.ndarray | None = None, exhaustive: int = MAX_EXHAUSTIVE_LANDMARKS) -> np.ndarray:
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
        (exhaustive search up to ``exhaustive`` matches; above, the match
        with the most disagreements is dropped until all agree).
    """
    k = len(dist_1)
    if k == 0:
        return np.zeros(0, np.int64)
    distortion = np.abs(dist_1 - dist_2)
    agree = distortion <= relative * np.maximum(dist_1, dist_2) + floor
    np.fill_diagonal(agree, True)
    if k > exhaustive:
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


def distance_fields(shape, known: dict, vertices) -> np.ndarray:
    """``(n, len(vertices))`` the fast-marching distances from each of ``vertices`` (prepared
    numbering), read from ``known`` (``{vertex: (n,) distance}``) and kept there: a vertex's field
    is computed once per pair, whichever seed or start asks for it; those the shape keeps (its
    feature points', :func:`~darcyan.dense.maps.shape_operators`) are read from it."""
    kept = getattr(shape, "known_distance_field", lambda vertex: None)
    for v in vertices:
        if int(v) not in known:
            field = kept(int(v))
            known[int(v)] = shape.solver.distance(int(v)) if field is None else field
    return np.stack([known[int(v)] for v in vertices], axis=1) if len(vertices) else np.zeros((shape.mesh.n_vertices, 0))


def _landmark_pairs(shape_1, shape_2, correspondence, config: DenseConfig, fields: tuple | None = None):
    """Landmark pairs in local numbering and their distance fields ``(n, k)`` on both shapes
    (``fields``: one ``{vertex: (n,) distance}`` per shape, read and filled in)."""
    fields = ({}, {}) if fields is None else fields
    src = shape_1.mesh_index(correspondence.source_vertex)
    tgt = shape_2.mesh_index(correspondence.target_vertex)
    cost = np.asarray(getattr(correspondence, "distance", np.zeros(len(src))), dtype=np.float64)
    ok = (src >= 0) & (tgt >= 0)
    src, tgt, cost = src[ok], tgt[ok], cost[ok]

    fields_1, fields_2 = distance_fields(shape_1, fields[0], src), distance_fields(shape_2, fields[1], tgt)
    if config.landmarks == "consistent" and len(src):
        finite = np.where(np.isfinite(cost), cost, 0.0)
        scale = finite.max() if finite.max() > 0 else 1.0
        keep = consistent_landmarks(fields_1[src], fields_2[tgt], config.consistency, config.consistency_floor,
                                    cost=finite / scale * config.landmark_tie_weight, exhaustive=config.exhaustive_landmarks)
        src, tgt, fields_1, fields_2 = src[keep], tgt[keep], fields_1[:, keep], fields_2[:, keep]
    return src, tgt, fields_1, fields_2


def landmark_set(shape_1, shape_2, matching, config: DenseConfig, fields: tuple,
                 turns: tuple | None = None) -> tuple | None:
    """``(source, target, fields_1, fields_2, turns_1, turns_2, coords_1, coords_2)`` of one
    matching's consistent landmarks (``None`` below :data:`MIN_LANDMARKS`): their pairs, the
    distances to them ``(n, k)``, their :func:`orientation_coordinates` and the landmark
    coordinates, the distances beside the turns weighed by ``orientation_weight``. ``turns``:
    one ``{(a, b): (n,) column}`` per shape, the turns' columns read and filled in (the
    matchings of one pair share most of their landmarks)."""
    src, tgt, fields_1, fields_2 = _landmark_pairs(shape_1, shape_2, matching, config, fields)
    if len(src) < MIN_LANDMARKS:
        return None
    known_1, known_2 = (None, None) if turns is None else turns
    turns_1 = orientation_coordinates(shape_1, fields_1, vertices=src, known=known_1)
    turns_2 = orientation_coordinates(shape_2, fields_2, vertices=tgt, known=known_2)
    return (src, tgt, fields_1, fields_2, turns_1, turns_2, coordinates_of(fields_1, turns_1, config),
            coordinates_of(fields_2, turns_2, config))


def coordinates_of(fields: np.ndarray, turns: np.ndarray, config: DenseConfig) -> np.ndarray:
    """``(n, k [+ k (k - 1) / 2])`` the landmark coordinates: the distances to the landmarks
    ``fields (n, k)`` beside their turns ``turns (n, k (k - 1) / 2)``
    (:func:`orientation_coordinates`) weighed by ``config.orientation_weight`` (none at 0)."""
    if config.orientation_weight <= 0:
        return fields
    return np.hstack([fields, config.orientation_weight * turns])


def landmark_coordinates(shape_1, shape_2, matching, config: DenseConfig = DenseConfig()) -> tuple:
    """``(coords_1 (n1, c), coords_2 (n2, c))``: the landmark coordinates that a dense map seeded
    by ``matching`` (source_vertex, target_vertex in input numbering) uses beside the spectral
    terms (see :func:`~darcyan.dense.zoomout.map_embeddings`), in prepared numbering.

    Raises:
        DarcyanError: when ``matching`` has fewer than :data:`MIN_LANDMARKS` consistent matches.
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    landmarks = landmark_set(shape_1, shape_2, matching, config, ({}, {}))
    if landmarks is None:
        raise DarcyanError(f"{shape_1.name} -> {shape_2.name}: fewer than {MIN_LANDMARKS} consistent landmark "
                           f"matches")
    return landmarks[-2:]


def orientation_coordinates(shape, fields: np.ndarray, others: np.ndarray | None = None,
                            vertices: np.ndarray | None = None, known: dict | None = None) -> np.ndarray:
    """``(n, k (k - 1) / 2)``: at each vertex, for each two landmarks a < b, the sine of the turn
    from the gradient of the distance to a to that of the distance to b, about the outward normal
    (``fields (n, k)``: the distances). Distances to a few extremities cannot tell the front of a
    body from its back, nor left from right where the extremities sit symmetrically; these
    signs can: a reflection flips every one of them, an isometry keeps them. Averaged by area
    from the faces to the vertices. With ``others (n, j)``: ``(n, k j)``, the turn from each
    field's gradient to each of the others' instead (column ``a j + b``: field a to other b).

    ``vertices (k,)`` (the landmarks whose distances ``fields`` are) with ``known`` (``{(a, b):
    (n,) column}``, for this shape): each pair's column is read there, or made and kept there (the
    turn from b to a is the turn from a to b negated: the same numbers as made afresh, a zero's
    sign aside): the seeds of one pair share most of their landmarks (without ``others`` only)."""
    if others is None and vertices is not None and known is not None:
        return _known_turns(shape, fields, [int(v) for v in vertices], known)
    k = fields.shape[1]
    if others is None:
        a, b = np.triu_indices(k, k=1)
    else:
        a, b = np.repeat(np.arange(k), others.shape[1]), k + np.tile(np.arange(others.shape[1]), k)
        fields = np.hstack([fields, others])
    return _turns(shape, fields, a, b)


def _known_turns(shape, fields: np.ndarray, vertices: list, known: dict) -> np.ndarray:
    """:func:`orientation_coordinates` of ``fields`` (the distances to ``vertices``), its columns
    read from ``known`` or made and kept there."""
    pairs = list(zip(*np.triu_indices(len(vertices), k=1)))
    missing = [(i, j) for i, j in pairs if (vertices[i], vertices[j]) not in known
               and (vertices[j], vertices[i]) not in known]
    if missing:
        made = _turns(shape, fields, np.array([i for i, _ in missing], dtype=np.int64),
                      np.array([j for _, j in missing], dtype=np.int64))
        for column, (i, j) in enumerate(missing):
            known[(vertices[i], vertices[j])] = made[:, column]
    out = np.empty((shape.mesh.n_vertices, len(pairs)))
    for column, (i, j) in enumerate(pairs):
        key = (vertices[i], vertices[j])
        out[:, column] = known[key] if key in known else -known[key[::-1]]
    return out


def _turns(shape, fields: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(n, len(a))`` the turn from the gradient of ``fields[:, a[p]]`` to that of
    ``fields[:, b[p]]`` for each p (:func:`orientation_coordinates`); each column depends on its
    two fields alone, bit for bit."""
    from ..geometry.operators import face_gradients

    mesh = shape.mesh
    grads = face_gradients(mesh, fields, getattr(shape, "gradient", None))  # (m, 3, k [+ j])
    unit, corners, weight = _face_frame(shape)
    norm = np.linalg.norm(grads, axis=1)  # (m, k)
    sine = np.empty((len(grads), len(a)))  # (m, pairs)
    # By blocks of faces: the (m, pairs) operands below, a dozen of them, took 0.7 GB at 420k faces.
    for start in range(0, len(grads), FACE_BLOCK):
        faces = slice(start, start + FACE_BLOCK)
        g = grads[faces]
        ga, gb = [g[:, i, a] for i in range(3)], [g[:, i, b] for i in range(3)]  # (block, pairs) each
        # The cross product of each pair, with numpy.cross's operations in its order (the same bits,
        # without its copies of the (m, 3, pairs) operands: 40% of this function's time at 52k).
        c0 = ga[1] * gb[2]
        c0 -= ga[2] * gb[1]
        c1 = ga[2] * gb[0]
        c1 -= ga[0] * gb[2]
        c2 = ga[0] * gb[1]
        c2 -= ga[1] * gb[0]
        cross = np.stack([c0, c1, c2], axis=1)  # (block, 3, pairs)
        sine[faces] = np.einsum("mi,mip->mp", unit[faces], cross) / np.maximum(norm[faces][:, a] * norm[faces][:, b],
                                                                               1e-12)
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
