"""Geodesic distance (Fast Marching Method) and geodesic tracing on a mesh.

One :class:`GeodesicSolver` is built per mesh and reused for every distance field and every
traced geodesic: the solvers of potpourri3d (geometry-central) do the numerical work.

On a large mesh, the feature points' distance fields and grids need exact geodesics only near
each feature point: :class:`LocalGeodesicSolver` cuts a :class:`GeodesicBall` around it (chosen
with a coarse estimate of the distance) and runs fast marching, tracing and point location on the
ball alone. Within the ball's radius the distances are those of fast marching on the whole mesh,
bit for bit: a vertex's fast-marching value depends only on the triangles around it and on
smaller values, all inside the ball.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..config import GeodesicMargins
from ..errors import MeshError
from .mesh import Mesh


class GeodesicSolver:
    """Fast-marching distances and geodesic tracing on one mesh.

    Args:
        mesh: a prepared mesh (manifold, consistently oriented; see :func:`darcyan.prepare_mesh`).
    """

    def __init__(self, mesh: Mesh):
        self.mesh = mesh
        self._fmm_solver = None  # built at the first distance asked (a large mesh may need none)
        self._tracer = None
        self._tree = None

    def __getstate__(self) -> dict:
        # The native solvers do not pickle; a copy sent to another process builds its own on use.
        return {**self.__dict__, "_fmm_solver": None, "_tracer": None, "_tree": None}

    @property
    def _fmm(self):
        if self._fmm_solver is None:
            import potpourri3d as pp3d

            try:
                self._fmm_solver = pp3d.MeshFastMarchingDistanceSolver(self.mesh.vertices, self.mesh.faces)
            except (RuntimeError, ValueError) as exc:
                raise MeshError(self.mesh.name, f"geodesic solver refused the mesh "
                                                f"({str(exc).splitlines()[0][:160]})") from None
        return self._fmm_solver

    def distance(self, vertex: int) -> np.ndarray:
        """``(n,)`` fast-marching geodesic distance from ``vertex`` to every vertex (mesh units)."""
        return self.distance_from_points([(int(vertex), [])])

    def distance_multi(self, vertices) -> np.ndarray:
        """``(n,)`` distance to the nearest of several source ``vertices``."""
        return self.distance_from_points([(int(v), []) for v in vertices])

    def distance_from_points(self, points: list) -> np.ndarray:
        """``(n,)`` distance to the nearest of surface ``points``, each ``(face, [b0, b1, b2])``
        (barycentric coordinates) or ``(vertex, [])``.

        Raises:
            MeshError: naming the mesh, for an index out of range (potpourri3d would not return).
        """
        for index, weights in points:
            limit = len(self.mesh.faces) if len(weights) else self.mesh.n_vertices
            if not 0 <= int(index) < limit:
                kind = "face" if len(weights) else "vertex"
                raise MeshError(self.mesh.name, f"geodesic distance from {kind} {int(index)}: out of range "
                                                f"(the mesh has {limit} {kind}{'s' if kind == 'face' else 'es'})")
        d = self._fmm.compute_distance([[p] for p in points])
        return np.asarray(d, dtype=np.float64).reshape(-1)

    def trace(self, vertex: int, direction: np.ndarray, length: float) -> np.ndarray:
        """The straightest geodesic from ``vertex`` leaving along ``direction`` (3D, projected to
        the tangent plane) for ``length``: ``(k, 3)`` points, the first at the vertex, the others
        where it crosses edges; shorter when it reaches a boundary."""
        if not 0 <= int(vertex) < self.mesh.n_vertices:
            raise MeshError(self.mesh.name, f"geodesic from vertex {int(vertex)}: out of range "
                                            f"(the mesh has {self.mesh.n_vertices} vertices)")
        if self._tracer is None:
            import potpourri3d as pp3d

            self._tracer = pp3d.GeodesicTracer(self.mesh.vertices, self.mesh.faces)
        d = np.asarray(direction, dtype=np.float64)
        d = d / np.linalg.norm(d) * float(length)
        return np.asarray(self._tracer.trace_geodesic_from_vertex(int(vertex), d), dtype=np.float64)

    def locate(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Surface coordinates of the closest surface points to ``points`` ``(k, 3)``.

        Returns ``faces (k,) int64`` and ``barycentric (k, 3)``. The AABB tree is built once.
        """
        points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        if len(points) == 0:
            return np.zeros(0, np.int64), np.zeros((0, 3))
        if self._tree is None:
            import igl

            self._tree = igl.AABB()
            self._tree.init(self.mesh.vertices, self.mesh.faces)
        _, faces, closest = self._tree.squared_distance(self.mesh.vertices, self.mesh.faces, points)
        faces = np.asarray(faces, dtype=np.int64)
        return faces, barycentric(self.mesh, faces, closest)


def barycentric(mesh: Mesh, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``(k, 3)`` barycentric coordinates of ``points`` (lying in them) in triangles ``faces``."""
    a, b, c = (mesh.vertices[mesh.faces[faces, i]] for i in range(3))
    v0, v1, v2 = b - a, c - a, points - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    denom = d00 * d11 - d01 * d01
    denom = np.where(denom == 0, 1.0, denom)
    w1 = (d11 * d20 - d01 * d21) / denom
    w2 = (d00 * d21 - d01 * d20) / denom
    bary = np.stack([1 - w1 - w2, w1, w2], axis=1)
    return np.clip(bary, 0.0, 1.0) / np.clip(bary, 0.0, 1.0).sum(axis=1, keepdims=True)


def interpolate(mesh: Mesh, values: np.ndarray, faces: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Per-vertex ``values`` ``(n, ...)`` interpolated at surface points ``(faces, bary)``."""
    corner_values = values[mesh.faces[faces]]  # (k, 3, ...)
    return np.einsum("kj,kj...->k...", bary, corner_values)


def vertex_normals(mesh: Mesh) -> np.ndarray:
    """``(n, 3)`` unit area-weighted vertex normals (outward for an outward-oriented mesh): the
    normalized sum of the adjacent faces' area vectors; 0 where that sum is 0 (an unreferenced
    vertex, or one with zero-area faces only)."""
    import igl  # lazily: igl imports scipy

    # AREA named, though libigl's DEFAULT is area too: its ANGLE weighting would change the normals.
    normals = igl.per_vertex_normals(mesh.vertices, mesh.faces, igl.PER_VERTEX_NORMALS_WEIGHTING_TYPE_AREA)
    normals[~np.isfinite(normals).all(axis=1)] = 0.0  # libigl's 0 / 0
    return normals


def vertex_gradient(mesh: Mesh, field: np.ndarray, vertex: int) -> np.ndarray:
    """Area-weighted mean over the faces around ``vertex`` of the gradient of the piecewise-linear
    ``field`` ``(n,)``: a ``(3,)`` tangent vector."""
    f = mesh.faces[np.any(mesh.faces == vertex, axis=1)]
    v = mesh.vertices
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 0
    n_unit = n[ok] / area2[ok, None]
    ua, ub, uc = (field[f[ok, i]] for i in range(3))
    grad = (np.cross(n_unit, c[ok] - b[ok]) * ua[:, None] + np.cross(n_unit, a[ok] - c[ok]) * ub[:, None]
            + np.cross(n_unit, b[ok] - a[ok]) * uc[:, None]) / area2[ok, None]
    weights = area2[ok] / area2[ok].sum()
    return (grad * weights[:, None]).sum(axis=0)


@dataclass(frozen=True)
class GeodesicBall:
    """A piece of a mesh cut around a vertex, with its own solver.

    Attributes:
        mesh: the piece (faces keep their corner order, so barycentric coordinates carry over).
        solver: its :class:`GeodesicSolver`.
        vertices: ``(k,) int64`` index in the whole mesh of each vertex of the piece.
        faces: ``(f,) int64`` index in the whole mesh of each face of the piece.
        centre: index of the centre vertex in the piece.
        radius: geodesic radius (mesh units) within which the piece's fast marching from the
            centre equals the whole mesh's.
        distance: ``(k,)`` fast-marching distance from the centre over the piece; ``None`` when
            the piece is the whole mesh (``solver.distance(centre)`` then).
    """

    mesh: Mesh
    solver: GeodesicSolver
    vertices: np.ndarray
    faces: np.ndarray
    centre: int
    radius: float
    distance: np.ndarray | None


class LocalGeodesicSolver:
    """Distance fields from, and geodesic balls around, chosen vertices of a mesh, for the cost of
    each ball rather than of the whole mesh.

    Args:
        solver: the whole mesh's solver.
        radius: geodesic radius (mesh units) around a source within which its distance field is
            exact (equal to ``solver.distance``) and within which :meth:`ball` can trace.
        estimate: ``vertex -> (n,)`` approximate distance field (a coarse proxy's, see
            :class:`darcyan.geometry.proxy.CoarseProxy`), used to cut the balls and as the field beyond
            ``radius``; ``None``: no cutting, every field and ball is the whole mesh's.
        margin: the balls are cut where the estimate exceeds ``radius`` by this share of it (the
            coarse proxy's fast marching overestimates distances by up to ~12% of 0.25 on
            TOSCA); if the cut still comes within the radius, the margin doubles.
    """

    def __init__(self, solver: GeodesicSolver, radius: float,
                 estimate: Callable[[int], np.ndarray] | None = None, margin: float = GeodesicMargins().ball):
        self.solver = solver
        self.margin = float(margin)
        self.mesh = solver.mesh
        self.radius = float(radius)
        self.estimate = estimate
        self._balls: dict[int, GeodesicBall] = {}
        self._fields: dict[int, np.ndarray] = {}
        self._estimates: dict[int, np.ndarray] = {}

    def ball(self, vertex: int, keep: bool = True) -> GeodesicBall:
        """The :class:`GeodesicBall` of ``radius`` around ``vertex`` (built once; with ``keep``
        false, built anew and not kept, nor its estimate: for many balls asked once each)."""
        vertex = int(vertex)
        if vertex in self._balls:
            return self._balls[vertex]
        if not keep:
            ball = self._cut(vertex)
            self._estimates.pop(vertex, None)
            return ball
        self._balls[vertex] = self._cut(vertex)
        return self._balls[vertex]

    def distance(self, vertex: int) -> np.ndarray:
        """``(n,)`` distance from ``vertex``: fast marching within ``radius``; beyond it the
        estimate, never below ``radius`` (built once)."""
        vertex = int(vertex)
        if vertex not in self._fields:
            if self.estimate is None:
                self._fields[vertex] = self.solver.distance(vertex)
            else:
                ball = self.ball(vertex)
                near = ball.distance if ball.distance is not None else ball.solver.distance(ball.centre)
                field = np.maximum(self._estimate(vertex), np.nextafter(self.radius, np.inf))
                exact = near <= self.radius
                field[ball.vertices[exact]] = near[exact]
                self._fields[vertex] = field
        return self._fields[vertex]

    def _estimate(self, vertex: int) -> np.ndarray:
        if vertex not in self._estimates:
            self._estimates[vertex] = np.asarray(self.estimate(vertex), dtype=np.float64)
        return self._estimates[vertex]

    def _cut(self, vertex: int) -> GeodesicBall:
        mesh = self.mesh
        if self.estimate is None:
            return self._whole(vertex)
        estimate = self._estimate(vertex)
        margin = self.margin * self.radius
        while True:
            inside = (estimate[mesh.faces] <= self.radius + margin).all(axis=1)
            inside |= (mesh.faces == vertex).any(axis=1)
            cut_out = _manifold_piece(mesh, inside)
            if cut_out is None:
                return self._whole(vertex)
            piece, used, inside = cut_out
            solver = GeodesicSolver(piece)
            # Vertices on the cut (touching a face left out) must lie beyond the radius: then no
            # shortest path to a point within it leaves the piece. An estimate too low only makes
            # the piece larger; one too high cuts too close, and the margin grows.
            cut = np.zeros(mesh.n_vertices, bool)
            cut[mesh.faces[~inside]] = True
            centre = int(np.searchsorted(used, vertex))
            near = solver.distance(centre)
            if near[cut[used]].min(initial=np.inf) > self.radius:
                return GeodesicBall(piece, solver, used, np.flatnonzero(inside), centre, self.radius, near)
            margin *= 2.0

    def _whole(self, vertex: int) -> GeodesicBall:
        mesh = self.mesh
        return GeodesicBall(mesh, self.solver, np.arange(mesh.n_vertices), np.arange(mesh.n_faces), vertex,
                            np.inf, None)


def piece_bow_ties(piece: Mesh) -> np.ndarray:
    """The vertices where faces of ``piece``, a subset of the faces of a manifold mesh (a
    prepared one), meet in more than one fan: those with at least two more distinct edges than
    faces. Around a vertex of a manifold mesh the faces form one fan, and a subset of them falls
    into runs of consecutive faces, a run of j faces having j + 1 edges of its own (the whole
    closed fan: as many edges as faces); so edges minus faces counts the runs. The same vertices
    as :func:`darcyan.geometry.repair.nonmanifold_vertices` finds on such a piece, without its
    connected components (a few milliseconds a ball on a 52k-vertex mesh)."""
    n = piece.n_vertices
    edges = piece.edges()
    edges_at = np.bincount(edges.ravel(), minlength=n)
    faces_at = np.bincount(piece.faces.ravel(), minlength=n)
    return np.flatnonzero(edges_at - faces_at >= 2)


def _manifold_piece(mesh: Mesh, inside: np.ndarray) -> tuple[Mesh, np.ndarray, np.ndarray] | None:
    """The faces ``inside`` (a ``(m,)`` mask) of ``mesh`` as a mesh of their own, with every face
    around a vertex where they meet only at a corner added (the solvers refuse such bow ties).
    Returns the piece, ``(k,)`` the whole mesh's index of each of its vertices, and the final mask;
    ``None`` when the piece would be the whole mesh."""
    while not inside.all():
        faces = mesh.faces[inside]
        used = np.flatnonzero(np.bincount(faces.ravel(), minlength=mesh.n_vertices))
        index = np.full(mesh.n_vertices, -1, dtype=np.int64)
        index[used] = np.arange(len(used))
        piece = Mesh(mesh.vertices[used], index[faces], name=mesh.name)
        bow_ties = piece_bow_ties(piece)
        if not len(bow_ties):
            return piece, used, inside
        around = np.zeros(mesh.n_vertices, bool)
        around[used[bow_ties]] = True
        inside = inside | around[mesh.faces].any(axis=1)
    return None

