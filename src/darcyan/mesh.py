"""Triangle meshes: the :class:`Mesh` type, file I/O, validation, repair and scale normalization.

Readers are strict: a file whose header disagrees with its body, a number field holding text, a
face pointing at a vertex that does not exist, NaN coordinates and the like raise a
:class:`~darcyan.errors.MeshError` naming the file and the problem. Valid but imperfect meshes
(holes, several connected components) load; :func:`prepare_mesh` keeps the largest component and
warns about what it left out. Every derived mesh keeps ``input_index``, the index of each of its
vertices in the file it came from, so results can always be reported in the file's numbering.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .errors import MeshError

READ_FORMATS = (".off", ".obj", ".ply", ".vert", ".tri")
WRITE_FORMATS = (".off", ".ply")
MIN_VERTICES = 4
MIN_FACES = 2
# A face is degenerate when its area is below this fraction of the mean face area.
DEGENERATE_AREA_FRACTION = 1e-12


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

    def face_areas(self) -> np.ndarray:
        """``(m,)`` triangle areas."""
        return face_areas(self.vertices, self.faces)

    def area(self) -> float:
        return float(self.face_areas().sum())

    def edges(self) -> np.ndarray:
        """``(e, 2)`` unique undirected edges, smaller index first."""
        e = np.sort(self.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        return np.unique(e, axis=0)

    def content_hash(self) -> str:
        """Hash of the geometry and connectivity (not the name): a cache key for per-shape work."""
        h = hashlib.sha1()
        h.update(self.vertices.tobytes())
        h.update(self.faces.tobytes())
        return h.hexdigest()

    def with_vertices(self, vertices: np.ndarray) -> "Mesh":
        return Mesh(vertices, self.faces, self.name, self.input_index)


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` areas of the triangles ``faces`` of ``vertices``."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


# ----------------------------------------------------------------------------------------------
# Reading


def load_mesh(path: str | os.PathLike) -> Mesh:
    """Read a triangle mesh from OFF, OBJ, PLY (ASCII or binary), or TOSCA's ``.vert``+``.tri``.

    Polygons with more than three corners are split into triangles (fan). The mesh is checked
    by :func:`check_mesh`; nothing is repaired or dropped here.

    Raises:
        MeshError: missing or unreadable file, unknown extension, malformed content.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in READ_FORMATS:
        raise MeshError(path, f"unsupported file type {ext or '(none)'!r}; "
                              f"expected one of {', '.join(READ_FORMATS)}")
    if ext in (".vert", ".tri"):
        vertices, faces = _read_vert_tri(path)
    else:
        data = _read_bytes(path)
        if ext == ".off":
            vertices, faces = _parse_off(data, path)
        else:
            vertices, faces = _parse_with_trimesh(data, ext, path)
    mesh = Mesh(vertices, faces, name=str(path))
    check_mesh(mesh)
    return mesh


def _read_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise MeshError(path, "no such file") from None
    except IsADirectoryError:
        raise MeshError(path, "is a directory, not a mesh file") from None
    except PermissionError:
        raise MeshError(path, "permission denied") from None
    except OSError as exc:
        raise MeshError(path, f"cannot read: {exc.strerror or exc}") from None


def _decode_text(data: bytes, path: Path) -> str:
    if b"\x00" in data:
        raise MeshError(path, "binary content in a text mesh format")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes every byte
            raise MeshError(path, "not a text file") from None


def _numbers(rows: list[list[str]], line_numbers: list[int], dtype, path: Path, what: str) -> np.ndarray:
    """Convert equal-length token rows to an array, naming the first bad line on failure."""
    try:
        return np.array(rows, dtype=dtype)
    except (ValueError, OverflowError):
        for row, line in zip(rows, line_numbers):
            try:
                np.array(row, dtype=dtype)
            except (ValueError, OverflowError):
                raise MeshError(path, f"line {line}: {what} expected, found {' '.join(row)!r}") from None
        raise MeshError(path, f"malformed {what}") from None  # pragma: no cover


def _parse_off(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    text = _decode_text(data, path)
    lines = []  # (line number, tokens) of the non-empty, comment-free lines
    for number, raw in enumerate(text.splitlines(), start=1):
        tokens = raw.split("#", 1)[0].split()
        if tokens:
            lines.append((number, tokens))
    if not lines:
        raise MeshError(path, "empty file")
    number, head = lines[0]
    keyword = head[0]
    if keyword.upper() not in ("OFF", "COFF", "NOFF", "CNOFF"):
        raise MeshError(path, f"line {number}: not an OFF file (header {keyword[:20]!r})")
    counts = head[1:]
    body = lines[1:]
    if not counts:
        if not body:
            raise MeshError(path, "missing vertex and face counts")
        number, counts = body[0]
        body = body[1:]
    if len(counts) < 2:
        raise MeshError(path, f"line {number}: expected 'vertices faces [edges]' counts")
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except ValueError:
        raise MeshError(path, f"line {number}: counts must be integers, found {' '.join(counts)!r}") from None
    if n_vertices < 0 or n_faces < 0:
        raise MeshError(path, f"line {number}: negative counts")
    if len(body) < n_vertices:
        raise MeshError(path, f"truncated: header says {n_vertices} vertices, file has {len(body)} data lines")
    vertex_lines = body[:n_vertices]
    face_lines = body[n_vertices:]
    bad = [(n, t) for n, t in vertex_lines if len(t) < 3]
    if bad:
        raise MeshError(path, f"line {bad[0][0]}: a vertex needs 3 coordinates, found {len(bad[0][1])}")
    vertices = _numbers([t[:3] for _, t in vertex_lines], [n for n, _ in vertex_lines], np.float64,
                        path, "vertex coordinates")
    if len(face_lines) < n_faces:
        raise MeshError(path, f"truncated: header says {n_faces} faces, found {len(face_lines)}")
    if len(face_lines) > n_faces:
        extra = face_lines[n_faces][0]
        raise MeshError(path, f"line {extra}: data after the last face (vertex or face count in the "
                              f"header is wrong: {n_vertices} vertices, {n_faces} faces)")
    faces = _polygons_to_triangles(face_lines, path)
    return vertices, faces


def _polygons_to_triangles(face_lines: list[tuple[int, list[str]]], path: Path) -> np.ndarray:
    """Faces given as ``k i1 .. ik [colour]`` rows: triangles as they are, polygons fanned."""
    if not face_lines:
        return np.zeros((0, 3), dtype=np.int64)
    sizes = []
    for number, tokens in face_lines:
        try:
            k = int(tokens[0])
        except ValueError:
            raise MeshError(path, f"line {number}: face expected ('k i1 .. ik'), found {' '.join(tokens[:6])!r}") from None
        if k < 3 or len(tokens) < k + 1:
            raise MeshError(path, f"line {number}: face with {k} corners needs {k} indices, found {len(tokens) - 1}")
        sizes.append(k)
    if all(k == 3 for k in sizes):
        return _numbers([t[1:4] for _, t in face_lines], [n for n, _ in face_lines], np.int64, path,
                        "integer vertex indices")
    triangles = []
    for (number, tokens), k in zip(face_lines, sizes):
        idx = _numbers([tokens[1:k + 1]], [number], np.int64, path, "integer vertex indices")[0]
        triangles.extend((idx[0], idx[j], idx[j + 1]) for j in range(1, k - 1))
    warnings.warn(f"{path}: polygons with more than 3 corners were split into triangles", MeshWarning,
                  stacklevel=3)
    return np.array(triangles, dtype=np.int64)


def _read_vert_tri(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """TOSCA's native pair: ``name.vert`` (x y z rows) and ``name.tri`` (1-based i j k rows)."""
    vert_path, tri_path = path.with_suffix(".vert"), path.with_suffix(".tri")
    tables = []
    for p, dtype, what in ((vert_path, np.float64, "vertex coordinates"), (tri_path, np.int64, "integer vertex indices")):
        text = _decode_text(_read_bytes(p), p)
        rows = [(n, line.split()) for n, line in enumerate(text.splitlines(), start=1) if line.strip()]
        bad = [(n, t) for n, t in rows if len(t) != 3]
        if bad:
            raise MeshError(p, f"line {bad[0][0]}: expected 3 values, found {len(bad[0][1])}")
        tables.append(_numbers([t for _, t in rows], [n for n, _ in rows], dtype, p, what).reshape(-1, 3))
    vertices, faces = tables
    return vertices, faces - 1


def _parse_with_trimesh(data: bytes, ext: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    import io

    import trimesh

    if not data.strip():
        raise MeshError(path, "empty file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loaded = trimesh.load(io.BytesIO(data), file_type=ext[1:], process=False, force="mesh")
    except MeshError:
        raise
    except Exception as exc:  # trimesh raises many types on malformed input
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise MeshError(path, f"malformed {ext[1:].upper()} file ({reason[:200]})") from None
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))))
    if faces.size == 0:
        faces = np.zeros((0, 3), dtype=np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise MeshError(path, f"faces are not triangles (shape {faces.shape})")
    if vertices.ndim != 2 or vertices.shape[-1] != 3:
        raise MeshError(path, "no vertex coordinates found")
    return vertices, faces.astype(np.int64)


# ----------------------------------------------------------------------------------------------
# Writing


def save_mesh(mesh: Mesh, path: str | os.PathLike) -> None:
    """Write ``mesh`` as OFF (ASCII) or PLY (binary), chosen by the extension."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".off":
        with open(path, "w") as fh:
            fh.write(f"OFF\n{mesh.n_vertices} {mesh.n_faces} 0\n")
            np.savetxt(fh, mesh.vertices, fmt="%.9g")
            np.savetxt(fh, np.hstack([np.full((mesh.n_faces, 1), 3), mesh.faces]), fmt="%d")
    elif ext == ".ply":
        import trimesh

        trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(path, file_type="ply")
    else:
        raise MeshError(path, f"cannot write {ext or '(none)'!r}; expected one of {', '.join(WRITE_FORMATS)}")


# ----------------------------------------------------------------------------------------------
# Validation and repair


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
    _, first, inverse = np.unique(sorted_faces, axis=0, return_index=True, return_inverse=True)
    duplicate = np.flatnonzero(first[inverse.ravel()] != np.arange(len(faces)))
    areas = mesh.face_areas()
    mean_area = areas.mean() if len(areas) else 0.0
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    degenerate = np.flatnonzero(repeated | (areas <= DEGENERATE_AREA_FRACTION * mean_area))
    used = np.zeros(mesh.n_vertices, bool)
    used[faces.ravel()] = True
    keep = np.ones(len(faces), bool)
    keep[duplicate] = False
    keep[degenerate] = False
    kept = faces[keep]
    edges = np.sort(kept[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return MeshReport(duplicate, degenerate, np.flatnonzero(~used), int((counts > 2).sum()))


def prepare_mesh(mesh: Mesh, repair: bool = False) -> tuple[Mesh, list[str]]:
    """Make ``mesh`` ready for analysis: checked, optionally repaired, largest component only.

    Without ``repair``, duplicate faces, degenerate faces and unreferenced vertices are errors
    that name the fix; with it they are dropped and described in the returned list. Non-manifold
    edges are always an error (no safe automatic fix). With several connected components the
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
    mesh = _orient_outward(mesh)
    return mesh, changes


def _largest_component(mesh: Mesh) -> Mesh:
    """Keep the largest connected component by area; drop vertices no face uses."""
    n = mesh.n_vertices
    f = mesh.faces
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
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
    f = mesh.faces
    n_faces = len(f)
    half_edges = np.stack([f[:, [0, 1, 2]].ravel(), f[:, [1, 2, 0]].ravel()], axis=1)
    face_of = np.repeat(np.arange(n_faces), 3)
    key = np.sort(half_edges, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    same = np.all(key[order][1:] == key[order][:-1], axis=1)
    h1, h2 = order[:-1][same], order[1:][same]  # half-edges on one undirected (manifold) edge

    def corner(faces_idx, vertex):  # corner id 3*t + (position of vertex in face t)
        return 3 * faces_idx + np.argmax(f[faces_idx] == vertex[:, None], axis=1)

    links = []
    for end in (0, 1):  # both end points of the shared edge
        v = half_edges[h1, end]
        links.append((corner(face_of[h1], v), corner(face_of[h2], v)))
    rows = np.concatenate([r for r, _ in links])
    cols = np.concatenate([c for _, c in links])
    graph = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * n_faces, 3 * n_faces))
    _, fan = connected_components(graph, directed=False)
    fans = np.unique(np.stack([f.ravel(), fan], axis=1), axis=0)
    bad = np.flatnonzero(np.bincount(fans[:, 0], minlength=mesh.n_vertices) > 1)
    if len(bad):
        raise MeshError(mesh.name, f"{len(bad)} non-manifold vertices (faces meeting only at a "
                                   f"vertex, first: {int(mesh.input_index[bad[0]])})")


def _orient_outward(mesh: Mesh) -> Mesh:
    """Flip all faces if a closed mesh encloses negative volume (inward-facing normals)."""
    f = mesh.faces
    directed = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    undirected = np.sort(directed, axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    _, dir_counts = np.unique(directed, axis=0, return_counts=True)
    if (dir_counts > 1).any():
        raise MeshError(mesh.name, "faces are not consistently oriented (an edge is used twice in "
                                   "the same direction)")
    closed = bool((counts == 2).all())
    if closed:
        v = mesh.vertices
        volume = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6.0
        if volume < 0:
            return Mesh(mesh.vertices, f[:, ::-1].copy(), mesh.name, mesh.input_index)
    return mesh


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


def boundary_vertices(mesh: Mesh) -> np.ndarray:
    """``(n,) bool``: vertices on an edge used by only one face."""
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    uniq, counts = np.unique(e, axis=0, return_counts=True)
    mask = np.zeros(mesh.n_vertices, bool)
    mask[uniq[counts == 1].ravel()] = True
    return mask
