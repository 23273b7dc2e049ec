"""Discrete differential operators of a triangle mesh: Meyer's mixed Voronoi areas and the
cotangent Laplacian (Meyer, Desbrun, Schroeder and Barr 2003), computed by libigl.

libigl's ``cotmatrix`` (negative semidefinite, as before) and ``massmatrix(...,
MASSMATRIX_TYPE_VORONOI)`` equal the formulas written out (``tests/test_operators.py``) and the
hand-written code they replace to rounding (1e-13 of the largest entry on TOSCA meshes), obtuse
triangles included (1/2 of the face to the obtuse corner, 1/4 to the others). They differ only on
what a prepared mesh never holds: a
zero-area face gives libigl inf or NaN (it divides by the area or an edge length) where the
formulas give nothing, so such faces are left out; and libigl sizes the mass matrix by the
largest vertex index in the faces, so trailing unreferenced vertices get their zero area back.

``igl`` is imported inside the functions: it imports scipy, which a cached match must not.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .mesh import Mesh

if TYPE_CHECKING:
    import scipy.sparse as sp


def mixed_voronoi_area(mesh: Mesh) -> np.ndarray:
    """``(n,)`` Meyer's mixed area: Voronoi for non-obtuse triangles, else 1/2 or 1/4 of the face
    (computed once per mesh, read-only, like :meth:`~darcyan.geometry.mesh.Mesh.face_areas`:
    curvature, the heat diffusions and both spectra of one mesh read the same array)."""
    return mesh.kept("_mixed_voronoi_area", lambda: _mixed_voronoi_area(mesh))


def cotangent_laplacian(mesh: Mesh) -> sp.csr_matrix:
    """``(n, n)`` L with ``(L x)_i = sum_j (cot a_ij + cot b_ij) / 2 * (x_j - x_i)`` (negative
    semidefinite; computed once per mesh, its arrays read-only)."""
    return mesh.kept("_cotangent_laplacian", lambda: _cotangent_laplacian(mesh))


def _mixed_voronoi_area(mesh: Mesh) -> np.ndarray:
    import igl  # lazily: igl imports scipy

    area = igl.massmatrix(mesh.vertices, mesh.faces, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    if not np.isfinite(area).all():  # a face with coincident corners (NaN cosines)
        area = igl.massmatrix(mesh.vertices, nondegenerate_faces(mesh), igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    if len(area) < mesh.n_vertices:  # libigl's matrix ends at the last vertex used by a face
        area = np.concatenate([area, np.zeros(mesh.n_vertices - len(area))])
    return area


def _cotangent_laplacian(mesh: Mesh) -> sp.csr_matrix:
    import igl  # lazily: igl imports scipy

    laplacian = igl.cotmatrix(mesh.vertices, mesh.faces)
    if not np.isfinite(laplacian.data).all():  # a zero-area face: libigl divides by its area
        laplacian = igl.cotmatrix(mesh.vertices, nondegenerate_faces(mesh))
    return laplacian.tocsr()


def nondegenerate_faces(mesh: Mesh, keep_collinear: bool = False) -> np.ndarray:
    """The faces of nonzero area (``keep_collinear``: also those of zero area whose three corners
    are distinct points): libigl gives inf or NaN on the others, which add nothing to an
    operator's sum (no cotangent, area or normal; their angles are all 0)."""
    v, f = mesh.vertices, mesh.faces
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    if keep_collinear:
        return f[(a != b).any(axis=1) & (b != c).any(axis=1) & (c != a).any(axis=1)]
    return f[np.linalg.norm(np.cross(b - a, c - a), axis=1) > 0]


def gradient_operator(mesh: Mesh):
    """``(3m, n)`` libigl's ``grad``: a piecewise-linear vertex field to its gradient on each
    face (all x components, then all y, then all z; scipy sparse)."""
    import igl  # lazily: igl imports scipy

    return igl.grad(mesh.vertices, mesh.faces)


def face_gradients(mesh: Mesh, fields: np.ndarray, operator=None) -> np.ndarray:
    """``(m, 3, k)`` the gradient of each of ``fields (n, k)`` (piecewise linear over the faces)
    on each face, in the face's plane (``operator``: the mesh's :func:`gradient_operator`, when
    already built)."""
    fields = np.asarray(fields, dtype=np.float64).reshape(mesh.n_vertices, -1)
    operator = gradient_operator(mesh) if operator is None else operator
    gradient = operator @ fields  # (3m, k): all x, then all y, then all z
    return np.nan_to_num(gradient.reshape(3, mesh.n_faces, -1).transpose(1, 0, 2))
