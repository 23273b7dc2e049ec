"""Heat on a surface: diffusion, the heat kernel's diagonal, and the curvature signature built
from them (the mean curvature diffused over a few lengths), used by feature points, the mirror
test and dense maps alike."""

from __future__ import annotations

import numpy as np

from ..config import HeatKernel, MirrorTest
from .curvature import principal_curvatures
from .mesh import Mesh
from .operators import mixed_voronoi_area


def heat_diffuse(mesh: Mesh, values: np.ndarray, length: float,
                 steps: int = HeatKernel().diffusion_steps) -> np.ndarray:
    """Diffuse ``values (n,)`` for the time that spreads heat over about ``length``: ``steps``
    backward Euler steps of du/dt = Laplace(u) with total time length**2 / 2 (one factorization),
    on the mesh's mixed Voronoi areas and cotangent Laplacian (kept on it: computed once)."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    from .operators import cotangent_laplacian

    area = mixed_voronoi_area(mesh)
    laplacian = cotangent_laplacian(mesh)
    step = length**2 / 2 / steps
    mass = sp.diags(area)
    solve = splu((mass - step * laplacian).tocsc()).solve
    for _ in range(steps):
        values = solve(mass @ values)
    return values


def heat_kernel_diagonal(mesh: Mesh, length: float, heat: HeatKernel = HeatKernel()) -> np.ndarray:
    """``(n,)`` ``k_t(v, v) = sum_i exp(-lambda_i t) phi_i(v)^2`` at ``t = length**2 / 2`` (the
    heat kernel signature at one time; 1/area units) from the Laplace-Beltrami eigenpairs whose
    ``exp(-lambda t)`` exceeds ``exp(-heat.decay)`` (Weyl's law: about
    ``heat.decay / (4 pi t)`` of them on a surface of area 1). Unlike the HKS baseline
    (:func:`darcyan.eval.baselines.heat_kernel_signature`: many times, scaled by the heat trace,
    without the constant eigenfunction) one time, unscaled, so that ratios between vertices are
    those of the kernel itself."""
    from .spectral import laplace_beltrami_spectrum

    time = length**2 / 2
    count = int(np.clip(np.ceil(heat.decay * mesh.area() / (4 * np.pi * time)), 10, 400))
    spectrum = laplace_beltrami_spectrum(mesh, count, tol=heat.tolerance)
    return (spectrum.vectors**2 * np.exp(-spectrum.values * time)).sum(axis=1)


def curvature_signature(mesh, mean_curvature: np.ndarray, lengths=MirrorTest().signature_lengths,
                        diffusion_steps: int = HeatKernel().diffusion_steps, known: dict | None = None) -> np.ndarray:
    """``(n, len(lengths))`` mean curvature diffused over each of ``lengths``, each scaled to mean
    magnitude 1 over the surface (weighted by the vertices' mixed Voronoi areas): a cheap,
    intrinsic, mirror-blind signature that differs between the front and the back of a torso or
    a limb. ``known``: columns already made for this mesh, curvature and steps, by length; those
    missing are made and added to it.

    The mean is over the area, not the vertices: a mesh whose vertices crowd where it curves (a
    decimated copy, whose collapses keep the fingers and the face) would otherwise be scaled by
    its curved parts, and two meshings of one surface would not compare (on faust-5k's
    mixed-resolution copies the signatures of corresponding points differed twice as much
    between a mesh and a decimated copy; ``docs/decisions/every-pair.md``)."""
    known = {} if known is None else known
    area = mixed_voronoi_area(mesh)
    for length in lengths:
        if length not in known:
            c = heat_diffuse(mesh, mean_curvature, length, diffusion_steps)
            known[length] = c / max(float(np.abs(c) @ area / area.sum()), 1e-12)
    return np.stack([known[length] for length in lengths], axis=1)


def shape_signature(shape, proxy_vertices: int, lengths, steps: int, smoothing: int) -> np.ndarray:
    """``(n, len(lengths))`` :func:`curvature_signature` of a prepared shape (Meyer curvatures
    after ``smoothing`` averagings, ``steps`` diffusion steps), on its coarse proxy of about
    ``proxy_vertices`` vertices (:meth:`~darcyan.geometry.shape.Shape.proxy`; read back at every
    vertex) when it has one, else on the mesh itself (also with ``proxy_vertices`` 0). Each
    length's column is made once per shape and proxy: the mirror test's signature and a dense
    map's share two of their lengths."""
    proxy = shape.proxy(proxy_vertices) if proxy_vertices > 0 else None
    known = shape.derived(("diffused mean curvature", 0 if proxy is None else proxy_vertices, smoothing, steps), dict)
    if proxy is None:
        return curvature_signature(shape.mesh, shape.curvatures(smoothing).mean, lengths, steps, known)
    coarse_mean = None if set(lengths) <= known.keys() else principal_curvatures(proxy.mesh, smoothing=smoothing).mean
    return proxy.to_full(curvature_signature(proxy.mesh, coarse_mean, lengths, steps, known))
