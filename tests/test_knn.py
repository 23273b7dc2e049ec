"""Nearest-neighbour searches (darcyan.geometry.knn) against scipy's k-d tree and brute force."""

import numpy as np
import pytest

from darcyan.geometry.knn import KDTREE_MAX_DIM, QUERY_BLOCK, NearestPoints, nearest_neighbours, nearest_points, nearest_rows


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


def test_prepared_search_equals_a_kd_tree_for_every_set_of_queries():
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(5)
    points = (20.0 + rng.random((2000, 9))).astype(np.float32)
    search = NearestPoints(points)  # prepared once, then searched with several sets of queries
    tree = cKDTree(points)
    for size in (1, QUERY_BLOCK - 1, QUERY_BLOCK, QUERY_BLOCK + 1, 2 * QUERY_BLOCK + 5):  # about the blocks' edges
        queries = (20.0 + rng.random((size, 9))).astype(np.float32)
        found = search(queries)
        distance = np.linalg.norm(queries.astype(np.float64) - points[found].astype(np.float64), axis=1)
        np.testing.assert_array_equal(distance, tree.query(queries)[0])
    ties = NearestPoints(np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 0.0]]))
    np.testing.assert_array_equal(ties(np.array([[1.0, 0.0], [0.0, 0.0]])), [0, 0])
    np.testing.assert_array_equal(search(np.zeros((0, 9))), np.zeros(0, np.int64))


def test_nearest_neighbours_equal_a_kd_tree():
    from scipy.spatial import cKDTree

    points = np.random.default_rng(1).random((500, 3))
    expected = cKDTree(points).query(points, k=7)[1][:, 1:]
    np.testing.assert_array_equal(nearest_neighbours(points, 6), expected)


@pytest.mark.parametrize("dim, tree_from", [(3, 0), (3, None), (40, None)])  # 3: the k-d tree, or numpy's search
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_nearest_rows_agrees_with_brute_force(dim, tree_from, dtype, monkeypatch):
    import darcyan.geometry.knn as knn

    if tree_from is not None:
        monkeypatch.setattr(knn, "NUMPY_SEARCH_MAX_POINTS", tree_from)
    rng = np.random.default_rng(dim)
    reference, queries = rng.normal(size=(500, dim)).astype(dtype), rng.normal(size=(200, dim)).astype(dtype)
    expected = np.argmin(((queries[:, None, :] - reference[None]) ** 2).sum(axis=2), axis=1)
    found = nearest_rows(reference, queries)
    assert found.dtype == np.int64 and np.array_equal(found, expected)


def test_nearest_rows_takes_a_k_d_tree_for_many_points_in_few_dimensions(monkeypatch):
    # numpy's exact search holds a block of 64 queries x all points: beyond
    # NUMPY_SEARCH_MAX_POINTS points (or queries) the k-d tree searches, in O(points) memory.
    import darcyan.geometry.knn as knn

    def refused(points, queries):
        raise AssertionError("numpy's search on a large set")

    monkeypatch.setattr(knn, "nearest_points", refused)
    rng = np.random.default_rng(3)
    reference = rng.normal(size=(knn.NUMPY_SEARCH_MAX_POINTS + 1, 3))
    queries = rng.normal(size=(5, 3))
    expected = np.argmin(((queries[:, None, :] - reference[None]) ** 2).sum(axis=2), axis=1)
    assert np.array_equal(nearest_rows(reference, queries), expected)
    with pytest.raises(AssertionError):
        nearest_rows(reference[:100], queries)


def test_nearest_rows_refuses_coordinates_that_are_not_finite():
    reference, queries = np.zeros((5, 3)), np.ones((2, 3))
    for bad in (np.nan, np.inf):
        broken = reference.copy()
        broken[2, 1] = bad
        with pytest.raises(ValueError, match="not finite"):
            nearest_rows(broken, queries)
        with pytest.raises(ValueError, match="not finite"):
            nearest_rows(queries, broken)
    with pytest.raises(ValueError, match="not finite"):
        nearest_rows(reference, queries, np.array([0.0, np.nan, 0.0, 0.0, 0.0]))


def test_nearest_rows_with_offsets_in_few_dimensions_are_exact_in_double_precision():
    # Rows a hair apart, away from the origin (offsets of about 200, gaps of 1e-8): single
    # precision cannot tell them apart (its rounding of the offsets is 1e-5), double precision
    # does, as the k-d tree did before offsets.
    rng = np.random.default_rng(4)
    reference = 10.0 + 1e-4 * rng.normal(size=(300, 2))
    queries = 10.0 + 1e-4 * rng.normal(size=(100, 2))
    offsets = (reference**2).sum(axis=1)
    expected = np.argmin(((queries[:, None, :] - reference[None]) ** 2).sum(axis=2), axis=1)
    assert np.array_equal(nearest_rows(reference, queries, offsets), expected)
    single = np.argmin(offsets.astype(np.float32)[None] - 2 * queries.astype(np.float32) @ reference.T.astype(np.float32),
                       axis=1)
    assert not np.array_equal(single, expected)  # the case needs double precision


@pytest.mark.parametrize("dim", [3, 40])
def test_nearest_rows_with_offsets_minimize_the_offset_less_twice_the_product(dim):
    # Offsets |r|^2 give the nearest rows (in 3 dimensions: the brute force, not the k-d tree);
    # other offsets change the rows found to those of least offset - 2 q.r.
    rng = np.random.default_rng(dim)
    reference, queries = rng.normal(size=(500, dim)), rng.normal(size=(200, dim))
    lengths = (reference**2).sum(axis=1)
    assert np.array_equal(nearest_rows(reference, queries, lengths), nearest_rows(reference, queries))
    offsets = lengths + rng.uniform(0.0, 4.0 * dim, 500)
    expected = np.argmin(offsets[None, :] - 2.0 * queries @ reference.T, axis=1)
    found = nearest_rows(reference, queries, offsets)
    assert np.array_equal(found, expected)
    assert not np.array_equal(found, nearest_rows(reference, queries))


def test_nearest_rows_near_equals_the_full_search_on_a_smooth_surface_embedding(sphere):
    # Rows: a smooth embedding of the sphere's vertices (position and a few smooth functions of
    # it, like a dense map's coordinates); queries: the embedding at random points of the sphere.
    # Searched near their nearest sample only, they must find the rows a full search finds.
    from darcyan.dense.config import DenseConfig
    from darcyan.geometry.knn import nearest_rows_near

    rng = np.random.default_rng(1)
    points = sphere.vertices

    def embed(p):
        return np.hstack([p, 0.3 * np.sin(2 * p), 0.2 * np.cos(3 * p[:, :1]) * p[:, 1:], 0.2 * p**2])

    directions = rng.normal(size=(2000, 3))
    queries = embed(2.0 * directions / np.linalg.norm(directions, axis=1, keepdims=True))
    reference = embed(points)
    assert reference.shape[1] > KDTREE_MAX_DIM  # the brute-force branch of nearest_rows, like a dense map's
    coarse = np.sort(rng.choice(len(points), 600, replace=False))
    expected = nearest_rows(reference, queries)
    found = nearest_rows_near(reference, queries, points, coarse, DenseConfig().local_search_reach)
    assert np.mean(found == expected) >= 0.995
    # only the nearest sample's own cell: it misses (measured 0.86), the test can fail
    assert np.mean(nearest_rows_near(reference, queries, points, coarse, 1) == expected) < 0.9
    # In inner-product form (a dense map's read-out): the rows of the full search with the same
    # offsets, with and without a guess of each query's sample.
    offsets = (reference**2).sum(axis=1) + 0.05 * points[:, 0]
    expected = nearest_rows(reference, queries, offsets)
    assert np.mean(expected == nearest_rows(reference, queries)) < 0.99  # the offsets change the rows
    found = nearest_rows_near(reference, queries, points, coarse, DenseConfig().local_search_reach, offsets=offsets)
    assert np.mean(found == expected) >= 0.995
    guess = nearest_rows(reference[coarse], queries, offsets[coarse])
    found = nearest_rows_near(reference, queries, points, coarse, DenseConfig().local_search_reach, guess, 64, offsets)
    assert np.mean(found == expected) >= 0.995


def test_nearest_rows_near_by_blocks_of_queries_equals_one_product(sphere, monkeypatch):
    # Many queries share a nearest sample (all near one point): searched by blocks of queries,
    # each must get the row that one product over all of them gives, in single as in double precision.
    import darcyan.geometry.knn as knn

    rng = np.random.default_rng(2)
    points = sphere.vertices
    reference = np.hstack([points, np.sin(points), points**2])
    queries = reference[rng.choice(len(points), 5)].repeat(300, axis=0) + rng.normal(scale=0.05, size=(1500, 9))
    coarse = np.sort(rng.choice(len(points), 50, replace=False))
    sizes = np.bincount(knn.nearest_rows(reference[coarse], queries))
    assert sizes.max() > knn.NN_BLOCK_ROWS
    blocked = knn.nearest_rows_near(reference, queries, points, coarse, 4)
    # A sample with one query more than a block: a one-row block would be BLAS's gemv, whose
    # last bits differ from a product of many rows; the row goes with the block before it.
    one_more = queries[:knn.NN_BLOCK_ROWS + 1]
    assert len(set(knn.nearest_rows(reference[coarse], one_more))) == 1
    tail = knn.nearest_rows_near(reference, one_more, points, coarse, 4)
    monkeypatch.setattr(knn, "NN_BLOCK_ROWS", 10**9)
    assert np.array_equal(knn.nearest_rows_near(reference, queries, points, coarse, 4), blocked)
    assert np.array_equal(knn.nearest_rows_near(reference, one_more, points, coarse, 4), tail)


def test_nearest_rows_takes_any_layout_of_single_precision_rows():
    rng = np.random.default_rng(5)
    reference, queries = rng.normal(size=(300, 12)), rng.normal(size=(100, 12))
    expected = nearest_rows(reference, queries)
    fortran = np.asfortranarray(reference.astype(np.float32))
    columns = np.hstack([queries, queries]).astype(np.float32)[:, :12]  # a strided view
    assert np.array_equal(nearest_rows(fortran, columns), expected)
