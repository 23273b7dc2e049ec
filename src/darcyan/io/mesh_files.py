"""Mesh files: strict readers (OFF, OBJ, PLY, STL, glTF, TOSCA ``.vert``/``.tri``) and writers.

Every reader keeps the file's vertices in the file's order with the file's coordinates (nothing
merged, dropped or reordered) and gives triangles; every problem is one :class:`MeshError` line
naming the file, and the line where there is one.

PLY, STL and glTF records are read by trimesh. Its PLY reader takes the layout on trust (lines after the
last element are ignored, ``4 0 1 2`` in a list of triangles is a triangle, a line of spaces in the
body a vertex at -1), so the header and an ASCII body's lines are checked before it runs, and a
binary body's list lengths after. OFF, OBJ and ``.vert``/``.tri`` are parsed here: trimesh knows no
``.vert``/``.tri``; its OFF reader has the same blind spots and fails on polygons of five corners,
and checking an OFF file line by line already parses it; its OBJ reader renumbers vertices (splits
them by texture coordinate or normal, drops unreferenced ones) and reads index 0 as the first vertex.
"""

from __future__ import annotations

import io
import json
import os
import warnings
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from ..errors import MeshError
from ..geometry.mesh import Mesh, MeshWarning
from ..geometry.repair import check_mesh

READ_FORMATS = (".off", ".obj", ".ply", ".stl", ".glb", ".gltf", ".vert", ".tri")
WRITE_FORMATS = (".off", ".ply")
POINT_FORMATS = (".xyz",)  # recognised only to say that a triangle mesh is needed

# ----------------------------------------------------------------------------------------------
# Reading


def load_mesh(path: str | os.PathLike) -> Mesh:
    """Read a triangle mesh from OFF, OBJ, PLY or STL (ASCII or binary), glTF 2.0 (``.glb``, or
    ``.gltf`` with its buffers beside it), or TOSCA's ``.vert``+``.tri``.

    Polygons with more than three corners are split into triangles (fan). STL stores every
    triangle with its own three corners: it is read as that triangle soup (three vertices per
    face, nothing welded); ``--repair`` welds it. glTF: see :func:`_read_gltf`. The mesh is
    checked by :func:`check_mesh`; nothing is repaired or dropped here.

    Raises:
        MeshError: missing or unreadable file, unknown extension, malformed content, points
            without faces (``.xyz``, a PLY with only vertices, an OFF with 0 faces).
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in READ_FORMATS + POINT_FORMATS:
        raise MeshError(path, f"unsupported file type {ext or '(none)'!r}; "
                              f"expected one of {', '.join(READ_FORMATS)}")
    if ext in (".vert", ".tri"):
        vertices, faces = _read_vert_tri(path)
    else:
        data = _read_bytes(path)
        if not data.strip():
            raise MeshError(path, "empty file")
        read = {".off": _read_off, ".obj": _read_obj, ".ply": _read_ply, ".stl": _read_stl, ".glb": _read_gltf,
                ".gltf": _read_gltf, ".xyz": _read_xyz}[ext]
        vertices, faces = read(data, path)
    if len(faces) == 0 and len(vertices) > 0:
        raise MeshError(path, f"{len(vertices)} points and no faces: a triangle mesh is needed")
    mesh = Mesh(vertices, faces, name=str(path))
    check_mesh(mesh)
    return mesh


def mesh_file_parts(path: str | os.PathLike) -> list[Path]:
    """The files a mesh is read from: ``path``, and beside it TOSCA's other half (``.vert`` and
    ``.tri``, in that order) or the buffer files a ``.gltf`` file names (its geometry lives
    there; a ``.gltf`` that does not parse, or names a buffer that is no file of its folder, is
    refused when loaded, and here names none)."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext in (".vert", ".tri"):
        return [path.with_suffix(".vert"), path.with_suffix(".tri")]
    if ext != ".gltf" or not path.is_file():
        return [path]
    try:
        return [path] + _gltf_buffer_files(path, _gltf_document(path.read_bytes(), path))
    except (OSError, MeshError):
        return [path]


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
        return data.decode("latin-1")  # decodes every byte; a stray one fails as a number later


def _data_lines(text: str) -> list[tuple[int, list[str]]]:
    """``(line number, tokens)`` of every line with data: ``#`` comments and blank lines left out."""
    lines = enumerate(text.splitlines(), start=1)
    if "#" not in text:  # most files: a tenth faster
        return [(n, t) for n, line in lines if (t := line.split())]
    return [(n, t) for n, line in lines if (t := line.split("#", 1)[0].split())]


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


def _triangulate(polygons, path: Path, where) -> np.ndarray:
    """``(t, 3)`` triangles from integer polygons (an ``(n, k)`` array or a list of index
    sequences): triangles as they are, larger polygons fanned from their first corner in file
    order (with a :class:`MeshWarning`); fewer than 3 corners is an error, ``where(i)`` names
    polygon i."""
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2:
        if polygons.shape[1] == 3 or len(polygons) == 0:
            return polygons.astype(np.int64).reshape(-1, 3)
        polygons = list(polygons)
    if len(polygons) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    sizes = np.fromiter(map(len, polygons), dtype=np.int64, count=len(polygons))
    small = np.flatnonzero(sizes < 3)
    if len(small):
        raise MeshError(path, f"{where(small[0])}: a face needs at least 3 corners, found {sizes[small[0]]}")
    try:
        if (sizes == 3).all():
            return np.array(polygons, dtype=np.int64).reshape(-1, 3)
        triangles = [(p[0], p[j], p[j + 1]) for p in polygons for j in range(1, len(p) - 1)]
        out = np.array(triangles, dtype=np.int64).reshape(-1, 3)
    except OverflowError:
        raise MeshError(path, "a face index is too large for a vertex index") from None
    warnings.warn(f"{path}: polygons with more than 3 corners were split into triangles", MeshWarning,
                  stacklevel=4)
    return out


def _trimesh_read(fmt: str, data: bytes, path: Path, hint: str = "", **options) -> dict:
    """What trimesh's reader for ``fmt`` makes of ``data``: the keyword arguments of a Trimesh
    (``vertices``, ``faces``, ``metadata``; ``geometry`` holding several parts). Whatever it raises
    becomes one MeshError line, ``hint`` appended."""
    import trimesh.exchange.load  # here: importing trimesh takes half a second

    try:
        return trimesh.exchange.load.mesh_loaders[fmt](io.BytesIO(data), **options)
    except Exception as exc:  # a third-party parser raises whatever it trips on
        detail = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise MeshError(path, f"not a readable {fmt.upper()} file ({detail}){hint}") from None


# OFF -------------------------------------------------------------------------------------------

_OFF_KEYWORDS = ("OFF", "COFF", "NOFF", "CNOFF")


# Bytes that str.split() treats as whitespace, and line breaks other than "\n" that
# str.splitlines() honours: files with the latter take the slow, line-by-line path.
_ASCII_SPACE = np.zeros(256, bool)
_ASCII_SPACE[list(b" \t\n\r\x0b\x0c\x1c\x1d\x1e\x1f")] = True
_ODD_BREAKS = b"\x0b\x0c\x1c\x1d\x1e"


def _token_layout(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """``(tokens on each non-empty line, the byte offset of each token's first byte)`` of a
    plain-ASCII text (lines ended by ``\n`` or ``\r\n``), or ``None`` when the text has
    comments, non-ASCII bytes or unusual line breaks."""
    if b"#" in data or data.count(b"\r") != data.count(b"\r\n"):
        return None
    b = np.frombuffer(data, np.uint8)
    if b.size == 0 or (b >= 128).any() or any(c in data for c in _ODD_BREAKS):
        return None
    space = _ASCII_SPACE[b]
    starts = ~space
    starts[1:] &= space[:-1]
    # each token's line: the newlines before its first byte (a running count of the newlines
    # over every byte took 8 bytes a byte of the file: 144 MB for a 210k-vertex mesh)
    newlines = np.flatnonzero(b == ord("\n"))
    token_starts = np.flatnonzero(starts)
    counts = np.bincount(np.searchsorted(newlines, token_starts), minlength=len(newlines) + 1)
    return counts[counts > 0], token_starts


def _read_off_fast(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """The common case, vectorized: plain OFF, one vertex ``x y z`` and one triangle ``3 i j k``
    per line. ``None`` when the file is anything else (then the line-by-line parser runs and
    names the offending line)."""
    layout = _token_layout(data)
    if layout is None or len(layout[0]) < 2:
        return None
    per_line, token_starts = layout
    head = 1 if per_line[0] > 1 else 2  # counts on the OFF line or on the next one
    header_tokens = int(per_line[:head].sum())
    body = per_line[head:]
    if header_tokens < 3 or len(body) < 2:
        return None
    tokens = data[:token_starts[header_tokens]].decode("ascii").split()
    if tokens[0].upper() not in _OFF_KEYWORDS:
        return None
    try:
        n_vertices, n_faces = int(tokens[1]), int(tokens[2])
    except ValueError:
        return None
    if n_vertices <= 0 or n_faces <= 0 or len(body) != n_vertices + n_faces:
        return None
    if (body[:n_vertices] != 3).any() or (body[n_vertices:] != 4).any():
        return None
    # numpy's own text parser on each block (the vertices' floats as float() reads them, the
    # faces' integers strictly): a third of the time of converting the split tokens
    first_face = token_starts[header_tokens + 3 * n_vertices]
    try:
        vertices = np.loadtxt(io.BytesIO(data[token_starts[header_tokens]:first_face]), dtype=np.float64, ndmin=2)
        faces = np.loadtxt(io.BytesIO(data[first_face:]), dtype=np.int64, ndmin=2)
    except (ValueError, OverflowError):
        return None
    if vertices.shape != (n_vertices, 3) or faces.shape != (n_faces, 4) or (faces[:, 0] != 3).any():
        return None
    return vertices, faces[:, 1:].copy()


def _read_off(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``OFF`` (or COFF, NOFF, CNOFF), the counts ``vertices faces [edges]`` (on that line or the
    next), then exactly that many vertex lines ``x y z [...]`` and face lines ``k i1 .. ik [...]``."""
    fast = _read_off_fast(data)  # the 52k TOSCA files in 0.07 s (line by line 0.47 s, speed.py)
    if fast is not None:
        return fast
    rows = _data_lines(_decode_text(data, path))
    if not rows:
        raise MeshError(path, "empty file")
    number, head = rows[0]
    if head[0].upper() not in _OFF_KEYWORDS:
        raise MeshError(path, f"line {number}: not an OFF file (header {head[0][:20]!r})")
    counts, body = head[1:], rows[1:]
    if not counts:
        if not body:
            raise MeshError(path, "missing vertex and face counts")
        (number, counts), body = body[0], body[1:]
    if len(counts) < 2:
        raise MeshError(path, f"line {number}: expected 'vertices faces [edges]' counts")
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except ValueError:
        raise MeshError(path, f"line {number}: counts must be integers, found {' '.join(counts)!r}") from None
    if n_vertices < 0 or n_faces < 0:
        raise MeshError(path, f"line {number}: negative counts")
    # The counts must describe the body exactly: one too many vertices would read a face as a vertex.
    if len(body) < n_vertices + n_faces:
        raise MeshError(path, f"truncated: header says {n_vertices} vertices and {n_faces} faces, "
                              f"file has {len(body)} data lines")
    if len(body) > n_vertices + n_faces:
        raise MeshError(path, f"line {body[n_vertices + n_faces][0]}: data after the last face (vertex or face "
                              f"count in the header is wrong: {n_vertices} vertices, {n_faces} faces)")
    vertex_rows, face_rows = body[:n_vertices], body[n_vertices:]
    short = next((row for row in vertex_rows if len(row[1]) < 3), None)
    if short:
        raise MeshError(path, f"line {short[0]}: a vertex needs 3 coordinates, found {len(short[1])}")
    vertices = _numbers([t[:3] for _, t in vertex_rows], [n for n, _ in vertex_rows], np.float64, path,
                        "vertex coordinates")
    return vertices.reshape(-1, 3), _triangulate(_off_polygons(face_rows, path), path,
                                                 lambda i: f"line {face_rows[i][0]}")


def _off_polygons(face_rows: list[tuple[int, list[str]]], path: Path):
    """Face lines ``k i1 .. ik [colour]`` as an ``(n, 3)`` array when all are triangles (the
    common case, at once), else a list of index arrays."""
    if all(t[0] == "3" and len(t) >= 4 for _, t in face_rows):
        return _numbers([t[1:4] for _, t in face_rows], [n for n, _ in face_rows], np.int64, path,
                        "integer vertex indices").reshape(-1, 3)
    polygons = []
    for number, tokens in face_rows:
        try:
            k = int(tokens[0])
        except ValueError:
            raise MeshError(path, f"line {number}: face expected ('k i1 .. ik'), found {' '.join(tokens[:6])!r}") from None
        if k < 3:
            raise MeshError(path, f"line {number}: a face needs at least 3 corners, found {k}")
        if len(tokens) < k + 1:
            raise MeshError(path, f"line {number}: face with {k} corners needs {k} indices, found {len(tokens) - 1}")
        polygons.append(_numbers([tokens[1:k + 1]], [number], np.int64, path, "integer vertex indices")[0])
    return polygons


# OBJ -------------------------------------------------------------------------------------------


def _read_obj(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Wavefront OBJ: ``v x y z [...]`` and ``f i[/t[/n]] ...`` statements (1-based indices,
    negative ones relative to the vertices read so far); every other statement is ignored."""
    coords, coord_lines, polygons, face_lines = [], [], [], []
    for number, tokens in _data_lines(_decode_text(data, path)):
        if tokens[0] == "v":
            if len(tokens) < 4:
                raise MeshError(path, f"line {number}: a vertex needs 3 coordinates, found {len(tokens) - 1}")
            coords.append(tokens[1:4])
            coord_lines.append(number)
        elif tokens[0] == "f":
            try:
                idx = [int(c.split("/", 1)[0]) for c in tokens[1:]]
            except ValueError:
                raise MeshError(path, f"line {number}: integer vertex indices expected, found "
                                      f"{' '.join(tokens[1:7])!r}") from None
            if 0 in idx:
                raise MeshError(path, f"line {number}: vertex index 0 (OBJ indices start at 1)")
            seen = len(coords)
            resolved = [i - 1 if i > 0 else seen + i for i in idx]
            if min(resolved, default=0) < 0:
                raise MeshError(path, f"line {number}: relative index {min(idx)} points before the first vertex")
            polygons.append(resolved)
            face_lines.append(number)
    vertices = _numbers(coords, coord_lines, np.float64, path, "vertex coordinates") if coords else np.zeros((0, 3))
    return vertices.reshape(-1, 3), _triangulate(polygons, path, lambda i: f"line {face_lines[i]}")


# PLY -------------------------------------------------------------------------------------------

# The property types trimesh's PLY reader knows, as numpy type codes.
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "int64": "i8", "uint64": "u8", "float16": "f2", "float": "f4", "float32": "f4",
              "double": "f8", "float64": "f8"}
_PLY_FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")
_PLY_FACE_LISTS = ("vertex_indices", "vertex_index")  # the names trimesh looks for


def _read_ply(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """PLY (Turk's polygon file format), ASCII or binary: the header and an ASCII body's lines
    checked here, the records read by trimesh."""
    fmt, elements, body, header_lines = _ply_header(data, path)
    _, vertex = elements.get("vertex", (0, {}))
    if any(not isinstance(vertex.get(c), str) for c in "xyz"):
        raise MeshError(path, f"PLY vertex element needs scalar x, y, z properties "
                              f"(has {', '.join(vertex) or 'none'})")
    n_faces, face = elements.get("face", (0, {}))
    index_list = next((name for name in _PLY_FACE_LISTS if name in face), None)
    if face and (index_list is None or not isinstance(face[index_list], tuple) or face[index_list][1][0] not in "iu"):
        raise MeshError(path, "PLY face element has no vertex_indices list of integers")
    if fmt == "ascii":
        _check_ply_ascii(_decode_text(data[body:], path), elements, path, header_lines)
    # fix_texture=False: trimesh would otherwise split vertices by texture coordinate.
    hint = "" if fmt == "ascii" else ("; a count in the header is wrong, the file is truncated, or the faces "
                                      "have different numbers of corners, which trimesh's binary reader cannot read")
    try:
        loaded = _trimesh_read("ply", data, path, hint, fix_texture=False, skip_materials=True)
    except MeshError:
        if fmt == "ascii":
            raise
        loaded = None
    if fmt != "ascii" and (loaded is None or (n_faces and not _uniform_binary_faces(loaded, index_list))):
        # trimesh reads binary faces of one size only; Blender and others write triangles and
        # quads mixed: those files are read record by record here.
        records = _ply_binary_records(data, body, elements, fmt, path)
        vertices = np.stack([records["vertex"][c] for c in "xyz"], axis=1).astype(np.float64)
        lists = records.get("face", {}).get(index_list, [])
        return vertices, _triangulate(lists, path, lambda i: f"face {i}")
    vertices = np.asarray(loaded.get("vertices", np.zeros((0, 3))), dtype=np.float64)
    if n_faces == 0:
        return vertices, np.zeros((0, 3), dtype=np.int64)
    # The face lists as read, before trimesh triangulates them its own way (and out of file order).
    try:
        lists = loaded["metadata"]["_ply_raw"]["face"]["data"][index_list]
    except (KeyError, TypeError, ValueError):  # trimesh drops an element whose records are missing
        raise MeshError(path, f"truncated: the {n_faces} faces the header announces are missing") from None
    if fmt != "ascii":
        # trimesh reads every binary record as long as the first: the other lengths must agree.
        counts, lists = lists["f0"], lists["f1"]
        if (counts != lists.shape[1]).any():
            raise MeshError(path, "binary PLY faces with different numbers of corners (trimesh reads "
                                  "faces of one size only; triangulate the file first)")
    if lists.dtype != object:  # (n, k); trimesh squeezes one face with two lists to 1-D
        lists = lists.reshape(n_faces, -1)
    return vertices, _triangulate(lists, path, lambda i: f"face {i}")


def _uniform_binary_faces(loaded: dict, index_list: str) -> bool:
    """True when trimesh read every binary face with the corner count it announces."""
    try:
        lists = loaded["metadata"]["_ply_raw"]["face"]["data"][index_list]
        return bool((lists["f0"] == lists["f1"].shape[1]).all())
    except (KeyError, TypeError, ValueError, IndexError):
        return True  # nothing to compare: the checks below say what is wrong


def _ply_binary_records(data: bytes, body: int, elements: dict, fmt: str, path: Path) -> dict:
    """Every element of a binary PLY body: ``{element: {property: array or list of arrays}}``.
    Elements of scalar properties are read at once; those with lists record by record."""
    order = "<" if fmt == "binary_little_endian" else ">"
    records, pos = {}, body

    def take(kind: str, count: int):
        nonlocal pos
        size = np.dtype(kind).itemsize * count
        if pos + size > len(data):
            raise MeshError(path, f"truncated: the binary body ends inside element {name!r}")
        values = np.frombuffer(data, order + kind, count, pos)
        pos += size
        return values

    for name, (count, properties) in elements.items():
        if all(isinstance(kind, str) for kind in properties.values()):
            record = np.dtype([(p, order + kind) for p, kind in properties.items()])
            if pos + record.itemsize * count > len(data):
                raise MeshError(path, f"truncated: the binary body ends inside element {name!r}")
            table = np.frombuffer(data, record, count, pos)
            pos += record.itemsize * count
            records[name] = {p: table[p] for p in properties}
            continue
        columns = {p: [] for p in properties}
        for _ in range(count):
            for p, kind in properties.items():
                if isinstance(kind, str):
                    columns[p].append(take(kind, 1)[0])
                else:
                    length = int(take(kind[0], 1)[0])
                    if length < 0:
                        raise MeshError(path, f"element {name!r}: a list of {length} items")
                    columns[p].append(take(kind[1], length))
        records[name] = columns
    if pos != len(data):
        raise MeshError(path, f"{len(data) - pos} bytes after the last element the header announces: "
                              f"a count in the header is wrong")
    return records


def _ply_header(data: bytes, path: Path) -> tuple[str, dict, int, int]:
    """``(format, elements, body offset, header line count)``, ``elements[name]`` being ``(count,
    properties)`` and a property a numpy type code, or a ``(count type, item type)`` pair for a
    list. The lines are split as trimesh splits them (at ``\\n``; the format on line 2; the end at
    the first line naming ``end_header``), and checked more strictly."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshError(path, "not a PLY file (it must start with 'ply' and have an 'end_header' line)")
    end = data.find(b"\n", end) + 1 or len(data)
    try:
        lines = [line.split() for line in data[:end].decode("ascii").rstrip("\n").split("\n")]
    except UnicodeDecodeError:
        raise MeshError(path, "PLY header contains non-ASCII bytes") from None
    if lines[0] != ["ply"] or len(lines) < 3 or lines[1][:1] != ["format"]:
        raise MeshError(path, "not a PLY file (it must start with a 'ply' line and a 'format' line)")
    if len(lines[1]) != 3 or lines[1][1] not in _PLY_FORMATS:
        raise MeshError(path, f"line 2: unknown PLY format {' '.join(lines[1][1:])[:60]!r}")
    if lines[-1] != ["end_header"]:
        raise MeshError(path, f"line {len(lines)}: malformed 'end_header' line")
    elements: dict[str, tuple[int, dict]] = {}
    for number, tokens in enumerate(lines[2:-1], start=3):
        line = " ".join(tokens)[:60]
        if tokens[:1] in (["comment"], ["obj_info"]):
            continue
        if len(tokens) == 3 and tokens[0] == "element" and tokens[2].isdigit() and tokens[1] not in elements:
            elements[tokens[1]] = (int(tokens[2]), {})
            properties = elements[tokens[1]][1]
        elif tokens[:1] == ["property"] and elements and tokens[-1] not in properties:
            if len(tokens) == 3 and tokens[1] in _PLY_TYPES:
                properties[tokens[2]] = _PLY_TYPES[tokens[1]]
            elif len(tokens) == 5 and tokens[1] == "list" and tokens[2] in _PLY_TYPES and tokens[3] in _PLY_TYPES \
                    and _PLY_TYPES[tokens[2]][0] in "iu":
                properties[tokens[4]] = (_PLY_TYPES[tokens[2]], _PLY_TYPES[tokens[3]])
            else:
                raise MeshError(path, f"line {number}: malformed property {line!r}")
        else:
            raise MeshError(path, f"line {number}: unexpected PLY header line {line!r}")
    return lines[1][1], elements, end, len(lines)


def _check_ply_ascii(text: str, elements: dict, path: Path, header_lines: int) -> None:
    """An ASCII body line by line against the header, as trimesh takes it: one record per line
    from the first, each with as many numbers as its properties say (a list: its length, then that
    many items, whole numbers for an integer list); after the last record only blank lines."""
    lines = text.splitlines()
    total = sum(count for count, _ in elements.values())
    announced = ", ".join(f"{count} {name}" for name, (count, _) in elements.items())
    if len(lines) < total:
        raise MeshError(path, f"truncated: header announces {total} element lines ({announced}), "
                              f"the file has {len(lines)}")
    extra = next((i for i in range(total, len(lines)) if lines[i].strip()), None)
    if extra is not None:
        raise MeshError(path, f"line {header_lines + 1 + extra}: data after the last element (a count in the "
                              f"header is wrong: {announced})")
    start = 0
    for name, (count, properties) in elements.items():
        for i in range(start, start + count):
            where, tokens = f"line {header_lines + 1 + i}", lines[i].split()
            try:
                values = [float(t) for t in tokens]
            except ValueError:
                raise MeshError(path, f"{where}: {name} values expected, found {' '.join(tokens[:8])!r}") from None
            pos = 0
            for kind in properties.values():
                if isinstance(kind, tuple):  # a list: its length, then its items
                    k = values[pos] if pos < len(values) else -1.0
                    items = values[pos + 1:pos + 1 + int(k)] if k >= 0 and k.is_integer() else None
                    if items is None or len(items) < k or (kind[1][0] in "iu" and not all(v.is_integer() for v in items)):
                        raise MeshError(path, f"{where}: malformed {name} {' '.join(tokens[:8])!r}")
                    pos += int(k)
                pos += 1
            if pos < len(tokens):
                raise MeshError(path, f"{where}: {name} has {len(tokens) - pos} values more than the header declares")
            if pos > len(tokens):
                raise MeshError(path, f"{where}: {name} has {len(tokens)} values, the header declares {pos}")
        start += count


# STL and point clouds --------------------------------------------------------------------------


def _read_stl(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """STL, binary or ASCII, as trimesh reads it (an ASCII file may hold several solids). STL has
    no shared vertices, only each face's three corners: corners at exactly the same point are one
    vertex, numbered in the order of their first corner in the file (:func:`_shared_corners`)."""
    announced = int.from_bytes(data[80:84], "little") if len(data) >= 84 else 0
    binary = len(data) == 84 + 50 * announced  # trimesh's test
    text = "" if binary else data.decode("utf-8", "replace").lower()
    if "\x00" in text or "\ufffd" in text:
        raise MeshError(path, f"not an STL file: neither binary ({len(data)} bytes, not 84 + 50 per "
                              f"triangle for the {announced} it announces) nor text")
    loaded = _trimesh_read("stl", data, path)
    parts = loaded["geometry"].values() if "geometry" in loaded else [loaded]
    vertices = np.concatenate([np.asarray(p["vertices"], np.float64).reshape(-1, 3) for p in parts] or [np.zeros((0, 3))])
    if len(vertices) == 0:
        raise MeshError(path, "no triangles (an ASCII STL has them between 'solid' and 'endsolid')")
    # trimesh takes the numbers after each ASCII 'vertex' three by three: count the keywords.
    if not binary and (text.count("vertex") != len(vertices) or 3 * text.count("endfacet") != len(vertices)):
        raise MeshError(path, f"ASCII STL with {text.count('endfacet')} facets and {text.count('vertex')} 'vertex' "
                              f"lines, {len(vertices)} vertices read: every facet needs 3 vertices of 3 numbers")
    return _shared_corners(vertices)


def _shared_corners(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (n, 3), faces (m, 3))`` from a triangle soup's corners ``(3 m, 3)``: corners at
    exactly the same point are one vertex (no tolerance: a file's copies of a point are written
    from one value), vertices in the order of their first corner."""
    unique, first, inverse = np.unique(corners, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    return unique[order], rank[inverse.reshape(-1)].reshape(-1, 3)


def _read_gltf(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """glTF 2.0 as trimesh reads it (a ``.gltf`` file's buffers from its folder): the triangles of
    every mesh of the scene, each placed by its node's transform, one after another in the order
    trimesh lists them; a file of one mesh keeps its own vertex order. Points and lines are left
    out. A glTF splits its vertices along texture and normal seams: the seam check names
    ``--repair``, which welds them."""
    import trimesh  # here: importing trimesh takes half a second

    fmt = path.suffix.lower()[1:]
    resolver = None
    if fmt == "gltf":
        missing = [part.name for part in _gltf_buffer_files(path, _gltf_document(data, path)) if not part.is_file()]
        if missing:
            raise MeshError(path, f"its buffer {missing[0]} is missing (a .gltf file keeps its geometry in the files "
                                  f"it names, beside it)")

        class Folder(trimesh.resolvers.FilePathResolver):
            def get(self, name):  # a glTF's URIs are percent-encoded; trimesh opens them as written
                return super().get(unquote(name))

        resolver = Folder(path.parent)
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=fmt, force="mesh", process=False, resolver=resolver)
    except Exception as exc:  # a third-party parser raises whatever it trips on
        detail = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise MeshError(path, f"not a readable glTF file ({detail})") from None
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0:
        raise MeshError(path, "no triangles (a glTF scene without meshes, or of points and lines only)")
    return np.asarray(loaded.vertices, dtype=np.float64).reshape(-1, 3), faces


def _gltf_document(data: bytes, path: Path) -> dict:
    """The JSON object of a ``.gltf`` file; MeshError when it is none."""
    try:
        document = json.loads(data)
    except ValueError as exc:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        detail = " ".join(str(exc).split())[:120]
        raise MeshError(path, f"not a glTF file: its JSON does not parse ({detail})") from None
    if not isinstance(document, dict):
        raise MeshError(path, "not a glTF file: its JSON is not an object")
    return document


def _gltf_buffer_files(path: Path, document: dict) -> list[Path]:
    """The files that a ``.gltf`` file's buffers name (percent-decoded, beside it; a ``data:`` URI
    embeds its bytes). MeshError for a buffer that names no file of its folder: an empty name, a
    URL, a path that leads out of the folder."""
    folder = path.parent.resolve()
    buffers = document.get("buffers", [])
    files = []
    for buffer in buffers if isinstance(buffers, list) else []:
        uri = buffer.get("uri") if isinstance(buffer, dict) else None
        if uri is None or (isinstance(uri, str) and uri.startswith("data:")):
            continue
        if not isinstance(uri, str) or not uri.strip():
            raise MeshError(path, f"a buffer's uri is {uri!r}: it names no file")
        if "://" in uri:
            raise MeshError(path, f"its buffer {uri} is not a local file: only files beside it are read")
        part = path.parent / unquote(uri)
        if not part.resolve().is_relative_to(folder):
            raise MeshError(path, f"its buffer {uri} lies outside its folder: only files beside it are read")
        files.append(part)
    return files


def _read_xyz(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A point cloud, one point per line: never a mesh (its lines are only counted for the message)."""
    raise MeshError(path, f"{len(_data_lines(_decode_text(data, path)))} points and no faces: a triangle mesh is needed")


# TOSCA -----------------------------------------------------------------------------------------


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
