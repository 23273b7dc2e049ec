"""The curvature descriptor on the Darcyan grid (the paper's section 2.3).

For each level curve k, the mean of kmax and of kmin over its intersection points with the
radial lines: ``[k1max, k1min, ..., knmax, knmin]``. A level whose points all left the surface
(a boundary closer than lambda_k) is NaN, and matching compares only the levels both have.

The mean over a level forgets the angle, and with it handedness: a left hand and a right hand
give the same descriptor. :func:`angular_profiles` keeps the angular variation of the innermost
levels, which :func:`darcyan.method.symmetry.handedness` compares in both turning senses.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..geometry.curvature import Curvatures
from ..geometry.mesh import Mesh
from .grid import DarcyanGrid


def curvature_samples(mesh: Mesh, grid: DarcyanGrid, curvatures: Curvatures) -> np.ndarray:
    """``(2, n, m * q)``: kmax and kmin at every point of one grid (1/mesh length; NaN where
    missing); the descriptor averages it over the angles, the angular profile keeps them."""
    return np.stack([grid.sample(mesh, curvatures.kmax), grid.sample(mesh, curvatures.kmin)])


def curvature_descriptor(mesh: Mesh, grid: DarcyanGrid, curvatures: Curvatures) -> np.ndarray:
    """``(2n,)`` descriptor ``[k1max, k1min, ..., knmax, knmin]`` of one grid (1/mesh length)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN levels stay NaN on purpose
        per_level = np.nanmean(curvature_samples(mesh, grid, curvatures), axis=2)  # (2, n)
    return per_level.T.reshape(-1)


def curvature_descriptors(mesh: Mesh, grids: list[DarcyanGrid], curvatures: Curvatures) -> np.ndarray:
    """``(k, 2n)`` descriptors of several grids."""
    if not grids:
        return np.zeros((0, 0))
    return np.stack([curvature_descriptor(mesh, g, curvatures) for g in grids])


def angular_profiles(mesh: Mesh, grids: list[DarcyanGrid], curvatures: Curvatures, levels: int) -> np.ndarray:
    """``(k, 2, levels, a)``: kmax and kmin at the grid points of the innermost ``levels`` level
    curves (all ``a = m * q`` radial lines, counter-clockwise about the outward normal from each
    grid's reference direction), each level's mean over the angles removed (that is the
    descriptor's part). NaN where a radial line left the surface."""
    if not grids:
        return np.zeros((0, 2, levels, 0))
    out = []
    for grid in grids:
        profile = curvature_samples(mesh, grid, curvatures)[:, :levels]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN levels stay NaN
            out.append(profile - np.nanmean(profile, axis=2, keepdims=True))
    return np.stack(out)
