"""The meshes people actually have: bow ties, non-manifold edges, triangle soups, decimated meshes.

* Non-manifold vertices (fans of faces meeting only at a vertex) are split by default, one copy
  per fan, with a warning; every copy maps back to the input vertex.
* Non-manifold edges and duplicate faces are split apart (faces glued in pairs that close a fan)
  or dropped by default, with a note, and refused as strict (``--strict``).
* A triangle soup is refused with a message saying so without ``--repair``, and welded back to the
  original mesh with it.
* Meshes decimated by fast_simplification to 10% and 5% of their vertices (duplicate faces,
  sheets pinched along an edge) prepare and describe.
* A surface that cannot be oriented (a Moebius strip) is cut open where its faces disagree.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from darcyan import MeshError, MeshWarning, analyze_mesh
from darcyan.cli import main
from darcyan.config import Repairing
from darcyan.geometry import synthetic
from darcyan.geometry.mesh import Mesh, _edge_counts
from darcyan.geometry.repair import nonmanifold_vertices, prepare_mesh, split_nonmanifold, submesh, weld_vertices
from darcyan.io.mesh_files import load_mesh, save_mesh


def tosca_5k(tosca, name: str) -> Mesh:
    return load_mesh(tosca / "tosca-5k" / f"{name}.off")


def soup(mesh: Mesh) -> Mesh:
    """Every face with its own three vertices (what STL files and some exporters write)."""
    return Mesh(mesh.vertices[mesh.faces].reshape(-1, 3), np.arange(3 * mesh.n_faces).reshape(-1, 3), "soup")


def cone_fan(apex: np.ndarray, rim_radius: float, height: float, rim_first: int, sides: int = 6):
    """An open cone around ``apex`` (vertex 0): rim vertices and faces numbered from ``rim_first``."""
    angles = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    rim = apex + np.c_[rim_radius * np.cos(angles), rim_radius * np.sin(angles), np.full(sides, height)]
    ring = rim_first + np.arange(sides)
    faces = np.c_[np.zeros(sides, int), ring, np.roll(ring, -1)]
    return rim, faces if height > 0 else faces[:, [0, 2, 1]]


def test_bow_tie_of_two_fans_is_split_and_each_copy_maps_back():
    apex = np.zeros(3)
    rim_up, faces_up = cone_fan(apex, 1.0, 1.0, 1)
    rim_down, faces_down = cone_fan(apex, 2.0, -1.0, 7)  # the larger fan: the one kept
    mesh = Mesh(np.vstack([apex, rim_up, rim_down]), np.vstack([faces_up, faces_down]), "bow tie")
    np.testing.assert_array_equal(nonmanifold_vertices(mesh), [0])

    with pytest.warns(MeshWarning, match="split 1 non-manifold vertices .*first: input vertex 0"):
        split, dropped = split_nonmanifold(mesh)
    assert dropped == 0 and split.n_vertices == mesh.n_vertices + 1
    np.testing.assert_array_equal(split.input_index, np.r_[np.arange(13), 0])  # the copy is vertex 0
    apexes = {int(split.faces[t][0]) for t in range(split.n_faces)}
    assert apexes == {0, 13} and len(nonmanifold_vertices(split)) == 0

    with pytest.warns(MeshWarning) as caught:
        prepared, changes = prepare_mesh(mesh)
    messages = [str(w.message) for w in caught]
    assert any("split 1 non-manifold vertices" in m for m in messages)
    assert any("2 connected components" in m for m in messages)
    assert changes == []
    np.testing.assert_array_equal(np.sort(prepared.input_index), np.r_[0, np.arange(7, 13)])
    np.testing.assert_array_equal(prepared.vertices, mesh.vertices[prepared.input_index])


def test_two_triangles_sharing_a_corner_are_split():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -2, 0]], float)
    with pytest.warns(MeshWarning, match="split 1 non-manifold vertices"):
        split, _ = split_nonmanifold(Mesh(vertices, [[0, 1, 2], [0, 3, 4]]))
    np.testing.assert_array_equal(split.faces, [[0, 1, 2], [5, 3, 4]])
    np.testing.assert_array_equal(split.input_index, [0, 1, 2, 3, 4, 0])


def test_pinched_real_mesh_prepares_with_a_warning_and_describes(tosca):
    mesh = tosca_5k(tosca, "wolf0")
    # Glue the two vertices farthest apart along x (snout and tail) into one: vertex `kept` then
    # has two fans of faces, and `gone` leaves the file.
    kept, gone = int(np.argmax(mesh.vertices[:, 0])), int(np.argmin(mesh.vertices[:, 0]))
    faces = np.where(mesh.faces == gone, kept, mesh.faces)
    pinched = Mesh(np.delete(mesh.vertices, gone, axis=0), faces - (faces > gone), "pinched")
    kept -= kept > gone
    np.testing.assert_array_equal(nonmanifold_vertices(pinched), [kept])

    with pytest.warns(MeshWarning, match=f"split 1 non-manifold vertices .*first: input vertex {kept}\\)"):
        prepared, changes = prepare_mesh(pinched)
    assert changes == [] and prepared.n_vertices == pinched.n_vertices + 1
    assert (prepared.input_index == kept).sum() == 2
    np.testing.assert_array_equal(prepared.vertices, pinched.vertices[prepared.input_index])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        analysis = analyze_mesh(pinched)
    assert len(analysis.feature_vertices) > 0
    assert ((0 <= analysis.feature_vertices) & (analysis.feature_vertices < pinched.n_vertices)).all()


def test_soup_is_refused_without_repair_and_welded_back_with_it(tosca):
    mesh = tosca_5k(tosca, "wolf0")
    soupy = soup(mesh)
    with pytest.raises(MeshError, match=f"{mesh.n_faces} components of 1 face each: a triangle soup\\? "
                                        f"--repair \\(repair=True in Python\\) welds coincident vertices"):
        prepare_mesh(soupy)

    welded, changes = prepare_mesh(soupy, repair=True)
    assert welded.n_vertices == mesh.n_vertices
    assert changes == [f"welded {soupy.n_vertices - mesh.n_vertices} coincident vertices into others "
                       f"({mesh.n_vertices} vertices left)"]
    # Each welded vertex is its first copy in the soup: the smallest input index of its group.
    _, first_copy = np.unique(mesh.faces.ravel(), return_index=True)
    np.testing.assert_array_equal(np.sort(welded.input_index), np.sort(first_copy))

    original = analyze_mesh(mesh)
    analysis = analyze_mesh(soupy, repair=True)
    assert analysis.changes == tuple(changes)
    assert ((0 <= analysis.feature_vertices) & (analysis.feature_vertices < soupy.n_vertices)).all()
    np.testing.assert_array_equal(soupy.vertices[analysis.feature_vertices],
                                  mesh.vertices[original.feature_vertices])
    np.testing.assert_allclose(analysis.feature_agd, original.feature_agd, rtol=1e-6)


def split_along_equator(mesh: Mesh) -> Mesh:
    """``mesh`` (a sphere about the origin) cut open along z = 0: the faces above get their own
    copies of the vertices they share with those below (a file split along a texture seam)."""
    above = mesh.vertices[mesh.faces].mean(axis=1)[:, 2] > 0
    shared = np.intersect1d(mesh.faces[above], mesh.faces[~above])
    copy = np.arange(mesh.n_vertices)
    copy[shared] = mesh.n_vertices + np.arange(len(shared))
    faces = np.where(above[:, None], copy[mesh.faces], mesh.faces)
    return Mesh(np.vstack([mesh.vertices, mesh.vertices[shared]]), faces, "seamed sphere")


def test_a_surface_split_along_seams_is_refused_without_repair_and_welded_with_it():
    """Taken as it comes, each seam would be the rim of a cut and a piece a component left out."""
    sphere = synthetic.icosphere(3)
    seamed = split_along_equator(sphere)
    copies = seamed.n_vertices - sphere.n_vertices
    assert copies > 20
    with pytest.raises(MeshError, match=f"{2 * copies} boundary vertices coincide with others .*--repair .*welds"):
        prepare_mesh(seamed)
    welded, changes = prepare_mesh(seamed, repair=True)
    assert welded.n_vertices == sphere.n_vertices and changes[0].startswith(f"welded {copies} coincident")
    assert _edge_counts(welded.faces, welded.n_vertices)[1].min() == 2  # closed again
    cap = submesh(seamed, seamed.vertices[seamed.faces].mean(axis=1)[:, 2] > 0)
    assert prepare_mesh(cap)[0].n_faces == cap.n_faces  # one side of the seam alone is valid as it is


def test_weld_tolerance_zero_never_welds():
    # A plane's strip of 2 x 2 squares cut along its middle column of vertices: the copies sit
    # exactly on the originals, on the boundary; the default welds them, 0 leaves them.
    grid = np.array([[x, y, 0.0] for y in range(3) for x in range(3)], dtype=np.float64)
    left = np.array([[0, 1, 4], [0, 4, 3], [3, 4, 7], [3, 7, 6]])
    right = np.array([[1, 2, 5], [1, 5, 4], [4, 5, 8], [4, 8, 7]])
    vertices = np.vstack([grid, grid[[1, 4, 7]]])  # copies 9, 10, 11 of the middle column
    copy = {1: 9, 4: 10, 7: 11}
    faces = np.vstack([left, np.vectorize(lambda v: copy.get(v, v))(right)])
    cut = Mesh(vertices, faces, "cut")
    welded = weld_vertices(cut)
    assert welded.n_vertices == 9 and sorted(welded.input_index) == list(range(9))
    assert weld_vertices(cut, 0.0) is cut
    with pytest.warns(MeshWarning, match="component"):  # the halves stay apart: one is kept
        kept, changes = prepare_mesh(cut, repair=True, settings=Repairing(weld_tolerance=0.0))
    assert kept.n_vertices == 6 and not any("welded" in c for c in changes)
    with pytest.raises(MeshError, match="a triangle soup\\? \\(welding is off: weld_tolerance 0\\)"):
        prepare_mesh(soup(cut), repair=True, settings=Repairing(weld_tolerance=0.0))


def test_soup_is_one_error_line_on_the_command_line(capsys, tmp_path):
    path = tmp_path / "soup.off"
    save_mesh(soup(synthetic.icosphere(2)), path)
    assert main(["features", str(path), "--no-cache"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == (f"darcyan: error: {path}: 320 components of 1 face each: a triangle soup? "
                                 f"--repair (repair=True in Python) welds coincident vertices\n")


def test_fin_on_an_edge_is_split_off_and_refused_as_strict():
    sphere = synthetic.icosphere(2)
    a, b, _ = sphere.faces[0]
    apex = sphere.vertices[[a, b]].mean(axis=0) * 1.5
    fin = Mesh(np.vstack([sphere.vertices, apex]), np.vstack([sphere.faces, [[a, b, sphere.n_vertices]]]), "fin")
    with pytest.raises(MeshError, match=r"^fin: 1 non-manifold edges \(more than two faces on one edge\) "
                                        r"\(refused as strict; by default they are dropped or split\)$"):
        prepare_mesh(fin, settings=Repairing(strict=True))
    with pytest.warns(MeshWarning, match="2 connected components; using the largest, leaving out 1 components with 1 faces"):
        prepared, changes = prepare_mesh(fin)
    assert changes == ["split 1 non-manifold edges (more than two faces on one edge) into pairs of faces"]
    np.testing.assert_array_equal(prepared.input_index, np.arange(sphere.n_vertices))
    np.testing.assert_array_equal(prepared.faces, sphere.faces)


def test_tetrahedra_sharing_an_edge_come_apart_whole():
    small = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0.5], [0.5, 1, 0.5]])
    large = np.array([[-3, 0, 0.5], [-1.5, -3, 0.5]])  # with vertices 0 and 1: a larger tetrahedron
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3],  # outward
                      [0, 4, 1], [1, 4, 5], [0, 1, 5], [0, 5, 4]])
    mesh = Mesh(np.vstack([small, large]), faces, "two tetrahedra")
    keys, counts = _edge_counts(faces, mesh.n_vertices)
    assert counts.max() == 4  # edge 0-1 carries all four faces of the two
    with pytest.raises(MeshError, match="refused as strict"):
        prepare_mesh(mesh, settings=Repairing(strict=True))
    with pytest.warns(MeshWarning, match="2 connected components; using the largest, leaving out 1 components with 4 faces"):
        prepared, changes = prepare_mesh(mesh)
    assert changes == ["split 1 non-manifold edges (more than two faces on one edge) into pairs of faces"]
    assert prepared.n_faces == 4  # no face dropped: the larger tetrahedron, whole
    np.testing.assert_array_equal(np.sort(prepared.input_index), [0, 1, 4, 5])


def test_a_moebius_strip_is_cut_open_where_its_faces_disagree():
    n = 40
    u = np.linspace(0, 2 * np.pi, n, endpoint=False)
    centre = np.c_[np.cos(u), np.sin(u), np.zeros(n)]
    across = np.c_[np.cos(u / 2) * np.cos(u), np.cos(u / 2) * np.sin(u), np.sin(u / 2)] * 0.3
    vertices = np.vstack([centre - across, centre + across])  # vertex i on one edge, n + i on the other
    i = np.arange(n)
    j = (i + 1) % n
    last = i == n - 1  # the strip closes with a half twist: the sides swap
    low_j, high_j = np.where(last, n + j, j), np.where(last, j, n + j)
    faces = np.vstack([np.c_[i, low_j, n + i], np.c_[n + i, low_j, high_j]])
    with pytest.raises(MeshError, match="not consistently oriented .*refused as strict"):
        prepare_mesh(Mesh(vertices, faces, "moebius"), settings=Repairing(strict=True))
    for repair in (False, True):
        prepared, changes = prepare_mesh(Mesh(vertices, faces, "moebius"), repair=repair)
        assert any("not orientable" in change for change in changes)
        keys, counts = _edge_counts(prepared.faces, prepared.n_vertices)
        directed = prepared.faces.ravel() * prepared.n_vertices + prepared.faces[:, [1, 2, 0]].ravel()
        assert len(np.unique(directed)) == len(directed)  # every edge now agrees
        assert prepared.n_faces >= len(faces) - 4  # a cut, not a loss of the strip
        assert set(prepared.input_index.tolist()) <= set(range(2 * n))


@pytest.mark.parametrize("reduction", [0.9, 0.95])
def test_decimated_mesh_prepares_and_describes(tosca, reduction):
    import fast_simplification

    mesh = tosca_5k(tosca, "michael0")
    points, faces = fast_simplification.simplify(mesh.vertices, mesh.faces, target_reduction=reduction)
    decimated = Mesh(points, faces, f"michael0 at {reduction:.0%} reduction")
    with pytest.raises(MeshError, match="non-manifold edges .*refused as strict"):
        prepare_mesh(decimated, settings=Repairing(strict=True))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)  # pieces pinched off by the decimation are left out
        prepared, changes = prepare_mesh(decimated)
        analysis = analyze_mesh(decimated)
    assert any(c.startswith("split ") and "non-manifold edges" in c for c in changes)
    assert prepared.n_vertices > 0.9 * decimated.n_vertices
    assert not len(nonmanifold_vertices(prepared)) and _edge_counts(prepared.faces, prepared.n_vertices)[1].max() == 2
    assert analysis.changes == tuple(changes) and len(analysis.feature_vertices) >= 4
    assert ((0 <= analysis.feature_vertices) & (analysis.feature_vertices < decimated.n_vertices)).all()


def test_welded_copies_keep_their_results():
    """Every vertex of a soup is a copy that repair welds into one prepared vertex: each copy,
    not only the one kept, gets the kept vertex's place in a dense map (in the input numbering)."""
    from darcyan import analyze_mesh, match_shapes
    from darcyan.dense import UNMAPPED, DenseConfig, dense_map

    def soup(mesh):
        return Mesh(mesh.vertices[mesh.faces].reshape(-1, 3), np.arange(3 * mesh.n_faces).reshape(-1, 3))

    poses = [soup(synthetic.figure(pose, 4)) for pose in (0, 1)]
    a, b = (analyze_mesh(p, repair=True) for p in poses)
    assert (a.shape.mesh_index(np.arange(poses[0].n_vertices)) >= 0).all()
    result = dense_map(a, b, match_shapes(a, b), DenseConfig(basis_size=30, zoomout_samples=500))
    assert (result.target != UNMAPPED).all()
    # one numbering for both poses: most copies land on a copy of their own corner
    same_corner = np.linalg.norm(poses[1].vertices[result.target] - poses[1].vertices, axis=1) < 1e-9
    assert same_corner.mean() > 0.5


def outward_share(mesh: Mesh, centre: np.ndarray) -> float:
    """Share of the faces whose normals point away from ``centre``."""
    v, f = mesh.vertices, mesh.faces
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    return float((np.einsum("ij,ij->i", normals, v[f].mean(axis=1) - centre) > 0).mean())


@pytest.mark.parametrize("holes", [0, 3])
def test_an_inside_out_surface_is_turned_outward_holes_or_not(holes):
    """Its normals decide the curvatures' signs and every turning sense: inside out, left and
    right would swap (a FAUST pair: 1 of 5 matches right, before this)."""
    sphere = synthetic.icosphere(3)
    taken = [0, 400, 900][:holes]  # faces far apart: small holes, no vertex left without a face
    inside_out = Mesh(sphere.vertices, np.delete(sphere.faces[:, ::-1], taken, axis=0), "inside out")
    assert outward_share(inside_out, 0) == 0
    kept_open = Repairing(hole_edges=0)  # the holes left open: the test closes them by fans of its own
    prepared, changes = prepare_mesh(inside_out, settings=kept_open)
    assert outward_share(prepared, 0) == 1 and prepared.n_faces == sphere.n_faces - holes
    assert changes == ["flipped every face: the surface was inside out (its faces enclosed a negative volume)"]
    right_way = Mesh(sphere.vertices, np.delete(sphere.faces, taken, axis=0), "outward")
    prepared, changes = prepare_mesh(right_way, settings=kept_open)
    assert (prepared.faces == right_way.faces).all() and changes == []


@pytest.mark.parametrize("flip", [False, True])
def test_a_patch_is_left_as_it_comes(flip):
    """A bowl has no inside to tell (its fan across the rim is most of its area), nor has a flat
    disc: either orientation is kept. A cylinder open at both ends is tested (its two end discs
    are a fifth of its area) and keeps the outward one."""
    sphere = synthetic.icosphere(3)
    bowl = submesh(sphere, (sphere.vertices[sphere.faces][:, :, 2] < -0.3).all(axis=1))
    for patch in (bowl, synthetic.flat_disc()):
        faces = patch.faces[:, ::-1].copy() if flip else patch.faces
        prepared, changes = prepare_mesh(Mesh(patch.vertices, faces, patch.name))
        assert (prepared.faces == faces).all() and changes == []
    cylinder = synthetic.cylinder(height=5.0)  # end discs a fifth of its side
    faces = cylinder.faces[:, ::-1].copy() if flip else cylinder.faces
    prepared, _ = prepare_mesh(Mesh(cylinder.vertices, faces, "cylinder"))
    assert outward_share(prepared, np.zeros(3)) > 0.99  # about the axis: z of the centre is 0
    untested = Repairing(outward_cap_share=0.15)
    without_test = prepare_mesh(Mesh(cylinder.vertices, faces, "cylinder"), settings=untested)[0]
    assert (without_test.faces == faces).all()


def test_an_inside_out_person_with_holes_matches_as_the_right_way_out(faust, tmp_path, capsys):
    """tr_reg_001 written inside out with three small holes matches tr_reg_000 as the file does
    (its holes closed, then every face flipped)."""
    mesh = load_mesh(faust / "tr_reg_001.off")
    copy = tmp_path / "tr_reg_001_inside_out.off"
    save_mesh(Mesh(mesh.vertices, np.delete(mesh.faces[:, ::-1], [0, 3000, 6000], axis=0)), copy)
    outputs = []
    for target in (faust / "tr_reg_001.off", copy):
        assert main(["match", str(faust / "tr_reg_000.off"), str(target), "--no-cache", "-q"]) == 0
        out, err = capsys.readouterr()
        outputs.append([line.split(",")[:2] for line in out.splitlines()])
        assert ("inside out" in err) == (target == copy)
    assert outputs[0] == outputs[1] and len(outputs[0]) >= 5


def test_small_holes_are_closed_between_their_own_vertices_and_cuts_are_not():
    """A hole (a boundary loop shorter than ``hole_length``) gets a fan of faces oriented like its
    neighbours, no new vertex; a longer loop (a cut) stays open; 0 closes none."""
    sphere = synthetic.icosphere(4)  # edges about 0.02 sqrt(area): a one-face hole's loop 0.07
    holed = Mesh(sphere.vertices, np.delete(sphere.faces, 400, axis=0), "holed")
    prepared, changes = prepare_mesh(holed)
    assert prepared.n_faces == sphere.n_faces and prepared.n_vertices == sphere.n_vertices
    assert _edge_counts(prepared.faces, prepared.n_vertices)[1].min() == 2  # closed, manifold
    assert sorted(prepared.faces[-1]) == sorted(sphere.faces[400])
    assert outward_share(prepared, np.zeros(3)) == 1  # the new face turned like its neighbours
    assert changes == ["closed 1 small hole (boundary loops of at most 4 edges, shorter than 0.1 sqrt(area)) "
                       "with 1 faces between their own vertices"]
    assert prepare_mesh(holed, settings=Repairing(hole_length=0))[0].n_faces == holed.n_faces
    assert prepare_mesh(holed, settings=Repairing(hole_edges=2))[0].n_faces == holed.n_faces

    # the faces around a vertex, and the vertex with them: a hexagonal hole (loop about 0.14)
    ring = (sphere.faces == 100).any(axis=1)
    ringed = submesh(sphere, ~ring)
    assert prepare_mesh(ringed)[0].n_faces == ringed.n_faces  # six edges, longer than 0.1: left open
    assert prepare_mesh(ringed, settings=Repairing(hole_length=0.2, hole_edges=5))[0].n_faces == ringed.n_faces
    prepared, changes = prepare_mesh(ringed, settings=Repairing(hole_length=0.2, hole_edges=6))
    assert prepared.n_faces == ringed.n_faces + ring.sum() - 2 and "closed 1 small hole" in changes[0]
    assert _edge_counts(prepared.faces, prepared.n_vertices)[1].min() == 2
    assert outward_share(prepared, np.zeros(3)) == 1


def test_the_hole_a_dropped_zero_area_face_leaves_stays_open():
    """Repair drops a zero-area face; closing its hole would put the face back."""
    sphere = synthetic.icosphere(4)
    a, b, c = sphere.faces[400]
    vertices = sphere.vertices.copy()
    vertices[b] = (vertices[a] + vertices[c]) / 2  # face 400 flat, its neighbour across a-c too
    prepared, changes = prepare_mesh(Mesh(vertices, sphere.faces, "flattened"), repair=True)
    assert changes[0].startswith("dropped 1 degenerate") and not any("closed" in c for c in changes)
    assert prepared.face_areas().min() > 1e-9 * prepared.face_areas().mean()


def test_an_open_proxy_keeps_the_orientation_of_its_mesh():
    """A mesh whose rims are too long to be tested is left as it comes; its decimated proxy, whose
    rims are shorter, must not be turned against it."""
    from darcyan.geometry.proxy import CoarseProxy

    cylinder = synthetic.cylinder(height=3.9)  # end discs 0.256 of its side: not tested
    inside_out = Mesh(cylinder.vertices, cylinder.faces[:, ::-1].copy(), "inside-out cylinder")
    full, _ = prepare_mesh(inside_out)
    assert outward_share(full, np.zeros(3)) == 0
    proxy = CoarseProxy(full, 200)
    assert outward_share(proxy.mesh, np.zeros(3)) < 0.01


def test_duplicate_faces_are_the_same_by_one_key_or_by_lexsort(monkeypatch):
    """inspect_mesh's duplicate faces (the later copies, corners in any order) by one int64 key
    per face and by numpy's lexsort, which larger meshes use."""
    from darcyan.geometry import repair

    base = synthetic.icosphere(subdivisions=2)
    rng = np.random.default_rng(0)
    copies = base.faces[rng.choice(base.n_faces, 40, replace=False)]
    copies = np.take_along_axis(copies, np.argsort(rng.random(copies.shape), axis=1), axis=1)  # corners shuffled
    faces = np.vstack([base.faces, copies])[rng.permutation(base.n_faces + len(copies))]
    mesh = Mesh(base.vertices, faces)
    by_key = repair.inspect_mesh(mesh).duplicate_faces
    monkeypatch.setattr(repair, "ONE_KEY_VERTICES", 0)
    by_lexsort = repair.inspect_mesh(Mesh(base.vertices, faces)).duplicate_faces
    assert len(by_key) == 40
    np.testing.assert_array_equal(by_key, by_lexsort)
