"""The final step of a dense map: the source deformed onto the target, then read out in space.

ZoomOut's map is intrinsic: between two bodies, or two meshings of one, the most isometric map
is not the true one, and intrinsic refinements drift towards it (``docs/decisions/``). Here
the source mesh is deformed as rigidly as possible towards the images of its vertices
(:class:`~darcyan.geometry.deformation.ArapDeformation`: it follows the map on the scale of
limbs and keeps its own shape below it, bends and turns included), and each source vertex is
sent to the target vertex nearest its deformed position and normal. Repeated a few times,
each round's map pulls the next deformation. Where two parts lie side by side (fingers), the
nearest point in space may lie on the wrong one: an image whose geodesic distances to the
landmarks disagree with the source vertex's clearly more than ZoomOut's image's did is not taken.

On a large source the deformation is that of its coarse copy
(:meth:`~darcyan.geometry.shape.Shape.proxy`), whose points under the full mesh's vertices are
pulled towards their images; each full vertex then moves with the point of the copy under it,
keeping its offset from the copy (the detail the copy lacks). The limbs' bends and turns are
far coarser than the copy's edges, and the copy has a ninth of the unknowns of a 52k-vertex source
(a 35th of a 210k one).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..geometry.deformation import ArapDeformation
from ..geometry.geodesics import vertex_normals
from ..geometry.knn import nearest_rows
from ..geometry.mesh import Mesh
from .config import DenseConfig

if TYPE_CHECKING:
    import scipy.sparse as sp


@dataclass(frozen=True)
class Alignment:
    """What :func:`align` made: ``map_12 (n1,)`` the aligned map, and ``residual``: how far the
    last deformation stayed from the images it was pulled towards (area-weighted mean distance,
    sqrt(area) units; NaN without alignment). A map that an as-rigid-as-possible deformation can
    follow (an isometry, or near one) leaves a small residual; one that would need the source
    mirrored or torn (a left-right or front-back flip, limbs sent to other limbs) a large one."""

    map_12: np.ndarray
    residual: float


def aligned_map(shape_1, shape_2, map_12: np.ndarray, config: DenseConfig = DenseConfig(),
                fields_1: np.ndarray | None = None, fields_2: np.ndarray | None = None) -> np.ndarray:
    """:func:`align`'s map alone."""
    return align(shape_1, shape_2, map_12, config, fields_1, fields_2).map_12


def align(shape_1, shape_2, map_12: np.ndarray, config: DenseConfig = DenseConfig(),
          fields_1: np.ndarray | None = None, fields_2: np.ndarray | None = None) -> Alignment:
    """``(n1,) int64``: ``map_12 (n1,)`` (for each vertex of ``shape_1``'s mesh one of
    ``shape_2``'s) after ``config.alignment_rounds`` rounds of deformation and nearest points
    (unchanged with 0 rounds). With the geodesic distances to the landmarks on both shapes
    (``fields_1 (n1, k)``, ``fields_2 (n2, k)``), a vertex keeps its image in ``map_12`` where
    the new image's distances differ from its own by more than ``config.alignment_slack``
    beyond those of the old image (the largest difference over the landmarks). ``map_12`` must
    map every vertex (no :data:`~darcyan.dense.maps.UNMAPPED`). Memory and time O(n1 + n2) (times
    k) beside the deformation's sparse factorization, kept with ``shape_1``."""
    if config.alignment_rounds == 0:
        return Alignment(map_12, float("nan"))
    start = map_12
    length, weight = config.alignment_length, config.alignment_normal_weight
    deformation, lift = _deformation(shape_1, length, config.alignment_proxy_vertices, config.alignment_stretch)
    target = np.hstack([shape_2.mesh.vertices, weight * shape_2.normals])
    fitted, turns = None, None
    for _ in range(config.alignment_rounds):
        pulled_to = shape_2.mesh.vertices[map_12]
        fitted = deformation.fit(lift.unlifted(pulled_to, turns), config.alignment_iterations, start=fitted)
        turns = lift.turns(deformation, fitted)
        positions = lift.lifted(fitted, turns)
        normals = vertex_normals(Mesh(positions, shape_1.mesh.faces))
        map_12 = nearest_rows(target, np.hstack([positions, weight * normals]))
    if fields_1 is not None and fields_2 is not None and fields_1.shape[1] > 0:
        before = np.abs(fields_1 - fields_2[start]).max(axis=1)
        after = np.abs(fields_1 - fields_2[map_12]).max(axis=1)
        map_12 = np.where(after > before + config.alignment_slack, start, map_12)
    areas = shape_1.vertex_areas / shape_1.vertex_areas.sum()
    residual = float(areas @ np.linalg.norm(positions - pulled_to, axis=1))
    return Alignment(map_12, residual)


@dataclass(frozen=True)
class _Lift:
    """How the deformed mesh's positions become the source's: the identity, or the coarse
    copy's positions interpolated at the full vertices (``interpolation (n1, n_proxy)``) plus
    each vertex's ``offset (n1, 3)`` from the copy at rest, turned with the copy around it (so
    that a rigid motion of the copy moves the source rigidly, its detail included; where the
    copy's one-rings turn unlike each other, the blend of their rotations is not quite one, and
    shortens the offset a little). The offsets turn but keep their length when the copy's
    one-rings may stretch (``DenseConfig.alignment_stretch``): a scale s leaves about (s - 1)
    times an offset, at most 0.003 sqrt(area) on the test figure's copy, unfollowed."""

    interpolation: sp.csr_matrix | None = None
    offset: np.ndarray | None = None

    def turns(self, deformation: ArapDeformation, positions: np.ndarray) -> np.ndarray | None:
        """``(n1, 3, 3)`` the copy's one-ring rotations for its ``positions``, interpolated at
        the source's vertices (``None`` without a copy)."""
        if self.interpolation is None:
            return None
        rotations = deformation.rotations(positions)
        return (self.interpolation @ rotations.reshape(len(rotations), 9)).reshape(-1, 3, 3)

    def lifted(self, positions: np.ndarray, turns: np.ndarray | None) -> np.ndarray:
        """``(n1, 3)`` the source's positions for the deformed mesh's ``positions``."""
        if self.interpolation is None:
            return positions
        return self.interpolation @ positions + self._turned(turns)

    def unlifted(self, targets: np.ndarray, turns: np.ndarray | None) -> np.ndarray:
        """``(n1, 3)`` the targets of the deformed mesh's points under the source's vertices
        (``turns``: the last fit's, ``None`` at rest)."""
        return targets if self.interpolation is None else targets - self._turned(turns)

    def _turned(self, turns: np.ndarray | None) -> np.ndarray:
        return self.offset if turns is None else np.einsum("nab,nb->na", turns, self.offset)


def _deformation(shape_1, length: float, proxy_vertices: int, stretch: float = 0.0) -> tuple:
    """``(ArapDeformation, _Lift)`` of ``shape_1``, built once per shape, length, proxy size and stretch:
    on the mesh itself, or on its coarse copy of about ``proxy_vertices`` vertices when it has
    one (``proxy_vertices`` 0: never)."""
    proxy = shape_1.proxy(proxy_vertices) if proxy_vertices > 0 else None
    if proxy is None:
        return shape_1.derived(("arap", length, stretch), lambda: (ArapDeformation(
            shape_1.mesh.vertices, shape_1.laplacian, shape_1.vertex_areas, length, stretch=stretch), _Lift()))

    def build():
        from ..geometry.operators import cotangent_laplacian

        interpolation = proxy.interpolation()
        coarse = proxy.mesh
        # the full vertices are the points pulled, each with its own area
        deformation = ArapDeformation(coarse.vertices, cotangent_laplacian(coarse), shape_1.vertex_areas, length,
                                      sampling=interpolation, stretch=stretch)
        return deformation, _Lift(interpolation, shape_1.mesh.vertices - interpolation @ coarse.vertices)

    return shape_1.derived(("arap", length, proxy_vertices, stretch), build)
