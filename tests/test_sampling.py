"""Vertex samples (darcyan.geometry.sampling): random ones uniform over the surface, distinct,
seeded; farthest-point ones spread evenly and independent of the numbering."""

import numpy as np
import pytest

from darcyan.errors import DarcyanError
from darcyan.geometry.mesh import Mesh
from darcyan.geometry.sampling import farthest_point_vertices, sample_vertices


def test_samples_by_area_are_uniform_over_the_surface_not_the_vertices():
    from darcyan.geometry.operators import mixed_voronoi_area

    # A unit square whose vertex columns crowd toward x = 0 (x = t^2): 71% of the vertices lie
    # left of x = 0.5, half of the area does.
    t = np.linspace(0.0, 1.0, 60)
    x, y = np.meshgrid(t**2, t, indexing="ij")
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    idx = np.arange(x.size).reshape(x.shape)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    square = Mesh(vertices, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]))
    rng = np.random.default_rng(0)
    left = lambda areas: float((vertices[sample_vertices(x.size, 800, rng, areas), 0] < 0.5).mean())  # noqa: E731
    assert abs(left(mixed_voronoi_area(square)) - 0.5) < 0.05
    assert abs(left(None) - np.sqrt(0.5)) < 0.05


def test_samples_are_distinct_and_seeded(sphere):
    from darcyan.geometry.operators import mixed_voronoi_area

    areas = mixed_voronoi_area(sphere)
    a = sample_vertices(sphere.n_vertices, 300, np.random.default_rng(1), areas)
    b = sample_vertices(sphere.n_vertices, 300, np.random.default_rng(1), areas)
    assert np.array_equal(a, b) and len(np.unique(a)) == 300
    assert len(sample_vertices(sphere.n_vertices, 10**6, np.random.default_rng(1), areas)) == sphere.n_vertices


def test_farthest_points_on_a_line_halve_the_gaps():
    # Points 0..16 on a line from 0: then 16, then 8, then 4 and 12 (ties: the smaller index).
    line = np.stack([np.arange(17.0), np.zeros(17), np.zeros(17)], axis=1)
    assert farthest_point_vertices(line, 5, 0).tolist() == [0, 16, 8, 4, 12]
    assert sorted(farthest_point_vertices(line, 100, 3)) == list(range(17))  # every point, each once
    for start in (-1, 17):
        with pytest.raises(DarcyanError, match="start vertex"):
            farthest_point_vertices(line, 5, start)


def test_farthest_points_cover_the_sphere_evenly(sphere):
    # Gonzalez's bounds, measured by brute force: every vertex lies within r of the first k picks
    # (r the distance of the next pick), and no two picks are closer than r.
    order = farthest_point_vertices(sphere.vertices, 61, 0)
    picks, following = sphere.vertices[order[:60]], sphere.vertices[order[60]]
    r = np.linalg.norm(picks - following, axis=1).min()
    to_picks = np.linalg.norm(sphere.vertices[:, None] - picks[None], axis=2)
    assert to_picks.min(axis=1).max() <= r + 1e-12
    between = np.linalg.norm(picks[:, None] - picks[None], axis=2) + np.eye(60) * 10
    assert between.min() >= r - 1e-12
    # A random draw of as many leaves a larger hole.
    drawn = sphere.vertices[sample_vertices(sphere.n_vertices, 60, np.random.default_rng(0))]
    assert np.linalg.norm(sphere.vertices[:, None] - drawn[None], axis=2).min(axis=1).max() > 1.2 * r


def test_farthest_points_do_not_depend_on_the_numbering(sphere):
    # Jittered: on the exact icosphere whole circles of vertices tie, and ties go by index.
    points = sphere.vertices + np.random.default_rng(2).normal(scale=1e-3, size=sphere.vertices.shape)
    order = np.random.default_rng(4).permutation(sphere.n_vertices)  # renumbered vertex i is order[i]
    first = farthest_point_vertices(points, 200, 7)
    again = farthest_point_vertices(points[order], 200, int(np.argsort(order)[7]))
    assert np.array_equal(order[again], first)


def test_farthest_points_take_coincident_vertices_last_and_once():
    # Four spots, the second twice (a vertex split where a mesh was not manifold).
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0], [3, 0, 0], [7, 0, 0]], dtype=float)
    assert farthest_point_vertices(points, 5, 0).tolist() == [0, 4, 3, 1, 2]
    assert farthest_point_vertices(points, 4, 0).tolist() == [0, 4, 3, 1]


def brute_force_farthest_points(positions, count, start):
    nearest, out, current = np.full(len(positions), np.inf), [], start
    for _ in range(count):
        out.append(current)
        nearest = np.minimum(nearest, ((positions - positions[current]) ** 2).sum(axis=1))
        current = int(np.argmax(nearest))
    return out


def test_farthest_points_equal_the_brute_force_order(sphere):
    # The k-d tree skips the vertices beyond the largest gap; the order must not change, ties
    # (whole circles of them on the exact icosphere) included.
    jittered = sphere.vertices + np.random.default_rng(1).normal(scale=1e-3, size=sphere.vertices.shape)
    for points, count in ((sphere.vertices, 400), (jittered, 400), (sphere.vertices[:642], 642)):  # all 642
        for start in (0, 17, len(points) - 1):
            assert farthest_point_vertices(points, count, start).tolist() == \
                brute_force_farthest_points(points, count, start)
