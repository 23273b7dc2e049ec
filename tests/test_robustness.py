"""Bad input and real-world meshes (issue 5).

* Malformed files, for every reader (OFF, OBJ, PLY ASCII and binary, TOSCA .vert/.tri): each is
  answered through the command line by exactly one line ``darcyan: error: <file>: <problem>`` and
  exit status 2 (the cases of tests/test_cli.py and tests/test_mesh.py are not repeated here).
* Holes: a TOSCA mesh with a region cut away still runs end to end; grids beside the hole mark
  the points beyond the boundary missing instead of inventing them; matching the cut shape to the
  uncut pose keeps the correct matches of the extremities the cut did not touch.
* Repair: duplicate and zero-area faces, unreferenced vertices and flipped faces are fixed by
  default with one note per change and results still numbered as in the input file, and
  refused under ``--strict``; a fin on an edge (a non-manifold edge) is split off; with several
  components the largest is used with a warning.
* Noise: vertex noise that crumples the surface is detected, said in a warning, and smoothed away
  before analysis; the matches stay correct where the unsmoothed analysis goes wrong.
"""

from __future__ import annotations

import csv
import io
import os
import struct

import numpy as np
import pytest
from conftest import run_cli as run

from darcyan.cli import main
from darcyan.config import DarcyanConfig
from darcyan.geometry import synthetic
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import Mesh, boundary_vertices
from darcyan.io.mesh_files import load_mesh, save_mesh
from darcyan.method.descriptors import curvature_descriptors
from darcyan.method.grid import darcyan_grid
from darcyan.method.pipeline import analyze_mesh, match_shapes

pytestmark = pytest.mark.usefixtures("private_cache")  # each test its own $DARCYAN_CACHE

# A small closed mesh (octahedron, flattened at the bottom so no face is degenerate).
V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.5]])
F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])


# ------------------------------------------------------------------------------------------------
# Writers of the small mesh in every format, with hooks to break them


def xyz(vertex) -> str:
    return " ".join(f"{c:g}" for c in vertex)


def off_text(vertices=V, faces=F, n_vertices=None, n_faces=None) -> str:
    n_vertices = len(vertices) if n_vertices is None else n_vertices
    n_faces = len(faces) if n_faces is None else n_faces
    rows = [xyz(v) for v in vertices] + [f"3 {a} {b} {c}" for a, b, c in faces]
    return f"OFF\n{n_vertices} {n_faces} 0\n" + "\n".join(rows) + "\n"


def obj_text(vertices=V, faces=F) -> str:
    rows = [f"v {xyz(v)}" for v in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    return "\n".join(rows) + "\n"


def ply_header(encoding: str, n_vertices: int, n_faces: int) -> bytes:
    return (f"ply\nformat {encoding} 1.0\nelement vertex {n_vertices}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {n_faces}\nproperty list uchar int vertex_indices\n"
            f"end_header\n").encode()


def ply_ascii(vertices=V, faces=F, n_vertices=None, n_faces=None) -> bytes:
    head = ply_header("ascii", len(vertices) if n_vertices is None else n_vertices,
                      len(faces) if n_faces is None else n_faces)
    rows = [xyz(v) for v in vertices] + [f"3 {a} {b} {c}" for a, b, c in faces]
    return head + ("\n".join(rows) + "\n").encode()


def ply_binary(vertices=V, faces=F, n_vertices=None, n_faces=None) -> bytes:
    head = ply_header("binary_little_endian", len(vertices) if n_vertices is None else n_vertices,
                      len(faces) if n_faces is None else n_faces)
    body = b"".join(struct.pack("<3f", *v) for v in vertices)
    body += b"".join(struct.pack("<B3i", 3, *f) for f in faces)
    return head + body


def vert_tri(vertices=V, faces=F) -> tuple[str, str]:
    return ("\n".join(xyz(v) for v in vertices) + "\n",
            "\n".join(f"{a + 1} {b + 1} {c + 1}" for a, b, c in faces) + "\n")


NAN_V = np.vstack([V[:1], [[np.nan, 0, 0]], V[2:]])
INF_V = np.vstack([V[:1], [[np.inf, 0, 0]], V[2:]])
NEG_F = np.vstack([F[:-1], [[0, 3, -2]]])
RANGE_F = np.vstack([F[:-1], [[0, 3, 6]]])  # 6 vertices: index 6 is one past the end

# name -> (file content, expected words in the error line)
MALFORMED = {
    # OFF (the header/count/text cases at library level live in test_mesh.py)
    "truncated.off": (off_text()[:-12], "truncated"),
    "vertex_count_plus_one.off": (off_text(n_vertices=7), "truncated"),
    "vertex_count_minus_one.off": (off_text(n_vertices=5), "wrong"),
    "text_in_index.off": (off_text().replace("3 0 2 4", "3 0 two 4"), "integer vertex indices"),
    "inf.off": (off_text(INF_V), "infinite"),
    "negative.off": (off_text(faces=NEG_F), "negative vertex index"),
    "two_corners.off": (off_text().replace("3 0 2 4", "2 0 2"), "at least 3 corners"),
    "empty.off": ("", "empty file"),
    "blank.off": ("\n  \n", "empty file"),
    "garbage.off": (bytes(range(256)) * 8, "binary content"),
    # OBJ
    "truncated.obj": (obj_text()[:-4], "at least 3 corners"),
    "text.obj": (obj_text().replace("v 1 0 0", "v one 0 0"), "line 1"),
    "nan.obj": (obj_text(NAN_V), "NaN"),
    "inf.obj": (obj_text(INF_V), "infinite"),
    "two_coordinates.obj": (obj_text().replace("v 1 0 0", "v 1 0"), "3 coordinates"),
    "index_zero.obj": (obj_text().replace("f 1 3 5", "f 0 3 5"), "index 0"),
    "relative_before_start.obj": (obj_text().replace("f 1 3 5", "f -9 3 5"), "before the first vertex"),
    "out_of_range.obj": (obj_text(faces=RANGE_F), "out of range"),
    "text_index.obj": (obj_text().replace("f 1 3 5", "f 1 x 5"), "integer vertex indices"),
    "no_faces.obj": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n", "a triangle mesh is needed"),
    "empty.obj": ("", "empty file"),
    "garbage.obj": (bytes(range(256)) * 8, "binary content"),
    # PLY, ASCII
    "truncated_ascii.ply": (ply_ascii()[:-12], "truncated"),
    "vertex_count_plus_one_ascii.ply": (ply_ascii(n_vertices=7), "truncated"),
    "vertex_count_minus_one_ascii.ply": (ply_ascii(n_vertices=5), "count in the header is wrong"),
    "face_count_plus_one_ascii.ply": (ply_ascii(n_faces=9), "truncated"),
    "face_count_minus_one_ascii.ply": (ply_ascii(n_faces=7), "count in the header is wrong"),
    "text_ascii.ply": (ply_ascii().replace(b"\n1 0 0\n", b"\none 0 0\n"), "line 10"),
    "nan_ascii.ply": (ply_ascii(NAN_V), "NaN"),
    "inf_ascii.ply": (ply_ascii(INF_V), "infinite"),
    "negative_ascii.ply": (ply_ascii(faces=NEG_F), "negative vertex index"),
    "out_of_range_ascii.ply": (ply_ascii(faces=RANGE_F), "out of range"),
    "long_face_ascii.ply": (ply_ascii().replace(b"3 0 2 4", b"3 0 2 4 7"), "more than the header declares"),
    "no_end_header.ply": (b"ply\nformat ascii 1.0\nelement vertex 6\n", "end_header"),
    "bad_format.ply": (ply_ascii().replace(b"format ascii", b"format utf8"), "unknown PLY format"),
    "no_xyz.ply": (ply_ascii().replace(b"property float z", b"property float w"), "x, y, z"),
    "empty.ply": (b"", "empty file"),
    "not_ply.ply": (b"solid cube\nfacet normal 0 0 1\n", "not a PLY file"),
    # PLY, binary
    "truncated_binary.ply": (ply_binary()[:-5], "truncated"),
    "vertex_count_plus_one_binary.ply": (ply_binary(n_vertices=7), "face"),
    "vertex_count_minus_one_binary.ply": (ply_binary(n_vertices=5), "count in the header is wrong"),
    "face_count_plus_one_binary.ply": (ply_binary(n_faces=9), "truncated"),
    "face_count_minus_one_binary.ply": (ply_binary(n_faces=7), "count in the header is wrong"),
    "nan_binary.ply": (ply_binary(NAN_V), "NaN"),
    "inf_binary.ply": (ply_binary(INF_V), "infinite"),
    "negative_binary.ply": (ply_binary(faces=NEG_F), "negative vertex index"),
    "out_of_range_binary.ply": (ply_binary(faces=RANGE_F), "out of range"),
    "garbage_body_binary.ply": (ply_header("binary_little_endian", 6, 8) + bytes(range(97)), "truncated"),
    "garbage_header.ply": (b"ply\n" + bytes(range(1, 256)) * 4, "PLY"),
    # STL
    "no_triangles.stl": ("solid x\nendsolid x\n", "no triangles"),
    "truncated_binary.stl": (bytes(80) + struct.pack("<I", 2) + bytes(60), "not an STL file"),
    # unsupported extensions
    "mesh.off.gz": (b"\x1f\x8b\x08\x00", "unsupported file type '.gz'"),
    "no_extension": (off_text(), "unsupported file type '(none)'"),
}


def write_case(folder, name: str, content) -> os.PathLike:
    path = folder / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    return path


def assert_one_error_line(code, out, err, path, words):
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"darcyan: error: {path}: "), lines[0]
    assert words in lines[0], lines[0]
    assert "Traceback" not in err


@pytest.mark.parametrize("name", sorted(MALFORMED))
def test_malformed_file_is_one_error_line_and_exit_2(capsys, tmp_path, name):
    content, words = MALFORMED[name]
    path = write_case(tmp_path, name, content)
    assert_one_error_line(*run(capsys, "features", path), path, words)


VERT_TRI = {
    # name -> (.vert content, .tri content, file named in the error, expected words)
    "text": (vert_tri()[0].replace("1 0 0", "1 zero 0"), vert_tri()[1], ".vert", "line 1"),
    "nan": (*vert_tri(NAN_V), ".vert", "NaN"),
    "two_columns": (vert_tri()[0], vert_tri()[1].replace("1 3 5", "1 3"), ".tri", "expected 3 values"),
    "zero_index": (vert_tri()[0], vert_tri()[1].replace("1 3 5", "0 3 5"), ".tri", "negative vertex index"),
    "out_of_range": (*vert_tri(faces=RANGE_F), ".tri", "out of range"),
    "float_index": (vert_tri()[0], vert_tri()[1].replace("1 3 5", "1 3.5 5"), ".tri", "integer vertex indices"),
    "empty": ("", "", ".tri", "empty mesh"),
}


@pytest.mark.parametrize("name", sorted(VERT_TRI))
@pytest.mark.parametrize("open_as", [".vert", ".tri"])
def test_malformed_vert_tri_pair(capsys, tmp_path, name, open_as):
    vert, tri, culprit, words = VERT_TRI[name]
    write_case(tmp_path, f"{name}.vert", vert)
    write_case(tmp_path, f"{name}.tri", tri)
    code, out, err = run(capsys, "features", tmp_path / f"{name}{open_as}")
    culprit_path = tmp_path / f"{name}{culprit}"
    if words in ("NaN", "negative vertex index", "out of range", "empty mesh"):
        culprit_path = tmp_path / f"{name}{open_as}"  # checks of the assembled mesh name the opened file
    assert_one_error_line(code, out, err, culprit_path, words)


def test_missing_sibling_of_a_vert_tri_pair(capsys, tmp_path):
    write_case(tmp_path, "alone.vert", vert_tri()[0])
    assert_one_error_line(*run(capsys, "features", tmp_path / "alone.vert"), tmp_path / "alone.tri",
                          "no such file")


def test_the_writers_above_make_valid_files(tmp_path):
    """The malformed cases are single edits of files that load: the edit is what is refused."""
    tri = vert_tri()
    write_case(tmp_path, "ok.tri", tri[1])
    cases = {"ok.off": off_text(), "ok.obj": obj_text(), "ok_a.ply": ply_ascii(), "ok_b.ply": ply_binary(),
             "ok.vert": tri[0]}
    for name, content in cases.items():
        mesh = load_mesh(write_case(tmp_path, name, content))
        np.testing.assert_allclose(mesh.vertices, V)
        np.testing.assert_array_equal(mesh.faces, F)


def test_a_directory_is_refused(capsys, tmp_path):
    folder = tmp_path / "folder.off"
    folder.mkdir()
    assert_one_error_line(*run(capsys, "features", folder), folder, "directory")


def test_an_unreadable_file_is_refused(capsys, tmp_path):
    path = write_case(tmp_path, "locked.off", off_text())
    path.chmod(0)
    try:
        if os.access(path, os.R_OK):
            pytest.skip("running as root (or with CAP_DAC_OVERRIDE): a chmod 000 file is still readable")
        assert_one_error_line(*run(capsys, "features", path), path, "permission denied")
    finally:
        path.chmod(0o600)


def test_output_to_an_unwritable_place_is_one_line(capsys, tmp_path):
    source = tmp_path / "figure.off"
    save_mesh(synthetic.figure(0), source)
    target = tmp_path / "no_such_folder" / "out.csv"
    code, out, err = run(capsys, "features", source, "-o", target)
    assert code == 2 and len(err.strip().splitlines()) == 1 and str(target) in err


# ------------------------------------------------------------------------------------------------
# Holes: a TOSCA wolf with regions cut away


def wolf(tosca, pose: int) -> Mesh:
    return load_mesh(tosca / "tosca-hires" / f"wolf{pose}.off")


def cut(mesh: Mesh, centre: np.ndarray, radius: float) -> Mesh:
    """Remove the faces with a corner within Euclidean ``radius`` of ``centre``; every vertex stays
    (so the file numbering is unchanged; the unused ones are dropped by ``repair``)."""
    near = np.linalg.norm(mesh.vertices - centre, axis=1) < radius
    keep = ~near[mesh.faces].any(axis=1)
    return Mesh(mesh.vertices, mesh.faces[keep], f"{mesh.name} (cut)")


# The match error threshold of the evaluation (geodesic error / sqrt(area)).
THRESHOLD = 0.05
HOLE_RADIUS = 0.06  # in sqrt(area) units


@pytest.fixture(scope="module")
def wolves(tosca):
    meshes = [wolf(tosca, 0), wolf(tosca, 1)]
    described = [analyze_mesh(m) for m in meshes]
    return meshes, described


def correct_sources(correspondence, target: Mesh, solver: GeodesicSolver) -> set[int]:
    """Source vertices whose match lies within THRESHOLD of the truth (identity within a class)."""
    scale = np.sqrt(target.area())
    return {int(s) for s, t in zip(correspondence.source_vertex, correspondence.target_vertex)
            if solver.distance(int(s))[int(t)] / scale <= THRESHOLD}


# A hole is kept this far (sqrt(area) units) from every feature point and from the vertex of
# least AGD, the body centre toward which every grid's angle 0 points (the pipeline's anchor).
CLEAR_OF_FEATURES = 0.35
CLEAR_OF_ANCHOR = 0.2


def anchor_vertex(shape) -> int:
    """The least-AGD vertex (input numbering) of a described shape."""
    return int(shape.mesh.input_index[np.argmin(shape.agd.values)])


@pytest.fixture(scope="module")
def torso_hole(wolves):
    """wolf0 with a hole on the torso: the least-AGD vertex among those clear of the feature
    points and of the anchor. Returns (hole centre in input units, described holed shape)."""
    (mesh_0, _), (shape_0, _) = wolves
    scale = np.sqrt(mesh_0.area())
    solver = GeodesicSolver(mesh_0)
    agd = np.empty(mesh_0.n_vertices)
    agd[shape_0.mesh.input_index] = shape_0.agd.values
    clear = (solver.distance_multi(shape_0.feature_vertices) / scale > CLEAR_OF_FEATURES) & \
        (solver.distance(anchor_vertex(shape_0)) / scale > CLEAR_OF_ANCHOR)
    candidates = np.flatnonzero(clear)
    centre = mesh_0.vertices[candidates[np.argmin(agd[candidates])]]
    holed = cut(mesh_0, centre, HOLE_RADIUS * scale)
    assert holed.n_faces < mesh_0.n_faces
    return centre, analyze_mesh(holed, repair=True)


def test_hole_away_from_the_extremities(wolves, torso_hole):
    (mesh_0, mesh_1), (shape_0, shape_1) = wolves
    _, shape = torso_hole
    assert any("unreferenced" in c for c in shape.changes)
    assert boundary_vertices(shape.mesh).any()
    # Matching the cut shape to the uncut pose keeps every correct match of the uncut shape.
    solver_1 = GeodesicSolver(mesh_1)
    before = correct_sources(match_shapes(shape_0, shape_1), mesh_1, solver_1)
    after = correct_sources(match_shapes(shape, shape_1), mesh_1, solver_1)
    assert len(before) >= 3
    assert before <= after | _moved(before, shape, mesh_0)


def test_hole_at_the_body_centre(wolves):
    """The hole where AGD is least: its minimum moves across the flat torso (to the other flank), so
    anything anchored there (e.g. the direction of angle 0 of the grids) moves with it; a version
    that oriented its matching by that anchor swapped left and right limbs here."""
    (mesh_0, mesh_1), (shape_0, shape_1) = wolves
    scale = np.sqrt(mesh_0.area())
    shape = analyze_mesh(cut(mesh_0, mesh_0.vertices[anchor_vertex(shape_0)], HOLE_RADIUS * scale), repair=True)
    solver_1 = GeodesicSolver(mesh_1)
    before = correct_sources(match_shapes(shape_0, shape_1), mesh_1, solver_1)
    after = correct_sources(match_shapes(shape, shape_1), mesh_1, solver_1)
    assert len(before) >= 3
    assert before <= after | _moved(before, shape, mesh_0)


def _moved(vertices: set[int], shape, mesh: Mesh) -> set[int]:
    """Those of ``vertices`` that are no longer a feature point of ``shape`` (AGD changes a little
    when a hole is cut: a feature point can move to a neighbouring vertex)."""
    return {v for v in vertices if v not in set(shape.feature_vertices.tolist())}


def test_grids_beside_a_hole_mark_missing_points(wolves, torso_hole):
    _, (shape_0, _) = wolves
    config = DarcyanConfig()
    centre, shape = torso_hole
    mesh, solver = shape.mesh, shape.solver
    hole_centre = (centre - shape.normalization.centre) * shape.normalization.scale
    to_boundary = solver.distance_multi(np.flatnonzero(boundary_vertices(mesh)))
    uncut = {int(v): i for i, v in enumerate(shape_0.mesh.input_index)}
    max_edge = np.linalg.norm(np.diff(mesh.vertices[mesh.edges()], axis=1), axis=2).max()
    # A centre half the grid radius from the hole: some radial lines run into it.
    beside = int(np.argmin(np.abs(to_boundary - config.radius / 2)))
    grid = darcyan_grid(mesh, solver, beside, config)
    assert not grid.valid.all(), "a grid reaching over the hole must miss points"
    assert (~grid.valid[-1]).sum() > (~grid.valid[0]).sum()  # more missing on the outer levels
    # On the uncut shape the same grid is complete: the missing points are the hole's doing.
    twin = darcyan_grid(shape_0.mesh, shape_0.solver, uncut[int(mesh.input_index[beside])], config)
    assert twin.valid.all()
    # The same centre, and one on the rim of the hole (where the tracer spreads the radial lines
    # over the surface side only): nothing invented, descriptors NaN only for empty levels.
    for v in (beside, int(np.argmin(to_boundary))):
        grid = darcyan_grid(mesh, solver, v, config)
        assert grid.valid.any()
        assert np.isfinite(grid.points[grid.valid]).all() and np.isnan(grid.points[~grid.valid]).all()
        assert (grid.faces[~grid.valid] == -1).all()
        # Nothing is invented inside the hole: every point found is on the remaining surface.
        inside = np.linalg.norm(grid.points[grid.valid] - hole_centre, axis=1)
        assert inside.min() > HOLE_RADIUS - max_edge
        # A descriptor level is NaN exactly when all of its points are missing.
        descriptor = curvature_descriptors(mesh, [grid], shape.curvatures)[0].reshape(-1, 2)
        np.testing.assert_array_equal(np.isnan(descriptor).any(axis=1), ~grid.valid.any(axis=1))
        np.testing.assert_array_equal(np.isnan(descriptor).all(axis=1), ~grid.valid.any(axis=1))


def test_hole_through_an_extremity_neighbourhood(wolves):
    (mesh_0, mesh_1), (shape_0, shape_1) = wolves
    scale = np.sqrt(mesh_0.area())
    config = DarcyanConfig()
    # A hole one grid radius from the first extremity: its grid reaches into the hole.
    tip = int(shape_0.feature_vertices[0])
    along = GeodesicSolver(mesh_0).distance(tip) / scale
    centre_vertex = int(np.argmin(np.abs(along - config.radius)))
    holed = cut(mesh_0, mesh_0.vertices[centre_vertex], config.radius / 2 * scale)
    shape = analyze_mesh(holed, repair=True)
    assert boundary_vertices(shape.mesh).any()
    for grid, descriptor in zip(shape.grids, shape.descriptors):
        levels = descriptor.reshape(-1, 2)
        np.testing.assert_array_equal(np.isnan(levels).all(axis=1), ~grid.valid.any(axis=1))
        np.testing.assert_array_equal(np.isnan(levels).any(axis=1), ~grid.valid.any(axis=1))
    # The extremities away from the cut stay correctly matched against the uncut pose.
    solver_0, solver_1 = GeodesicSolver(mesh_0), GeodesicSolver(mesh_1)
    far = config.radius + config.extremity_radius + config.radius / 2
    away = {v for v in shape_0.feature_vertices.tolist() if solver_0.distance(v)[centre_vertex] / scale > far}
    before = correct_sources(match_shapes(shape_0, shape_1), mesh_1, solver_1) & away
    after = correct_sources(match_shapes(shape, shape_1), mesh_1, solver_1)
    assert len(before) >= 2
    assert before <= after | _moved(before, shape, mesh_0)


# ------------------------------------------------------------------------------------------------
# Repair through the command line


def features_rows(out: str) -> list[tuple[int, float]]:
    return [(int(r["vertex"]), float(r["agd"])) for r in csv.DictReader(io.StringIO(out))]


@pytest.fixture(scope="module")
def clean_wolf(tosca, tmp_path_factory):
    """wolf0 as a file and its features (vertex, agd) through the command line."""
    folder = tmp_path_factory.mktemp("wolf")
    path = folder / "wolf0.off"
    mesh = wolf(tosca, 0)
    save_mesh(mesh, path)
    code = main(["features", str(path), "--no-cache", "-o", str(folder / "features.csv")])
    assert code == 0
    return mesh, features_rows((folder / "features.csv").read_text())


def notes(err: str) -> list[str]:
    return [line for line in err.strip().splitlines() if line.startswith("darcyan: note: ")]


def test_unreferenced_vertex_at_index_0_is_dropped_and_indices_stay_the_files(capsys, tmp_path, clean_wolf):
    mesh, clean = clean_wolf
    path = tmp_path / "shifted.off"
    save_mesh(Mesh(np.vstack([[[500.0, 500.0, 500.0]], mesh.vertices]), mesh.faces + 1), path)
    code, out, err = run(capsys, "features", path, "--strict", "--no-cache")
    assert_one_error_line(code, out, err, path, "refused as strict")
    code, out, err = run(capsys, "features", path, "--no-cache")
    assert code == 0
    assert notes(err) == [f"darcyan: note: {path}: dropped 1 unreferenced vertices"]
    shifted = features_rows(out)
    assert [v for v, _ in shifted] == [v + 1 for v, _ in clean]
    np.testing.assert_allclose([a for _, a in shifted], [a for _, a in clean], rtol=1e-5)


def test_duplicate_and_zero_area_faces_are_dropped_with_notes(capsys, tmp_path, clean_wolf):
    mesh, clean = clean_wolf
    a, b, c = mesh.faces[10]
    extra = np.array([[a, b, c], [b, c, a], [a, a, b]])  # a duplicate, the same rotated, a zero-area face
    path = tmp_path / "dirty.off"
    save_mesh(Mesh(mesh.vertices, np.vstack([mesh.faces, extra])), path)
    assert_one_error_line(*run(capsys, "features", path, "--strict", "--no-cache"), path, "duplicate faces")
    code, out, err = run(capsys, "features", path, "--no-cache")
    assert code == 0
    assert notes(err) == [f"darcyan: note: {path}: dropped 2 duplicate faces",
                          f"darcyan: note: {path}: dropped 1 degenerate (zero-area) faces"]
    assert features_rows(out) == clean


def test_flipped_faces_are_reoriented_by_default(capsys, tmp_path, clean_wolf):
    mesh, clean = clean_wolf
    faces = mesh.faces.copy()
    flipped = np.arange(100, 1100, 100)
    faces[flipped] = faces[flipped, ::-1]
    path = tmp_path / "flipped.off"
    save_mesh(Mesh(mesh.vertices, faces), path)
    assert_one_error_line(*run(capsys, "features", path, "--strict", "--no-cache"), path, "consistently oriented")
    code, out, err = run(capsys, "features", path, "--no-cache")
    assert code == 0
    assert notes(err) == [f"darcyan: note: {path}: reoriented {len(flipped)} faces to agree with their neighbours"]
    repaired = features_rows(out)
    assert [v for v, _ in repaired] == [v for v, _ in clean]
    np.testing.assert_allclose([a for _, a in repaired], [a for _, a in clean], rtol=1e-5)


def test_non_manifold_edge_is_split_off_by_default_and_an_error_as_strict(capsys, tmp_path, clean_wolf):
    mesh, clean = clean_wolf
    a, b, _ = mesh.faces[0]
    apex = mesh.vertices[[a, b]].mean(axis=0) + [0.0, 0.0, 5.0]
    path = tmp_path / "fin.off"
    faces = np.vstack([mesh.faces, [[a, b, mesh.n_vertices]]])  # a fin: edge a-b now has three faces
    save_mesh(Mesh(np.vstack([mesh.vertices, apex]), faces), path)
    code, out, err = run(capsys, "features", path, "--strict", "--no-cache")
    assert_one_error_line(code, out, err, path, "non-manifold edges")
    assert "strict" in err
    code, out, err = run(capsys, "features", path, "--no-cache")
    assert code == 0
    assert notes(err) == [f"darcyan: note: {path}: split 1 non-manifold edges (more than two faces on one "
                          f"edge) into pairs of faces"]
    assert f"darcyan: warning: {path}: 2 connected components" in err  # the fin, left out
    assert features_rows(out) == clean


@pytest.mark.parametrize("where", ["after", "before"])
def test_several_components_use_the_largest_with_one_warning(capsys, tmp_path, clean_wolf, where):
    mesh, clean = clean_wolf
    ball = synthetic.icosphere(2, 5.0)
    ball_vertices = ball.vertices + mesh.vertices.max(axis=0) + 50.0
    if where == "after":
        combined = Mesh(np.vstack([mesh.vertices, ball_vertices]), np.vstack([mesh.faces, ball.faces + mesh.n_vertices]))
        shift = 0
    else:
        combined = Mesh(np.vstack([ball_vertices, mesh.vertices]), np.vstack([ball.faces, mesh.faces + ball.n_vertices]))
        shift = ball.n_vertices
    path = tmp_path / f"two_parts_{where}.off"
    save_mesh(combined, path)
    code, out, err = run(capsys, "features", path, "--no-cache")
    assert code == 0
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"darcyan: warning: {path}: 2 connected components")
    assert f"{ball.n_faces} faces" in lines[0]
    assert features_rows(out) == [(v + shift, a) for v, a in clean]


def test_a_cache_hit_repeats_the_warning_of_the_run_that_filled_it(capsys, tmp_path, clean_wolf):
    mesh, clean = clean_wolf
    ball = synthetic.icosphere(2, 5.0)
    combined = Mesh(np.vstack([mesh.vertices, ball.vertices + mesh.vertices.max(axis=0) + 50.0]),
                    np.vstack([mesh.faces, ball.faces + mesh.n_vertices]))
    path = tmp_path / "two_parts.off"
    save_mesh(combined, path)
    runs = [run(capsys, "features", path) for _ in range(2)]  # the second is served by the cache
    assert [code for code, _, _ in runs] == [0, 0]
    assert runs[0][1] == runs[1][1] and features_rows(runs[1][1]) == clean
    for _, _, err in runs:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"darcyan: warning: {path}: 2 connected components")


# ------------------------------------------------------------------------------------------------
# Vertex noise


@pytest.mark.slow
def test_noisy_figure_is_denoised_and_still_matched():
    """The figure in two poses with Gaussian vertex noise of 1% of the diagonal (about an edge),
    scored against the clean target: every match correct with the default denoising, and not
    without it (measured: 5/5 against 3/4), so the test fails if denoising stops working."""
    import warnings

    from conftest import noisy_copy

    from darcyan import MeshWarning
    from darcyan.eval.metrics import geodesic_errors
    from darcyan.method.pipeline import analyze_mesh, match_shapes

    clean = [synthetic.figure(0), synthetic.figure(1)]
    noisy = [noisy_copy(mesh, 0.01, seed) for seed, mesh in enumerate(clean)]
    reference = analyze_mesh(clean[1])

    def correct(config):
        shapes = [analyze_mesh(m, config) for m in noisy]
        found = match_shapes(shapes[0], shapes[1], config)
        errors = geodesic_errors(reference.mesh, reference.solver, found.target_vertex, found.source_vertex)
        return int((errors <= 0.05).sum()), len(shapes[0])

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MeshWarning)
        hits, features = correct(DarcyanConfig())
    assert any("crumpled" in str(w.message) for w in caught)
    assert hits == features >= 5
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        hits_raw, _ = correct(DarcyanConfig(denoise_area_ratio=0))
    assert hits_raw < hits
