"""Reading, writing, checking and repairing meshes."""


import numpy as np
import pytest
from conftest import noisy_copy

from darcyan import MeshError, MeshWarning
from darcyan.config import Denoising, Repairing
from darcyan.geometry import synthetic
from darcyan.geometry.denoise import denoise_mesh, surface_roughness, taubin_smooth
from darcyan.geometry.mesh import Mesh, normalize_mesh
from darcyan.geometry.repair import prepare_mesh
from darcyan.io.mesh_files import load_mesh, save_mesh

TETRA_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_bytes(text.encode() if isinstance(text, str) else text)
    return path


@pytest.mark.parametrize("ext", [".off", ".ply", ".obj"])
def test_round_trip_keeps_vertices_and_faces(tmp_path, ext, figure_poses):
    mesh = figure_poses[0]
    path = tmp_path / f"m{ext}"
    if ext == ".obj":
        lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in mesh.vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces]
        path.write_text("\n".join(lines))
    else:
        save_mesh(mesh, path)
    back = load_mesh(path)
    np.testing.assert_allclose(back.vertices, mesh.vertices, rtol=1e-7)
    np.testing.assert_array_equal(back.faces, mesh.faces)


def test_binary_and_ascii_ply(tmp_path):
    import trimesh

    t = trimesh.Trimesh(TETRA_V, TETRA_F, process=False)
    for encoding in ("binary", "ascii"):
        path = tmp_path / f"{encoding}.ply"
        path.write_bytes(t.export(file_type="ply", encoding=encoding))
        back = load_mesh(path)
        np.testing.assert_array_equal(back.faces, TETRA_F)


def test_tosca_vert_tri_pair(tmp_path):
    np.savetxt(tmp_path / "t.vert", TETRA_V)
    np.savetxt(tmp_path / "t.tri", TETRA_F + 1, fmt="%d")
    for name in ("t.vert", "t.tri"):
        back = load_mesh(tmp_path / name)
        np.testing.assert_array_equal(back.faces, TETRA_F)


def test_polygons_are_split_with_a_warning(tmp_path):
    path = write(tmp_path, "q.off", "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n4 0 1 2 3\n3 0 1 4\n")
    with pytest.warns(MeshWarning, match="split"):
        mesh = load_mesh(path)
    assert mesh.n_faces == 3


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_stl_corners_at_one_point_are_one_vertex_in_file_order(tmp_path, encoding):
    import trimesh

    mesh = synthetic.icosphere(2)
    path = tmp_path / f"{encoding}.stl"
    trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(
        path, file_type="stl" if encoding == "binary" else "stl_ascii")
    back = load_mesh(path)
    corners = mesh.vertices[mesh.faces]
    if encoding == "binary":  # binary STL stores float32
        corners = corners.astype(np.float32).astype(np.float64)
    assert back.n_faces == mesh.n_faces and back.n_vertices == mesh.n_vertices  # every shared corner one vertex
    np.testing.assert_array_equal(back.vertices[back.faces], corners)
    first_corner = {}
    for corner, vertex in enumerate(mesh.faces.ravel()):  # the file's order: vertex of each first corner
        first_corner.setdefault(int(vertex), corner)
    order = sorted(first_corner, key=first_corner.get)
    expected = mesh.vertices[order]
    if encoding == "binary":
        expected = expected.astype(np.float32).astype(np.float64)
    np.testing.assert_array_equal(back.vertices, expected)
    prepare_mesh(back, settings=Repairing(strict=True))  # a closed surface: nothing left to repair



@pytest.mark.parametrize("ext", [".glb", ".gltf"])
def test_gltf_is_read_with_its_vertex_order_and_its_nodes_placed(tmp_path, ext):
    import trimesh

    mesh = synthetic.icosphere(2)
    path = tmp_path / f"one{ext}"
    trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(path)
    back = load_mesh(path)
    np.testing.assert_allclose(back.vertices, mesh.vertices, atol=1e-6)  # float32 in the file
    np.testing.assert_array_equal(back.faces, mesh.faces)
    # Two meshes, the second moved by its node: both read, each where its node puts it.
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False), node_name="a", geom_name="a")
    scene.add_geometry(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False), node_name="b", geom_name="b",
                       transform=trimesh.transformations.translation_matrix([5.0, 0.0, 0.0]))
    scene.export(tmp_path / f"two{ext}")
    two = load_mesh(tmp_path / f"two{ext}")
    assert two.n_vertices == 2 * mesh.n_vertices and two.n_faces == 2 * mesh.n_faces
    moved = two.vertices[:, 0] > 2.5
    assert moved.sum() == mesh.n_vertices
    np.testing.assert_allclose(np.sort(two.vertices[moved] - [5.0, 0.0, 0.0], axis=0), np.sort(mesh.vertices, axis=0),
                               atol=1e-6)


def test_a_bad_gltf_is_one_error_naming_it(tmp_path):
    import trimesh

    with pytest.raises(MeshError, match=r"bad\.glb: not a readable glTF file"):
        load_mesh(write(tmp_path, "bad.glb", b"glTF" + bytes(40)))
    trimesh.Trimesh(TETRA_V, TETRA_F, process=False).export(tmp_path / "t.gltf")
    buffer = next(tmp_path.glob("*.bin"))
    buffer.unlink()
    with pytest.raises(MeshError, match=rf"t\.gltf: its buffer {buffer.name} is missing"):
        load_mesh(tmp_path / "t.gltf")
    points = trimesh.Scene(trimesh.PointCloud(TETRA_V))
    points.export(tmp_path / "points.glb")
    with pytest.raises(MeshError, match="points.glb: no triangles"):
        load_mesh(tmp_path / "points.glb")


def test_a_gltf_buffer_must_be_a_file_beside_it(tmp_path):
    # Percent-encoded names are read (the glTF spec's URIs); a URL, a path out of the folder, a
    # malformed file are each one error line naming the .gltf.
    import json

    import trimesh

    folder = tmp_path / "model"
    folder.mkdir()
    trimesh.Trimesh(TETRA_V, TETRA_F, process=False).export(folder / "t.gltf")
    document = json.loads((folder / "t.gltf").read_text())
    for buffer in document["buffers"]:
        old = folder / buffer["uri"]
        buffer["uri"] = "my%20" + buffer["uri"]
        old.rename(folder / ("my " + old.name))
    (folder / "spaced.gltf").write_text(json.dumps(document))
    np.testing.assert_allclose(load_mesh(folder / "spaced.gltf").vertices, TETRA_V)
    for uri, problem in (("../outside.bin", "lies outside its folder"), ("https://example.com/b.bin", "not a local file"),
                         ("", "names no file")):
        document["buffers"][0]["uri"] = uri
        (folder / "bad.gltf").write_text(json.dumps(document))
        with pytest.raises(MeshError, match=f"bad.gltf: .*{problem}"):
            load_mesh(folder / "bad.gltf")
    (folder / "broken.gltf").write_text('{"asset": {"version": "2.0"}, "buffers": [')
    with pytest.raises(MeshError, match="broken.gltf: not a glTF file: its JSON does not parse"):
        load_mesh(folder / "broken.gltf")


def test_the_cache_key_of_a_gltf_follows_its_buffer(tmp_path):
    # A .gltf keeps its geometry in the files it names: a changed buffer is another mesh, a
    # renamed copy of the same files the same one.
    import trimesh

    from darcyan.io.cache import file_digest

    trimesh.Trimesh(TETRA_V, TETRA_F, process=False).export(tmp_path / "t.gltf")
    text, before = (tmp_path / "t.gltf").read_bytes(), file_digest(tmp_path / "t.gltf")
    # trimesh names its buffers gltf_buffer_0.bin, ...: this export overwrites t.gltf's.
    trimesh.Trimesh(TETRA_V * 2.0, TETRA_F, process=False).export(tmp_path / "u.gltf")
    assert (tmp_path / "t.gltf").read_bytes() == text and file_digest(tmp_path / "t.gltf") != before
    np.testing.assert_allclose(load_mesh(tmp_path / "t.gltf").vertices, TETRA_V * 2.0)
    (tmp_path / "copy.gltf").write_bytes(text)
    assert file_digest(tmp_path / "copy.gltf") == file_digest(tmp_path / "t.gltf")

@pytest.mark.parametrize("name, text", [
    ("points.xyz", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n"),
    ("points.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                   "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"),
    ("points.off", "OFF\n4 0 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"),
])
def test_points_without_faces_need_a_triangle_mesh(tmp_path, name, text):
    path = write(tmp_path, name, text)
    with pytest.raises(MeshError, match="4 points and no faces: a triangle mesh is needed") as info:
        load_mesh(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


BAD_OFF = {
    "empty.off": ("", "empty"),
    "header.off": ("PLY\n3 1 0\n", "not an OFF file"),
    "counts.off": ("OFF\nthree 1 0\n", "integers"),
    "truncated.off": ("OFF\n4 4 0\n0 0 0\n1 0 0\n", "truncated"),
    "text.off": ("OFF\n4 1 0\n0 0 0\n1 zero 0\n0 1 0\n0 0 1\n3 0 1 2\n", "line 4"),
    "nan.off": ("OFF\n4 2 0\n0 0 0\nnan 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n", "NaN"),
    "inf.off": ("OFF\n4 2 0\n0 0 0\ninf 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n", "NaN or infinite"),
    "range.off": ("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 9\n", "out of range"),
    "negative.off": ("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 -1 3\n", "negative"),
    # The vertex count one more / one less than the real one.
    "plus_one.off": ("OFF\n5 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n", "truncated"),
    "minus_one.off": ("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n", "count in the header is wrong"),
    "extra.off": ("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n", "after the last face"),
    "binary.off": (b"\x00\x01\x02garbage\xff" * 10, "binary"),
}


@pytest.mark.parametrize("name", sorted(BAD_OFF))
def test_malformed_files_raise_mesh_error_naming_file(tmp_path, name):
    text, message = BAD_OFF[name]
    path = write(tmp_path, name, text)
    with pytest.raises(MeshError, match=message) as info:
        load_mesh(path)
    assert str(path) in str(info.value)


def test_missing_file_and_unknown_extension(tmp_path):
    with pytest.raises(MeshError, match="no such file"):
        load_mesh(tmp_path / "nothing.off")
    with pytest.raises(MeshError, match="unsupported file type"):
        load_mesh(write(tmp_path, "m.dxf", "0\nSECTION\n"))


def test_garbage_ply_is_a_mesh_error(tmp_path):
    with pytest.raises(MeshError):
        load_mesh(write(tmp_path, "g.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 9\n\xff\xfe"))


STRICT = Repairing(strict=True)


def test_duplicate_and_degenerate_faces_are_dropped_by_default_and_refused_as_strict():
    faces = np.vstack([TETRA_F, TETRA_F[:1], [[0, 0, 1]]])
    with pytest.raises(MeshError, match="^dup: 1 duplicate faces, 1 degenerate .*refused as strict"):
        prepare_mesh(Mesh(TETRA_V, faces, "dup"), settings=STRICT)
    for repair in (False, True):
        mesh, changes = prepare_mesh(Mesh(TETRA_V, faces, "dup"), repair=repair)
        assert mesh.n_faces == 4 and changes == ["dropped 1 duplicate faces", "dropped 1 degenerate (zero-area) faces"]
        np.testing.assert_array_equal(mesh.faces, TETRA_F)


def test_unreferenced_vertices_are_dropped_keeping_input_numbering():
    vertices = np.vstack([[[9, 9, 9]], TETRA_V])
    with pytest.raises(MeshError, match="unreferenced"):
        prepare_mesh(Mesh(vertices, TETRA_F + 1), settings=STRICT)
    mesh, _ = prepare_mesh(Mesh(vertices, TETRA_F + 1))
    np.testing.assert_array_equal(mesh.input_index, [1, 2, 3, 4])


def test_non_manifold_edge_is_refused_as_strict():
    vertices = np.vstack([TETRA_V, [[1, 1, 1]]])
    faces = np.vstack([TETRA_F, [[1, 2, 4]]])  # edge 1-2 now has three faces
    with pytest.raises(MeshError, match="non-manifold edges"):
        prepare_mesh(Mesh(vertices, faces), settings=STRICT)


def test_bow_tie_vertex_is_split_with_a_warning():
    second = TETRA_V + [3, 0, 0]
    second[0] = TETRA_V[1]  # share vertex 1 only
    vertices = np.vstack([TETRA_V, second[1:]])
    f2 = TETRA_F.copy()
    f2 = np.where(f2 == 0, 1, f2 + 3)
    with pytest.warns(MeshWarning) as caught:
        mesh, _ = prepare_mesh(Mesh(vertices, np.vstack([TETRA_F, f2])))
    messages = [str(w.message) for w in caught]
    assert len(messages) == 2 and "split 1 non-manifold vertices" in messages[0]
    assert "2 connected components" in messages[1]  # the two tetrahedra come apart
    np.testing.assert_array_equal(mesh.input_index, [4, 5, 6, 1])  # the larger one; its copy of 1 last


def test_several_components_keep_the_largest_with_a_warning():
    big = synthetic.icosphere(3, 2.0)
    small = synthetic.icosphere(1, 0.5)
    vertices = np.vstack([small.vertices + 10, big.vertices])
    faces = np.vstack([small.faces, big.faces + small.n_vertices])
    with pytest.warns(MeshWarning, match="2 connected components"):
        mesh, _ = prepare_mesh(Mesh(vertices, faces))
    assert mesh.n_vertices == big.n_vertices
    np.testing.assert_array_equal(mesh.input_index, np.arange(big.n_vertices) + small.n_vertices)


def test_normalization_gives_unit_area_centred(figure_poses):
    mesh, norm = normalize_mesh(figure_poses[0])
    assert np.isclose(mesh.area(), 1.0)
    assert np.isclose(norm.to_input_length(1.0), np.sqrt(figure_poses[0].area()))


def test_clean_meshes_are_not_denoised(sphere, figure_poses):
    for mesh in (sphere, *figure_poses):
        same, steps, _ = denoise_mesh(mesh, 1.1)
        assert steps == 0 and same is mesh
        assert mesh.area() / taubin_smooth(mesh, Denoising().block).area() < 1.04
    # Coarse clean meshes lose more than 10% of their area to smoothing, but are not rough.
    for subdivisions in (2, 3):
        coarse = synthetic.figure(1, subdivisions=subdivisions)
        same, steps, _ = denoise_mesh(coarse, 1.1)
        assert steps == 0 and same is coarse
        assert coarse.area() / taubin_smooth(coarse, Denoising().block).area() > 1.1
        assert surface_roughness(coarse) < 1.0 < surface_roughness(noisy_copy(coarse, 0.005))


def test_noise_is_detected_and_the_true_area_recovered(sphere):
    """A sphere of radius 2 (area 16 pi) under noise of half an edge: the area grows about 2-fold;
    after denoising it is back within 3% of the analytic area, vertex count and faces unchanged."""
    noisy = noisy_copy(sphere, 0.005)  # sigma 0.035: the sphere's diagonal is 4 sqrt(3), its edges ~0.075
    assert noisy.area() > 1.5 * 16 * np.pi
    smoothed, steps, ratio = denoise_mesh(noisy, 1.1)
    assert steps > 0 and ratio > 1.1
    assert smoothed.area() == pytest.approx(16 * np.pi, rel=0.03)
    np.testing.assert_array_equal(smoothed.faces, sphere.faces)
    radii = np.linalg.norm(smoothed.vertices, axis=1)
    assert np.abs(radii - 2.0).max() < 0.1
    assert denoise_mesh(noisy, 0)[1] == 0  # 0: off


def test_tosca_meshes_stay_below_the_denoising_threshold(tosca):
    """Clean scanned-quality meshes are analysed as they are (the default's results do not move)."""
    paths = sorted((tosca / "tosca-5k").glob("*.off"))
    assert paths, tosca / "tosca-5k"
    for path in paths:
        mesh = load_mesh(path)
        _, steps, _ = denoise_mesh(mesh, 1.1)
        assert steps == 0, f"{path.name}: roughness {surface_roughness(mesh):.3f}"


@pytest.mark.parametrize("order, fmt", [("<", "binary_little_endian"), (">", "binary_big_endian")])
def test_binary_ply_with_triangles_and_quads_loads(tmp_path, order, fmt):
    """Blender and others write binary PLY faces of mixed sizes, which trimesh's reader cannot."""
    import struct

    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], float)
    faces = [[0, 1, 2, 3], [1, 4, 2]]
    header = (f"ply\nformat {fmt} 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
              f"element face 2\nproperty list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack(order + "3f", *p) for p in vertices)
    body += b"".join(struct.pack(order + "B", len(f)) + struct.pack(order + f"{len(f)}i", *f) for f in faces)
    path = tmp_path / "mixed.ply"
    path.write_bytes(header + body)
    with pytest.warns(MeshWarning, match="split into triangles"):
        mesh = load_mesh(path)
    np.testing.assert_array_equal(mesh.vertices, vertices)
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]
    path.write_bytes(header + body[:-3])
    with pytest.raises(MeshError, match="truncated"):
        load_mesh(path)


def test_binary_ply_with_a_negative_list_length_is_one_error(tmp_path):
    import struct

    header = (b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
              b"property float z\nelement face 2\nproperty list char int vertex_indices\nend_header\n")
    body = b"".join(struct.pack("<3f", *p) for p in [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    body += struct.pack("<b4i", 4, 0, 1, 2, 3) + struct.pack("<b", -1) + b"\x00\x00\x00"
    path = tmp_path / "negative.ply"
    path.write_bytes(header + body)
    with pytest.raises(MeshError, match="negative.ply"):
        load_mesh(path)


def test_a_mesh_is_shown_by_its_name_and_size():
    assert repr(Mesh(TETRA_V, TETRA_F, "tetra")) == "Mesh('tetra', 4 vertices, 4 faces)"


def test_kept_operators_are_computed_once_and_stay_read_only_across_pickling(sphere):
    """A mesh's mixed areas and cotangent Laplacian are one object for every reader, read-only,
    and read-only again in a copy sent to another process (pickled)."""
    import pickle

    from darcyan.geometry.operators import cotangent_laplacian, mixed_voronoi_area

    mesh = Mesh(sphere.vertices.copy(), sphere.faces.copy())
    area, laplacian = mixed_voronoi_area(mesh), cotangent_laplacian(mesh)
    assert mixed_voronoi_area(mesh) is area and cotangent_laplacian(mesh) is laplacian
    copy = pickle.loads(pickle.dumps(mesh))
    for kept in (area, laplacian.data, mixed_voronoi_area(copy), cotangent_laplacian(copy).data,
                 cotangent_laplacian(copy).indices):
        with pytest.raises(ValueError):
            kept[0] = 1.0
    np.testing.assert_array_equal(mixed_voronoi_area(copy), area)


@pytest.mark.parametrize("text", ["OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                                  "\n\nOFF 3 1 0\r\n  0 0 0  \r\n\r\n1 0 0\r\n0 1 0\r\n3 0 1 2",
                                  "OFF\n\n\n3 1\n0 0 0\n1\t0 0\n0 1 0\n\n3 0 1 2\n\n", "x", "\n\n  \n"])
def test_the_fast_reader_counts_each_lines_tokens_as_splitting_it_does(text):
    from darcyan.io.mesh_files import _token_layout

    expected = [len(line.split()) for line in text.splitlines() if line.split()]
    counts = (_token_layout(text.encode()) or (None,))[0]
    assert counts is not None and counts.tolist() == expected


@pytest.mark.parametrize("text, plain", [
    ("OFF\n4 2 0\n0.1 -0.0 1e-3\n1.0000000000000002 2.5E+2 -7\n  +3 .5 5.\n1e308 -4.9e-324 0.30000000000000004\n"
     "3 0 1 2\n3 0 2 3\n", True),
    ("\n\nOFF 3 1 0\r\n  0 0 0  \r\n\r\n1 0 0\r\n0 1 0\r\n3 0 1 2", True),
    ("OFF\n\n\n3 1\n0 0 0\n1\t0 0\n0 1 0\n\n3 0 1 2\n\n", True),
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n", False),  # a face index that is not an integer
    ("OFF\n3 1 0\n0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n", False),  # a coordinate that is not a number
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", False),  # a face that says it has four corners
    ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 99999999999999999999\n", False),  # beyond int64
])
def test_the_fast_reader_reads_what_the_line_by_line_reader_reads(text, plain, tmp_path, monkeypatch):
    """The vectorized OFF reader gives the line-by-line reader's arrays bit for bit (floats as
    Python's float() reads them, -0.0 and subnormals included), and leaves every file it cannot
    read plainly to it, whose error names the line."""
    import darcyan.io.mesh_files as mesh_files

    fast = mesh_files._read_off_fast(text.encode())
    monkeypatch.setattr(mesh_files, "_read_off_fast", lambda data: None)
    if not plain:
        assert fast is None
        with pytest.raises(MeshError, match="line"):
            mesh_files._read_off(text.encode(), tmp_path / "a.off")
        return
    slow = mesh_files._read_off(text.encode(), tmp_path / "a.off")
    assert fast is not None
    for got, expected in zip(fast, slow):
        assert got.dtype == np.asarray(expected).dtype
        np.testing.assert_array_equal(got, expected)
        assert np.array_equal(np.signbit(got), np.signbit(expected))  # -0.0 kept


def test_the_fast_reader_reads_the_shared_meshes_as_the_line_by_line_reader(faust, monkeypatch):
    """On a FAUST and a TOSCA file: the same arrays bit for bit."""
    import darcyan.io.mesh_files as mesh_files

    for path in (faust / "tr_reg_000.off", faust.parent / "tosca-hires" / "cat0.off"):
        data = path.read_bytes()
        fast = mesh_files._read_off_fast(data)
        assert fast is not None
        with monkeypatch.context() as patched:
            patched.setattr(mesh_files, "_read_off_fast", lambda data: None)
            slow = mesh_files._read_off(data, path)
        for got, expected in zip(fast, slow):
            np.testing.assert_array_equal(got, expected)
