"""Mesh files: strict readers (OFF, OBJ, PLY, TOSCA ``.vert``/``.tri``) and writers."""

from __future__ import annotations

import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MeshError
from ..geometry.mesh import Mesh, MeshWarning
from ..geometry.repair import check_mesh

READ_FORMATS = (".off", ".obj", ".ply", ".vert", ".tri")
WRITE_FORMATS = (".off", ".ply")

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
        if not data.strip():
            raise MeshError(path, "empty file")
        parse = {".off": _parse_off, ".ply": _parse_ply, ".obj": _parse_obj}[ext]
        vertices, faces = parse(data, path)
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


# Bytes that str.split() treats as whitespace, and line breaks other than "\n" that
# str.splitlines() honours: files with the latter take the slow, line-by-line path.
_ASCII_SPACE = np.zeros(256, bool)
_ASCII_SPACE[list(b" \t\n\r\x0b\x0c\x1c\x1d\x1e\x1f")] = True
_ODD_BREAKS = b"\x0b\x0c\x1c\x1d\x1e"


def _tokens_per_line(data: bytes) -> np.ndarray | None:
    """Tokens on each non-empty line of a plain-ASCII text (lines ended by ``\n`` or ``\r\n``), or
    ``None`` when the text has comments, non-ASCII bytes or unusual line breaks."""
    if b"#" in data or data.count(b"\r") != data.count(b"\r\n"):
        return None
    b = np.frombuffer(data, np.uint8)
    if b.size == 0 or (b >= 128).any() or any(c in data for c in _ODD_BREAKS):
        return None
    space = _ASCII_SPACE[b]
    starts = ~space
    starts[1:] &= space[:-1]
    line_of = np.cumsum(b == ord("\n"))
    counts = np.bincount(line_of[starts], minlength=int(line_of[-1]) + 1)
    return counts[counts > 0]


def _parse_off_fast(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """The common case, vectorized: plain OFF, one vertex ``x y z`` and one triangle ``3 i j k``
    per line. ``None`` when the file is anything else (then the line-by-line parser runs and
    names the offending line)."""
    per_line = _tokens_per_line(data)
    if per_line is None or len(per_line) < 2:
        return None
    tokens = data.decode("ascii").split()
    if tokens[0].upper() not in ("OFF", "COFF", "NOFF", "CNOFF"):
        return None
    head = 1 if per_line[0] > 1 else 2  # counts on the OFF line or on the next one
    count_at = 1
    try:
        n_vertices, n_faces = int(tokens[count_at]), int(tokens[count_at + 1])
    except (ValueError, IndexError):
        return None
    header_tokens = int(per_line[:head].sum())
    body = per_line[head:]
    if n_vertices < 0 or n_faces < 0 or len(body) != n_vertices + n_faces:
        return None
    if (body[:n_vertices] != 3).any() or (body[n_vertices:] != 4).any():
        return None
    split = header_tokens + 3 * n_vertices
    try:
        vertices = np.array(tokens[header_tokens:split], dtype=np.float64).reshape(-1, 3)
        faces = np.array(tokens[split:], dtype=np.int64).reshape(-1, 4)
    except (ValueError, OverflowError):
        return None
    if (faces[:, 0] != 3).any():
        return None
    return vertices, faces[:, 1:].copy()


def _parse_off(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    fast = _parse_off_fast(data)
    if fast is not None:
        return fast
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
        if k < 3:
            raise MeshError(path, f"line {number}: a face needs at least 3 corners, found {k}")
        if len(tokens) < k + 1:
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


def _triangulate(polygons: list, labels: list[str], path: Path) -> np.ndarray:
    """``(t, 3)`` triangles from polygons (sequences of vertex indices): triangles as they are,
    larger polygons fanned (with a :class:`MeshWarning`); fewer than 3 corners is an error.
    ``labels[i]`` names polygon i in messages (a line or face number)."""
    if not polygons:
        return np.zeros((0, 3), dtype=np.int64)
    sizes = np.fromiter((len(p) for p in polygons), dtype=np.int64, count=len(polygons))
    small = np.flatnonzero(sizes < 3)
    if len(small):
        raise MeshError(path, f"{labels[small[0]]}: a face needs at least 3 corners, found {sizes[small[0]]}")
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


# PLY (Turk's polygon file format), ASCII and binary, read without a third-party parser so that
# every disagreement between header and body is an error instead of a silently different mesh.
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_PLY_FACE_LISTS = ("vertex_indices", "vertex_index")
_PLY_END_HEADER = re.compile(rb"(?:^|\n)end_header[ \t]*(?:\r\n|\n|\r|\Z)")


@dataclass
class _PlyElement:
    """One ``element`` of a PLY header: its properties are ``(name, type)`` for scalars and
    ``(name, count type, item type)`` for lists (numpy type codes without byte order)."""

    name: str
    count: int
    properties: list = field(default_factory=list)


def _parse_ply_header(data: bytes, path: Path) -> tuple[str, list[_PlyElement], int, int]:
    """``(byte order, elements, body offset, header line count)``; byte order '' means ASCII."""
    if not data.startswith(b"ply"):
        raise MeshError(path, "not a PLY file (it must start with 'ply')")
    end = _PLY_END_HEADER.search(data)
    if end is None:
        raise MeshError(path, "PLY header has no 'end_header' line")
    try:
        lines = data[:end.start()].decode("ascii").splitlines()
    except UnicodeDecodeError:
        raise MeshError(path, "PLY header contains non-ASCII bytes") from None
    order, elements = None, []
    for number, line in enumerate(lines, start=1):
        tokens = line.split()
        if number == 1:
            if tokens != ["ply"]:
                raise MeshError(path, "not a PLY file (it must start with a 'ply' line)")
            continue
        if not tokens or tokens[0] in ("comment", "obj_info"):
            continue
        where = f"line {number}"
        if tokens[0] == "format":
            if len(tokens) != 3 or tokens[1] not in _PLY_FORMATS:
                raise MeshError(path, f"{where}: unknown PLY format {' '.join(tokens[1:])!r}")
            order = _PLY_FORMATS[tokens[1]]
        elif tokens[0] == "element":
            if len(tokens) != 3 or not tokens[2].isdigit():
                raise MeshError(path, f"{where}: expected 'element NAME COUNT', found {line.strip()[:60]!r}")
            elements.append(_PlyElement(tokens[1], int(tokens[2])))
        elif tokens[0] == "property":
            if not elements:
                raise MeshError(path, f"{where}: property before any element")
            if len(tokens) == 5 and tokens[1] == "list" and tokens[2] in _PLY_TYPES and tokens[3] in _PLY_TYPES \
                    and _PLY_TYPES[tokens[2]][0] in "iu":
                elements[-1].properties.append((tokens[4], _PLY_TYPES[tokens[2]], _PLY_TYPES[tokens[3]]))
            elif len(tokens) == 3 and tokens[1] in _PLY_TYPES:
                elements[-1].properties.append((tokens[2], _PLY_TYPES[tokens[1]]))
            else:
                raise MeshError(path, f"{where}: malformed property {line.strip()[:60]!r}")
        else:
            raise MeshError(path, f"{where}: unexpected PLY header line {line.strip()[:60]!r}")
    if order is None:
        raise MeshError(path, "PLY header has no format line")
    return order, elements, end.end(), len(lines) + 1


def _parse_ply(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    order, elements, offset, header_lines = _parse_ply_header(data, path)
    names = [e.name for e in elements]
    if "vertex" not in names:
        raise MeshError(path, "PLY file has no vertex element")
    vertex = elements[names.index("vertex")]
    columns = [p[0] for p in vertex.properties]
    missing = [c for c in "xyz" if c not in columns]
    if missing or any(len(p) == 3 for p in vertex.properties):
        raise MeshError(path, f"PLY vertex element needs scalar x, y, z properties (has {', '.join(columns) or 'none'})")
    face = elements[names.index("face")] if "face" in names else _PlyElement("face", 0, [("vertex_indices", "u1", "i4")])
    lists = [i for i, p in enumerate(face.properties) if len(p) == 3 and p[0] in _PLY_FACE_LISTS]
    if not lists:
        raise MeshError(path, "PLY face element has no vertex_indices list")
    if face.properties[lists[0]][2][0] not in "iu":
        raise MeshError(path, "PLY face indices must be integers")
    body = data[offset:]
    records = (_ply_ascii_records if order == "" else _ply_binary_records)(body, elements, order, path, header_lines)
    xyz = [columns.index(c) for c in "xyz"]
    vertices = np.stack([np.asarray(records["vertex"][i], dtype=np.float64) for i in xyz], axis=1) \
        if vertex.count else np.zeros((0, 3))
    polygons = records["face"][lists[0]] if "face" in records and face.count else []
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2 and polygons.shape[1] == 3:
        return vertices, polygons.astype(np.int64)
    return vertices, _triangulate(list(polygons), [f"face {i}" for i in range(len(polygons))], path)


def _ply_ascii_records(body: bytes, elements: list[_PlyElement], order: str, path: Path,
                       header_lines: int) -> dict:
    """Every element's properties from an ASCII body: ``{element: [values per property]}``, one
    line per record, the line count and each line's length checked against the header."""
    text = _decode_text(body, path)
    lines = [(n, t) for n, raw in enumerate(text.splitlines(), start=header_lines + 1) if (t := raw.split())]
    total = sum(e.count for e in elements)
    announced = ", ".join(f"{e.count} {e.name}" for e in elements)
    if len(lines) < total:
        raise MeshError(path, f"truncated: header announces {total} element lines ({announced}), "
                              f"the file has {len(lines)}")
    if len(lines) > total:
        raise MeshError(path, f"line {lines[total][0]}: data after the last element (a count in the "
                              f"header is wrong: {announced})")
    out, start = {}, 0
    for e in elements:
        rows, start = lines[start:start + e.count], start + e.count
        if e.name not in ("vertex", "face"):
            continue
        if all(len(p) == 2 for p in e.properties):
            bad = [(n, t) for n, t in rows if len(t) != len(e.properties)]
            if bad:
                raise MeshError(path, f"line {bad[0][0]}: {e.name} has {len(bad[0][1])} values, the header "
                                      f"declares {len(e.properties)}")
            table = _numbers([t for _, t in rows], [n for n, _ in rows], np.float64, path, f"{e.name} values") \
                if rows else np.zeros((0, len(e.properties)))
            out[e.name] = list(table.reshape(len(rows), -1).T)
            continue
        columns: list[list] = [[] for _ in e.properties]
        for n, t in rows:
            pos = 0
            for i, prop in enumerate(e.properties):
                try:
                    if len(prop) == 2:
                        columns[i].append(float(t[pos]))
                        pos += 1
                    else:
                        k = int(t[pos])
                        if k < 0 or pos + 1 + k > len(t):
                            raise IndexError
                        columns[i].append([int(x) for x in t[pos + 1:pos + 1 + k]])
                        pos += 1 + k
                except (ValueError, IndexError):
                    raise MeshError(path, f"line {n}: malformed {e.name} {' '.join(t[:8])!r}") from None
            if pos != len(t):
                raise MeshError(path, f"line {n}: {e.name} has {len(t) - pos} values more than the header declares")
        out[e.name] = columns
    return out


def _ply_binary_records(body: bytes, elements: list[_PlyElement], order: str, path: Path,
                        header_lines: int) -> dict:
    """Every element's properties from a binary body (see :func:`_ply_ascii_records`); the body
    must end exactly after the last element."""
    out, pos = {}, 0
    for e in elements:
        out[e.name], pos = _ply_binary_element(body, pos, e, order, path)
    if pos != len(body):
        raise MeshError(path, f"{len(body) - pos} bytes after the last element (a count in the header "
                              f"is wrong: {', '.join(f'{e.count} {e.name}' for e in elements)})")
    return out


def _ply_binary_element(body: bytes, pos: int, e: _PlyElement, order: str, path: Path) -> tuple[list, int]:
    """One binary element starting at byte ``pos``: its columns and the offset after it."""
    left = len(body) - pos
    if e.count == 0 or not e.properties:
        return [np.zeros(0) for _ in e.properties], pos

    def truncated():
        return MeshError(path, f"truncated: the file ends inside element {e.name!r} ({e.count} announced)")

    # Fast path: every list of the element as long as in its first record (one structured read).
    fields, cursor = [], pos
    for i, prop in enumerate(e.properties):
        if len(prop) == 2:
            fields.append((f"s{i}", order + prop[1]))
            cursor += np.dtype(prop[1]).itemsize
        else:
            count_type = np.dtype(order + prop[1])
            if cursor + count_type.itemsize > len(body):
                raise truncated()
            k = int(np.frombuffer(body, count_type, 1, cursor)[0])
            fields += [(f"c{i}", count_type), (f"v{i}", order + prop[2], (k,))]
            cursor += count_type.itemsize + k * np.dtype(prop[2]).itemsize
    dtype = np.dtype(fields)
    if e.count <= left // dtype.itemsize:
        table = np.frombuffer(body, dtype, e.count, pos)
        if all(len(p) == 2 or (table[f"c{i}"] == dtype[f"v{i}"].shape[0]).all() for i, p in enumerate(e.properties)):
            columns = [table[f"s{i}"] if len(p) == 2 else table[f"v{i}"].reshape(e.count, -1)
                       for i, p in enumerate(e.properties)]
            return columns, pos + e.count * dtype.itemsize
    elif all(len(p) == 2 for p in e.properties):
        raise truncated()
    # General path: records of different lengths, read one by one.
    min_size = sum(np.dtype(p[1]).itemsize for p in e.properties)
    if e.count * min_size > left:
        raise truncated()
    columns = [[] for _ in e.properties]
    for _ in range(e.count):
        for i, prop in enumerate(e.properties):
            if len(prop) == 2:
                t = np.dtype(order + prop[1])
                if pos + t.itemsize > len(body):
                    raise truncated()
                columns[i].append(np.frombuffer(body, t, 1, pos)[0])
                pos += t.itemsize
            else:
                ct, it = np.dtype(order + prop[1]), np.dtype(order + prop[2])
                if pos + ct.itemsize > len(body):
                    raise truncated()
                k = int(np.frombuffer(body, ct, 1, pos)[0])
                pos += ct.itemsize
                if k < 0 or pos + k * it.itemsize > len(body):
                    raise truncated()
                columns[i].append(np.frombuffer(body, it, k, pos))
                pos += k * it.itemsize
    return columns, pos


def _parse_obj(data: bytes, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Wavefront OBJ: ``v x y z [...]`` and ``f i[/t[/n]] ...`` statements (1-based indices,
    negative ones relative to the vertices read so far); every other statement is ignored."""
    text = _decode_text(data, path)
    coords, coord_lines, polygons, labels = [], [], [], []
    for number, raw in enumerate(text.splitlines(), start=1):
        tokens = raw.split("#", 1)[0].split()
        if not tokens:
            continue
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
            labels.append(f"line {number}")
    vertices = _numbers(coords, coord_lines, np.float64, path, "vertex coordinates") if coords else np.zeros((0, 3))
    return vertices.reshape(-1, 3), _triangulate(polygons, labels, path)


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
