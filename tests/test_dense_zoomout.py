"""Bijective ZoomOut (:mod:`darcyan.dense.zoomout`): its terms, fits, samples, read-out and ensemble."""

import dataclasses

import numpy as np
import pytest
from conftest import FAST_DENSE

from darcyan.dense.config import DenseConfig
from darcyan.dense.maps import dense_map
from darcyan.errors import ConfigError
from darcyan.geometry.mesh import Mesh


def _term(x, y):
    return ((x[:, None] - y[None]) ** 2).sum(-1)


def _scores(search):
    """``(n_a, n_b)`` what a MapSearch minimizes over its reference rows."""
    return search.offsets[None, :] - 2.0 * search.queries @ search.references.T


def _same_up_to_each_query(scores, distances):
    # Scores in inner-product form leave out each query's own length: the same for every
    # reference row, so they must differ from the squared distances by one number per row.
    gap = distances - scores
    return np.allclose(gap, gap[:, :1], rtol=1e-10, atol=1e-9 * np.abs(distances).max())


def test_zoomout_search_measures_the_sum_of_its_terms():
    # The search's scores are the sum of the four terms (coupling, bijectivity, orthogonality,
    # landmarks), each query's own part aside, whatever the weights; and its nearest rows are
    # the rows of least summed terms.
    from darcyan.dense.zoomout import map_embeddings

    rng = np.random.default_rng(0)
    b_a, b_b = rng.normal(size=(40, 12)), rng.normal(size=(50, 12))
    c_ab, c_ba = rng.normal(size=(12, 12)), rng.normal(size=(12, 12))
    f_a, f_b = rng.normal(size=(40, 4)), rng.normal(size=(50, 4))
    for config in (DenseConfig(), DenseConfig(bijectivity=0.5, orthogonality=2.0), DenseConfig(bijectivity=0.0),
                   DenseConfig(bijectivity=0.0, orthogonality=0.0)):
        search = map_embeddings(b_a, b_b, c_ab, c_ba, config, f_a, f_b)
        want = (_term(b_a @ c_ab, b_b) + config.bijectivity**2 * _term(b_a, b_b @ c_ba)
                + config.orthogonality**2 * _term(b_a, b_b @ c_ab.T) + config.landmark_weight**2 * _term(f_a, f_b))
        assert _same_up_to_each_query(_scores(search), want)
        assert np.array_equal(search.nearest(), np.argmin(want, axis=1))
    assert not _same_up_to_each_query(_scores(search), want + _term(f_a, f_b))  # the check can fail


def test_zoomout_search_is_narrower_than_its_terms():
    # The search reads p + c + d columns (basis, landmark and other coordinates), not the 2k + 1
    # + c + d of the stacked terms.
    from darcyan.dense.zoomout import map_embeddings

    rng = np.random.default_rng(2)
    b_a, b_b = rng.normal(size=(30, 18)), rng.normal(size=(35, 18))
    c_ab, c_ba = rng.normal(size=(15, 12)), rng.normal(size=(15, 12))
    f_a, f_b, g_a, g_b = rng.normal(size=(30, 4)), rng.normal(size=(35, 4)), rng.normal(size=(30, 2)), rng.normal(size=(35, 2))
    search = map_embeddings(b_a, b_b, c_ab, c_ba, DenseConfig(), f_a, f_b, g_a, g_b, dtype=np.float32)
    assert search.queries.shape == (30, 15 + 4 + 2) and search.references.shape == (35, 15 + 4 + 2)
    assert search.queries.dtype == np.float32 and search.offsets.shape == (35,)


def test_rectangular_zoomout_search_measures_the_sum_of_its_terms():
    # With a margin the maps are (p, k): each term compares the columns the docstring names.
    from darcyan.dense.zoomout import map_embeddings

    rng = np.random.default_rng(1)
    p, k = 15, 12
    b_a, b_b = rng.normal(size=(40, 18)), rng.normal(size=(50, 18))
    c_ab, c_ba = rng.normal(size=(p, k)), rng.normal(size=(p, k))
    f_a, f_b = rng.normal(size=(40, 4)), rng.normal(size=(50, 4))
    config = DenseConfig(bijectivity=0.5, orthogonality=2.0)
    g_a, g_b = rng.normal(size=(40, 3)), rng.normal(size=(50, 3))
    search = map_embeddings(b_a, b_b, c_ab, c_ba, config, f_a, f_b, g_a, g_b)
    want = (_term(b_a[:, :p] @ c_ab, b_b[:, :k]) + 0.25 * _term(b_a[:, :k], b_b[:, :p] @ c_ba)
            + 4.0 * _term(b_a[:, :k], b_b[:, :k] @ c_ab[:k].T) + config.landmark_weight**2 * _term(f_a, f_b)
            + _term(g_a, g_b))
    assert _same_up_to_each_query(_scores(search), want)
    assert np.array_equal(search.nearest(), np.argmin(want, axis=1))


@pytest.mark.slow
@pytest.mark.parametrize("commutativity", [0.0, 3.0])
def test_zoomout_with_a_margin_keeps_the_true_map_of_a_renumbered_copy(figure_poses, commutativity):
    # From the true correspondence of a renumbered copy, each step's rectangular fit is exact (the
    # first k eigenfunctions of the copy lie in the span of the first k + margin of the shape), so
    # ZoomOut and the final read-out return the truth at every vertex; a fit or coupling term on
    # mismatched columns would not (the columns of the other terms: the test above). The
    # commutativity term costs nothing there (the copy's eigenvalues are the shape's, and the true
    # map pairs each eigenfunction with its own), so it must not move the map either.
    from darcyan.dense.zoomout import read_out_map, zoomout
    from darcyan.geometry.shape import prepare_shape

    mesh = figure_poses[0]
    order = np.random.default_rng(7).permutation(mesh.n_vertices)
    shape, copy = prepare_shape(mesh), prepare_shape(Mesh(mesh.vertices[order], np.argsort(order)[mesh.faces]))
    config = DenseConfig(basis_start=10, basis_size=20, basis_step=5, basis_margin=6, margin_from=15,
                         landmark_weight=0, signature_weight=0, signature_turns=0, commutativity=commutativity)
    spectrum_1, spectrum_2 = shape.spectrum(26), copy.spectrum(26)
    basis_1, basis_2 = spectrum_1.vectors, spectrum_2.vectors
    truth_12, truth_21 = np.argsort(order), order
    c_12, c_21 = zoomout(basis_1, basis_2, truth_12, truth_21, config,
                         values_1=spectrum_1.values, values_2=spectrum_2.values)
    assert c_12.shape == c_21.shape == (26, 20)
    none = np.zeros((mesh.n_vertices, 0)), np.zeros((copy.n_vertices, 0))
    assert (read_out_map(copy, basis_1, basis_2, c_12, c_21, config, *none, np.arange(copy.n_vertices))
            == truth_12).all()


@pytest.mark.slow
def test_the_coarse_to_fine_read_out_finds_the_true_map_as_the_full_one(figure_poses):
    # The read-out of a large target searches near each image's nearest sample (cells of the
    # ZoomOut samples, with and without the guess from the source's samples), in the search's
    # inner-product form: from the true functional maps of a renumbered copy it must find the
    # true map, as the full search does; offsets left out of the coarse level would not.
    import darcyan.dense.zoomout as zoomout_module
    from darcyan.dense.zoomout import read_out_map, zoomout
    from darcyan.geometry.shape import prepare_shape

    mesh = figure_poses[0]
    order = np.random.default_rng(8).permutation(mesh.n_vertices)
    shape, copy = prepare_shape(mesh), prepare_shape(Mesh(mesh.vertices[order], np.argsort(order)[mesh.faces]))
    config = DenseConfig(basis_start=10, basis_size=20, basis_step=5, basis_margin=6, margin_from=15,
                         landmark_weight=0, signature_weight=0, signature_turns=0)
    basis_1, basis_2 = shape.spectrum(26).vectors, copy.spectrum(26).vectors
    truth_12, truth_21 = np.argsort(order), order
    c_12, c_21 = zoomout(basis_1, basis_2, truth_12, truth_21, config)
    none = np.zeros((mesh.n_vertices, 0)), np.zeros((copy.n_vertices, 0))
    rng = np.random.default_rng(0)
    sample_1 = np.sort(rng.choice(mesh.n_vertices, 400, replace=False))
    sample_2 = np.sort(rng.choice(copy.n_vertices, 400, replace=False))
    local = dataclasses.replace(config, local_search_above=0)
    full = read_out_map(copy, basis_1, basis_2, c_12, c_21, config, *none, sample_2)
    assert (full == truth_12).mean() > 0.99
    for guess in ({}, {"sample_1": sample_1, "positions_1": shape.mesh.vertices}):
        found = read_out_map(copy, basis_1, basis_2, c_12, c_21, local, *none, sample_2, **guess)
        assert (found == full).mean() > 0.99
    # Without the offsets the coarse level's choices are not the nearest samples: it can fail.
    real = zoomout_module.nearest_rows_near
    zoomout_module.nearest_rows_near = lambda *args: real(*args[:-1])
    try:
        dropped = read_out_map(copy, basis_1, basis_2, c_12, c_21, local, *none, sample_2)
    finally:
        zoomout_module.nearest_rows_near = real
    assert (dropped == full).mean() < 0.99


def test_commutativity_shrinks_by_the_squared_relative_gap_of_the_eigenvalues():
    from darcyan.dense.zoomout import commutativity_shrinkage

    a, b = np.array([0.0, 1.0, 2.0, 5.0]), np.array([0.0, 1.0, 4.0])
    factor = commutativity_shrinkage(a, b, 4, 3, 2.0)
    assert factor.shape == (4, 3)
    assert factor[0, 0] == 1.0 and factor[1, 1] == 1.0  # equal frequencies (the constants too): kept
    assert np.isclose(factor[2, 2], 1 / (1 + 2.0 * (2 / 6) ** 2)) and np.isclose(factor[3, 1], 1 / (1 + 2.0 * (4 / 6) ** 2))
    assert np.isclose(factor[0, 2], 1 / 3)  # the constant against any other: the full weight
    # A shape scaled by s has its eigenvalues divided by s^2: the term does not see a scale.
    assert np.allclose(commutativity_shrinkage(7.0 * a, 7.0 * b, 4, 3, 2.0), factor)
    assert commutativity_shrinkage(a, b, 2, 3, 2.0).shape == (2, 3)
    assert (commutativity_shrinkage(a, b, 4, 3, 0.0) == 1.0).all()
    # The constants' eigenvalue is 0 up to rounding only (0 on one shape, 2e-14 on another):
    # still the same frequency, not a relative gap of 1.
    rounded = commutativity_shrinkage(a, np.array([2e-14, 1.0, 4.0]), 4, 3, 2.0)
    assert rounded[0, 0] == 1.0 and np.allclose(rounded, factor)


def test_zoomout_shrinks_each_direction_by_its_own_eigenvalues():
    # One step (basis_start == basis_size) returns the fits of the given maps: each shrunk with the
    # eigenvalues of the shape it maps from as rows and of the other as columns.
    from darcyan.dense.zoomout import _Fitter, commutativity_shrinkage, zoomout

    rng = np.random.default_rng(5)
    b_1, b_2 = rng.normal(size=(60, 14)), rng.normal(size=(50, 14))
    map_12, map_21 = rng.integers(0, 50, 60), rng.integers(0, 60, 50)
    v_1, v_2 = np.sort(rng.uniform(0, 10, 14)), np.sort(rng.uniform(20, 60, 14))
    config = DenseConfig(basis_start=10, basis_size=10, basis_margin=4, margin_from=10, commutativity=3.0)
    c_12, c_21 = zoomout(b_1, b_2, map_12, map_21, config, values_1=v_1, values_2=v_2)
    plain_12, plain_21 = _Fitter(b_1).fit(b_2[map_12, :10], 14), _Fitter(b_2).fit(b_1[map_21, :10], 14)
    assert np.allclose(c_12, plain_12 * commutativity_shrinkage(v_1, v_2, 14, 10, 3.0), atol=1e-12)
    assert np.allclose(c_21, plain_21 * commutativity_shrinkage(v_2, v_1, 14, 10, 3.0), atol=1e-12)
    assert not np.allclose(c_12, plain_12 * commutativity_shrinkage(v_2, v_1, 14, 10, 3.0), atol=1e-6)
    unshrunk = zoomout(b_1, b_2, map_12, map_21, config)  # without eigenvalues: plain fits
    assert np.allclose(unshrunk[0], plain_12, atol=1e-12) and np.allclose(unshrunk[1], plain_21, atol=1e-12)


@pytest.mark.slow
def test_the_dense_map_shrinks_its_fits_with_both_shapes_eigenvalues(figure_pair, monkeypatch):
    import darcyan.dense.zoomout as zoomout_module

    seen = []
    real = zoomout_module.commutativity_shrinkage
    monkeypatch.setattr(zoomout_module, "commutativity_shrinkage", lambda *a: seen.append(a[:2]) or real(*a))
    shape_1, shape_2, matches = figure_pair
    dense_map(shape_1, shape_2, matches, FAST_DENSE)
    want_1 = zoomout_module.dense_eigenvalues(shape_1.shape, FAST_DENSE)
    want_2 = zoomout_module.dense_eigenvalues(shape_2.shape, FAST_DENSE)
    assert seen and all(a is want_1 and b is want_2 or a is want_2 and b is want_1 for a, b in seen)
    seen.clear()
    dense_map(shape_1, shape_2, matches, dataclasses.replace(FAST_DENSE, commutativity=0.0))
    assert not seen


def test_a_shrunk_fit_minimizes_the_commutativity_term_on_an_orthonormal_sample_basis():
    # The documented claim: with B^T B = s I, the shrunk least-squares map is the exact minimizer
    # of |B C - Y|^2 + s w sum(r_ij^2 C_ij^2), here solved column by column as stacked least squares.
    from darcyan.dense.zoomout import _Fitter, commutativity_shrinkage

    rng = np.random.default_rng(3)
    s = 50
    basis = np.sqrt(s) * np.linalg.qr(rng.normal(size=(s, 12)))[0]  # B^T B = s I
    mapped = rng.normal(size=(s, 8))
    values_a, values_b = np.sort(rng.uniform(0, 40, 12)), np.sort(rng.uniform(0, 40, 8))
    c = _Fitter(basis).fit(mapped, 10) * commutativity_shrinkage(values_a, values_b, 10, 8, 3.0)
    ratio = 1 / commutativity_shrinkage(values_a, values_b, 10, 8, 3.0) - 1  # w r_ij^2
    for j in range(8):
        stacked = np.vstack([basis[:, :10], np.diag(np.sqrt(s * ratio[:, j]))])
        want = np.linalg.lstsq(stacked, np.r_[mapped[:, j], np.zeros(10)], rcond=None)[0]
        assert np.allclose(c[:, j], want, atol=1e-10)


def test_functional_map_fits_equal_least_squares_with_fewer_samples_than_columns_too():
    from darcyan.dense.zoomout import _Fitter

    rng = np.random.default_rng(2)
    for samples in (40, 6):  # QR once; fewer samples than columns: least squares each time
        basis, mapped = rng.normal(size=(samples, 10)), rng.normal(size=(samples, 7))
        expected = np.linalg.lstsq(basis[:, :7], mapped, rcond=None)[0]
        assert np.allclose(_Fitter(basis).fit(mapped), expected, atol=1e-10)
        wider = np.linalg.lstsq(basis[:, :9], mapped, rcond=None)[0]  # a margin: (9, 7)
        assert np.allclose(_Fitter(basis).fit(mapped, 9), wider, atol=1e-10)


@pytest.mark.slow
def test_coarse_coordinates_steer_only_the_zoomout_steps_up_to_signature_until(figure_poses):
    # A renumbered copy: the true map is known. ZoomOut from a random first map cannot find it
    # with 20 eigenfunctions alone; coordinates that correspond (here the positions), in the
    # coarse steps, lead it there; and steps above signature_until ignore them exactly.
    from darcyan.dense.zoomout import map_embeddings, zoomout
    from darcyan.geometry.shape import prepare_shape

    mesh = figure_poses[0]
    order = np.random.default_rng(5).permutation(mesh.n_vertices)  # copy vertex i is mesh vertex order[i]
    copy = Mesh(mesh.vertices[order], np.argsort(order)[mesh.faces])
    basis_1, basis_2 = (prepare_shape(m).spectrum(20).vectors for m in (mesh, copy))
    rng = np.random.default_rng(0)
    first_12, first_21 = rng.integers(0, mesh.n_vertices, (2, mesh.n_vertices))
    truth_12 = np.argsort(order)  # mesh vertex v is copy vertex truth_12[v]
    size = np.ptp(mesh.vertices, axis=0).max()

    def within(config, coarse):  # coarse: (coarse_1, coarse_2[, steady_1, steady_2])
        c_12, c_21 = zoomout(basis_1, basis_2, first_12, first_21, config, None, None, *coarse)
        image = map_embeddings(basis_1, basis_2, c_12, c_21, config).nearest()
        return np.mean(np.linalg.norm(copy.vertices[image] - copy.vertices[truth_12], axis=1) < 0.05 * size)

    config = DenseConfig(basis_start=4, basis_size=20, basis_step=4, signature_until=20)
    positions = (10.0 * mesh.vertices / size, 10.0 * copy.vertices / size)
    assert within(config, positions) > 0.95
    assert within(config, (None, None)) < 0.5
    ignored = dataclasses.replace(config, signature_until=3)
    assert within(ignored, positions) == within(ignored, (None, None))
    # Steady coordinates (the signature turns) join every step, whatever signature_until says.
    assert within(ignored, (None, None) + positions) > 0.95


def test_the_final_read_out_carries_the_steady_coordinates(figure_poses):
    # A renumbered copy, functional maps that say nothing (zero): coordinates that correspond (the
    # positions, scaled to dominate) give the true map exactly; without them the map is not it.
    from darcyan.dense.zoomout import read_out_map
    from darcyan.geometry.shape import prepare_shape

    mesh = figure_poses[0]
    order = np.random.default_rng(6).permutation(mesh.n_vertices)
    shape, copy = prepare_shape(mesh), prepare_shape(Mesh(mesh.vertices[order], np.argsort(order)[mesh.faces]))
    basis_1, basis_2 = shape.spectrum(10).vectors, copy.spectrum(10).vectors
    zero = np.zeros((10, 10))
    config = DenseConfig(basis_size=10, bijectivity=0, orthogonality=0, landmark_weight=0)
    no_landmarks = np.zeros((mesh.n_vertices, 0)), np.zeros((copy.n_vertices, 0))
    args = (copy, basis_1, basis_2, zero, zero, config, *no_landmarks, np.arange(copy.n_vertices))
    truth = np.argsort(order)
    steady = 1e3 * shape.mesh.vertices, 1e3 * copy.mesh.vertices
    assert (read_out_map(*args, *steady) == truth).all()
    assert (read_out_map(*args) != truth).mean() > 0.5


def test_consensus_map_keeps_the_image_two_of_three_maps_agree_on():
    from darcyan.dense.zoomout import consensus_map

    # Points of a helix (no two equidistant from a third by accident); the true map is the identity.
    t = np.linspace(0, 6 * np.pi, 300)
    positions = np.stack([np.cos(t), np.sin(t), 0.1 * t], axis=1)
    truth = np.arange(len(t))
    rng = np.random.default_rng(0)
    maps = []
    for region in (slice(0, 100), slice(100, 200), slice(200, 300)):  # each map wrong in a region of its own
        wrong = truth.copy()
        wrong[region] = rng.integers(0, len(t), size=len(truth[region]))
        maps.append(wrong)
    assert all((m != truth).mean() > 0.3 for m in maps)
    assert np.array_equal(consensus_map(positions, maps), truth)
    # Fewer than three maps: no majority, the first map as it is.
    assert np.array_equal(consensus_map(positions, maps[:2]), maps[0])
    assert np.array_equal(consensus_map(positions, maps[:1]), maps[0])


def test_ensemble_members_draw_seeded_samples_of_their_own(figure_poses):
    from darcyan.dense.zoomout import zoomout_sample
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    config = DenseConfig(zoomout_samples=500)
    first, second = zoomout_sample(shape, config), zoomout_sample(shape, config, member=1)
    assert np.array_equal(second, zoomout_sample(shape, config, member=1))  # seeded
    assert len(np.intersect1d(first, second)) < 0.9 * len(first)
    with pytest.raises(ConfigError, match="ensemble"):
        DenseConfig(ensemble=0)


def test_farthest_seed_points_are_spread_when_zoomout_runs_on_every_vertex(figure_poses):
    from darcyan.dense.zoomout import seed_subset, zoomout_samples
    from darcyan.geometry.sampling import farthest_point_vertices
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    config = DenseConfig(sampling="farthest", zoomout_samples=0)
    every, _ = zoomout_samples(shape, shape, config)
    assert np.array_equal(every, np.arange(shape.n_vertices))
    points = seed_subset(shape, every, 300, config)
    assert np.array_equal(points[:10], farthest_point_vertices(shape.mesh.vertices, 10, int(points[0])))
    sampled = DenseConfig(sampling="farthest", zoomout_samples=1000)
    first = zoomout_samples(shape, shape, sampled)[0]
    assert np.array_equal(seed_subset(shape, first, 300, sampled), first[:300])


def test_zoomouts_two_directions_side_by_side_give_the_same_bits_as_one_after_the_other(figure_poses, monkeypatch):
    # Each direction's search runs alone in its thread beside the other's (darcyan.parallel.side_by_side);
    # with one thread they run in turn, each split into the same blocks: the same functional maps.
    import darcyan.parallel as parallel
    from darcyan.dense.zoomout import zoomout
    from darcyan.geometry.shape import prepare_shape

    shape_1, shape_2 = prepare_shape(figure_poses[0]), prepare_shape(figure_poses[1])
    config = DenseConfig(basis_start=6, basis_size=20, basis_step=2, basis_margin=4, margin_from=10,
                         landmark_weight=0, signature_weight=0, signature_turns=0)
    rng = np.random.default_rng(3)
    sample_1, sample_2 = (rng.choice(s.n_vertices, 600, replace=False) for s in (shape_1, shape_2))
    basis_1, basis_2 = shape_1.spectrum(24).vectors[sample_1], shape_2.spectrum(24).vectors[sample_2]
    start_12, start_21 = rng.integers(0, 600, 600), rng.integers(0, 600, 600)
    searched = []
    real_side_by_side = parallel.side_by_side
    monkeypatch.setattr("darcyan.dense.zoomout.side_by_side",
                        lambda tasks: searched.append(parallel.own_threads()) or real_side_by_side(tasks))
    threads = parallel.own_threads()
    if threads < 2:
        pytest.skip("one core: nothing runs side by side")
    together = zoomout(basis_1, basis_2, start_12, start_21, config)
    monkeypatch.setattr(parallel, "MAX_OWN_THREADS", 1)
    in_turn = zoomout(basis_1, basis_2, start_12, start_21, config)
    assert max(searched) == threads and min(searched) == 1  # both ways were run
    for a, b in zip(together, in_turn):
        np.testing.assert_array_equal(a, b)
