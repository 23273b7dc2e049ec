"""Handles: the genus, the shortest loop around a handle, and the cut along it (analytic tori)."""

import numpy as np
import pytest

from darcyan import Mesh
from darcyan.config import Repairing
from darcyan.geometry import synthetic
from darcyan.geometry.handles import HandleLoops, genus
from darcyan.geometry.mesh import boundary_loops
from darcyan.geometry.repair import prepare_mesh, submesh

CUT = Repairing(handle_length=0.1)  # off by default


def boundary_loop_count(mesh: Mesh) -> int:
    return len(boundary_loops(mesh)[1])


def thin_torus(minor: float = 0.01, nv: int = 12) -> Mesh:
    """A torus whose tube is thin beside the whole: a loop around the tube is 2 pi minor long
    (the polygon's perimeter), about 0.1 of sqrt(area) at minor 0.01 and major 1."""
    return synthetic.torus(1.0, minor, nu=300, nv=nv)


def tube_loop_length(minor: float, nv: int, mesh: Mesh) -> float:
    """The perimeter of the tube's cross-section polygon, in sqrt(area) units."""
    return nv * 2 * minor * np.sin(np.pi / nv) / np.sqrt(mesh.area())


def test_genus_of_analytic_surfaces(sphere):
    assert genus(sphere) == 0 and boundary_loop_count(sphere) == 0
    torus = synthetic.torus(nu=40, nv=20)
    assert genus(torus) == 1 and boundary_loop_count(torus) == 0
    # a hole does not change the genus: one face of each left out
    assert genus(submesh(torus, np.arange(1, torus.n_faces))) == 1
    holed = submesh(sphere, np.arange(1, sphere.n_faces))
    assert genus(holed) == 0 and boundary_loop_count(holed) == 1


def test_shortest_loop_of_a_torus_goes_around_its_tube():
    """The shortest loop that cannot be shrunk to a point on a torus of radii 1 and 0.3 goes
    once around the tube: 2 pi 0.3 (the loops around the hole are at least 2 pi 0.7)."""
    torus = synthetic.torus(1.0, 0.3, nu=120, nv=40)
    loop = HandleLoops(torus).shortest([0, 777, 2345], accept=lambda loop: True)
    perimeter = 40 * 2 * 0.3 * np.sin(np.pi / 40)
    assert loop.length == pytest.approx(perimeter, rel=0.02)
    # the loop stays on one cross-section of the tube: all its vertices at one angle about z
    angles = np.unique(np.round(np.arctan2(torus.vertices[loop.vertices, 1], torus.vertices[loop.vertices, 0]), 6))
    assert len(angles) == 1


@pytest.mark.parametrize("minor,nv", [(0.005, 12), (0.008, 16)])
def test_a_thin_handle_is_cut_along_its_tube(minor, nv):
    torus = thin_torus(minor, nv)
    prepared, changes = prepare_mesh(torus, settings=CUT)
    assert genus(prepared) == 0 and boundary_loop_count(prepared) == 2
    assert prepared.n_vertices == torus.n_vertices + nv  # one copy of each vertex of the loop
    copied = prepared.input_index[torus.n_vertices:]
    assert len(np.unique(copied)) == nv  # nv distinct vertices, each copied in place
    np.testing.assert_array_equal(prepared.vertices[torus.n_vertices:], torus.vertices[copied])
    # the loop goes round the tube: its vertices lie on one cross-section
    assert len(np.unique(np.round(np.arctan2(torus.vertices[copied, 1], torus.vertices[copied, 0]), 6))) == 1
    (note,) = [c for c in changes if c.startswith("cut 1 handle")]
    length = float(note.split("each, ")[1].split(" ")[0])
    assert length == pytest.approx(tube_loop_length(minor, nv, torus), rel=0.01)


def test_a_handle_with_no_short_loop_is_left_with_a_note():
    torus = synthetic.torus(1.0, 0.3, nu=120, nv=40)  # the tube 0.31 of sqrt(area) around
    prepared, changes = prepare_mesh(torus, settings=CUT)
    assert genus(prepared) == 1 and prepared.n_vertices == torus.n_vertices
    assert any(c.startswith("left 1 handle") for c in changes)
    # any length: cut along the tube
    prepared, _ = prepare_mesh(torus, settings=Repairing(handle_length=1.0))
    assert genus(prepared) == 0 and prepared.n_vertices == torus.n_vertices + 40


def test_no_cut_by_default_or_when_switched_off():
    torus = thin_torus(0.005)
    for settings in (Repairing(), Repairing(handle_length=0), Repairing(handle_length=0.1, handle_roots=0)):
        prepared, changes = prepare_mesh(torus, settings=settings)
        assert genus(prepared) == 1 and not any("handle" in c for c in changes)


def test_cut_does_not_depend_on_the_numbering():
    torus = thin_torus(0.005)
    order = np.random.default_rng(3).permutation(torus.n_vertices)
    inverse = np.argsort(order)
    renumbered = Mesh(torus.vertices[order], inverse[torus.faces])
    a, notes_a = prepare_mesh(torus, settings=CUT)
    b, notes_b = prepare_mesh(renumbered, settings=CUT)
    assert notes_a == notes_b and a.n_vertices == b.n_vertices
    assert genus(b) == 0


def test_a_handle_is_cut_on_a_surface_with_holes():
    torus = thin_torus(0.005)
    holed = submesh(torus, np.arange(2, torus.n_faces))  # two faces lost
    prepared, changes = prepare_mesh(holed, settings=Repairing(hole_length=0, handle_length=0.1))
    assert genus(prepared) == 0 and boundary_loop_count(prepared) == 3
    assert any(c.startswith("cut 1 handle") for c in changes)


def test_a_config_file_switches_the_cut_on_and_the_shape_says_so():
    """What ``--config`` with ``{"repairing": {"handle_length": 0.1}}`` does: the prepared shape
    is cut and carries the note the command prints."""
    from darcyan import DarcyanConfig
    from darcyan.geometry.shape import prepare_shape

    config = DarcyanConfig().updated({"repairing": {"handle_length": 0.1}})
    shape = prepare_shape(thin_torus(0.005), config)
    assert genus(shape.mesh) == 0
    assert any(change.startswith("cut 1 handle open") for change in shape.changes)
    assert not any("handle" in change for change in prepare_shape(thin_torus(0.005)).changes)


def test_a_sphere_is_never_cut(sphere):
    prepared, changes = prepare_mesh(sphere, settings=Repairing(handle_length=10.0))
    assert prepared.n_vertices == sphere.n_vertices and not any("handle" in c for c in changes)


def slab_with_two_holes() -> Mesh:
    """A genus-2 surface: marching cubes of a voxel slab (10 x 5 x 2) with two square holes
    through it."""
    from skimage.measure import marching_cubes

    solid = np.zeros((14, 9, 6))
    solid[2:12, 2:7, 2:4] = 1
    solid[4:6, 4:5, :] = 0
    solid[8:10, 4:5, :] = 0
    vertices, faces, _, _ = marching_cubes(solid, 0.5)
    return Mesh(vertices, faces[:, ::-1])


def test_every_handle_of_a_genus_two_surface_is_cut():
    slab = slab_with_two_holes()
    assert genus(slab) == 2
    prepared, changes = prepare_mesh(slab, settings=Repairing(handle_length=1.0, hole_length=0))
    assert genus(prepared) == 0 and boundary_loop_count(prepared) == 4
    assert any(c.startswith("cut 2 handles open") for c in changes)


def test_off_by_default_costs_nothing(monkeypatch):
    """With the defaults the genus is not even computed."""
    import darcyan.geometry.handles as handles

    def fail(mesh):
        raise AssertionError("genus computed")

    monkeypatch.setattr(handles, "genus", fail)
    prepared, changes = prepare_mesh(thin_torus(0.005))
    assert prepared.n_vertices == thin_torus(0.005).n_vertices
    with pytest.raises(AssertionError, match="genus computed"):
        prepare_mesh(thin_torus(0.005), settings=CUT)


def test_loops_are_sought_on_a_manifold_mesh_only(sphere):
    from darcyan.errors import DarcyanError

    bow_tie = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0.0]]), np.array([[0, 1, 2], [0, 3, 4]]))
    with pytest.raises(DarcyanError, match="manifold"):
        HandleLoops(bow_tie)
    assert HandleLoops(sphere).through(0) == []  # no handle, no loop


def test_loops_of_a_large_mesh_go_around_its_handle():
    """Above ~46k faces the products of face indices that name a pair of faces pass 2**31: in
    int32 (scipy's indices) they overflowed, the spanning tree's edges were not recognised, and
    the search returned face boundaries, which cut nothing open. A torus has exactly two loops
    through any root (2 g), the shorter once around the tube."""
    torus = synthetic.torus(1.0, 0.005, nu=2500, nv=12)  # 60,000 faces
    assert torus.n_faces ** 2 > 2**31
    loops = HandleLoops(torus).through(0)
    assert len(loops) == 2
    shortest = min(loops, key=lambda loop: loop.length)
    assert len(shortest.vertices) == 12  # once around the tube
    assert shortest.length == pytest.approx(12 * 2 * 0.005 * np.sin(np.pi / 12), rel=0.01)
