"""Checks and repair of a mesh before analysis: strict checks, repairable defects, largest
component, consistent and outward orientation."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import MeshError
from .mesh import Mesh, MeshWarning, _edge_counts

MIN_VERTICES = 4
MIN_FACES = 2
# A face is degenerate when its area is below this fraction of the mean face area.
DEGENERATE_AREA_FRACTION = 1e-12



@dataclass
class MeshReport:
    """What :func:`inspect_mesh` found. Counts refer to the mesh as given."""

    duplicate_faces: np.ndarray  # indices of faces repeating an earlier face
    degenerate_faces: np.ndarray  # repeated corner or (near) zero area
    unreferenced_vertices: np.ndarray
    nonmanifold_edges: int


def check_mesh(mesh: Mesh) -> None:
    """Raise :class:`MeshError` for input no computation can use.

    Checks shape and size, finite coordinates and face indices in range. Repairable defects
    (duplicate or degenerate faces, unreferenced vertices, non-manifold edges) are left to
    :func:`prepare_mesh`.
    """
    if mesh.n_vertices == 0 or mesh.n_faces == 0:
        raise MeshError(mesh.name, f"empty mesh ({mesh.n_vertices} vertices, {mesh.n_faces} faces)")
    if mesh.n_vertices < MIN_VERTICES or mesh.n_faces < MIN_FACES:
        raise MeshError(mesh.name, f"mesh too small ({mesh.n_vertices} vertices, {mesh.n_faces} faces)")
    finite = np.isfinite(mesh.vertices).all(axis=1)
    if not finite.all():
        first = int(np.flatnonzero(~finite)[0])
        raise MeshError(mesh.name, f"{int((~finite).sum())} vertices have NaN or infinite coordinates "
                                   f"(first: vertex {first})")
    low, high = int(mesh.faces.min()), int(mesh.faces.max())
    if low < 0:
        raise MeshError(mesh.name, f"negative vertex index {low} in faces")
    if high >= mesh.n_vertices:
        raise MeshError(mesh.name, f"face index {high} out of range: the mesh has {mesh.n_vertices} vertices")


def inspect_mesh(mesh: Mesh) -> MeshReport:
    """Find the defects :func:`prepare_mesh` can repair or must refuse."""
    faces = mesh.faces
    sorted_faces = np.sort(faces, axis=1)
    order = np.lexsort(sorted_faces.T[::-1])  # stable: the first of equal faces comes first
    ranked = sorted_faces[order]
    duplicate = np.sort(order[1:][(ranked[1:] == ranked[:-1]).all(axis=1)])
    areas = mesh.face_areas()
    mean_area = areas.mean() if len(areas) else 0.0
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    degenerate = np.flatnonzero(repeated | (areas <= DEGENERATE_AREA_FRACTION * mean_area))
    used = np.zeros(mesh.n_vertices, bool)
    used[faces.ravel()] = True
    keep = np.ones(len(faces), bool)
    keep[duplicate] = False
    keep[degenerate] = False
    _, counts = _edge_counts(faces[keep], mesh.n_vertices)
    return MeshReport(duplicate, degenerate, np.flatnonzero(~used), int((counts > 2).sum()))


def prepare_mesh(mesh: Mesh, repair: bool = False) -> tuple[Mesh, list[str]]:
    """Make ``mesh`` ready for analysis: checked, optionally repaired, largest component only.

    Without ``repair``, duplicate faces, degenerate faces, unreferenced vertices and
    inconsistently oriented faces are errors that name the fix; with it the first three are
    dropped, the faces reoriented, and each change described in the returned list. Non-manifold
    edges and vertices are always an error (no safe automatic fix). With several connected components the
    largest (by area) is kept and a :class:`MeshWarning` says how much was left out.

    Returns:
        The prepared mesh (``input_index`` maps back to ``mesh``'s input numbering) and a list of
        human-readable changes.
    """
    check_mesh(mesh)
    report = inspect_mesh(mesh)
    changes: list[str] = []
    problems = []
    if len(report.duplicate_faces):
        problems.append(f"{len(report.duplicate_faces)} duplicate faces")
    if len(report.degenerate_faces):
        problems.append(f"{len(report.degenerate_faces)} degenerate (zero-area) faces")
    if len(report.unreferenced_vertices):
        problems.append(f"{len(report.unreferenced_vertices)} unreferenced vertices")
    if problems and not repair:
        raise MeshError(mesh.name, ", ".join(problems) + " (use --repair / repair=True to drop them)")
    if report.nonmanifold_edges:
        raise MeshError(mesh.name, f"{report.nonmanifold_edges} non-manifold edges (shared by more "
                                   f"than two faces); fix them in a mesh editor")
    faces = mesh.faces
    if problems:
        keep = np.ones(len(faces), bool)
        keep[report.duplicate_faces] = False
        keep[report.degenerate_faces] = False
        faces = faces[keep]
        changes = [f"dropped {p}" for p in problems]
    mesh = _largest_component(Mesh(mesh.vertices, faces, mesh.name, mesh.input_index))
    _check_vertex_manifold(mesh)
    if repair and not _consistently_oriented(mesh.faces, mesh.n_vertices):
        mesh, flipped = _orient_consistently(mesh)
        changes.append(f"reoriented {flipped} faces to agree with their neighbours")
    mesh = _orient_outward(mesh)
    return mesh, changes


def _largest_component(mesh: Mesh) -> Mesh:
    """Keep the largest connected component by area; drop vertices no face uses."""
    n = mesh.n_vertices
    f = mesh.faces
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    graph = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    n_comp, labels = connected_components(graph, directed=False)
    face_label = labels[f[:, 0]]
    areas = mesh.face_areas()
    comp_area = np.bincount(face_label, weights=areas, minlength=n_comp)
    best = int(np.argmax(comp_area))
    keep_faces = face_label == best
    n_face_comps = len(np.unique(face_label))
    if n_face_comps > 1:
        left = comp_area.sum() - comp_area[best]
        warnings.warn(
            f"{mesh.name}: {n_face_comps} connected components; using the largest, leaving out "
            f"{n_face_comps - 1} components with {int((~keep_faces).sum())} faces "
            f"({100 * left / comp_area.sum():.1f}% of the area)", MeshWarning, stacklevel=3)
    return _submesh(mesh, keep_faces)


def _submesh(mesh: Mesh, keep_faces: np.ndarray) -> Mesh:
    faces = mesh.faces[keep_faces]
    used = np.unique(faces)
    remap = np.full(mesh.n_vertices, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return Mesh(mesh.vertices[used], remap[faces], mesh.name, mesh.input_index[used])


def _check_vertex_manifold(mesh: Mesh) -> None:
    """Refuse a vertex whose faces form more than one fan (a 'bow tie'): the solvers cannot."""
    bad = nonmanifold_vertices(mesh)
    if len(bad):
        raise MeshError(mesh.name, f"{len(bad)} non-manifold vertices (faces meeting only at a "
                                   f"vertex, first: {int(mesh.input_index[bad[0]])})")


def nonmanifold_vertices(mesh: Mesh) -> np.ndarray:
    """Vertices whose faces form more than one fan (edge-manifold input assumed)."""
    f = mesh.faces
    n_faces = len(f)
    # Half-edge h = 3t + i runs from corner h (vertex f[t, i]) to corner nxt[h] of the same face.
    start = f.ravel()
    nxt = np.arange(3 * n_faces).reshape(-1, 3)[:, [1, 2, 0]].ravel()
    end = start[nxt]
    key = np.minimum(start, end) * mesh.n_vertices + np.maximum(start, end)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    h1, h2 = order[:-1][same], order[1:][same]  # the two half-edges of each interior edge
    # Link the corners of the two faces at each end point of their shared edge.
    opposite = start[h1] == end[h2]  # the faces run the edge in opposite directions (usual case)
    rows = np.concatenate([h1, nxt[h1]])
    cols = np.concatenate([np.where(opposite, nxt[h2], h2), np.where(opposite, h2, nxt[h2])])
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    graph = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * n_faces, 3 * n_faces))
    _, fan = connected_components(graph, directed=False)
    fans = np.unique(f.ravel() * (3 * n_faces) + fan)  # distinct (vertex, fan) pairs
    return np.flatnonzero(np.bincount(fans // (3 * n_faces), minlength=mesh.n_vertices) > 1)


def _consistently_oriented(faces: np.ndarray, n_vertices: int) -> bool:
    """True when no directed edge is used by two faces (neighbours agree on orientation)."""
    directed = faces.ravel() * n_vertices + faces[:, [1, 2, 0]].ravel()
    directed = np.sort(directed)
    return not (directed[1:] == directed[:-1]).any()


def _orient_consistently(mesh: Mesh) -> tuple[Mesh, int]:
    """Flip faces so that neighbours agree (breadth-first over each component), keeping the
    orientation of the majority of the input's faces; returns the mesh and the flip count."""
    import igl

    faces, _ = igl.bfs_orient(mesh.faces)
    faces = np.asarray(faces, dtype=np.int64)
    flipped = (faces != mesh.faces).any(axis=1)
    if flipped.sum() * 2 > len(faces):
        faces, flipped = faces[:, ::-1].copy(), ~flipped
    return Mesh(mesh.vertices, faces, mesh.name, mesh.input_index), int(flipped.sum())


def _orient_outward(mesh: Mesh) -> Mesh:
    """Flip all faces if a closed mesh encloses negative volume (inward-facing normals)."""
    f = mesh.faces
    _, counts = _edge_counts(f, mesh.n_vertices)
    if not _consistently_oriented(f, mesh.n_vertices):
        raise MeshError(mesh.name, "faces are not consistently oriented (an edge is used twice in "
                                   "the same direction); use --repair / repair=True to reorient them")
    closed = bool((counts == 2).all())
    if closed:
        v = mesh.vertices
        volume = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6.0
        if volume < 0:
            return Mesh(mesh.vertices, f[:, ::-1].copy(), mesh.name, mesh.input_index)
    return mesh


