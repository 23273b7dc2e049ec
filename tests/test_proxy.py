"""The decimated proxy used for smooth global fields."""

import numpy as np
import pytest

from darcyan import DarcyanConfig, analyze_mesh
from darcyan.bench.runner import run_bench
from darcyan.geometry import synthetic
from darcyan.geometry.proxy import coarse_proxy
from darcyan.geometry.repair import prepare_mesh
from darcyan.method.features import average_geodesic_distance


def test_proxy_agd_matches_the_exact_average_on_a_sphere(sphere):
    mesh, _ = prepare_mesh(sphere)
    proxy = coarse_proxy(mesh, 2000)
    assert proxy is not None and proxy.mesh.n_vertices < 2500
    agd = proxy.to_full(average_geodesic_distance(proxy.mesh, proxy.solver, 16).values)
    assert agd.shape == (mesh.n_vertices,)
    # pi r / 2 for r = 2; fast marching on the coarse copy overestimates by up to about 5%
    np.testing.assert_allclose(agd, np.pi * 2.0 / 2, rtol=0.06)


def test_small_meshes_get_no_proxy(sphere):
    mesh, _ = prepare_mesh(sphere)
    assert coarse_proxy(mesh, 6000) is None and coarse_proxy(mesh, 0) is None


def test_features_with_proxy_are_the_figure_tips_and_those_without():
    shape = analyze_mesh(synthetic.figure(1), DarcyanConfig(proxy_vertices=2500))  # 10k -> 2.5k
    exact = analyze_mesh(synthetic.figure(1), DarcyanConfig(proxy_vertices=0))
    tips = synthetic.figure_tips()
    assert len(shape) == len(tips) == len(exact)
    dist = np.array([shape.solver.distance(t)[shape.features.vertices] for t in tips])
    assert (dist.min(axis=1) < 0.05).all()  # the evaluation's threshold (sqrt(area) units)
    # The proxy is a stand-in for the AGD's distances only: the maxima are those of the full mesh.
    to_exact = np.array([shape.solver.distance(v)[exact.features.vertices] for v in shape.features.vertices])
    assert (to_exact.min(axis=1) < 0.03).all()


def test_proxy_distance_field_is_close_to_great_circle_arcs(sphere):
    mesh, _ = prepare_mesh(sphere)
    proxy = coarse_proxy(mesh, 2000)
    d = proxy.distance(5)
    arc = 2.0 * np.arccos(np.clip(mesh.vertices @ mesh.vertices[5] / 4.0, -1, 1))  # r = 2
    assert d.shape == (mesh.n_vertices,)
    # coarse fast marching errs by up to about an edge of the copy (here 0.19) plus a few percent
    e = proxy.mesh.edges()
    edge = np.linalg.norm(proxy.mesh.vertices[e[:, 0]] - proxy.mesh.vertices[e[:, 1]], axis=1).mean()
    np.testing.assert_allclose(d, arc, rtol=0.03, atol=1.5 * edge)
    assert np.median(np.abs(d - arc)) < edge


@pytest.mark.slow
def test_feature_points_found_with_a_proxy_repeat_across_poses(tosca, tmp_path):
    # tosca-5k michael with a 1500-vertex proxy standing in for its 5000 vertices: the feature
    # points must repeat across poses nearly as well as without a proxy (0.97 on these pairs).
    # Diffusing AGD on the proxy put the maxima on its vertices, placed anew in every pose: 0.71.
    lines = (tosca / "tosca-5k" / "test_pairs.txt").read_text().splitlines()
    pairs = tmp_path / "pairs.txt"
    pairs.write_text("".join(f"{line}\n" for line in [x for x in lines if x.startswith("michael")][:12]))
    result = run_bench(tosca / "tosca-5k", tmp_path / "out", pairs_file=pairs, progress=False, plots=False,
                       config=DarcyanConfig(proxy_vertices=1500), no_cache=True)
    overall = result.results["methods"]["darcyan"]["overall"]
    assert overall["pairs"] == 12
    assert overall["repeatability"] >= 0.85, overall


def test_smooth_basis_on_a_proxy_spans_the_sphere_harmonics(sphere):
    # On a sphere the first non-constant eigenfunctions are x, y and z: the basis computed on
    # the proxy and interpolated must lie in their span, like the one computed on the mesh.
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(sphere)
    coordinates = np.hstack([np.ones((shape.mesh.n_vertices, 1)), shape.mesh.vertices])
    for proxy_vertices in (0, 1000):
        basis = shape.smooth_basis(4, proxy_vertices)
        assert basis.shape == (shape.mesh.n_vertices, 4)
        fitted = coordinates @ np.linalg.lstsq(coordinates, basis, rcond=None)[0]
        assert np.linalg.norm(fitted - basis) <= 0.01 * np.linalg.norm(basis)
    # the 5th to 9th (degree-2 harmonics) are not in that span: the check can fail
    fifth = shape.smooth_basis(9, 1000)[:, 4:]
    fitted = coordinates @ np.linalg.lstsq(coordinates, fifth, rcond=None)[0]
    assert np.linalg.norm(fitted - fifth) > 0.5 * np.linalg.norm(fifth)


def test_a_coarse_shape_keeps_the_units_and_its_nearest_vertices_are_near(sphere):
    """The proxy as a shape of its own: on the sphere of radius 2 (normalized to area 1) its
    vertices lie on the same sphere, its input numbering is its own, and every full vertex's
    nearest copy vertex is within one of the copy's edges of it."""
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(sphere)
    assert shape.coarse_shape(6000) is None  # 10k vertices: no proxy of 6000
    coarse = shape.coarse_shape(2000)
    assert coarse is shape.coarse_shape(2000) and 1500 < coarse.n_vertices < 2500
    radius = np.sqrt(1 / (4 * np.pi))  # area 1
    np.testing.assert_allclose(np.linalg.norm(coarse.mesh.vertices, axis=1), radius, rtol=0.01)
    nearest = shape.proxy(2000).nearest_vertices(np.arange(shape.n_vertices))
    gap = np.linalg.norm(coarse.mesh.vertices[nearest] - shape.mesh.vertices, axis=1)
    edges = coarse.mesh.edges()
    mean_edge = np.linalg.norm(np.diff(coarse.mesh.vertices[edges], axis=1), axis=2).mean()
    assert gap.max() < 1.5 * mean_edge
    # and at most an edge farther than the copy's nearest vertex in space
    from scipy.spatial import cKDTree

    assert (gap - cKDTree(coarse.mesh.vertices).query(shape.mesh.vertices)[0]).max() < mean_edge


def test_each_vertex_is_mapped_to_the_copy_vertex_it_was_collapsed_into(sphere):
    """``_collapse_targets`` follows fast_simplification's collapses to the decimated vertex each
    full vertex ended on: what the library's own ``replay_simplification`` gives (which replays
    the whole decimation to find it)."""
    import fast_simplification

    from darcyan.geometry.proxy import _collapse_targets

    mesh, _ = prepare_mesh(sphere)
    v, f, collapses = fast_simplification.simplify(mesh.vertices, mesh.faces, target_reduction=0.8, agg=3,
                                                   return_collapses=True)
    _, _, replayed = fast_simplification.replay_simplification(mesh.vertices, mesh.faces, collapses)
    into = _collapse_targets(mesh.faces, collapses, mesh.n_vertices, len(v))
    assert into.shape == (mesh.n_vertices,) and (into >= 0).mean() > 0.99
    np.testing.assert_array_equal(into[into >= 0], replayed[into >= 0])


@pytest.mark.slow
def test_a_proxys_distances_stay_on_their_part_where_parts_touch(tosca):
    """tosca-hires michael14 holds a hand to its head: the copy's closest point to some hand
    vertices lies on the head. Read on the faces around the copy vertex each was collapsed into
    instead, the copy's fast marching from any feature point, read at every full vertex, stays
    within 0.1 sqrt(area) of the full mesh's (it was off by up to 1.0 when read at the closest
    point alone)."""
    from darcyan.method.pipeline import describe_shape, load_shape

    path = tosca / "tosca-hires" / "michael14.off"
    shape = load_shape(path, DarcyanConfig(), warn=False)
    proxy = shape.proxy(6000)
    assert proxy.strays > 0
    for vertex in shape.mesh_index(describe_shape(path, DarcyanConfig()).feature_vertices):
        error = np.abs(proxy.distance(int(vertex)) - shape.solver.distance(int(vertex)))
        assert error.max() < 0.1 and np.median(error) < 0.02


def test_closest_barycentric_gives_libigls_closest_point_on_each_triangle():
    """Random points and triangles: the point the barycentric coordinates give is at libigl's
    squared distance from its point (corners, sides and insides alike), and the coordinates are
    non-negative and sum to 1."""
    import igl

    from darcyan.geometry.proxy import closest_barycentric

    rng = np.random.default_rng(1)
    a, b, c = (rng.normal(size=(500, 3)) for _ in range(3))
    points = 1.5 * rng.normal(size=(500, 3))
    bary = closest_barycentric(points, a, b, c)
    closest = bary[:, :1] * a + bary[:, 1:2] * b + bary[:, 2:] * c
    expected = [igl.point_mesh_squared_distance(points[i:i + 1], np.stack([a[i], b[i], c[i]]),
                                                np.array([[0, 1, 2]]))[0][0] for i in range(500)]
    np.testing.assert_allclose(((closest - points) ** 2).sum(axis=1), expected, atol=1e-12)
    assert (bary >= 0).all() and np.allclose(bary.sum(axis=1), 1)
    # a triangle of no area (two corners on one point, or all three on a line): its nearest corner
    point, far = np.array([[0.0, 0.0, 1.0], [5.0, 0.0, 0.0]]), np.array([[4.0, 0.0, 0.0], [4.0, 0.0, 0.0]])
    origin = np.zeros((2, 3))
    np.testing.assert_array_equal(closest_barycentric(point, origin, origin, far), [[1, 0, 0], [0, 0, 1]])
