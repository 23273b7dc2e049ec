"""Denoising of surfaces crumpled at the scale of their edges (Taubin smoothing)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..config import Denoising
from .mesh import Mesh, vertex_adjacency

if TYPE_CHECKING:
    import scipy.sparse as sp

def _umbrella(mesh: Mesh) -> sp.csr_matrix:
    """The uniform-weight one-ring averaging operator (rows sum to 1)."""
    import scipy.sparse as sp

    adjacency = vertex_adjacency(mesh)
    degree = np.maximum(np.asarray(adjacency.sum(axis=1)).ravel(), 1)
    return sp.diags(1.0 / degree) @ adjacency


def surface_roughness(mesh: Mesh, average: sp.csr_matrix | None = None) -> float:
    """median |L L x| / median |L x| for the umbrella Laplacian L = average - identity.

    Dimensionless. On a smooth surface L x is the mean-curvature normal, itself smooth, so a second
    application shrinks it; on uncorrelated vertex noise L acts as on white noise and the ratio
    is ~1.25 whatever the noise's amplitude. ``average``: the mesh's umbrella operator, if built.
    """
    average = _umbrella(mesh) if average is None else average
    lx = average @ mesh.vertices - mesh.vertices
    llx = average @ lx - lx
    first = float(np.median(np.linalg.norm(lx, axis=1)))
    return float(np.median(np.linalg.norm(llx, axis=1))) / first if first > 0 else 0.0


def taubin_smooth(mesh: Mesh, steps: int, average: sp.csr_matrix | None = None,
                  denoising: Denoising = Denoising()) -> Mesh:
    """``steps`` Taubin lambda|mu smoothing steps with uniform one-ring weights; faces, vertex
    numbering and the map back to the input are kept. ``average``: the umbrella operator, if built
    (it depends on the connectivity only)."""
    average = _umbrella(mesh) if average is None else average
    v = mesh.vertices
    for _ in range(steps):
        v = v + denoising.taubin_lambda * (average @ v - v)
        v = v + denoising.taubin_mu * (average @ v - v)
    return mesh.with_vertices(v)


def denoise_mesh(mesh: Mesh, area_ratio: float, denoising: Denoising = Denoising()) -> tuple[Mesh, int, float]:
    """Smooth ``mesh`` when its surface is crumpled at the scale of its edges.

    Vertex noise inflates the surface area (2.5-fold at a noise of half an edge), which breaks the
    scale normalization and every length of the method. A clean mesh loses at most ~3% of its area
    to ``denoising.block`` Taubin steps (all TOSCA meshes, 5k and full resolution; coarse meshes of
    less than ~1000 vertices lose more); a noisy one much more. When the area exceeds
    ``area_ratio`` times the area after one block and the :func:`surface_roughness` is that of
    noise (above ``denoising.noise_roughness``), Taubin blocks are applied until a block shrinks the area by
    less than ``denoising.settled`` (at most ``denoising.max_steps`` steps). ``area_ratio`` <= 0
    disables the test.

    Returns the mesh to analyse (the input itself when left alone), the number of steps applied and
    the measured ratio (area / area after one block; NaN when the roughness test, which is checked
    first because it is 10 times cheaper, already rules noise out).
    """
    if area_ratio <= 0:
        return mesh, 0, float("nan")
    average = _umbrella(mesh)  # connectivity only: one operator for every step
    if surface_roughness(mesh, average) <= denoising.noise_roughness:
        return mesh, 0, float("nan")
    smoothed = taubin_smooth(mesh, denoising.block, average, denoising)
    previous = max(smoothed.area(), 1e-300)
    ratio = mesh.area() / previous
    if not ratio > area_ratio:
        return mesh, 0, ratio
    steps = denoising.block
    while steps < denoising.max_steps:
        smoothed = taubin_smooth(smoothed, denoising.block, average, denoising)
        steps += denoising.block
        area = max(smoothed.area(), 1e-300)
        settled, previous = previous / area < denoising.settled, area
        if settled:
            break
    return smoothed, steps, ratio
