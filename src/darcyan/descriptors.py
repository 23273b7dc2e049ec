"""The curvature descriptor on the Darcyan grid (the paper's section 2.3).

For each level curve k, the mean of kmax and of kmin over its intersection points with the
radial lines: ``[k1max, k1min, ..., knmax, knmin]``. A level whose points all left the surface
(a boundary closer than lambda_k) is NaN, and matching compares only the levels both have.
"""

from __future__ import annotations

import warnings

import numpy as np

from .curvature import Curvatures
from .grid import DarcyanGrid
from .mesh import Mesh


def curvature_descriptor(mesh: Mesh, grid: DarcyanGrid, curvatures: Curvatures) -> np.ndarray:
    """``(2n,)`` descriptor ``[k1max, k1min, ..., knmax, knmin]`` of one grid (1/mesh length)."""
    kmax = grid.sample(mesh, curvatures.kmax)
    kmin = grid.sample(mesh, curvatures.kmin)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN levels stay NaN on purpose
        per_level = np.stack([np.nanmean(kmax, axis=1), np.nanmean(kmin, axis=1)], axis=1)
    return per_level.reshape(-1)


def curvature_descriptors(mesh: Mesh, grids: list[DarcyanGrid], curvatures: Curvatures) -> np.ndarray:
    """``(k, 2n)`` descriptors of several grids."""
    if not grids:
        return np.zeros((0, 0))
    return np.stack([curvature_descriptor(mesh, g, curvatures) for g in grids])
