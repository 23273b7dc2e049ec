"""Vertex samples (darcyan.geometry.sampling): uniform over the surface, distinct, seeded."""

import numpy as np

from darcyan.geometry.mesh import Mesh
from darcyan.geometry.sampling import sample_vertices


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
