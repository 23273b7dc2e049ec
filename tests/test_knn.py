"""Nearest-neighbour searches (darcyan.geometry.knn) against scipy's k-d tree and brute force."""

import numpy as np
import pytest

from darcyan.geometry.knn import nearest_neighbours, nearest_points, nearest_rows


@pytest.mark.parametrize("dim", [3, 8, 11])
def test_nearest_points_equals_a_kd_tree(dim):
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(dim)
    # Far from the origin (large |p|^2 against small gaps: the screening's worst case), float32
    # input like the cached distance fields, and queries exactly on points.
    points = (50.0 + rng.random((3000, dim))).astype(np.float32)
    queries = np.vstack([50.0 + rng.random((300, dim)), points[:40]]).astype(np.float32)
    expected_distance, _ = cKDTree(points).query(queries)
    found = nearest_points(points, queries)
    distance = np.linalg.norm(queries.astype(np.float64) - points[found].astype(np.float64), axis=1)
    np.testing.assert_array_equal(distance, expected_distance)
    np.testing.assert_array_equal(found[300:], np.arange(40))


def test_nearest_points_breaks_ties_by_the_smallest_index():
    points = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 5.0], [0.0, 0.0]])
    queries = np.array([[1.0, 0.0], [0.1, 0.0], [0.0, 0.0]])  # 0 and 1 tie; 0 and 3 coincide
    np.testing.assert_array_equal(nearest_points(points, queries), [0, 0, 0])


def test_nearest_neighbours_equal_a_kd_tree():
    from scipy.spatial import cKDTree

    points = np.random.default_rng(1).random((500, 3))
    expected = cKDTree(points).query(points, k=7)[1][:, 1:]
    np.testing.assert_array_equal(nearest_neighbours(points, 6), expected)


@pytest.mark.parametrize("dim", [3, 40])
def test_nearest_rows_agrees_with_brute_force(dim):
    rng = np.random.default_rng(dim)
    reference, queries = rng.normal(size=(500, dim)), rng.normal(size=(200, dim))
    expected = np.argmin(((queries[:, None, :] - reference[None]) ** 2).sum(axis=2), axis=1)
    assert np.array_equal(nearest_rows(reference, queries), expected)
