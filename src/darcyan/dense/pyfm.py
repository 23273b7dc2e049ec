"""pyFM's functional-map pipeline (PyPI ``pyfmaps``, optional extra ``[pyfm]``), in one place.

WKS descriptors (plus landmark WKS when landmarks are given), a functional map fitted with
Laplacian and descriptor commutativity, refined by ZoomOut, converted to a point map. Two
settings are used: :data:`README_PIPELINE`, the package README's example (the sparse ``pyfm``
baseline of ``darcyan bench``), and :data:`DENSE_PIPELINE` (``darcyan bench --dense``'s pyFM
map, and ``DenseConfig(method="pyfm")`` with darcyan's landmarks).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import MeshError, require
from ..geometry.mesh import Mesh
from ..geometry.spectral import START_SEED


@dataclass(frozen=True)
class PyfmPipeline:
    """Sizes and weights of one pyFM pipeline.

    Attributes:
        descriptors: WKS energies; descriptor_step: keep every this-many-th descriptor.
        spectrum: eigenpairs computed per mesh (``k_process``).
        fmap_size: size of the fitted functional map; zoomout_step: eigenfunctions added per
            ZoomOut iteration, up to ``zoomout_to``.
        weights: pyFM's ``fit`` weights (descriptor, Laplacian and descriptor commutativity, ...).
    """

    descriptors: int
    descriptor_step: int
    spectrum: int
    fmap_size: int
    zoomout_step: int
    zoomout_to: int
    weights: dict = field(default_factory=dict)


README_PIPELINE = PyfmPipeline(descriptors=100, descriptor_step=5, spectrum=128, fmap_size=35, zoomout_step=1,
                               zoomout_to=50, weights={"w_descr": 1.0, "w_lap": 1e-2, "w_dcomm": 1e-1, "w_orient": 0.0})
DENSE_PIPELINE = PyfmPipeline(descriptors=100, descriptor_step=5, spectrum=200, fmap_size=50, zoomout_step=10,
                              zoomout_to=200, weights={"w_descr": 1e0, "w_lap": 1e-2, "w_dcomm": 1e-1})
PYFM_SHIFT = -0.01  # the shift of pyFM's own laplacian_spectrum


def pyfm_mesh(mesh: Mesh, spectrum: tuple | None = None):
    """A ``pyFM.mesh.TriMesh`` of ``mesh``; ``spectrum`` ``(values, vectors)`` from
    :func:`pyfm_spectrum` saves computing the eigenpairs again."""
    trimesh_module = require("pyFM.mesh", "pyfm")
    tri = trimesh_module.TriMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    if spectrum is not None:
        tri.compute_operators()
        tri.eigenvalues = np.asarray(spectrum[0], dtype=np.float64)
        tri.eigenvectors = np.asarray(spectrum[1], dtype=np.float64)
    return tri


def pyfm_spectrum(mesh: Mesh, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(values (k,), vectors (n, k))``: pyfmaps' own eigenproblem of ``mesh`` (its cotangent
    operators, solved as its ``laplacian_spectrum`` does: ``eigsh`` about :data:`PYFM_SHIFT`),
    from a fixed start vector. pyFM lets ARPACK draw its start, whose state carries over from
    one call to the next in a process: the same pair's map changed at 1.5% of its vertices
    between two calls, and a bench's pyFM figures from one run to the next."""
    from scipy.sparse.linalg import eigsh

    tri = pyfm_mesh(mesh)
    tri.compute_operators()
    start = np.random.default_rng(START_SEED).uniform(-1.0, 1.0, mesh.n_vertices)
    try:
        values, vectors = eigsh(tri.stiffness, k=min(k, mesh.n_vertices - 2), M=tri.mass, sigma=PYFM_SHIFT, v0=start)
    except (RuntimeError, ValueError) as exc:  # pyFM would fall back on LOBPCG: its baseline stops here
        raise MeshError(mesh.name, f"pyFM's Laplace-Beltrami eigenproblem failed ({exc})") from None
    return np.asarray(values), np.asarray(vectors)


def pyfm_point_map(mesh_1: Mesh, mesh_2: Mesh, pipeline: PyfmPipeline = DENSE_PIPELINE,
                   landmarks_1: np.ndarray | None = None, landmarks_2: np.ndarray | None = None,
                   spectra: tuple = (None, None)) -> np.ndarray:
    """``(n1,)`` the vertex of ``mesh_2`` of every vertex of ``mesh_1`` by pyFM's pipeline.

    ``landmarks_i (k,)``: pairwise corresponding vertices (local indices), used as extra
    descriptors; ``spectra``: ``(values, vectors)`` of each mesh from :func:`pyfm_spectrum`, or
    ``None`` to compute them here (the same, seeded: the same map every call). Both meshes
    prepared and of area 1.
    """
    functional = require("pyFM.functional", "pyfm")
    spectra = tuple(pyfm_spectrum(mesh, pipeline.spectrum) if spectrum is None else spectrum
                    for mesh, spectrum in zip((mesh_1, mesh_2), spectra))
    # pyFM maps its second mesh's vertices onto its first: mesh 2 goes first.
    model = functional.FunctionalMapping(pyfm_mesh(mesh_2, spectra[1]), pyfm_mesh(mesh_1, spectra[0]))
    extra = {} if landmarks_1 is None else {"landmarks": np.stack([landmarks_2, landmarks_1], axis=1)}
    model.preprocess(n_descr=pipeline.descriptors, descr_type="WKS", subsample_step=pipeline.descriptor_step,
                     k_process=pipeline.spectrum, **extra)
    model.fit(K=(pipeline.fmap_size, pipeline.fmap_size), **pipeline.weights)
    refined = model.zoomout_refine(nit=(pipeline.zoomout_to - pipeline.fmap_size) // pipeline.zoomout_step,
                                   step=pipeline.zoomout_step)
    return np.asarray(model.get_p2p(refined), dtype=np.int64)
