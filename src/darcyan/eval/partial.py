"""Partial shapes for evaluation: cut a part away from a mesh, keep the map back to it.

A :class:`PartialMesh` is a mesh with some of its vertices removed, as a scanner or an editor
leaves it: an extremity cut away (:func:`cut_ball` around a tip), a plane cut through a limb
(:func:`cut_plane`), a hole where a scanner saw nothing (:func:`cut_ball` elsewhere). It keeps,
for each of its vertices, the vertex of the full mesh it came from (so the full mesh's ground
truth carries over: :func:`partial_truth`) and which of its vertices lie on the rim of the cut.
Lengths are in units of the square root of the full mesh's area.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeshError
from ..geometry.geodesics import GeodesicSolver
from ..geometry.mesh import Mesh, boundary_vertices
from .metrics import GroundTruth


@dataclass(frozen=True, eq=False)
class PartialMesh:
    """``mesh``: the full mesh without the removed vertices (and the faces touching them);
    ``kept (n,) int64``: the full mesh's vertex each of its ``n`` vertices is; ``rim (n,) bool``:
    on the cut's edge (a boundary the full mesh did not have); ``kind``: how it was cut."""

    mesh: Mesh
    kept: np.ndarray
    rim: np.ndarray
    kind: str

    def from_full(self, full_vertices) -> np.ndarray:
        """``(k,)`` the partial mesh's index of each full-mesh vertex (-1 where it was cut away)."""
        lookup = np.full(int(self.kept.max(initial=-1)) + 1, -1, dtype=np.int64)
        lookup[self.kept] = np.arange(len(self.kept))
        full_vertices = np.asarray(full_vertices, dtype=np.int64)
        inside = full_vertices < len(lookup)
        out = np.full(len(full_vertices), -1, dtype=np.int64)
        out[inside] = lookup[full_vertices[inside]]
        return out


def remove_vertices(mesh: Mesh, removed: np.ndarray, kind: str) -> PartialMesh:
    """``mesh`` without the vertices where ``removed (n,) bool`` holds nor the faces on them."""
    removed = np.asarray(removed, dtype=bool)
    faces = mesh.faces[~removed[mesh.faces].any(axis=1)]
    if len(faces) == 0:
        raise MeshError(mesh.name, f"cut '{kind}' removes the whole mesh")
    kept = np.unique(faces)
    renumber = np.full(mesh.n_vertices, -1, dtype=np.int64)
    renumber[kept] = np.arange(len(kept))
    partial = Mesh(mesh.vertices[kept], renumber[faces], name=f"{mesh.name} ({kind})")
    rim = boundary_vertices(partial) & ~boundary_vertices(mesh)[kept]
    return PartialMesh(partial, kept, rim, kind)


def cut_ball(mesh: Mesh, centre: int, radius: float, kind: str = "ball",
             solver: GeodesicSolver | None = None) -> PartialMesh:
    """Remove the geodesic disc of ``radius`` (sqrt(area) units) around vertex ``centre``."""
    solver = solver or GeodesicSolver(mesh)
    distance = solver.distance(int(centre)) / np.sqrt(mesh.area())
    return remove_vertices(mesh, distance < radius, kind)


def cut_plane(mesh: Mesh, tip: int, depth: float, kind: str = "plane",
              solver: GeodesicSolver | None = None) -> PartialMesh:
    """Cut the limb that ends at vertex ``tip`` by a plane, ``depth`` (sqrt(area) units) along it.

    The plane passes through the centre of the geodesic circle of radius ``depth`` around the
    tip, normal to the line from that centre to the tip; the part of the tip's side connected to
    the tip is removed (another limb that crosses the plane stays).
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    solver = solver or GeodesicSolver(mesh)
    distance = solver.distance(int(tip)) / np.sqrt(mesh.area())
    edges = mesh.edges()
    a, b = distance[edges[:, 0]] - depth, distance[edges[:, 1]] - depth
    crossing = a * b < 0  # the geodesic circle crosses these edges
    if not crossing.any():
        raise MeshError(mesh.name, f"no surface at geodesic distance {depth:g} from vertex {tip}")
    t = (a / (a - np.where(crossing, b, a - 1)))[crossing, None]
    points = (1 - t) * mesh.vertices[edges[crossing, 0]] + t * mesh.vertices[edges[crossing, 1]]
    centre = points.mean(axis=0)
    normal = mesh.vertices[tip] - centre
    side = (mesh.vertices - centre) @ normal > 0
    both = side[edges[:, 0]] & side[edges[:, 1]]
    graph = sp.coo_matrix((np.ones(both.sum()), (edges[both, 0], edges[both, 1])),
                          shape=(mesh.n_vertices, mesh.n_vertices))
    _, label = connected_components(graph, directed=False)
    return remove_vertices(mesh, side & (label == label[tip]), kind)


def rim_distance(partial: PartialMesh, solver: GeodesicSolver | None = None) -> np.ndarray:
    """``(n,)`` geodesic distance from each vertex of the partial mesh to the cut's rim, in units
    of the square root of the partial mesh's area (inf without a rim)."""
    rim = np.flatnonzero(partial.rim)
    if len(rim) == 0:
        return np.full(partial.mesh.n_vertices, np.inf)
    solver = solver or GeodesicSolver(partial.mesh)
    return solver.distance_multi(rim) / np.sqrt(partial.mesh.area())


def partial_truth(truth: GroundTruth, partial: PartialMesh, partial_is_source: bool = True) -> GroundTruth:
    """``truth`` between the full mesh and another shape, carried to the partial mesh: the listed
    samples that were cut away are left out (``partial_is_source``: the full mesh was the truth's
    source; else its target)."""
    if truth.source_samples is None:
        raise MeshError(partial.mesh.name, "partial ground truth needs sample lists (.vts), not the identity")
    own = truth.source_samples if partial_is_source else truth.target_samples
    other = truth.target_samples if partial_is_source else truth.source_samples
    mapped = partial.from_full(own)
    keep = mapped >= 0
    if partial_is_source:
        return GroundTruth(mapped[keep], other[keep])
    return GroundTruth(other[keep], mapped[keep])
