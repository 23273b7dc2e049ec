"""Discrete differential operators of a triangle mesh: corner cotangents, Meyer's mixed
Voronoi areas and the cotangent Laplacian (Meyer, Desbrun, Schroeder and Barr 2003)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .mesh import Mesh

if TYPE_CHECKING:
    import scipy.sparse as sp


def _corner_geometry(mesh: Mesh):
    v, f = mesh.vertices, mesh.faces
    # Edge opposite corner i of each face, and the corner angles' cotangents.
    e = [v[f[:, (i + 2) % 3]] - v[f[:, (i + 1) % 3]] for i in range(3)]  # e[i] opposite corner i
    double_area = np.linalg.norm(np.cross(e[0], e[1]), axis=1)
    safe = np.where(double_area > 0, double_area, np.inf)
    cot = np.empty((len(f), 3))
    angles = np.empty((len(f), 3))
    for i in range(3):
        u = e[(i + 2) % 3]  # from corner i to the next corner
        w = -e[(i + 1) % 3]  # from corner i to the previous corner
        dot = np.einsum("ij,ij->i", u, w)
        cot[:, i] = dot / safe
        angles[:, i] = np.arctan2(double_area, dot)
    sq_len = np.stack([np.einsum("ij,ij->i", e[i], e[i]) for i in range(3)], axis=1)
    return cot, angles, sq_len, 0.5 * double_area


def mixed_voronoi_area(mesh: Mesh) -> np.ndarray:
    """``(n,)`` Meyer's mixed area: Voronoi for non-obtuse triangles, else 1/2 or 1/4 of the face."""
    return _mixed_area(mesh, *_corner_geometry(mesh))


def _mixed_area(mesh: Mesh, cot, angles, sq_len, area) -> np.ndarray:
    """:func:`mixed_voronoi_area` from the corner geometry already computed."""
    f = mesh.faces
    # Voronoi share of corner i: (|e_{i+1}|^2 cot(angle i+1) + |e_{i+2}|^2 cot(angle i+2)) / 8,
    # e_j being the edge opposite corner j (so e_{i+1}, e_{i+2} are the edges at corner i).
    share = np.empty_like(cot)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        share[:, i] = (sq_len[:, j] * cot[:, j] + sq_len[:, k] * cot[:, k]) / 8.0
    obtuse = angles > np.pi / 2
    any_obtuse = obtuse.any(axis=1)
    share[any_obtuse] = (area[any_obtuse, None] / 4.0) * np.ones(3)
    share[obtuse] = (area[:, None] / 2.0 * np.ones(3))[obtuse]
    return np.bincount(f.ravel(), weights=share.ravel(), minlength=mesh.n_vertices)


def cotangent_laplacian(mesh: Mesh) -> sp.csr_matrix:
    """``(n, n)`` L with ``(L x)_i = sum_j (cot a_ij + cot b_ij) / 2 * (x_j - x_i)`` (negative semidefinite)."""
    return _cotangent_matrix(mesh, _corner_geometry(mesh)[0])


def _cotangent_matrix(mesh: Mesh, cot: np.ndarray) -> sp.csr_matrix:
    """:func:`cotangent_laplacian` from the corner cotangents ``(m, 3)`` already computed."""
    import scipy.sparse as sp  # lazily: a cached match imports no scipy

    f = mesh.faces
    n = mesh.n_vertices
    # Corner i's cotangent weights the edge opposite it, (f[:, i+1], f[:, i+2]), both ways; the
    # diagonal holds minus each row's sum. One COO assembly, duplicates summed by tocsr().
    a, b = f[:, [1, 2, 0]].ravel(), f[:, [2, 0, 1]].ravel()
    half = cot.ravel() / 2
    weight_sum = np.bincount(a, weights=half, minlength=n) + np.bincount(b, weights=half, minlength=n)
    diagonal = np.arange(n)
    rows = np.concatenate([a, b, diagonal])
    cols = np.concatenate([b, a, diagonal])
    vals = np.concatenate([half, half, -weight_sum])
    return sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()
