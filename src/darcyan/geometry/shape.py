"""The prepared shape: a mesh made ready for analysis once, its operators built once.

:func:`prepare_shape` is the one way from an input :class:`~darcyan.geometry.mesh.Mesh` to what
every part of darcyan works on (the method, dense maps, the benchmark's scoring and baselines,
the pictures): checks and optional repair, the largest component, denoising of crumpled surfaces,
scale normalization to area 1. The :class:`Shape` it returns is immutable; its operators
(geodesic solver, normals, vertex areas, Laplacian, curvatures, spectra, coarse proxies) are
computed on first use and kept, so two consumers of one shape never build one twice.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..config import DarcyanConfig, Repairing
from ..errors import MeshError
from .curvature import Curvatures, principal_curvatures
from .denoise import denoise_mesh
from .geodesics import GeodesicSolver, vertex_normals
from .mesh import Mesh, MeshWarning, Normalization, local_index, normalize_mesh
from .operators import cotangent_laplacian, gradient_operator, mixed_voronoi_area
from .repair import prepare_mesh
from .spectral import SHIFT, Spectrum, laplace_beltrami_spectrum

# What a pickled Shape keeps of what it built (beside derived arrays): what costs time to make.
PORTABLE_MEMO = ("curvatures", "spectrum", "proxy", "proxy spectrum", "distance")


@dataclass(frozen=True, eq=False)
class Shape:
    """A mesh prepared for analysis, and the operators built on it.

    Attributes:
        mesh: the prepared mesh: checked (and repaired if asked), largest component, denoised if
            crumpled, centred and scaled to area 1 (lengths in sqrt(area) units of the input).
            ``mesh.input_index (n,)`` gives each vertex's index in the input.
        n_input_vertices: the input's vertex count, for range checks of results.
        input_positions: ``(n_input, 3)`` the input's vertices in the prepared mesh's frame (the
            same centring and scale), so that input vertices the preparation left out can be
            placed.
        normalization: the centring and scale applied to the input.
        changes: the repairs applied (empty without ``repair``).
        denoise_steps: Taubin smoothing steps applied (0: the surface was left as it was).
        coincident: an input vertex that is not on the prepared mesh but within this distance
            (prepared units) of one of its vertices is that vertex: a copy that repair welded.
        repairing: the :class:`~darcyan.config.Repairing` settings it was prepared with (with
            or without repair); what is later derived from it uses them too (a dense map's copy
            cut open at its handles: :func:`~darcyan.dense.maps.dense_shape`).
    """

    mesh: Mesh
    n_input_vertices: int
    input_positions: np.ndarray
    normalization: Normalization
    changes: tuple = ()
    denoise_steps: int = 0
    coincident: float = 0.0
    repairing: Repairing = Repairing()
    _memo: dict = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        return self.mesh.name

    @property
    def n_vertices(self) -> int:
        return self.mesh.n_vertices

    # -- operators, built on first use ---------------------------------------------------------

    @cached_property
    def solver(self) -> GeodesicSolver:
        """Fast-marching geodesic distances on :attr:`mesh` (one solver, reused)."""
        return GeodesicSolver(self.mesh)

    @cached_property
    def normals(self) -> np.ndarray:
        """``(n, 3)`` unit vertex normals (outward)."""
        return vertex_normals(self.mesh)

    @property
    def vertex_areas(self) -> np.ndarray:
        """``(n,)`` Meyer's mixed Voronoi areas (they sum to 1; kept on the mesh)."""
        return mixed_voronoi_area(self.mesh)

    @property
    def laplacian(self):
        """``(n, n)`` cotangent Laplacian (scipy CSR, negative semidefinite; kept on the mesh)."""
        return cotangent_laplacian(self.mesh)

    @cached_property
    def gradient(self):
        """``(3m, n)`` the face gradient of vertex fields (:func:`~darcyan.geometry.operators.gradient_operator`)."""
        return gradient_operator(self.mesh)

    def distance_field(self, vertex: int) -> np.ndarray:
        """``(n,)`` the fast-marching geodesic distance (mesh units) from ``vertex`` (prepared
        numbering) to every vertex, computed once per shape and vertex and kept: the feature
        points' fields serve the description and the dense map's landmarks alike, and a shape
        prepared in a worker process brings them back (:meth:`__getstate__`)."""
        vertex = int(vertex)
        return self._once(("distance", vertex), lambda: self.solver.distance(vertex))

    def keep_distance_field(self, vertex: int, field: np.ndarray) -> None:
        """Keep ``field`` ``(n,)`` as :meth:`distance_field` of ``vertex``: one computed elsewhere
        by the same solver (the description's exact fields of its feature points), so that it is
        not computed again. A field already kept stays. A vertex out of range or a field of
        another length is a :class:`~darcyan.errors.MeshError`."""
        vertex, field = int(vertex), np.asarray(field, dtype=np.float64)
        if not 0 <= vertex < self.n_vertices:
            raise MeshError(self.name, f"distance field of vertex {vertex}: out of range 0..{self.n_vertices - 1}")
        if field.shape != (self.n_vertices,):
            raise MeshError(self.name, f"distance field of vertex {vertex}: shape {field.shape}, expected "
                                       f"({self.n_vertices},)")
        self._memo.setdefault(("distance", vertex), field)

    def known_distance_field(self, vertex: int) -> np.ndarray | None:
        """The field :meth:`distance_field` kept for ``vertex``, or ``None``: a reader that does
        not keep the fields it computes itself (a dense map's other starts) looks here first."""
        return self._memo.get(("distance", int(vertex)))

    def curvatures(self, smoothing: int = 0) -> Curvatures:
        """Meyer principal curvatures after ``smoothing`` one-ring averaging iterations."""
        return self._once(("curvatures", smoothing), lambda: principal_curvatures(self.mesh, smoothing))

    def spectrum(self, k: int, tol: float = 0.0, shift: float = SHIFT, laplacian: str = "cotangent",
                 lanczos: float = 0.0, cholesky: bool = False) -> Spectrum:
        """The ``k`` smallest Laplace-Beltrami eigenpairs (seeded: the same bytes every run; see
        :func:`~darcyan.geometry.spectral.laplace_beltrami_spectrum`)."""
        return self._once(("spectrum", k, tol, shift, laplacian, lanczos, cholesky),
                          lambda: laplace_beltrami_spectrum(self.mesh, k, laplacian, tol, shift, lanczos, cholesky))

    def smooth_basis(self, k: int, proxy_vertices: int = 0, tol: float = 0.0, shift: float = SHIFT,
                     lanczos: float = 0.0, cholesky: bool = False, laplacian: str = "cotangent"):
        """``(n, k)`` the ``k`` first Laplace-Beltrami eigenfunctions at the vertices. On a mesh
        with more than twice ``proxy_vertices`` vertices they are computed on its coarse
        :meth:`proxy` and interpolated (smooth functions lose nothing there; the eigensolver on
        50k vertices takes tens of seconds), and are then not mass-orthonormal, and not an
        ndarray but :class:`~darcyan.geometry.proxy.InterpolatedRows`, interpolated as rows are
        read (index it first: ``basis[rows, :k]``; ``np.asarray(basis)`` makes the whole array).
        ``tol``: the eigensolver's relative accuracy (0: machine precision); ``lanczos``,
        ``cholesky``: how it solves, ``laplacian``: which (see
        :func:`~darcyan.geometry.spectral.laplace_beltrami_spectrum`)."""
        return self.smooth_spectrum(k, proxy_vertices, tol, shift, lanczos, cholesky, laplacian).vectors

    def smooth_spectrum(self, k: int, proxy_vertices: int = 0, tol: float = 0.0, shift: float = SHIFT,
                        lanczos: float = 0.0, cholesky: bool = False, laplacian: str = "cotangent") -> Spectrum:
        """The eigenpairs behind :meth:`smooth_basis`: on a large mesh the coarse proxy's
        eigenvalues and its eigenvectors interpolated to the vertices (``mass``: the mesh's
        mixed Voronoi vertex areas, whichever ``laplacian``; the interpolated vectors are then not mass-orthonormal, and are
        :class:`~darcyan.geometry.proxy.InterpolatedRows`: interpolated as they are read)."""
        proxy = self.proxy(proxy_vertices) if proxy_vertices > 0 else None
        if proxy is None:
            return self.spectrum(k, tol, shift, laplacian, lanczos, cholesky)

        def interpolated():
            coarse = self._once(("proxy spectrum", k, proxy_vertices, tol, shift, lanczos, cholesky, laplacian),
                                lambda: laplace_beltrami_spectrum(proxy.mesh, min(k, proxy.mesh.n_vertices - 1), laplacian,
                                                                  tol, shift, lanczos, cholesky))
            return Spectrum(coarse.values, proxy.rows_on_demand(coarse.vectors), self.vertex_areas)

        return self._once(("proxy basis", k, proxy_vertices, tol, shift, lanczos, cholesky, laplacian), interpolated)

    def proxy(self, vertices: int):
        """A :class:`~darcyan.geometry.proxy.CoarseProxy` of about ``vertices`` vertices, or
        ``None`` when the mesh has fewer than twice as many (then work on the mesh itself)."""
        from .proxy import coarse_proxy

        return self._once(("proxy", vertices), lambda: coarse_proxy(self.mesh, vertices))

    def coarse_shape(self, vertices: int) -> "Shape | None":
        """The :meth:`proxy` of about ``vertices`` vertices as a shape of its own (the same units;
        its input numbering is the copy's vertices: :meth:`CoarseProxy.nearest_vertices
        <darcyan.geometry.proxy.CoarseProxy.nearest_vertices>` carries a vertex of this shape
        there), or ``None`` when there is no proxy. Built once per shape and size."""
        proxy = self.proxy(vertices)
        if proxy is None:
            return None

        def build():
            coarse = Mesh(proxy.mesh.vertices, proxy.mesh.faces, name=proxy.mesh.name)
            positions = coarse.vertices.view()
            positions.flags.writeable = False
            return Shape(coarse, coarse.n_vertices, positions, self.normalization, repairing=self.repairing)

        return self._once(("coarse shape", vertices), build)

    def derived(self, key: tuple, compute):
        """``compute()``, once per shape and ``key``: what a higher layer derives from the shape
        alone (e.g. the dense maps' point signature) is kept with it like its own operators."""
        return self._once(("derived",) + tuple(key), compute)

    def __getstate__(self) -> dict:
        """What a copy sent to another process carries: the mesh and what was built on it, but
        not what is quickly rebuilt from what it carries and large (a proxy's basis interpolated
        to every vertex) or tied to this process (a factorization's solve; the geodesic solver's
        native objects, see :class:`~darcyan.geometry.geodesics.GeodesicSolver`)."""
        memo = {key: value for key, value in self._memo.items()
                if key[0] in PORTABLE_MEMO or (key[0] == "derived" and isinstance(value, np.ndarray))}
        return {**self.__dict__, "_memo": memo}

    def __setstate__(self, state: dict) -> None:
        object.__setattr__(self, "__dict__", state)  # frozen: no __setattr__

    def _once(self, key: tuple, compute):
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]

    # -- numbering ----------------------------------------------------------------------------

    def mesh_index(self, input_vertices, nearest: bool = False) -> np.ndarray:
        """``(k,) int64`` indices into :attr:`mesh` of vertices given in the input's numbering.

        A vertex the preparation left out (a small component, an unreferenced vertex) is -1, or
        with ``nearest`` the prepared vertex nearest its position. An index outside the input's
        range is a :class:`~darcyan.errors.MeshError`.
        """
        input_vertices = np.asarray(input_vertices, dtype=np.int64).reshape(-1)
        bad = (input_vertices < 0) | (input_vertices >= self.n_input_vertices)
        if bad.any():
            raise MeshError(self.name, f"vertex {int(input_vertices[bad][0])} out of range "
                                       f"0..{self.n_input_vertices - 1}")
        out = self._inverse_index[input_vertices]
        missing = out < 0
        if nearest and missing.any():
            from scipy.spatial import cKDTree

            out[missing] = cKDTree(self.mesh.vertices).query(self.input_positions[input_vertices[missing]])[1]
        return out

    @cached_property
    def _inverse_index(self) -> np.ndarray:
        inverse = local_index(self.mesh, np.arange(self.n_input_vertices))
        missing = np.flatnonzero(inverse < 0)
        if self.coincident > 0 and len(missing):  # welded copies: the vertex they were welded into
            from .knn import nearest_rows

            near = nearest_rows(self.mesh.vertices, self.input_positions[missing])
            gap = np.linalg.norm(self.mesh.vertices[near] - self.input_positions[missing], axis=1)
            inverse[missing[gap <= self.coincident]] = near[gap <= self.coincident]
        return inverse


def prepare_shape(mesh: Mesh, config: DarcyanConfig = DarcyanConfig(), repair: bool = False) -> Shape:
    """Prepare ``mesh`` (as read from a file) for analysis: see the module docstring.

    Warns (:class:`MeshWarning`) about what it leaves out or changes; raises
    :class:`~darcyan.errors.MeshError` for input it cannot use.
    """
    prepared, changes = prepare_mesh(mesh, repair, config.repairing)
    prepared, steps, area_ratio = denoise_mesh(prepared, config.denoise_area_ratio, config.denoising)
    if steps and not prepared.area() > 0:  # a smoothed copy of a few faces shrinks to nothing
        raise MeshError(mesh.name, f"mesh too small or coarse for a Darcyan grid ({mesh.n_vertices} vertices, "
                                   f"{mesh.n_faces} faces)")
    if steps:
        warnings.warn(f"{mesh.name}: the surface is crumpled at the scale of its edges (its area is "
                      f"{area_ratio:.2f} times that of a smoothed copy: vertex noise?); analysed after "
                      f"{steps} Taubin smoothing steps", MeshWarning, stacklevel=2)
    normalized, normalization = normalize_mesh(prepared)
    positions = (mesh.vertices - normalization.centre) * normalization.scale
    positions.flags.writeable = False
    coincident = 0.0
    if repair and steps == 0:  # copies welded into a vertex sit where it is (denoising moves it)
        edges = normalized.edges()
        mean_edge = float(np.linalg.norm(np.diff(normalized.vertices[edges], axis=1), axis=2).mean())
        coincident = config.repairing.weld_tolerance * mean_edge
    return Shape(normalized, mesh.n_vertices, positions, normalization, tuple(changes), steps, coincident=coincident,
                 repairing=config.repairing)
