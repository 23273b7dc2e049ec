"""Property-based fuzzing of the mesh readers (hypothesis).

Whatever the bytes in a file with a mesh extension, :func:`darcyan.load_mesh` either returns a
valid :class:`~darcyan.geometry.mesh.Mesh` (finite coordinates, triangle indices in range) or raises
darcyan's own :class:`~darcyan.errors.MeshError` naming the file. Any other exception, a hang or
a mesh with NaN coordinates or dangling indices is a bug. Inputs are raw bytes, valid files with
random byte edits (the interesting region: nearly valid files), and valid files with token edits.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from darcyan.errors import MeshError  # noqa: E402
from darcyan.geometry.mesh import Mesh  # noqa: E402
from darcyan.io.mesh_files import load_mesh  # noqa: E402

# An octahedron with one quad split: small enough to mutate densely, big enough to pass check_mesh.
VERTICES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.5]])
FACES = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])

import os  # noqa: E402

# Examples per test in the suite (reproducible); DARCYAN_FUZZ_EXAMPLES=5000 for a long random hunt.
EXAMPLES = int(os.environ.get("DARCYAN_FUZZ_EXAMPLES", "150"))
FUZZ_SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize="DARCYAN_FUZZ_EXAMPLES" not in os.environ,
                         suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _valid_files() -> dict[str, bytes]:
    off = "OFF\n6 8 0\n" + "".join(f"{x} {y} {z}\n" for x, y, z in VERTICES) + \
        "".join(f"3 {a} {b} {c}\n" for a, b, c in FACES)
    obj = "# fuzz seed\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in VERTICES) + \
        "".join(f"f {a + 1} {b + 1}/1 {c + 1}//2\n" for a, b, c in FACES)
    tm = trimesh.Trimesh(VERTICES, FACES, process=False)
    return {
        ".off": off.encode(),
        ".obj": obj.encode(),
        ".ply": tm.export(file_type="ply", encoding="binary"),
        "ascii.ply": tm.export(file_type="ply", encoding="ascii"),
        ".stl": tm.export(file_type="stl"),
        "ascii.stl": tm.export(file_type="stl_ascii").encode(),
        ".glb": tm.export(file_type="glb"),
        ".gltf": trimesh.exchange.gltf.export_gltf(trimesh.Scene(tm), embed_buffers=True)["model.gltf"],
        ".vert": "".join(f"{x} {y} {z}\n" for x, y, z in VERTICES).encode(),
        ".tri": "".join(f"{a + 1} {b + 1} {c + 1}\n" for a, b, c in FACES).encode(),
    }


VALID = _valid_files()
KINDS = sorted(VALID)


def _extension(kind: str) -> str:
    return kind[kind.index("."):]


def check_loads_or_mesh_error(folder, kind: str, data: bytes) -> None:
    """Write ``data`` as a file of ``kind`` (the other half of a .vert/.tri pair valid) and load it."""
    ext = _extension(kind)
    path = folder / f"fuzz{ext}"
    path.write_bytes(data)
    if ext in (".vert", ".tri"):
        other = ".tri" if ext == ".vert" else ".vert"
        (folder / f"fuzz{other}").write_bytes(VALID[other])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mesh = load_mesh(path)
    except MeshError as exc:
        assert str(path) in str(exc) or "fuzz." in str(exc)
        assert "\n" not in str(exc)
        return
    assert isinstance(mesh, Mesh)
    assert mesh.vertices.ndim == 2 and mesh.vertices.shape[1] == 3
    assert mesh.faces.ndim == 2 and mesh.faces.shape[1] == 3 and mesh.faces.dtype == np.int64
    assert np.isfinite(mesh.vertices).all()
    assert mesh.n_faces > 0 and mesh.faces.min() >= 0 and mesh.faces.max() < mesh.n_vertices


def mutate(data: bytes, edits: list[tuple[int, int, bytes]]) -> bytes:
    """Apply (position, delete count, insertion) edits, positions taken modulo the length."""
    out = bytearray(data)
    for position, delete, insert in edits:
        at = position % (len(out) + 1)
        out[at:at + delete] = insert
    return bytes(out)


EDITS = st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 4), st.binary(max_size=4)),
                 min_size=1, max_size=4)
TOKENS = st.sampled_from(["0", "-1", "1", "3", "4", "7", "nan", "inf", "-inf", "1e400", "x", "", "  ",
                          "\n", "\r\n", "#", "99999999999999999999", "3.5", "/", "f", "v", "OFF",
                          "ply", "end_header", "element vertex 2", "property list uchar int vertex_indices"])


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


def test_the_unmutated_files_load(folder):
    for kind in KINDS:
        check_loads_or_mesh_error(folder, kind, VALID[kind])
        path = folder / f"fuzz{_extension(kind)}"
        mesh = load_mesh(path)
        if kind.endswith(".stl"):  # corners at one point are one vertex, in file order
            np.testing.assert_allclose(mesh.vertices[mesh.faces], VERTICES[FACES])
            continue
        np.testing.assert_allclose(mesh.vertices, VERTICES)
        np.testing.assert_array_equal(mesh.faces, FACES)


@pytest.mark.parametrize("kind", KINDS)
@FUZZ_SETTINGS
@given(data=st.binary(max_size=400))
def test_arbitrary_bytes(folder, kind, data):
    check_loads_or_mesh_error(folder, kind, data)


@pytest.mark.parametrize("kind", KINDS)
@FUZZ_SETTINGS
@given(edits=EDITS)
def test_valid_files_with_byte_edits(folder, kind, edits):
    check_loads_or_mesh_error(folder, kind, mutate(VALID[kind], edits))


@pytest.mark.parametrize("kind", KINDS)
@FUZZ_SETTINGS
@given(cut=st.integers(0, 10_000))
def test_truncated_valid_files(folder, kind, cut):
    data = VALID[kind]
    check_loads_or_mesh_error(folder, kind, data[:cut % (len(data) + 1)])


@pytest.mark.parametrize("kind", [k for k in KINDS if k not in (".ply", ".stl", ".glb")])  # the text formats
@FUZZ_SETTINGS
@given(edits=st.lists(st.tuples(st.integers(0, 200), st.integers(0, 2), TOKENS), min_size=1, max_size=4))
def test_text_files_with_token_edits(folder, kind, edits):
    tokens = VALID[kind].decode().split(" ")
    for position, delete, token in edits:
        at = position % (len(tokens) + 1)
        tokens[at:at + delete] = [token]
    check_loads_or_mesh_error(folder, kind, " ".join(tokens).encode())
