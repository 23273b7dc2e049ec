"""The :class:`Mesh` type, its elementary measures (areas, edges, adjacency, boundary) and scale
normalization. File I/O is in :mod:`darcyan.io.mesh_files`, checks and repair in
:mod:`darcyan.geometry.repair`.

Readers are strict: a file whose header disagrees with its body, a number field holding text, a
face pointing at a vertex that does not exist, NaN coordinates and the like raise a
:class:`~darcyan.errors.MeshError` naming the file and the problem. Valid but imperfect meshes
(holes, several connected components) load; :func:`prepare_mesh` keeps the largest component and
warns about what it left out. Every derived mesh keeps ``input_index``, the index of each of its
vertices in the file it came from, so results can always be reported in the file's numbering.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import MeshError

if TYPE_CHECKING:
    import scipy.sparse as sp

# What Mesh.kept keeps that depends on the faces alone (Mesh.with_vertices carries it over).
TOPOLOGY_KEPT = ("_edge_counts", "_edges")


class MeshWarning(UserWarning):
    """Something valid but imperfect in the input was left out or changed."""


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh.

    Attributes:
        vertices: ``(n, 3) float64`` positions.
        faces: ``(m, 3) int64`` vertex indices, counter-clockwise seen from outside.
        name: where it came from (a file path, or a description), used in messages.
        input_index: ``(n,) int64``, for each vertex its index in the input file (identity for a
            mesh read as is; a subset after keeping the largest component or dropping vertices).
    """

    vertices: np.ndarray
    faces: np.ndarray
    name: str = "<mesh>"
    input_index: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Mesh({self.name!r}, {self.n_vertices} vertices, {self.n_faces} faces)"

    def __post_init__(self) -> None:
        v = np.ascontiguousarray(self.vertices, dtype=np.float64)
        f = np.ascontiguousarray(self.faces, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise MeshError(self.name, f"vertices must have shape (n, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise MeshError(self.name, f"faces must have shape (m, 3) (triangles), got {f.shape}")
        idx = self.input_index
        idx = np.arange(len(v), dtype=np.int64) if idx is None else np.asarray(idx, dtype=np.int64)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)
        object.__setattr__(self, "input_index", idx)

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def kept(self, key: str, compute):
        """``compute()``, once per mesh and ``key``, kept on the mesh (a mesh is not changed in
        place, so what is derived from it alone stays true): its measures and operators, read
        by every stage that works on it. What is kept is read-only (an array, or a sparse
        matrix's arrays) and travels with the mesh when it is pickled: a shape prepared in a
        worker process brings its operators back (a cotangent Laplacian is about 84 bytes a
        vertex), and they stay read-only there (:meth:`__setstate__`)."""
        cached = self.__dict__.get(key)
        if cached is None:
            cached = _read_only(compute())
            object.__setattr__(self, key, cached)
        return cached

    def __setstate__(self, state: dict) -> None:
        """Unpickled: what :meth:`kept` kept is made read-only again (pickling drops the flag)."""
        object.__setattr__(self, "__dict__", {key: _read_only(value) if key.startswith("_") else value
                                              for key, value in state.items()})

    def face_areas(self) -> np.ndarray:
        """``(m,)`` triangle areas (computed once, read-only: a mesh is not changed in place)."""
        return self.kept("_face_areas", lambda: face_areas(self.vertices, self.faces))

    def area(self) -> float:
        return float(self.face_areas().sum())

    def edge_counts(self) -> tuple[np.ndarray, np.ndarray]:
        """``(keys (e,), counts (e,))``: the unique undirected edges as sorted int64 keys ``lo *
        n_vertices + hi`` and how many faces use each (computed once, read-only): the edges,
        the boundary and the mesh checks all read them."""
        return self.kept("_edge_counts", lambda: _edge_counts(self.faces, self.n_vertices))

    def edges(self) -> np.ndarray:
        """``(e, 2)`` unique undirected edges, smaller index first, sorted (computed once, read-only)."""
        def edges():
            keys, _ = self.edge_counts()
            return np.stack([keys // max(self.n_vertices, 1), keys % max(self.n_vertices, 1)], axis=1)

        return self.kept("_edges", edges)

    def content_hash(self) -> str:
        """Hash of the geometry and connectivity (not the name): a cache key for per-shape work."""
        h = hashlib.sha1()
        h.update(self.vertices.tobytes())
        h.update(self.faces.tobytes())
        return h.hexdigest()

    def with_vertices(self, vertices: np.ndarray) -> "Mesh":
        """The same faces on other ``vertices`` ``(n, 3)``; what :meth:`kept` kept of the faces
        alone (the edges and their counts) carries over."""
        moved = Mesh(vertices, self.faces, self.name, self.input_index)
        for key in TOPOLOGY_KEPT:
            if key in self.__dict__:
                object.__setattr__(moved, key, self.__dict__[key])
        return moved


def _read_only(value):
    """``value`` with its arrays made read-only: an ndarray, a scipy sparse matrix's data and
    index arrays, those of a tuple's members (anything else as it is)."""
    if isinstance(value, tuple):
        return tuple(_read_only(part) for part in value)
    arrays = [value] if isinstance(value, np.ndarray) else [getattr(value, name, None)
                                                            for name in ("data", "indices", "indptr")]
    for array in arrays:
        if isinstance(array, np.ndarray):
            array.flags.writeable = False
    return value


def _edge_counts(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges of ``faces`` as sorted int64 keys ``lo * n_vertices + hi`` and how
    many faces use each (1-D keys: several times faster than ``np.unique(axis=0)`` on pairs)."""
    a, b = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    keys = np.minimum(a, b) * n_vertices + np.maximum(a, b)
    return np.unique(keys, return_counts=True)


def vertex_adjacency(mesh: Mesh) -> sp.csr_matrix:
    """``(n, n)`` symmetric 0/1 matrix: 1 where two vertices share an edge."""
    import scipy.sparse as sp  # lazily, like every scipy import: a cached match needs none

    n, e = mesh.n_vertices, mesh.edges()
    return sp.coo_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                         shape=(n, n)).tocsr()


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` areas of the triangles ``faces`` of ``vertices``."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def boundary_half_edges(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(tail, head)``: the face edges ``tail -> head`` (in their faces' direction) that no other
    face shares; both empty for a closed mesh (checked first: a 52k mesh in 5 ms)."""
    f, n = mesh.faces, mesh.n_vertices
    keys, counts = mesh.edge_counts()
    single = keys[counts == 1]  # sorted
    if not len(single):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    tail, head = f.ravel(), f[:, [1, 2, 0]].ravel()
    key = np.minimum(tail, head) * n + np.maximum(tail, head)
    once = single[np.minimum(np.searchsorted(single, key), len(single) - 1)] == key
    return tail[once], head[once]


def boundary_loop_vertices(mesh: Mesh) -> list:
    """Each boundary loop of a manifold, consistently oriented mesh as an array of its vertices in
    order, in the direction of its faces' edges (``loop[i] -> loop[i + 1]`` is an edge of a face;
    :func:`boundary_loops` labels the loops and gives their lengths)."""
    tail, head = boundary_half_edges(mesh)
    following = np.full(mesh.n_vertices, -1, dtype=np.int64)
    following[tail] = head
    loops, seen = [], np.zeros(mesh.n_vertices, bool)
    for start in tail:
        if seen[start]:
            continue
        loop = [start]
        seen[start] = True
        while following[loop[-1]] >= 0 and not seen[following[loop[-1]]]:
            loop.append(following[loop[-1]])
            seen[loop[-1]] = True
        loops.append(np.array(loop, dtype=np.int64))
    return loops


# ----------------------------------------------------------------------------------------------
# Scale normalization


@dataclass(frozen=True)
class Normalization:
    """``normalized = (input - centre) * scale``; ``scale = 1 / sqrt(area)``."""

    centre: np.ndarray
    scale: float

    def to_input_length(self, length):
        """A length on the normalized mesh in the input file's units."""
        return np.asarray(length) / self.scale


def normalize_mesh(mesh: Mesh) -> tuple[Mesh, Normalization]:
    """Centre ``mesh`` on its area-weighted centroid and scale it to total area 1 (the paper)."""
    areas = mesh.face_areas()
    total = float(areas.sum())
    if not total > 0:
        raise MeshError(mesh.name, "surface area is zero")
    centroids = mesh.vertices[mesh.faces].mean(axis=1)
    centre = (centroids * areas[:, None]).sum(axis=0) / total
    scale = 1.0 / np.sqrt(total)
    return mesh.with_vertices((mesh.vertices - centre) * scale), Normalization(centre, scale)


def local_index(mesh: Mesh, input_vertices) -> np.ndarray:
    """``(k,) int64``: for vertices given in the input's numbering, their index in ``mesh``
    (through ``mesh.input_index``; the first copy of a split vertex), -1 for a vertex ``mesh``
    does not hold."""
    lookup = np.full(int(mesh.input_index.max(initial=-1)) + 1, -1, dtype=np.int64)
    lookup[mesh.input_index[::-1]] = np.arange(mesh.n_vertices)[::-1]  # first copy wins
    input_vertices = np.asarray(input_vertices, dtype=np.int64).reshape(-1)
    inside = (input_vertices >= 0) & (input_vertices < len(lookup))
    out = np.full(len(input_vertices), -1, dtype=np.int64)
    out[inside] = lookup[input_vertices[inside]]
    return out


def boundary_vertices(mesh: Mesh) -> np.ndarray:
    """``(n,) bool``: vertices on an edge used by only one face."""
    n = mesh.n_vertices
    keys, counts = mesh.edge_counts()
    once = keys[counts == 1]
    mask = np.zeros(n, bool)
    mask[once // max(n, 1)] = True
    mask[once % max(n, 1)] = True
    return mask


def boundary_loops(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """The boundary's loops: ``label (n,) int64`` (-1 off the boundary, else the loop's number)
    and ``length (loops,)`` of each loop (mesh units). Loops that touch at a vertex count as one."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    n = mesh.n_vertices
    keys, counts = mesh.edge_counts()
    once = keys[counts == 1]
    a, b = once // max(n, 1), once % max(n, 1)
    label = np.full(n, -1, dtype=np.int64)
    if len(once) == 0:
        return label, np.zeros(0)
    on = np.unique(np.concatenate([a, b]))
    local = np.full(n, -1, dtype=np.int64)
    local[on] = np.arange(len(on))
    graph = sp.coo_matrix((np.ones(len(a)), (local[a], local[b])), shape=(len(on), len(on)))
    count, component = connected_components(graph, directed=False)
    label[on] = component
    lengths = np.bincount(component[local[a]], weights=np.linalg.norm(mesh.vertices[a] - mesh.vertices[b], axis=1),
                          minlength=count)
    return label, lengths


# ----------------------------------------------------------------------------------------------
