"""The Laplace-Beltrami spectrum of a mesh: the generalized eigenproblem
``stiffness phi = lambda mass phi`` solved by shift-invert ``eigsh``."""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..config import LAPLACIANS
from ..errors import ConfigError, MeshError, require
from .mesh import Mesh

if TYPE_CHECKING:
    import scipy.sparse as sp

SPECTRUM_SIZE = 100  # eigenpairs (the constant one included) behind HKS and WKS
SHIFT = -1e-3  # shift-invert target: just below 0, so the smallest eigenvalues converge first
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
                              tol: float = 0.0, shift: float = SHIFT, lanczos: float = 0.0,
                              cholesky: bool = False) -> Spectrum:
    """The ``k`` smallest eigenpairs of ``stiffness phi = lambda mass phi`` (shift-invert ``eigsh``
    about ``shift``, relative accuracy ``tol`` of the eigenvalues; 0: machine precision), from a
    fixed start vector (seed ``START_SEED``), so the same mesh gives the same bytes every time.
    ``lanczos``: Lanczos vectors kept per eigenpair (ARPACK's ``ncv``; 0: scipy's default,
    ``max(2 k + 1, 20)``); ``cholesky``: each shift-invert step solved by
    :func:`shifted_inverse` (about a third of the time of ``eigsh``'s own LU solves) instead of
    ``eigsh``'s LU. Either gives the eigenpairs to the tolerance asked, but where eigenvalues are
    equal (a symmetric mesh's) the rounding decides which vectors of their space come out, and
    whether a group cut at the k-th is found whole: the describe stage's spectra keep ``eigsh``'s
    own LU, so that its results stay those measured.

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
        vectors_kept = None if lanczos <= 0 else min(mesh.n_vertices, max(int(lanczos * k), k + 2))
        values, vectors = eigsh(stiffness, k=k, M=sp.diags(mass).tocsc(), sigma=shift, which="LM", tol=tol, v0=start,
                                ncv=vectors_kept, OPinv=shifted_inverse(stiffness, mass, shift) if cholesky else None)
    except (RuntimeError, ValueError) as exc:
        raise MeshError(mesh.name, f"Laplace-Beltrami eigenproblem failed ({exc})") from None
    order = np.argsort(values)
    return Spectrum(np.maximum(values[order], 0.0), vectors[:, order], mass)


def shifted_inverse(stiffness: sp.csr_matrix, mass: np.ndarray, shift: float):
    """``(stiffness - shift diag(mass))^-1`` as an ``(n, n)`` ``LinearOperator``: what shift-invert
    ``eigsh`` applies at every step, by a sparse Cholesky factorization (CHOLMOD, through
    ``cholespy``), whose solves take about a third of the time of those of the LU factorization
    ``eigsh`` makes by default (a 130-eigenpair solve does some 450). ``None`` (``eigsh`` then
    factorizes by LU itself) when the matrix is not positive definite (a shift at or above 0, or
    a factorization that fails) or too large for CHOLMOD's 32-bit indices."""
    if shift >= 0:
        return None
    import scipy.sparse as sp
    from cholespy import CholeskySolverD, MatrixType
    from scipy.sparse.linalg import LinearOperator

    shifted = (stiffness - shift * sp.diags(mass)).tocsr()
    if shifted.nnz >= np.iinfo(np.int32).max:
        return None
    shifted.sort_indices()
    n = shifted.shape[0]
    try:
        with _standard_output_muted():
            factor = CholeskySolverD(n, shifted.indptr.astype(np.int32), shifted.indices.astype(np.int32),
                                     np.ascontiguousarray(shifted.data, dtype=np.float64), MatrixType.CSR)
    except (ValueError, RuntimeError):  # not positive definite in floating point (a shift very near 0)
        return None

    def solve(b: np.ndarray) -> np.ndarray:
        x = np.empty(n)
        factor.solve(np.ascontiguousarray(b, dtype=np.float64).reshape(n), x)
        return x

    return LinearOperator((n, n), matvec=solve, dtype=np.float64)


@contextlib.contextmanager
def _standard_output_muted():
    """The process's standard output (file descriptor 1) sent to the null device: CHOLMOD prints
    its warnings there ("not positive definite", when :func:`shifted_inverse` falls back to LU),
    where ``darcyan match`` may be writing a map. Muted from the first caller in to the last
    out (threads may factorize at once); what another thread prints meanwhile is lost too (a
    factorization takes milliseconds). Best effort: with no standard output to redirect (closed,
    or none), the block runs as it is."""
    with _muting:
        first = _muted["depth"] == 0
        if first:
            _muted["saved"] = _redirect_standard_output()
        _muted["depth"] += 1
    try:
        yield
    finally:
        with _muting:
            _muted["depth"] -= 1
            if _muted["depth"] == 0 and _muted["saved"] is not None:
                saved, _muted["saved"] = _muted["saved"], None
                _flush_c_output()
                try:
                    os.dup2(saved, 1)
                finally:
                    os.close(saved)


_muting = threading.Lock()
_muted = {"depth": 0, "saved": None}  # callers inside, and the descriptor standard output had


def _redirect_standard_output() -> int | None:
    """Point file descriptor 1 at the null device; the duplicate of what it was (``None``: left
    as it is, there being nothing to redirect)."""
    try:
        if sys.stdout is not None:
            sys.stdout.flush()
        _flush_c_output()  # what C buffered before goes where it was meant to
        saved = os.dup(1)
    except (OSError, ValueError):  # no descriptor 1, or a closed sys.stdout
        return None
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 1)
        finally:
            os.close(null)
    except OSError:
        os.close(saved)
        return None
    return saved


def _flush_c_output() -> None:
    """Flush C's own stdio buffers (the C library's; none to ask on Windows)."""
    try:
        _c_library().fflush(None)
    except (OSError, AttributeError, TypeError):
        pass


@functools.cache
def _c_library():
    """The process's C library (loaded once: each factorization flushes it twice)."""
    import ctypes

    return ctypes.CDLL(None)
