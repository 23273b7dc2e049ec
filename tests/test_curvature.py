"""Meyer et al. curvatures against analytic surfaces."""

import numpy as np

from darcyan.geometry import synthetic
from darcyan.geometry.curvature import principal_curvatures
from darcyan.geometry.mesh import Mesh
from darcyan.geometry.operators import mixed_voronoi_area
from darcyan.geometry.repair import prepare_mesh


def test_sphere_principal_curvatures_are_one_over_r(sphere):
    mesh, _ = prepare_mesh(sphere)
    assert mesh.n_vertices >= 10_000
    c = principal_curvatures(mesh)
    np.testing.assert_allclose(c.kmax, 0.5, rtol=0.02)
    np.testing.assert_allclose(c.kmin, 0.5, rtol=0.02)


def test_sphere_mean_and_gaussian_curvature_are_one_over_r_and_r_squared(sphere):
    c = principal_curvatures(sphere)  # radius 2, outward-oriented as built
    np.testing.assert_allclose(c.mean, 0.5, rtol=1e-4)  # within 2e-6 on this icosphere
    np.testing.assert_allclose(c.gaussian, 0.25, rtol=1e-3)  # within 4e-4
    assert np.isclose((c.gaussian * c.area).sum(), 4 * np.pi, rtol=1e-12)  # Gauss-Bonnet


def test_inward_oriented_sphere_is_turned_outward(sphere):
    flipped = Mesh(sphere.vertices, sphere.faces[:, ::-1])
    mesh, _ = prepare_mesh(flipped)
    assert principal_curvatures(mesh).kmin.min() > 0.49


def test_cylinder_kmax_one_over_r_kmin_zero_away_from_caps():
    mesh, _ = prepare_mesh(synthetic.cylinder(radius=1.5, height=6.0))
    c = principal_curvatures(mesh)
    middle = np.abs(mesh.vertices[:, 2]) < 2.0
    np.testing.assert_allclose(c.kmax[middle], 1 / 1.5, rtol=0.02)
    np.testing.assert_allclose(c.kmin[middle], 0.0, atol=0.01)


def test_torus_gaussian_curvature_on_equators():
    R, r = 2.0, 0.75
    mesh, _ = prepare_mesh(synthetic.torus(R, r))
    c = principal_curvatures(mesh)
    rho = np.linalg.norm(mesh.vertices[:, :2], axis=1)
    outer = np.isclose(rho, R + r, atol=1e-6)
    inner = np.isclose(rho, R - r, atol=1e-6)
    assert outer.sum() > 10 and inner.sum() > 10
    np.testing.assert_allclose(c.gaussian[outer], 1 / (r * (R + r)), rtol=0.03)
    np.testing.assert_allclose(c.gaussian[inner], -1 / (r * (R - r)), rtol=0.03)
    assert (c.gaussian[outer] > 0).all() and (c.gaussian[inner] < 0).all()
    # Principal curvatures there: 1/r around the tube, cos(v)/(R + r cos v) along it.
    np.testing.assert_allclose(c.kmax[outer], 1 / r, rtol=0.03)
    np.testing.assert_allclose(c.kmin[outer], 1 / (R + r), rtol=0.05)
    np.testing.assert_allclose(c.kmin[inner], -1 / (R - r), rtol=0.05)


def test_gauss_bonnet_on_closed_meshes(figure_poses):
    for mesh, euler in ((synthetic.torus(), 0), (figure_poses[1], 2)):
        prepared, _ = prepare_mesh(mesh)
        c = principal_curvatures(prepared)
        total = (c.gaussian * c.area).sum()
        assert abs(total - 2 * np.pi * euler) < 1e-6


def test_mixed_area_covers_the_surface(figure_poses):
    mesh, _ = prepare_mesh(figure_poses[0])
    assert np.isclose(mixed_voronoi_area(mesh).sum(), mesh.area(), rtol=1e-9)


def test_smoothing_keeps_constant_curvature(sphere):
    mesh, _ = prepare_mesh(sphere)
    c = principal_curvatures(mesh, smoothing=3)
    np.testing.assert_allclose(c.kmax, 0.5, rtol=0.02)
