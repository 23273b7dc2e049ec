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
    """A grid centred 0.3 from the rim of the unit disc, radius 0.6. On a convex plane piece the
    radial geodesics are straight: point (k, l) belongs at centre + lambda_k (cos a_l ref + sin a_l
    side). Where that lies inside the disc the grid has it there; where it lies beyond the rim the
    grid has nothing (within an edge of the rim, whose chords cut the circle, either may happen)."""
    mesh, _ = prepare_mesh(synthetic.flat_disc(radius=1.0, rings=30))
    centre = int(np.argmin(np.linalg.norm(mesh.vertices - [0.7, 0, 0], axis=1)))
    config = DarcyanConfig(levels=4, radial_lines=8, radius=0.6, interpolation=1)
    grid = darcyan_grid(mesh, GeodesicSolver(mesh), centre, config)
    edges = mesh.edges()
    edge = np.linalg.norm(mesh.vertices[edges[:, 0]] - mesh.vertices[edges[:, 1]], axis=1).mean()
    ref = grid.reference
    assert abs(ref[2]) < 1e-9 and np.isclose(np.linalg.norm(ref), 1.0)
    side = np.cross([0.0, 0.0, 1.0], ref)  # counter-clockwise about +z (the disc's normal)
    directions = np.cos(grid.angles)[:, None] * ref + np.sin(grid.angles)[:, None] * side
    expected = mesh.vertices[centre] + np.asarray(grid.radii)[:, None, None] * directions[None]
    from_origin = np.linalg.norm(expected[..., :2], axis=2)
    inside, outside = from_origin < 1.0 - edge, from_origin > 1.0
    assert inside.any() and outside.any()  # the case has both
    assert grid.valid[inside].all()
    assert not grid.valid[outside].any()
    assert np.isnan(grid.points[~grid.valid]).all()
    # Fast marching overestimates distance by a fraction of an edge: points fall a little short.
    np.testing.assert_allclose(grid.points[grid.valid], expected[grid.valid], atol=0.5 * edge)


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
