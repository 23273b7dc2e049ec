"""A coarse stand-in of a large mesh for smooth, global fields.

The Average Geodesic Distance and the diffused curvature signature vary slowly over the
surface (they are smoothed over about 0.05-0.2 sqrt(area) on purpose), so computing them on a
mesh decimated to a few thousand vertices and interpolating back loses nothing that matters and
turns seconds into a fraction of one on 50k-vertex meshes. Everything local (curvature on the
grid, level curves, radial geodesics, feature positions) stays on the full mesh.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..config import Repairing
from ..errors import DarcyanError
from .geodesics import GeodesicSolver, interpolate
from .mesh import Mesh, local_index
from .repair import nonmanifold_vertices, prepare_mesh


class CoarseProxy:
    """A decimated copy of ``mesh`` and the map that carries its vertex fields back.

    Args:
        mesh: the full mesh (prepared).
        vertices: target vertex count of the copy.

    Attributes:
        mesh: the decimated mesh (same length units), ``solver`` its geodesic solver.
    """

    def __init__(self, full: Mesh, vertices: int):
        import fast_simplification

        reduction = 1.0 - vertices / full.n_vertices
        v, f, collapses = fast_simplification.simplify(full.vertices, full.faces, target_reduction=reduction,
                                                       agg=DECIMATION_AGGRESSIVENESS, return_collapses=True)
        f = np.asarray(f, dtype=np.int64)
        collapsed_into = _collapse_targets(full.faces, np.asarray(collapses, dtype=np.int64).reshape(-1, 2),
                                           full.n_vertices, len(v))
        for _ in range(CLEANUP_ROUNDS):  # dropping faces can leave new bow ties behind
            f = _drop_nonmanifold_faces(f)
            bow_ties = nonmanifold_vertices(Mesh(v, f))
            if not len(bow_ties):
                break
            f = f[~np.isin(f, bow_ties).any(axis=1)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a sliver component dropped by decimation is no news
            # Never welded: decimation merges vertices, it leaves no copies of one (none were
            # welded on any tosca-hires proxy), and the search would import scipy.spatial, 0.2 s.
            # Nor are holes closed, nor an open copy turned: decimation shrinks a model's openings
            # (the TOSCA eyes) to a few edges and its rims to fewer, and the copy must keep the
            # surface and the orientation of the mesh it stands for.
            self.mesh, _ = prepare_mesh(Mesh(v, f, name=f"{full.name} (decimated)"), repair=True,
                                        settings=Repairing(weld_tolerance=0.0, hole_edges=0,
                                                          outward_cap_share=0.0))
        self.solver = GeodesicSolver(self.mesh)
        self._faces, self._bary = self.solver.locate(full.vertices)
        on_copy = np.full(full.n_vertices, -1, dtype=np.int64)
        known = collapsed_into >= 0
        on_copy[known] = local_index(self.mesh, collapsed_into[known])
        self._keep_on_own_part(full.vertices, on_copy)

    def _keep_on_own_part(self, positions: np.ndarray, collapsed_into: np.ndarray) -> None:
        """Where two parts of the surface nearly touch (a hand held to the head, fingers side by
        side), the copy's closest point to a full vertex can lie on the other part. Each full
        vertex (``positions (n_full, 3)``) was collapsed into one vertex of the copy
        (``collapsed_into (n_full,)``, the copy's numbering, -1 where the copy lost it), on its
        own part: a closest point on a face with no corner in that vertex's one-ring is taken
        for one on another part (some are on the same part, where decimation moved the kept
        vertex far) and replaced by the closest point on the faces around that vertex.
        ``strays``: how many were replaced."""
        faces = self.mesh.faces
        known = np.flatnonzero(collapsed_into >= 0)
        target = collapsed_into[known]
        corners = faces[self._faces[known]]  # (k, 3)
        n = self.mesh.n_vertices
        ring, _ = self.mesh.edge_counts()  # the copy's edges as keys lo * n + hi
        pairs = np.minimum(target[:, None], corners) * n + np.maximum(target[:, None], corners)
        near = (corners == target[:, None]).any(axis=1) | np.isin(pairs, ring).any(axis=1)
        stray = known[~near]
        self.strays = len(stray)
        if not len(stray):
            return
        around = collapsed_into[stray]
        corner_of = faces.ravel()
        order = np.argsort(corner_of, kind="stable")
        start = np.searchsorted(corner_of[order], np.arange(n + 1))  # faces at vertex v: order[start[v]:start[v + 1]] // 3
        count = start[around + 1] - start[around]
        best = np.full(len(stray), np.inf)
        for j in range(int(count.max())):
            has = np.flatnonzero(count > j)
            face = order[start[around[has]] + j] // 3
            bary = closest_barycentric(positions[stray[has]], *(self.mesh.vertices[faces[face, i]] for i in range(3)))
            offset = interpolate(self.mesh, self.mesh.vertices, face, bary) - positions[stray[has]]
            gap = np.einsum("kd,kd->k", offset, offset)
            better = gap < best[has]
            best[has[better]] = gap[better]
            self._faces[stray[has[better]]] = face[better]
            self._bary[stray[has[better]]] = bary[better]

    def distance(self, vertex: int) -> np.ndarray:
        """``(n_full,)`` fast-marching distance on the copy from the point where the full mesh's
        ``vertex`` lies on it, read at every full vertex: within a few percent of the distance on
        the full mesh (decimation shortens and coarse fast marching lengthens paths a little)."""
        source = [(int(self._faces[vertex]), [float(b) for b in self._bary[vertex]])]
        return self.to_full(self.solver.distance_from_points(source))

    def nearest_vertices(self, vertices) -> np.ndarray:
        """``(k,) int64`` for each of the full mesh's ``vertices`` (its numbering), the copy's
        vertex nearest the point where it lies on the copy, among the corners of that point's face."""
        vertices = np.asarray(vertices, dtype=np.int64)
        corners = self.mesh.faces[self._faces[vertices]]  # (k, 3)
        positions = self.mesh.vertices[corners]  # (k, 3, 3)
        points = np.einsum("kc,kcd->kd", self._bary[vertices], positions)
        nearest = np.argmin(np.linalg.norm(positions - points[:, None, :], axis=2), axis=1)
        return corners[np.arange(len(vertices)), nearest].astype(np.int64)

    def to_full(self, values: np.ndarray) -> np.ndarray:
        """Per-vertex ``values`` of the copy ``(n_proxy, ...)`` interpolated at the full mesh's vertices."""
        return interpolate(self.mesh, values, self._faces, self._bary)

    def interpolation(self):
        """``(n_full, n_proxy)`` scipy CSR: what :meth:`to_full` does, as a matrix (each row the
        barycentric weights of a full vertex's point on the copy)."""
        import scipy.sparse as sp

        n_full = len(self._faces)
        rows = np.repeat(np.arange(n_full), 3)
        return sp.csr_matrix((self._bary.ravel(), (rows, self.mesh.faces[self._faces].ravel())),
                             shape=(n_full, self.mesh.n_vertices))

    def rows_on_demand(self, values: np.ndarray) -> "InterpolatedRows":
        """``values (n_proxy, k)`` read at the full mesh's vertices as :meth:`to_full` reads them,
        but row by row when indexed: an ``(n_full, k)`` array that is never held whole."""
        return InterpolatedRows(self, values)


class InterpolatedRows:
    """``(n_full, k)`` per-vertex values of a :class:`CoarseProxy` at the full mesh's vertices,
    interpolated when indexed, never held whole: ``rows[i]``, ``rows[sample]``, ``rows[a:b, :k]``
    and ``rows[:, :k]`` give numpy arrays, each row the bits :meth:`CoarseProxy.to_full` gives
    it (on a 210k-vertex mesh a basis of 130 functions is 218 MB held, a few MB read by blocks).
    ``np.asarray(rows)`` makes the whole array."""

    ndim = 2

    def __init__(self, proxy: CoarseProxy, values: np.ndarray):
        self.proxy, self.values = proxy, np.asarray(values)
        self.shape = (len(proxy._faces), self.values.shape[1])
        self.dtype = self.values.dtype

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key):
        rows, columns = key if isinstance(key, tuple) else (key, slice(None))
        single = np.ndim(rows) == 0 and not isinstance(rows, slice)
        rows = np.atleast_1d(np.arange(self.shape[0])[rows] if isinstance(rows, slice) else rows)
        out = interpolate(self.proxy.mesh, self.values[:, columns], self.proxy._faces[rows], self.proxy._bary[rows])
        return out[0] if single else out

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self[:, :]
        return out if dtype is None else out.astype(dtype)


def closest_barycentric(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``(k, 3)`` barycentric coordinates of the point of triangle ``(a[i], b[i], c[i])`` closest
    to ``points[i]`` (all ``(k, 3)``), by the regions of Ericson's *Real-Time Collision
    Detection* (5.1.5): a corner, a side or the inside."""
    ab, ac = b - a, c - a
    ap, bp, cp = points - a, points - b, points - c
    d1, d2 = np.einsum("kd,kd->k", ab, ap), np.einsum("kd,kd->k", ac, ap)
    d3, d4 = np.einsum("kd,kd->k", ab, bp), np.einsum("kd,kd->k", ac, bp)
    d5, d6 = np.einsum("kd,kd->k", ab, cp), np.einsum("kd,kd->k", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        on_ab = d1 / (d1 - d3)
        on_ac = d2 / (d2 - d6)
        on_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        total = va + vb + vc
        v, w = vb / total, vc / total
    regions = [(d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (vc <= 0) & (d1 >= 0) & (d3 <= 0),
               (d6 >= 0) & (d5 <= d6), (vb <= 0) & (d2 >= 0) & (d6 <= 0), (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)]
    zero, one = np.zeros_like(d1), np.ones_like(d1)
    choices = [np.stack(x, axis=1) for x in ((one, zero, zero), (zero, one, zero), (1 - on_ab, on_ab, zero),
                                               (zero, zero, one), (1 - on_ac, zero, on_ac),
                                               (zero, 1 - on_bc, on_bc))]
    inside = np.stack((1 - v - w, v, w), axis=1)
    out = inside
    for region, choice in zip(regions[::-1], choices[::-1]):  # the first region that holds wins
        out = np.where(region[:, None], choice, out)
    degenerate = ~np.isfinite(out).all(axis=1)  # a triangle of no area: its nearest corner
    if degenerate.any():
        corners = np.stack([a[degenerate], b[degenerate], c[degenerate]], axis=1)
        nearest = np.argmin(np.linalg.norm(corners - points[degenerate, None, :], axis=2), axis=1)
        out[degenerate] = np.eye(3)[nearest]
    return out


def _collapse_targets(faces: np.ndarray, collapses: np.ndarray, n_full: int, n_decimated: int) -> np.ndarray:
    """``(n_full,) int64``: the vertex of the decimated mesh (its ``n_decimated`` vertices, as
    ``fast_simplification.simplify`` numbers them) that each vertex of the full mesh was
    collapsed into, following ``collapses (c, 2)`` (``[kept, removed]`` in full numbering) to the
    end; -1 for the few that end on a vertex no face keeps (``replay_simplification`` sends
    those to a neighbour). Elsewhere what ``fast_simplification.replay_simplification`` gives,
    without replaying the decimation. All -1 (every vertex then keeps its closest point on the
    copy) when the collapses do not lead to ``n_decimated`` vertices or do not end."""
    into = np.arange(n_full)
    into[collapses[:, 1]] = collapses[:, 0]
    for _ in range(64):  # each vertex is removed once: follow the chains by pointer jumping
        further = into[into]
        if np.array_equal(further, into):
            break
        into = further
    else:  # a cycle: not collapses of one decimation
        return np.full(n_full, -1, dtype=np.int64)
    on_faces = into[faces]
    kept = (on_faces[:, 0] != on_faces[:, 1]) & (on_faces[:, 1] != on_faces[:, 2]) & (on_faces[:, 0] != on_faces[:, 2])
    survivors = np.unique(on_faces[kept])  # the decimated mesh keeps them in this order
    if len(survivors) != n_decimated:
        return np.full(len(into), -1, dtype=np.int64)
    position = np.minimum(np.searchsorted(survivors, into), len(survivors) - 1)
    return np.where(survivors[position] == into, position, -1).astype(np.int64)


def _drop_nonmanifold_faces(faces: np.ndarray) -> np.ndarray:
    """Decimation now and then folds a few faces onto one edge; the proxy can do without them."""
    a, b = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    n = int(faces.max(initial=-1)) + 1
    keys = np.minimum(a, b) * n + np.maximum(a, b)  # 1-D edge keys: faster than np.unique(axis=0)
    _, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
    bad_face = (counts[inverse.ravel()] > 2).reshape(-1, 3).any(axis=1)
    return faces[~bad_face]


def coarse_proxy(mesh: Mesh, vertices: int) -> CoarseProxy | None:
    """A :class:`CoarseProxy` when ``mesh`` is much larger than ``vertices`` (and ``vertices`` > 0),
    else ``None``: work on the mesh itself. Also ``None`` if decimation yields an unusable mesh."""
    if vertices <= 0 or mesh.n_vertices < PROXY_MIN_RATIO * vertices:
        return None
    try:
        return CoarseProxy(mesh, vertices)
    except DarcyanError:
        return None


CLEANUP_ROUNDS = 5
# fast_simplification's ``agg`` (its default 7): how far each pass of its quadric decimation may
# go. At 7 it tore TOSCA's 19k-52k meshes into 5-35 pieces (the copy keeps the largest, with holes
# where the rest was), and fast marching on the copy erred by 0.02 sqrt(area) at the median; at 3,
# the same 6,000 vertices in the same time keep the mesh's Euler characteristic within a few and
# halve the median error (``docs/decisions/features.md``, "The coarse copy keeps its parts apart").
DECIMATION_AGGRESSIVENESS = 3.0
# Only meshes this many times larger than the proxy are decimated: below, it saves too little.
PROXY_MIN_RATIO = 2.0
