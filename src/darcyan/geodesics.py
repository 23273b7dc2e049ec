"""Geodesic distance (Fast Marching Method) and geodesic tracing on a mesh.

One :class:`GeodesicSolver` is built per mesh and reused for every distance field and every
traced geodesic: the solvers of potpourri3d (geometry-central) do the numerical work.
"""

from __future__ import annotations

import numpy as np

from .errors import MeshError
from .mesh import Mesh


class GeodesicSolver:
    """Fast-marching distances and geodesic tracing on one mesh.

    Args:
        mesh: a prepared mesh (manifold, consistently oriented; see :func:`darcyan.prepare_mesh`).
    """

    def __init__(self, mesh: Mesh):
        import potpourri3d as pp3d

        self.mesh = mesh
        try:
            self._fmm = pp3d.MeshFastMarchingDistanceSolver(mesh.vertices, mesh.faces)
        except (RuntimeError, ValueError) as exc:
            raise MeshError(mesh.name, f"geodesic solver refused the mesh ({str(exc).splitlines()[0][:160]})") from None
        self._tracer = None
        self._tree = None

    def distance(self, vertex: int) -> np.ndarray:
        """``(n,)`` fast-marching geodesic distance from ``vertex`` to every vertex (mesh units)."""
        d = self._fmm.compute_distance([[(int(vertex), [])]])
        return np.asarray(d, dtype=np.float64).reshape(-1)

    def distance_multi(self, vertices) -> np.ndarray:
        """``(n,)`` distance to the nearest of several source ``vertices``."""
        d = self._fmm.compute_distance([[(int(v), [])] for v in vertices])
        return np.asarray(d, dtype=np.float64).reshape(-1)

    def trace(self, vertex: int, direction: np.ndarray, length: float) -> np.ndarray:
        """The straightest geodesic from ``vertex`` leaving along ``direction`` (3D, projected to
        the tangent plane) for ``length``: ``(k, 3)`` points, the first at the vertex, the others
        where it crosses edges; shorter when it reaches a boundary."""
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
    """``(n, 3)`` unit area-weighted vertex normals (outward for an outward-oriented mesh)."""
    v, f = mesh.vertices, mesh.faces
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # length = 2 * area
    corners = f.ravel()
    normals = np.stack([np.bincount(corners, weights=np.repeat(face_n[:, k], 3), minlength=len(v))
                        for k in range(3)], axis=1)  # sum of the adjacent faces' area vectors
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return normals / np.where(length == 0, 1.0, length)


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
