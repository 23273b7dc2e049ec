"""Checks and repair of a mesh before analysis.

:func:`prepare_mesh` takes a mesh as read from a file to one the solvers accept (potpourri3d's
fast marching and geodesic tracing build a manifold, consistently oriented halfedge mesh and
refuse anything else), in this order:

1. strict checks (:func:`check_mesh`): size, finite coordinates, face indices in range;
2. coincident vertices on the boundary: welded under ``repair`` (:func:`weld_vertices`); a
   triangle soup (faces that share no vertex) or a surface split along seams is refused without
   it, with a message saying so;
3. ordinary imperfections (:func:`inspect_mesh`): duplicate and degenerate faces, unreferenced
   vertices, non-manifold edges (more than two faces on one edge): faces and vertices dropped and
   edges split apart, each with a note; refused only under ``Repairing.strict`` (``--strict``);
4. non-manifold vertices (fans of faces meeting only at one vertex, "bow ties") are always split,
   one copy of the vertex per fan (:func:`split_nonmanifold`), with a :class:`MeshWarning`;
5. the largest connected component, with a warning about what was left out;
6. orientation: made consistent (unless strict), and a surface that cannot be oriented cut
   open where its faces disagree; then small holes
   closed (:func:`fill_small_holes`) and the faces turned outward
   (:func:`orient_outward`; the cuts left are closed for that test by a fan across each, a patch
   is left as it comes), each with a note.

Every vertex keeps ``input_index``, its index in the input, through all of them: a welded vertex
takes the smallest index of its group, every copy of a split vertex the index of the original.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..config import Repairing
from ..errors import MeshError
from .mesh import Mesh, MeshWarning, _edge_counts, boundary_loop_vertices, boundary_vertices, face_areas, vertex_adjacency

MIN_VERTICES = 4
MIN_FACES = 2
# A mesh is taken for a triangle soup when more than this fraction of its faces are components of
# a single face: its largest component would be one triangle.
SOUP_FRACTION = 0.5
# Rounds of dropping faces on edges that splitting left non-manifold (a fan running around a
# vertex that passes one edge twice): a last resort, never needed by tosca-5k and faust-5k
# decimated to 10%..1% of their vertices nor by thousands of randomly pinched spheres and tori.
TANGLE_ROUNDS = 3
# Below this many vertices a face's sorted corners fit one int64 key (n**3 < 2**63).
ONE_KEY_VERTICES = 2**21


@dataclass
class MeshReport:
    """What :func:`inspect_mesh` found. Counts refer to the mesh as given."""

    duplicate_faces: np.ndarray  # indices of faces repeating an earlier face
    degenerate_faces: np.ndarray  # repeated corner or (near) zero area
    unreferenced_vertices: np.ndarray
    nonmanifold_edges: int  # edges of more than two faces, not counting duplicate or degenerate ones


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


def inspect_mesh(mesh: Mesh, degenerate_area: float = Repairing().degenerate_area) -> MeshReport:
    """Find the defects :func:`prepare_mesh` can repair or must refuse (a face is degenerate
    below ``degenerate_area`` times the mean face area)."""
    faces = mesh.faces
    sorted_faces = np.sort(faces, axis=1)
    if mesh.n_vertices < ONE_KEY_VERTICES:  # one int64 key per face sorts 4x faster than lexsort
        n = mesh.n_vertices
        order = np.argsort((sorted_faces[:, 0] * n + sorted_faces[:, 1]) * n + sorted_faces[:, 2], kind="stable")
    else:
        order = np.lexsort(sorted_faces.T[::-1])  # stable: the first of equal faces comes first
    ranked = sorted_faces[order]
    duplicate = np.sort(order[1:][(ranked[1:] == ranked[:-1]).all(axis=1)])
    areas = mesh.face_areas()
    mean_area = areas.mean() if len(areas) else 0.0
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    degenerate = np.flatnonzero(repeated | (areas <= degenerate_area * mean_area))
    used = np.zeros(mesh.n_vertices, bool)
    used[faces.ravel()] = True
    keep = np.ones(len(faces), bool)
    keep[duplicate] = False
    keep[degenerate] = False
    _, counts = mesh.edge_counts() if keep.all() else _edge_counts(faces[keep], mesh.n_vertices)
    return MeshReport(duplicate, degenerate, np.flatnonzero(~used), int((counts > 2).sum()))


def prepare_mesh(mesh: Mesh, repair: bool = False, settings: Repairing = Repairing()) -> tuple[Mesh, list[str]]:
    """Make ``mesh`` ready for analysis (see the module docstring for the steps).

    Duplicate faces, degenerate faces, unreferenced vertices, non-manifold edges and
    inconsistently oriented faces are repaired (faces and vertices dropped, edges split, faces
    reoriented, a surface that cannot be oriented cut open), each change described in the
    returned list; under ``settings.strict`` they are errors. A triangle soup and a surface
    split along seams are refused without ``repair``, which welds coincident boundary vertices. Non-manifold vertices are split
    either way, and with several connected components the largest (by area) is kept, each with a
    :class:`MeshWarning`.

    Returns:
        The prepared mesh (``input_index`` maps back to ``mesh``'s input numbering) and a list of
        human-readable changes.
    """
    check_mesh(mesh)
    changes: list[str] = []
    ordinary = not settings.strict  # the ordinary imperfections are repaired unless strict (repair or not)
    if repair:
        before = mesh.n_vertices
        mesh = weld_vertices(mesh, settings.weld_tolerance)
        if mesh.n_vertices < before:
            changes.append(f"welded {before - mesh.n_vertices} coincident vertices into others "
                           f"({mesh.n_vertices} vertices left)")
    _refuse_soup(mesh, repair, settings.weld_tolerance)
    if not repair:
        _refuse_seams(mesh)

    report = inspect_mesh(mesh, settings.degenerate_area)
    droppable = []
    if len(report.duplicate_faces):
        droppable.append(f"{len(report.duplicate_faces)} duplicate faces")
    if len(report.degenerate_faces):
        droppable.append(f"{len(report.degenerate_faces)} degenerate (zero-area) faces")
    if len(report.unreferenced_vertices):
        droppable.append(f"{len(report.unreferenced_vertices)} unreferenced vertices")
    edges = f"{report.nonmanifold_edges} non-manifold edges (more than two faces on one edge)"
    if not ordinary and (droppable or report.nonmanifold_edges):
        problems = droppable + [edges] * bool(report.nonmanifold_edges)
        fix = "dropped or split" if report.nonmanifold_edges else "dropped"
        raise MeshError(mesh.name, ", ".join(problems) + f" (refused as strict; by default they are {fix})")
    if droppable:
        keep = np.ones(mesh.n_faces, bool)
        keep[report.duplicate_faces] = False
        keep[report.degenerate_faces] = False
        mesh = Mesh(mesh.vertices, mesh.faces[keep], mesh.name, mesh.input_index)
        changes += [f"dropped {p}" for p in droppable]  # unreferenced vertices: by the next step

    mesh, dropped = split_nonmanifold(mesh)
    if report.nonmanifold_edges:
        changes.append(f"split {edges} into pairs of faces"
                       + (f", dropping {dropped} faces they could not be split from" if dropped else ""))
    mesh = _largest_component(mesh)

    if not _consistently_oriented(mesh.faces, mesh.n_vertices):
        if not ordinary:
            raise MeshError(mesh.name, "faces are not consistently oriented (an edge is used twice in "
                                       "the same direction; refused as strict, by default they are reoriented)")
        mesh, flipped = _orient_consistently(mesh)
        changes.append(f"reoriented {flipped} faces to agree with their neighbours")
        if not _consistently_oriented(mesh.faces, mesh.n_vertices):
            mesh, cut = _cut_where_orientations_disagree(mesh)
            changes.append(f"dropped {cut} faces along edges where no choice of face orientations agrees "
                           f"(the surface as given is not orientable: a Moebius strip, or faces folded over)")
    mesh, cut_lengths, handles_left = cut_handles(mesh, settings.handle_length, settings.handle_roots)
    if cut_lengths:
        shown = ", ".join(f"{length:.3g}" for length in cut_lengths)
        changes.append(f"cut {len(cut_lengths)} handle{'s' * (len(cut_lengths) > 1)} open (parts joined where they "
                       f"touch?) along the shortest loop around each, {shown} sqrt(area) long")
    if handles_left:
        changes.append(f"left {handles_left} handle{'s' * (handles_left > 1)} as {'they are' if handles_left > 1 else 'it is'}: "
                       f"no loop found around {'them' if handles_left > 1 else 'it'} that is shorter than "
                       f"{settings.handle_length:g} sqrt(area) and cuts {'them' if handles_left > 1 else 'it'} open")
    mesh, holes, added, loops = cap_small_holes(mesh, settings)
    if holes:
        changes.append(f"closed {holes} small hole{'s' * (holes > 1)} (boundary loops of at most "
                       f"{settings.hole_edges} edges, shorter than {settings.hole_length:g} sqrt(area)) "
                       f"with {added} faces between their own vertices")
    outward = orient_outward(mesh, settings.outward_cap_share, loops)
    if outward is not mesh:
        changes.append("flipped every face: the surface was inside out (its faces enclosed a negative volume)")
    return outward, changes


# ----------------------------------------------------------------------------------------------
# Coincident vertices and triangle soups


def weld_vertices(mesh: Mesh, tolerance: float = Repairing().weld_tolerance) -> Mesh:
    """``mesh`` with boundary vertices closer than ``tolerance`` times the mean edge length made one.

    Only vertices on the boundary (on an edge of one face) are welded: that is where copies of
    one vertex leave a seam open, or every edge of a triangle soup. Two coincident vertices inside
    a closed surface are two points of it that touch (three faust-5k meshes have such a pair), and
    welding them would pinch it. Each group of coincident vertices (chained: within tolerance of
    one another) becomes its member of smallest ``input_index``, which keeps its position and
    index; the others are dropped and their faces renumbered (faces this collapses are left to
    :func:`inspect_mesh`). Returns ``mesh`` itself when nothing is welded, or ``tolerance`` is 0.
    """
    open_ = np.flatnonzero(boundary_vertices(mesh))
    if not len(open_) or tolerance <= 0:
        return mesh  # closed: nothing to weld (and no need to import scipy.spatial, 0.1-0.2 s)
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    v, f, n = mesh.vertices, mesh.faces, mesh.n_vertices
    mean_edge = float(np.linalg.norm(v[f] - v[f[:, [1, 2, 0]]], axis=2).mean())
    pairs = open_[cKDTree(v[open_]).query_pairs(tolerance * mean_edge, output_type="ndarray")]
    if not len(pairs):
        return mesh
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, group = connected_components(graph, directed=False)
    by_group = np.lexsort((mesh.input_index, group))  # each group's smallest input index first
    first = np.r_[True, group[by_group][1:] != group[by_group][:-1]]
    representative = np.empty(group.max() + 1, dtype=np.int64)
    representative[group[by_group[first]]] = by_group[first]
    kept = np.sort(by_group[first])  # the survivors, in their original order
    new_index = np.full(n, -1, dtype=np.int64)
    new_index[kept] = np.arange(len(kept))
    faces = new_index[representative[group]][f]
    return Mesh(v[kept], faces, mesh.name, mesh.input_index[kept])


def _refuse_seams(mesh: Mesh) -> None:
    """Refuse (without repair) a mesh whose boundary vertices lie at exactly the same points: a
    file split along seams (for textures, or by the program that wrote it) is one surface cut
    open, and taken as it comes its seams would be read as the rims of cuts and its pieces as
    components to leave out. (Exact copies, as writers make them: the search within the welding
    tolerance needs scipy.spatial, whose import costs a cold match 0.1-0.2 s.)"""
    open_ = np.flatnonzero(boundary_vertices(mesh))
    if len(open_) < 2:
        return
    _, counts = np.unique(mesh.vertices[open_], axis=0, return_counts=True)
    copies = int(counts[counts > 1].sum())
    if copies:
        raise MeshError(mesh.name, f"{copies} boundary vertices coincide with others (a surface split "
                                   f"along seams?); --repair (repair=True in Python) welds them")


def _refuse_soup(mesh: Mesh, repair: bool, tolerance: float) -> None:
    """Refuse a mesh whose faces mostly share no vertex: keeping its largest component (one
    triangle) would fail later with a misleading "too small or coarse"."""
    # A face is a component of its own exactly when no other face uses any of its vertices.
    uses = np.bincount(mesh.faces.ravel(), minlength=mesh.n_vertices)
    single = int((uses[mesh.faces] == 1).all(axis=1).sum())
    if single > SOUP_FRACTION * mesh.n_faces:
        if repair and tolerance > 0:  # welded already: the copies of a vertex are not where the others are
            raise MeshError(mesh.name, f"{single} components of 1 face each even after welding "
                                       f"coincident vertices: a triangle soup whose copies of a vertex "
                                       f"differ by more than {tolerance:g} of the mean edge?")
        if repair:
            raise MeshError(mesh.name, f"{single} components of 1 face each: a triangle soup? "
                                       f"(welding is off: weld_tolerance 0)")
        raise MeshError(mesh.name, f"{single} components of 1 face each: a triangle soup? "
                                   f"--repair (repair=True in Python) welds coincident vertices")


# ----------------------------------------------------------------------------------------------
# Handles


def cut_handles(mesh: Mesh, max_length: float, roots: int) -> tuple[Mesh, list[float], int]:
    """``(mesh, lengths, left)``: a connected, manifold, consistently oriented ``mesh`` cut open
    along the shortest loop around each of its handles (:mod:`darcyan.geometry.handles`) shorter
    than ``max_length`` (sqrt(area) units), one handle at a time, shortest first; ``lengths``
    are the cuts' (sqrt(area) units), ``left`` the handles around which no such loop was found.
    Each of a loop's vertices keeps one side and gets a copy for the other (appended;
    ``input_index`` the original's), and the two sides become boundary loops. A loop is taken
    only when the cut leaves the surface in one piece with fewer handles. ``roots``: farthest
    points (from the vertex nearest the centroid) whose loops are compared; 0 or ``max_length``
    0: nothing is cut, and nothing is computed."""
    from .handles import genus

    handles = genus(mesh) if max_length > 0 and roots > 0 else 0
    if handles <= 0:
        return mesh, [], 0
    scale = np.sqrt(mesh.area())
    lengths: list[float] = []
    while handles > 0:
        cut, handles_left, length = _cut_shortest_handle(mesh, handles, max_length * scale, roots)
        if cut is None:
            break
        mesh, handles = cut, handles_left
        lengths.append(length / scale)
    return mesh, lengths, handles


def _cut_shortest_handle(mesh: Mesh, handles: int, max_length: float, roots: int) -> tuple[Mesh | None, int, float]:
    """``(cut, its genus, the loop's length)``: ``mesh`` (of genus ``handles``) cut along the
    shortest loop around a handle that is shorter than ``max_length`` (mesh units) and leaves it
    in one piece with fewer handles; ``(None, handles, inf)`` when there is none."""
    from .handles import HandleLoops, genus
    from .sampling import farthest_point_vertices

    made: dict[int, tuple[Mesh, int]] = {}

    def accept(loop) -> bool:
        if id(loop) in made:  # the best loop so far, met again in a later round
            return True
        if loop.length >= max_length:
            return False
        cut = _cut_along(mesh, loop.vertices)
        left = genus(cut)
        if left < handles and _component_count(cut) == 1:
            made[id(loop)] = (cut, left)
            return True
        return False

    used = np.unique(mesh.faces)
    centre = used[np.argmin(np.linalg.norm(mesh.vertices[used] - mesh.vertices[used].mean(axis=0), axis=1))]
    roots = used[farthest_point_vertices(mesh.vertices[used], roots, int(np.searchsorted(used, centre)))]
    loop = HandleLoops(mesh).shortest(roots, accept)
    return (None, handles, np.inf) if loop is None else (*made[id(loop)], loop.length)


def _cut_along(mesh: Mesh, loop: np.ndarray) -> Mesh:
    """``mesh`` cut open along the closed loop of edges through ``loop``'s vertices (in order)."""
    n = mesh.n_vertices
    ends = np.roll(loop, -1)
    cut, _ = _split_fans(mesh, np.minimum(loop, ends) * n + np.maximum(loop, ends))
    return cut


def _component_count(mesh: Mesh) -> int:
    """How many connected pieces the faces of ``mesh`` make."""
    from scipy.sparse.csgraph import connected_components

    labels = connected_components(vertex_adjacency(mesh), directed=False)[1]
    return len(np.unique(labels[np.unique(mesh.faces)]))


# ----------------------------------------------------------------------------------------------
# Non-manifold edges and vertices


def split_nonmanifold(mesh: Mesh) -> tuple[Mesh, int]:
    """``mesh`` made manifold by splitting rather than dropping.

    Around an edge of more than two faces, the faces are glued in pairs that close a fan around
    one of its end points (see :func:`_glued_half_edges`); a face left without a partner gets an
    edge of its own. Then every vertex gets one copy per fan of faces around it (the first fan
    keeps the vertex, copies are appended; each copy's ``input_index`` is the original's), with
    a :class:`MeshWarning` for the vertices that were not on a non-manifold edge (those are the
    input's bow ties; the others are the edges' repair). Where a fan passes one edge twice the
    split cannot separate the edge: the faces beyond its first two are dropped and the split
    repeated.

    Returns the mesh and how many faces were dropped.
    """
    keys, counts = mesh.edge_counts()
    on_edge = np.zeros(mesh.n_vertices, bool)
    tangled = keys[counts > 2]
    on_edge[tangled // mesh.n_vertices] = on_edge[tangled % mesh.n_vertices] = True
    split_mesh, split = _split_fans(mesh)
    bow_ties = split[~on_edge[split]]
    if len(bow_ties):
        warnings.warn(f"{mesh.name}: split {len(bow_ties)} non-manifold vertices (fans of faces meeting "
                      f"only at a vertex; first: input vertex {int(mesh.input_index[bow_ties[0]])}) "
                      f"into one copy per fan", MeshWarning, stacklevel=3)
    dropped, rounds = 0, 0
    while (beyond := _faces_beyond_two(split_mesh.faces, split_mesh.n_vertices)).any():
        if rounds == TANGLE_ROUNDS:
            raise MeshError(mesh.name, f"{int(beyond.sum())} faces remain on non-manifold edges after "
                                       f"splitting; fix them in a mesh editor")
        kept = Mesh(split_mesh.vertices, split_mesh.faces[~beyond], mesh.name, split_mesh.input_index)
        split_mesh, _ = _split_fans(kept)
        dropped, rounds = dropped + int(beyond.sum()), rounds + 1
    return split_mesh, dropped


def nonmanifold_vertices(mesh: Mesh) -> np.ndarray:
    """Vertices whose faces form more than one fan (faces glued as :func:`_glued_half_edges` says)."""
    fans = np.unique(mesh.faces.ravel() * (3 * mesh.n_faces) + _corner_fans(mesh))  # (vertex, fan) pairs
    return np.flatnonzero(np.bincount(fans // (3 * mesh.n_faces), minlength=mesh.n_vertices) > 1)


def _split_fans(mesh: Mesh, cut_keys: np.ndarray | None = None) -> tuple[Mesh, np.ndarray]:
    """One vertex per (vertex, fan): the first fan of each vertex keeps it, the others get copies
    appended after the existing vertices. Returns the mesh and the vertices that were split.
    ``cut_keys``: edges (keys ``lo * n + hi``) not glued, so that the surface is cut along them."""
    n_corners = 3 * mesh.n_faces
    pair = mesh.faces.ravel() * n_corners + _corner_fans(mesh, cut_keys)
    pairs, corner_pair = np.unique(pair, return_inverse=True)
    vertex = pairs // n_corners
    copy = np.r_[False, vertex[1:] == vertex[:-1]]  # a second, third... fan of its vertex
    if not copy.any():
        return mesh, np.zeros(0, dtype=np.int64)
    new_vertex = vertex.copy()
    new_vertex[copy] = mesh.n_vertices + np.arange(int(copy.sum()))
    faces = new_vertex[corner_pair.ravel()].reshape(-1, 3)
    copied = vertex[copy]
    split = Mesh(np.vstack([mesh.vertices, mesh.vertices[copied]]), faces, mesh.name,
                 np.r_[mesh.input_index, mesh.input_index[copied]])
    return split, np.unique(copied)


def _corner_fans(mesh: Mesh, cut_keys: np.ndarray | None = None) -> np.ndarray:
    """``(3m,)`` for each face corner (corner ``3t + i`` is vertex ``faces[t, i]``) a label shared by
    the corners of one fan: the faces around a vertex reached from one another across glued edges
    (:func:`_glued_half_edges`), but for the edges whose keys are ``cut_keys``."""
    # Half-edge h = 3t + i runs from corner h (vertex f[t, i]) to corner nxt[h] of the same face.
    start = mesh.faces.ravel()
    nxt = np.arange(3 * mesh.n_faces).reshape(-1, 3)[:, [1, 2, 0]].ravel()
    h1, h2 = _glued_half_edges(mesh.n_vertices, start, nxt)
    if cut_keys is not None and len(cut_keys):
        n = mesh.n_vertices
        a, b = start[h1], start[nxt[h1]]
        glued = ~np.isin(np.minimum(a, b) * n + np.maximum(a, b), cut_keys)
        h1, h2 = h1[glued], h2[glued]
    return _fans(start, nxt, h1, h2)


def _fans(start: np.ndarray, nxt: np.ndarray, h1: np.ndarray, h2: np.ndarray) -> np.ndarray:
    """Fan labels of the corners when the half-edges ``h1[k]`` and ``h2[k]`` are glued."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    # Link the corners of the two faces at each end point of their shared edge.
    opposite = start[h1] == start[nxt[h2]]  # the faces run the edge in opposite directions (usual case)
    rows = np.concatenate([h1, nxt[h1]])
    cols = np.concatenate([np.where(opposite, nxt[h2], h2), np.where(opposite, h2, nxt[h2])])
    n_corners = len(start)
    graph = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n_corners, n_corners))
    return connected_components(graph, directed=False)[1]


def _glued_half_edges(n_vertices: int, start: np.ndarray, nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs ``(h1, h2)`` of half-edges glued into one edge of the surface.

    The two half-edges of an edge of two faces are glued. Around an edge of more than two faces,
    two faces are glued when they are the two ends of one fan around an end point of the edge:
    gluing them closes the fan, so that sheets pinched together along the edge (what decimation
    leaves) come apart at the split, each whole, and a fin hung on the edge is left alone. Gluing
    closes further fans, so this repeats until no pair is found (along a chain of such edges, one
    edge further each round); faces left without a partner get an edge of their own.
    """
    end = start[nxt]
    lo = np.minimum(start, end)
    key = lo * n_vertices + np.maximum(start, end)
    h1, h2, count = _twins(key)
    pending = np.flatnonzero(count > 2)  # half-edges of non-manifold edges
    edge = np.unique(key[pending], return_inverse=True)[1].ravel()  # those edges numbered 0, 1, ...
    while len(pending):
        fans = _fans(start, nxt, h1, h2)
        forward = start[pending] == lo[pending]
        at_lo = np.where(forward, pending, nxt[pending])  # each face's corner at the edge's lo end
        at_hi = np.where(forward, nxt[pending], pending)  # and at its hi end
        left = np.ones(len(pending), bool)
        for corner in (at_lo, at_hi):
            open_ = np.flatnonzero(left)
            i, j, _ = _twins(edge[open_] * len(start) + fans[corner[open_]])
            h1, h2 = np.r_[h1, pending[open_[i]]], np.r_[h2, pending[open_[j]]]
            left[open_[i]] = left[open_[j]] = False
        if left.all():
            break
        pending, edge = pending[left], edge[left]
    return h1, h2


def _twins(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The index pairs ``(i, j)`` of the values that occur exactly twice in ``keys``, and for each
    value of ``keys`` how often it occurs."""
    order = np.argsort(keys, kind="stable")
    ranked = keys[order]
    first = np.r_[True, ranked[1:] != ranked[:-1]]
    run = np.cumsum(first) - 1
    size = np.bincount(run)[run]
    pair = np.flatnonzero(first & (size == 2))
    count = np.empty(len(keys), dtype=np.int64)
    count[order] = size
    return order[pair], order[pair + 1], count


def _faces_beyond_two(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """``(m,) bool``: faces on an edge of more than two faces, other than its first two faces."""
    a, b = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * n_vertices + np.maximum(a, b)
    order = np.argsort(key, kind="stable")  # stable: faces of one edge by face index
    start = np.r_[True, key[order][1:] != key[order][:-1]]
    rank = np.arange(len(key)) - np.maximum.accumulate(np.where(start, np.arange(len(key)), 0))
    beyond = np.zeros(len(key), bool)
    beyond[order] = rank >= 2
    return beyond.reshape(-1, 3).any(axis=1)


# ----------------------------------------------------------------------------------------------
# Components and orientation


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
    if n_comp == 1:  # one component, every vertex on a face: the mesh as it is (what it keeps too)
        return mesh
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
    return submesh(mesh, keep_faces)


def submesh(mesh: Mesh, keep_faces: np.ndarray) -> Mesh:
    """The mesh of the faces ``keep_faces`` (indices or a mask) and the vertices they use,
    renumbered; ``input_index`` keeps each vertex's place in the input."""
    faces = mesh.faces[keep_faces]
    used = np.unique(faces)
    remap = np.full(mesh.n_vertices, -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return Mesh(mesh.vertices[used], remap[faces], mesh.name, mesh.input_index[used])


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


def _cut_where_orientations_disagree(mesh: Mesh) -> tuple[Mesh, int]:
    """``(mesh, faces dropped)``: a surface that no choice of face orientations makes agree (a
    Moebius strip; a few faces folded back along a scan's rim) cut open along the edges where
    the breadth-first orientation still disagrees, by dropping one face of each (the later one),
    then reoriented; at most :data:`TANGLE_ROUNDS` rounds, then refused."""
    dropped = 0
    for _ in range(TANGLE_ROUNDS):
        faces, n = mesh.faces, mesh.n_vertices
        directed = faces.ravel() * n + faces[:, [1, 2, 0]].ravel()
        order = np.argsort(directed, kind="stable")
        repeated = order[1:][directed[order][1:] == directed[order][:-1]]  # the later use of each edge
        keep = np.ones(len(faces), bool)
        keep[np.unique(repeated // 3)] = False
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshWarning)  # the cut's own slivers: counted as dropped faces
            mesh, _ = split_nonmanifold(Mesh(mesh.vertices, faces[keep], mesh.name, mesh.input_index))
            mesh = _largest_component(mesh)
        dropped += len(faces) - mesh.n_faces
        mesh, _ = _orient_consistently(mesh)
        if _consistently_oriented(mesh.faces, mesh.n_vertices):
            return mesh, dropped
    raise MeshError(mesh.name, "the surface is not orientable (a Moebius strip?): no choice of face "
                               "orientations agrees along every edge, and cutting it open did not help")


def cap_small_holes(mesh: Mesh, settings: Repairing = Repairing()) -> tuple[Mesh, int, int, list]:
    """:func:`fill_small_holes` with ``settings``' hole length, edge count and degenerate area:
    how :func:`prepare_mesh` caps a mesh's small holes (and a dense map's copy cut open at its
    handles, the loops its cuts leave)."""
    return fill_small_holes(mesh, settings.hole_length, settings.hole_edges, degenerate_area=settings.degenerate_area)


def fill_small_holes(mesh: Mesh, max_length: float, max_edges: int, loops: list | None = None,
                     degenerate_area: float = Repairing().degenerate_area) -> tuple[Mesh, int, int, list]:
    """``(mesh, holes closed, faces added, loops left open)``: every boundary loop of at most
    ``max_edges`` edges and shorter than ``max_length`` (sqrt(area) units) closed by a fan of
    faces from its first vertex, oriented like the faces around it; no vertex is added, so the
    numbering stays the input's. A loop is left open when its fan would repeat an edge the mesh
    has (a diagonal already joined) or hold a face below ``degenerate_area`` times the mean face
    area (the hole a dropped zero-area face leaves, two copies of a split vertex on one loop).
    ``loops``: the mesh's :func:`boundary_loop_vertices`, if known."""
    loops = boundary_loop_vertices(mesh) if loops is None else loops
    small = [loop for loop in loops if 3 <= len(loop) <= max_edges] if max_length > 0 else []
    if not small:
        return mesh, 0, 0, loops
    v, n = mesh.vertices, mesh.n_vertices
    limit = max_length * np.sqrt(mesh.area())
    smallest_face = degenerate_area * mesh.area() / mesh.n_faces
    edges = mesh.edge_counts()[0]  # sorted keys
    added, left = [], [loop for loop in loops if not 3 <= len(loop) <= max_edges]
    for loop in small:
        apex, rim = loop[0], loop[1:]
        diagonals = np.minimum(apex, rim[1:-1]) * n + np.maximum(apex, rim[1:-1])
        joined = edges[np.minimum(np.searchsorted(edges, diagonals), len(edges) - 1)] == diagonals
        # loop[i] -> loop[i + 1] is its face's edge: the fan crosses it the other way (loops share
        # no vertex, so no two fans share a diagonal)
        fan = np.stack([np.full(len(rim) - 1, apex), rim[1:], rim[:-1]], axis=1)
        if (np.linalg.norm(v[np.roll(loop, -1)] - v[loop], axis=1).sum() >= limit or joined.any()
                or face_areas(v, fan).min() <= smallest_face):
            left.append(loop)
        else:
            added.append(fan)
    if not added:
        return mesh, 0, 0, loops
    fill = np.vstack(added)
    return Mesh(v, np.vstack([mesh.faces, fill]), mesh.name, mesh.input_index), len(added), len(fill), left


def orient_outward(mesh: Mesh, max_cap_share: float = 0.25, loops: list | None = None) -> Mesh:
    """``mesh`` with every face flipped if its consistently oriented faces enclose a negative
    volume, else ``mesh`` itself. Each boundary loop (``loops``: the mesh's
    :func:`boundary_loop_vertices`, if known) is closed for the test by a fan from the loop's centroid
    (the signed volume of a closed chain of triangles is well defined); a mesh whose fans have
    more than ``max_cap_share`` of its area is returned as it is (a patch has no inside to tell).
    Without this, an inside-out file turns every turning sense around, and its left and right
    are swapped."""
    f, v = mesh.faces, mesh.vertices
    reference = v.mean(axis=0)  # signed volumes about a point near the mesh: fewer digits lost
    u = v - reference
    volume = np.einsum("ij,ij->i", u[f[:, 0]], np.cross(u[f[:, 1]], u[f[:, 2]])).sum() / 6.0
    loops = boundary_loop_vertices(mesh) if loops is None else loops
    if loops:
        a = np.concatenate(loops)
        b = np.concatenate([np.roll(loop, -1) for loop in loops])
        c = np.repeat([u[loop].mean(axis=0) for loop in loops], [len(loop) for loop in loops], axis=0)
        fan = np.cross(u[b] - c, u[a] - c)  # the fan (c, b, a) closes each boundary edge a -> b against its face
        if 0.5 * np.linalg.norm(fan, axis=1).sum() > max_cap_share * mesh.area():
            return mesh
        volume += np.einsum("ij,ij->i", c, np.cross(u[b], u[a])).sum() / 6.0
    if volume < 0:
        return Mesh(mesh.vertices, f[:, ::-1].copy(), mesh.name, mesh.input_index)
    return mesh
