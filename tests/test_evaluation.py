"""The metric against cases with known answers: sphere geodesics, perfect and mirrored maps,
vts ground truth, derived mirror maps."""

import numpy as np
import pytest

from darcyan.errors import MeshError
from darcyan.eval.metrics import (
    CURVE_TAUS,
    cumulative_curve,
    geodesic_errors,
    input_to_mesh_index,
    mirror_agreement,
    nearest_samples,
    read_vts,
    reflection_symmetry,
    score_pair,
    summarize,
)
from darcyan.geometry import synthetic
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import Mesh, normalize_mesh

FMM_TOLERANCE = 0.03  # relative error of fast marching on a 10k-vertex sphere


@pytest.fixture(scope="module")
def unit_sphere():
    """A sphere of area 1 (radius 1 / sqrt(4 pi)), symmetric under x -> -x, with its solver."""
    mesh, _ = normalize_mesh(synthetic.icosphere(subdivisions=5, radius=2.0))
    return mesh, GeodesicSolver(mesh)


def mirror_x(mesh: Mesh) -> np.ndarray:
    """The vertex nearest to each vertex's reflection in the plane x = 0."""
    from scipy.spatial import cKDTree

    _, image = cKDTree(mesh.vertices).query(mesh.vertices * [-1.0, 1.0, 1.0])
    return image


def test_error_is_the_great_circle_distance_over_sqrt_area(unit_sphere):
    mesh, solver = unit_sphere
    radius = np.linalg.norm(mesh.vertices, axis=1).mean()
    truth = np.array([0, 5, 17])
    matched = np.array([100, 2000, 9000])
    unit = mesh.vertices / np.linalg.norm(mesh.vertices, axis=1, keepdims=True)
    angle = np.arccos(np.clip(np.einsum("ij,ij->i", unit[truth], unit[matched]), -1, 1))
    expected = radius * angle / np.sqrt(mesh.area())
    np.testing.assert_allclose(geodesic_errors(mesh, solver, matched, truth), expected, rtol=FMM_TOLERANCE)
    score = score_pair(solver, matched, truth, None, matched)
    np.testing.assert_allclose(score.errors, expected, rtol=FMM_TOLERANCE)


def test_errors_are_normalized_by_sqrt_area():
    small = synthetic.icosphere(subdivisions=4, radius=1.0)
    big = Mesh(small.vertices * 3.0, small.faces)
    truth, matched = np.array([0, 1, 2]), np.array([50, 300, 2000])
    e_small = score_pair(GeodesicSolver(small), matched, truth, None, matched).errors
    e_big = score_pair(GeodesicSolver(big), matched, truth, None, matched).errors
    assert e_small.min() > 0.05
    np.testing.assert_allclose(e_big, e_small, rtol=1e-9)


def test_a_perfect_map_scores_one_at_every_threshold(unit_sphere):
    mesh, solver = unit_sphere
    truth = np.arange(0, mesh.n_vertices, 997)
    score = score_pair(solver, truth, truth, mirror_x(mesh)[truth], truth)
    summary = summarize([score])
    assert summary["rate"] == 1.0 and summary["rate_sym"] == 1.0 and summary["repeatability"] == 1.0
    assert summary["mean_error"] == 0.0
    assert np.all(np.asarray(summary["curve"]) == 1.0)
    assert len(summary["curve"]) == len(CURVE_TAUS) and CURVE_TAUS[0] == 0 and CURVE_TAUS[-1] == 0.25


def test_a_map_onto_the_mirror_image_scores_zero_strict_and_one_symmetric(unit_sphere):
    mesh, solver = unit_sphere
    mirror = mirror_x(mesh)
    far = np.flatnonzero(np.abs(mesh.vertices[:, 0]) > 0.15)[::211]  # well away from the mirror plane
    score = score_pair(solver, mirror[far], far, mirror[far], far)
    summary = summarize([score])
    assert summary["matches"] == len(far) > 5
    assert summary["rate"] == 0.0 and summary["correct"] == 0
    assert summary["rate_sym"] == 1.0 and summary["correct_sym"] == len(far)
    assert summary["curve_sym"][0] == 1.0


def test_summary_pools_matches_and_feature_points():
    a = {"features": 4, "errors": np.array([0.0, 0.01, 0.2]), "errors_sym": np.array([0.3, 0.3, 0.02]),
         "repeatable": [True, True, False, False], "repeatable_sym": [True, True, True, False]}
    b = {"features": 1, "errors": np.array([0.04]), "errors_sym": np.array([np.nan]),
         "repeatable": [True], "repeatable_sym": [True]}
    s = summarize([a, b], threshold=0.05)
    assert (s["pairs"], s["features"], s["matches"], s["correct"], s["correct_sym"]) == (2, 5, 4, 3, 4)
    assert s["rate"] == 0.75 and s["rate_sym"] == 1.0 and s["recall"] == 0.6
    assert s["repeatability"] == 0.6 and s["repeatability_sym"] == 0.8
    assert s["mean_error"] == pytest.approx(0.0625)
    assert summarize([])["rate"] is None


def test_cumulative_curve_counts_at_or_below_each_tau():
    np.testing.assert_allclose(cumulative_curve(np.array([0.0, 0.1, 0.3]), np.array([0.0, 0.1, 0.25])),
                               [1 / 3, 2 / 3, 2 / 3])


def test_read_vts_is_one_based_and_checked(tmp_path):
    good = tmp_path / "a.vts"
    good.write_text("1\n5\n3\n")
    np.testing.assert_array_equal(read_vts(good, 5), [0, 4, 2])
    bad = tmp_path / "b.vts"
    bad.write_text("0\n2\n")
    with pytest.raises(MeshError, match="out of range"):
        read_vts(bad, 5)
    with pytest.raises(MeshError, match="out of range"):
        read_vts(good, 4)
    with pytest.raises(MeshError, match="cannot read"):
        read_vts(tmp_path / "missing.vts")


def test_the_true_correspondent_is_at_the_nearest_listed_sample(unit_sphere):
    mesh, solver = unit_sphere
    unit = mesh.vertices / np.linalg.norm(mesh.vertices, axis=1, keepdims=True)
    poles = [int(np.argmax(unit @ d)) for d in np.eye(3)] + [int(np.argmin(unit[:, 2]))]  # +x, +y, +z, -z
    near_y = int(np.argmax(unit @ np.array([0.1, 1.0, 0.05])))  # beside the +y pole
    near_down = int(np.argmax(unit @ np.array([0.0, 0.2, -1.0])))  # beside the -z pole
    np.testing.assert_array_equal(nearest_samples(solver, [near_y, near_down, poles[0]], poles), [1, 3, 0])


def test_input_numbering_maps_to_the_prepared_mesh():
    full = synthetic.icosphere(subdivisions=2)
    keep = np.arange(5, full.n_vertices)
    part = Mesh(full.vertices[keep], np.zeros((0, 3), np.int64), input_index=keep)
    np.testing.assert_array_equal(input_to_mesh_index(part, [5, 6, 40]), [0, 1, 35])
    with pytest.raises(MeshError, match="not on the prepared mesh"):
        input_to_mesh_index(part, [2])
    # With positions, a left-out vertex goes to the nearest kept one.
    shifted = full.vertices.copy()
    shifted[2] = full.vertices[40] * 1.001
    assert input_to_mesh_index(part, [2], shifted)[0] == 35


def test_reflection_symmetry_finds_the_plane_of_a_symmetric_shape_and_not_of_the_figure(unit_sphere):
    # An ellipsoid with distinct axes, turned: its planes of symmetry are known.
    sphere = synthetic.icosphere(subdivisions=4)
    rotation, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))
    ellipsoid = Mesh(sphere.vertices * [2.0, 1.0, 0.6] @ rotation.T, sphere.faces)
    found = reflection_symmetry(ellipsoid)
    assert found.residual < 1e-6
    assert max(abs(found.normal @ rotation[:, i]) for i in range(3)) > 1 - 1e-6  # a principal plane
    assert (found.vertices[found.vertices] == np.arange(ellipsoid.n_vertices)).mean() > 0.99  # an involution
    assert (found.vertices != np.arange(ellipsoid.n_vertices)).mean() > 0.9
    # The built-in figure is deliberately asymmetric.
    from darcyan.bench.settings import MIRROR_MAX_RESIDUAL

    assert reflection_symmetry(synthetic.figure(0)).residual > 3 * MIRROR_MAX_RESIDUAL


def test_mirror_agreement_is_zero_for_the_true_mirror(unit_sphere):
    mesh, solver = unit_sphere
    mirror = mirror_x(mesh)
    samples = np.arange(0, mesh.n_vertices, 1500)
    np.testing.assert_allclose(mirror_agreement(solver, mirror, samples, mirror[samples]), 0.0)
    assert mirror_agreement(solver, np.arange(mesh.n_vertices), samples, mirror[samples]).max() > 0.1


@pytest.mark.parametrize("mesh_of", [lambda: synthetic.figure(1, subdivisions=4), lambda: synthetic.torus(nu=120, nv=60)])
def test_scores_read_on_geodesic_balls_are_those_of_whole_fast_marchings(mesh_of, monkeypatch):
    """A large target is scored through geodesic balls cut by Euclidean distance around each
    true correspondent (``BALL_SCORING_ABOVE``): the errors are the whole mesh's fast-marching
    ones bit for bit, for a right map (no whole field made at all), a map with a tenth of its
    vertices sent anywhere (those fall back on the whole field) and one sent a ring away, on a
    figure whose limbs pass near its body and on a torus."""
    import darcyan.eval.dense_scores as scores
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(mesh_of())
    mesh, solver = shape.mesh, shape.solver
    n = shape.n_input_vertices
    rng = np.random.default_rng(3)
    noisy = np.arange(n)
    moved = rng.choice(n, n // 10, replace=False)
    noisy[moved] = rng.integers(0, n, len(moved))
    near = mesh.input_index[mesh.edges()[:, 1]]  # each edge's first end sent to its other end
    shifted = np.arange(n)
    shifted[mesh.input_index[mesh.edges()[:, 0]]] = near
    maps = {"right": np.arange(n), "noisy": noisy, "shifted": shifted}
    whole = scores.evaluate_dense_maps(mesh, mesh, maps, sample=150, target_solver=solver)
    fields = []
    real = solver.distance
    monkeypatch.setattr(solver, "distance", lambda v: fields.append(v) or real(v))
    monkeypatch.setattr(scores, "BALL_SCORING_ABOVE", 0)
    on_balls = scores.evaluate_dense_maps(mesh, mesh, {"right": maps["right"]}, sample=150, target_solver=solver)
    assert not fields and on_balls["right"].errors.max() == 0.0  # no whole field for a right map
    on_balls = scores.evaluate_dense_maps(mesh, mesh, maps, sample=150, target_solver=solver)
    assert 0 < len(fields) < 150  # the noisy map's far images, not every sample
    for name in maps:
        np.testing.assert_array_equal(on_balls[name].errors, whole[name].errors)
    assert whole["noisy"].errors.max() > 5 * scores.BALL_SCORING_RADIUS  # errors far beyond the balls were read
    assert 0 < np.median(whole["shifted"].errors) <= scores.BALL_SCORING_RADIUS
    # only a ball's values within its radius are read (beyond it fast marching on the piece may
    # exceed the whole mesh's: here made so, and the errors stay the whole mesh's)
    import dataclasses

    from darcyan.geometry.geodesics import LocalGeodesicSolver

    cut = LocalGeodesicSolver.ball

    def off_beyond(self, vertex, keep=True):
        ball = cut(self, vertex, keep)
        if ball.distance is None:
            return ball
        return dataclasses.replace(ball, distance=np.where(ball.distance > ball.radius, ball.distance + 1.0,
                                                           ball.distance))

    monkeypatch.setattr(LocalGeodesicSolver, "ball", off_beyond)
    skewed = scores.evaluate_dense_maps(mesh, mesh, maps, sample=150, target_solver=solver)
    for name in maps:
        np.testing.assert_array_equal(skewed[name].errors, whole[name].errors)
