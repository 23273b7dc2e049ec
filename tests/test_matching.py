"""Matching against cases with known answers."""

import numpy as np

from darcyan import DarcyanConfig, analyze_mesh, match_shapes
from darcyan.demo import run_demo
from darcyan.matching import descriptor_distances, match_descriptors
from darcyan.mesh import Mesh

from conftest import random_rotation


def test_nearest_and_one_to_one_on_a_small_table():
    a = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 5.0]])
    b = np.array([[0.9, 0.0], [0.1, 0.0]])
    m = match_descriptors(a, b, "nearest")
    assert list(m.target) == [1, 0, 0]
    m = match_descriptors(a, b, "one-to-one")
    assert sorted(zip(m.source, m.target)) == [(0, 1), (1, 0)]


def test_distances_skip_missing_levels():
    a = np.array([[1.0, np.nan, 3.0]])
    b = np.array([[1.0, 7.0, 5.0], [np.nan, np.nan, np.nan]])
    d = descriptor_distances(a, b)
    assert np.isclose(d[0, 0], np.sqrt(4.0 * 3 / 2)) and np.isinf(d[0, 1])


def test_shape_matches_its_moved_renumbered_copy_exactly(figure_poses):
    base = figure_poses[1]
    perm = np.random.default_rng(7).permutation(base.n_vertices)
    inverse = np.argsort(perm)
    copy = Mesh(base.vertices[perm] @ random_rotation(2).T + [1.0, 2.0, 3.0], inverse[base.faces])
    config = DarcyanConfig()
    c = match_shapes(analyze_mesh(base, config), analyze_mesh(copy, config), config)
    assert len(c) == 5
    np.testing.assert_array_equal(perm[c.target_vertex], c.source_vertex)


def test_demo_pair_matches_every_extremity():
    result = run_demo()
    assert len(result.correspondence) == 5
    assert result.correct == 5
