"""The Darcyan grid on surfaces whose geodesic polar coordinates are known."""

import numpy as np
import pytest
from conftest import random_rotation

from darcyan import DarcyanConfig
from darcyan.geometry import synthetic
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import Mesh
from darcyan.geometry.repair import prepare_mesh
from darcyan.method.grid import darcyan_grid


def test_flat_disc_points_on_circles_at_equal_angles():
    mesh, _ = prepare_mesh(synthetic.flat_disc(radius=1.0, rings=50))
    centre = int(np.argmin(np.linalg.norm(mesh.vertices, axis=1)))
    config = DarcyanConfig(levels=4, radial_lines=12, radius=0.6, interpolation=1)
    grid = darcyan_grid(mesh, GeodesicSolver(mesh), centre, config)
    assert grid.valid.all() and grid.points.shape == (4, 12, 3)
    offsets = grid.points - mesh.vertices[centre]
    dist = np.linalg.norm(offsets, axis=2)
    # Fast marching overestimates distance by a fraction of an edge (edges here: 0.02).
    np.testing.assert_allclose(dist, np.array(config.level_radii)[:, None] * np.ones((1, 12)), atol=0.01)
    angles = np.unwrap(np.arctan2(offsets[..., 1], offsets[..., 0]), axis=1)
    steps = np.diff(angles, axis=1)
    np.testing.assert_allclose(steps, 2 * np.pi / 12, atol=0.02)  # counter-clockwise about +z


def test_sphere_points_on_latitude_circles(sphere):
    mesh, _ = prepare_mesh(sphere)
    r = 2.0
    config = DarcyanConfig(levels=5, radial_lines=16, radius=2.5, interpolation=2)
    grid = darcyan_grid(mesh, GeodesicSolver(mesh), 0, config)
    assert grid.valid.all()
    pole = mesh.vertices[0] / r
    height = grid.points @ pole  # distance lambda from the pole lies on height r cos(lambda / r)
    expected = r * np.cos(np.array(config.level_radii) / r)
    np.testing.assert_allclose(height, expected[:, None] * np.ones((1, 32)), atol=0.02 * r)


def test_grid_stops_at_the_boundary():
    mesh, _ = prepare_mesh(synthetic.flat_disc(radius=1.0, rings=30))
    edge_vertex = int(np.argmax(mesh.vertices[:, 0]))  # on the rim
    inner = int(np.argmin(np.linalg.norm(mesh.vertices - [0.7, 0, 0], axis=1)))
    config = DarcyanConfig(levels=4, radial_lines=8, radius=0.6, interpolation=1)
    grid = darcyan_grid(mesh, GeodesicSolver(mesh), inner, config)
    assert not grid.valid.all()  # lines toward the rim leave the disc before the outer levels
    assert grid.valid[0].all()  # the first level (0.15) fits
    assert np.isnan(grid.points[~grid.valid]).all()
    inside = np.linalg.norm(grid.points[grid.valid][:, :2], axis=1)
    assert (inside <= 1.0 + 1e-9).all()
    assert edge_vertex != inner


@pytest.fixture(scope="module")
def figure_descriptor():
    from darcyan import analyze_mesh

    return analyze_mesh(synthetic.figure(0))


def test_descriptor_invariant_to_rigid_motion_and_renumbering(figure_descriptor):
    from darcyan import analyze_mesh

    base = synthetic.figure(0)
    rng = np.random.default_rng(3)
    perm = rng.permutation(base.n_vertices)  # new vertex i is old vertex perm[i]
    inverse = np.argsort(perm)
    moved = Mesh(base.vertices[perm] @ random_rotation(5).T * 3.0 + [10.0, -4.0, 2.0], inverse[base.faces])
    other = analyze_mesh(moved)
    ref = figure_descriptor
    # The same extremities, in the new numbering.
    assert sorted(perm[other.feature_vertices]) == sorted(ref.feature_vertices)
    order = {v: i for i, v in enumerate(ref.feature_vertices)}
    for v, d in zip(perm[other.feature_vertices], other.descriptors):
        np.testing.assert_allclose(d, ref.descriptors[order[v]], rtol=0.03)


def test_grid_built_on_a_ball_equals_the_grid_on_the_whole_mesh():
    from darcyan.geometry.geodesics import LocalGeodesicSolver
    from darcyan.geometry.mesh import normalize_mesh
    from darcyan.geometry.proxy import coarse_proxy
    from darcyan.method.grid import darcyan_grids, grid_reach

    mesh, _ = normalize_mesh(prepare_mesh(synthetic.figure(1))[0])
    solver = GeodesicSolver(mesh)
    config = DarcyanConfig()
    local = LocalGeodesicSolver(solver, grid_reach(config), coarse_proxy(mesh, 2500).distance)
    tips = synthetic.figure_tips()
    toward = solver.distance(0)
    whole = darcyan_grids(mesh, solver, tips, config, toward=toward)
    cut = darcyan_grids(mesh, local, tips, config, toward=toward)
    assert max(local.ball(t).mesh.n_vertices for t in tips) < mesh.n_vertices / 2
    for a, b in zip(whole, cut):
        assert a.centre == b.centre
        np.testing.assert_array_equal(a.valid, b.valid)
        np.testing.assert_array_equal(a.faces, b.faces)  # reported in the whole mesh's numbering
        np.testing.assert_allclose(a.points[a.valid], b.points[b.valid], atol=1e-9)
        np.testing.assert_allclose(a.barycentric[a.valid], b.barycentric[b.valid], atol=1e-9)
