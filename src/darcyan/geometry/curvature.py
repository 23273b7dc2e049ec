"""Discrete principal curvatures after Meyer, Desbrun, Schroeder and Barr (2003).

*Discrete Differential-Geometry Operators for Triangulated 2-Manifolds*: the mean curvature
normal is the cotangent Laplacian of the positions over the mixed Voronoi area, the Gaussian
curvature is the angle defect over the same area, and

    kmax, kmin = H +- sqrt(max(H^2 - K, 0)).

Signs follow the outward normal: on a sphere of radius r both are +1/r; on a saddle kmin < 0.
The three operators come from libigl (``cotmatrix``, ``massmatrix`` of Voronoi type,
``gaussian_curvature``) and the normals are area-weighted (``per_vertex_normals``); see
:mod:`darcyan.geometry.operators`. (libigl's ``principal_curvature`` fits quadrics: a different
method, deliberately not used.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geodesics import vertex_normals
from .mesh import Mesh, boundary_vertices, vertex_adjacency
from .operators import cotangent_laplacian, mixed_voronoi_area, nondegenerate_faces


@dataclass(frozen=True)
class Curvatures:
    """Per-vertex curvature fields, all ``(n,)`` in 1/length of the mesh they were computed on."""

    kmax: np.ndarray
    kmin: np.ndarray
    mean: np.ndarray  # H = (kmax + kmin) / 2
    gaussian: np.ndarray  # K = kmax * kmin (before clamping H^2 - K at 0)
    area: np.ndarray  # A_mixed, the mixed Voronoi area of each vertex


def principal_curvatures(mesh: Mesh, smoothing: int = 0) -> Curvatures:
    """Meyer et al. principal curvatures at every vertex.

    Args:
        mesh: an outward-oriented triangle mesh.
        smoothing: iterations of area-weighted averaging over each vertex's one ring, applied to
            H and K before the principal curvatures are formed (0: raw operators). Meyer's
            operators are exact in the limit but noisy on irregular meshes; a little averaging
            makes the descriptor stable across triangulations.

    Returns:
        :class:`Curvatures` in 1/(mesh length unit).
    """
    area = mixed_voronoi_area(mesh)
    safe_area = np.where(area > 0, area, np.inf)
    laplace_x = cotangent_laplacian(mesh) @ mesh.vertices  # = -2 A H n
    normals = vertex_normals(mesh)
    mean = -np.einsum("ij,ij->i", laplace_x, normals) / (2.0 * safe_area)
    gaussian = angle_defect(mesh) / safe_area
    if smoothing:
        mean, gaussian = smooth_vertex_fields(mesh, [mean, gaussian], smoothing, area)
    disc = np.sqrt(np.maximum(mean**2 - gaussian, 0.0))
    return Curvatures(mean + disc, mean - disc, mean, gaussian, area)


def angle_defect(mesh: Mesh) -> np.ndarray:
    """``(n,)`` the integrated Gaussian curvature: 2 pi minus the angles around an interior vertex,
    pi minus them around a boundary vertex (the turning of the boundary there); over a closed
    mesh they sum to 2 pi times its Euler characteristic (Gauss-Bonnet)."""
    import igl  # lazily: igl imports scipy

    defect = igl.gaussian_curvature(mesh.vertices, mesh.faces)
    if not np.isfinite(defect).all():  # a face with coincident corners: NaN angles (ours: 0)
        defect = igl.gaussian_curvature(mesh.vertices, nondegenerate_faces(mesh, keep_collinear=True))
    # libigl subtracts the angles from 2 pi at every vertex, boundary ones included: pi there.
    return defect - np.pi * boundary_vertices(mesh)


def smooth_vertex_fields(mesh: Mesh, fields, iterations: int, area: np.ndarray | None = None):
    """Area-weighted one-ring averaging (each vertex with its neighbours), ``iterations`` times."""
    import scipy.sparse as sp

    adjacency = vertex_adjacency(mesh) + sp.identity(mesh.n_vertices, format="csr")
    if area is None:
        area = mixed_voronoi_area(mesh)
    weighted = adjacency @ sp.diags(area)
    weighted = sp.diags(1.0 / np.asarray(weighted.sum(axis=1)).ravel()) @ weighted
    stacked = np.stack([np.asarray(field, dtype=np.float64) for field in fields], axis=1)  # (n, k)
    for _ in range(iterations):
        stacked = weighted @ stacked  # all fields in one sparse product per iteration
    return [stacked[:, i] for i in range(stacked.shape[1])]
