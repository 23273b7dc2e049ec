"""The Laplace-Beltrami spectrum of a mesh: the generalized eigenproblem
``stiffness phi = lambda mass phi`` solved by shift-invert ``eigsh``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError, MeshError, require
from .mesh import Mesh

if TYPE_CHECKING:
    import scipy.sparse as sp

SPECTRUM_SIZE = 100  # eigenpairs (the constant one included) behind HKS and WKS
SHIFT = -1e-3  # shift-invert target: just below 0, so the smallest eigenvalues converge first
LAPLACIANS = ("cotangent", "robust")
# eigsh starts from a random vector unless given one: a fixed start makes every spectrum, and all
# that is built on it, the same bytes in every run and process.
START_SEED = 0


@dataclass(frozen=True)
class Spectrum:
    """Laplace-Beltrami eigenpairs: ``values (k,)`` ascending (the first ~0), ``vectors (n, k)``
    mass-orthonormal, ``mass (n,)`` lumped vertex areas; for a mesh of area 1."""

    values: np.ndarray
    vectors: np.ndarray
    mass: np.ndarray


def laplacian_operators(mesh: Mesh, laplacian: str = "cotangent") -> tuple[sp.csr_matrix, np.ndarray]:
    """``(stiffness (n, n) positive semidefinite, lumped mass (n,))`` of ``mesh``."""
    if laplacian == "cotangent":
        from .operators import cotangent_laplacian, mixed_voronoi_area

        return (-cotangent_laplacian(mesh)).tocsr(), mixed_voronoi_area(mesh)
    if laplacian == "robust":
        robust_laplacian = require("robust_laplacian", "bench")
        stiffness, mass = robust_laplacian.mesh_laplacian(np.asarray(mesh.vertices), np.asarray(mesh.faces))
        return stiffness.tocsr(), np.asarray(mass.diagonal()).ravel()
    raise ConfigError(f"laplacian must be one of {LAPLACIANS}, got {laplacian!r}")


def laplace_beltrami_spectrum(mesh: Mesh, k: int = SPECTRUM_SIZE, laplacian: str = "cotangent",
                              tol: float = 0.0, shift: float = SHIFT) -> Spectrum:
    """The ``k`` smallest eigenpairs of ``stiffness phi = lambda mass phi`` (shift-invert ``eigsh``
    about ``shift``, relative accuracy ``tol`` of the eigenvalues; 0: machine precision), from a
    fixed start vector (seed ``START_SEED``), so the same mesh gives the same bytes every time.

    Memory stays O(n k): one sparse factorization and the ``(n, k)`` eigenvectors.
    """
    import scipy.sparse as sp  # lazily, like every scipy import: a cached match needs none
    from scipy.sparse.linalg import eigsh

    stiffness, mass = laplacian_operators(mesh, laplacian)
    k = min(k, mesh.n_vertices - 2)
    if k < 3:
        raise MeshError(mesh.name, "mesh too small for a Laplace-Beltrami spectrum")
    mass = np.where(mass > 0, mass, mass[mass > 0].min(initial=1e-12))
    try:
        start = np.random.default_rng(START_SEED).uniform(-1.0, 1.0, mesh.n_vertices)
        values, vectors = eigsh(stiffness, k=k, M=sp.diags(mass).tocsc(), sigma=shift, which="LM", tol=tol, v0=start)
    except (RuntimeError, ValueError) as exc:
        raise MeshError(mesh.name, f"Laplace-Beltrami eigenproblem failed ({exc})") from None
    order = np.argsort(values)
    return Spectrum(np.maximum(values[order], 0.0), vectors[:, order], mass)
