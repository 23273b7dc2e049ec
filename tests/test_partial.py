"""Partial shapes: cutting (darcyan.eval.partial), cut rims kept from being extremities
(darcyan.method.features.cut_rim_zone), and matching a cut shape to a whole one."""

import warnings

import numpy as np
import pytest
from conftest import vts_truth

from darcyan import DarcyanConfig, load_mesh
from darcyan.errors import ConfigError
from darcyan.eval.metrics import GroundTruth, score_matches
from darcyan.eval.partial import cut_ball, cut_plane, partial_truth, remove_vertices, rim_distance
from darcyan.geometry import synthetic
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import MeshWarning, boundary_loops, normalize_mesh
from darcyan.method.pipeline import analyze_mesh, match_shapes

pytestmark = pytest.mark.usefixtures("private_cache")


def test_boundary_loops_measure_the_circles_of_a_disc_and_a_cylinder(sphere):
    label, lengths = boundary_loops(synthetic.flat_disc(radius=1.0))
    assert len(lengths) == 1 and lengths[0] == pytest.approx(2 * np.pi, rel=0.01)
    disc = synthetic.flat_disc(radius=1.0)
    assert (label >= 0).sum() == (np.linalg.norm(disc.vertices, axis=1) > 0.999).sum()
    _, lengths = boundary_loops(synthetic.cylinder(radius=0.5))
    assert np.allclose(lengths, np.pi, rtol=0.01) and len(lengths) == 2
    label, lengths = boundary_loops(sphere)
    assert len(lengths) == 0 and (label < 0).all()


def test_cut_ball_on_a_sphere_removes_a_cap_and_leaves_a_circle(sphere):
    # A geodesic disc of radius rho on a sphere of radius r: a cap of area 2 pi r^2 (1 - cos(rho/r))
    # whose rim is a circle of length 2 pi r sin(rho/r). Lengths of the cut: sqrt(area) units.
    r = 2.0
    scale = np.sqrt(sphere.area())
    partial = cut_ball(sphere, 0, 0.15)
    rho = 0.15 * scale
    edge = np.linalg.norm(np.diff(sphere.vertices[sphere.edges()], axis=1), axis=2).max()
    cap = lambda radius: 2 * np.pi * r**2 * (1 - np.cos(radius / r))  # noqa: E731
    circle = lambda radius: 2 * np.pi * r * np.sin(radius / r)  # noqa: E731
    # faces touching a removed vertex go too: the cut reaches at most one edge beyond rho
    assert cap(rho) <= sphere.area() - partial.mesh.area() <= cap(rho + edge)
    _, lengths = boundary_loops(partial.mesh)
    assert len(lengths) == 1 and lengths[0] >= 0.99 * circle(rho)  # along edges: a zigzag, not shorter
    # the rim: points at a geodesic distance (on a sphere: r times the angle) of rho to rho + edge
    centre = sphere.vertices[0] / r
    angle = np.arccos(np.clip(partial.mesh.vertices[partial.rim] @ centre / r, -1, 1))
    assert 0.98 * rho <= (r * angle).min() and (r * angle).max() <= rho + edge  # fast marching: ~1% long
    # the map back to the full mesh: same positions; the rim is the new boundary
    assert np.array_equal(partial.mesh.vertices, sphere.vertices[partial.kept])
    assert np.array_equal(partial.from_full(partial.kept), np.arange(partial.mesh.n_vertices))
    assert partial.from_full([0])[0] == -1
    assert partial.rim.sum() == (boundary_loops(partial.mesh)[0] >= 0).sum() > 0  # the only boundary: the cut


def test_cut_plane_takes_only_the_limb_it_cuts():
    full = synthetic.figure(0)
    tips = synthetic.figure_tips()
    partial = cut_plane(full, int(tips[1]), 0.2)
    assert partial.from_full([tips[1]])[0] == -1
    assert (partial.from_full(np.delete(tips, 1)) >= 0).all()  # the other limbs stay whole
    # every removed vertex is on the tip's side of the plane: farther along the limb than any rim vertex
    direction = full.vertices[tips[1]] / np.linalg.norm(full.vertices[tips[1]])
    removed = np.setdiff1d(np.arange(full.n_vertices), partial.kept)
    rim_along = partial.mesh.vertices[partial.rim] @ direction
    assert (full.vertices[removed] @ direction).min() >= rim_along.min() - 1e-9
    assert rim_distance(partial)[partial.rim].max() == 0


def test_partial_truth_leaves_out_the_samples_cut_away():
    full = synthetic.figure(0)
    partial = remove_vertices(full, np.arange(full.n_vertices) < 100, "first hundred")
    truth = GroundTruth(np.array([5, 150, 99, 300]), np.array([50, 60, 70, 80]))
    carried = partial_truth(truth, partial)
    assert np.array_equal(partial.kept[carried.source_samples], [150, 300])
    assert np.array_equal(carried.target_samples, [60, 80])
    reverse = partial_truth(GroundTruth(np.array([50, 60]), np.array([5, 150])), partial, partial_is_source=False)
    assert np.array_equal(reverse.source_samples, [60]) and np.array_equal(partial.kept[reverse.target_samples], [150])


@pytest.mark.slow
def test_a_cut_limb_leaves_no_extremity_at_its_rim_and_stays_unmatched(figure_poses):
    full_0, full_1 = figure_poses
    tips = synthetic.figure_tips()
    partial = cut_plane(full_0, int(tips[1]), 0.15)
    rim = rim_distance(partial)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MeshWarning)
        cut = analyze_mesh(partial.mesh)
    assert any("at the rim of a cut left out" in str(w.message) for w in caught)
    features = cut.description.feature_vertices
    assert rim[features].min() > DarcyanConfig().rims.clearance
    # Without the rule, the cut's rim is an extremity: the test above can fail.
    open_rims = analyze_mesh(partial.mesh, DarcyanConfig().updated({"rims": {"min_length": 0}}))
    assert rim[open_rims.description.feature_vertices].min() < 0.01

    whole = analyze_mesh(full_1)
    correspondence = match_shapes(cut.description, whole.description)
    assert len(correspondence) == len(features)  # every extremity left is matched ...
    normalized, _ = normalize_mesh(full_1)
    solver = GeodesicSolver(normalized)
    true_targets = partial.kept[correspondence.source_vertex]  # the figure's truth: one numbering
    errors = [solver.distance(int(t))[q] for t, q in zip(true_targets, correspondence.target_vertex)]
    assert max(errors) <= 0.05  # ... rightly
    near_cut_tip = solver.distance(int(tips[1]))[correspondence.target_vertex]
    assert near_cut_tip.min() > 0.2  # and nothing is matched to the limb that was cut away


@pytest.mark.slow
def test_a_person_without_a_hand_matches_the_rest_to_the_whole_person(faust):
    config = DarcyanConfig()
    full = load_mesh(faust / "tr_reg_000.off")
    whole_source = analyze_mesh(full, config)
    whole_target = analyze_mesh(load_mesh(faust / "tr_reg_001.off"), config)
    truth = vts_truth(faust, "tr_reg_000", "tr_reg_001")
    # cut away, one at a time, the extremity at each feature point
    for tip in whole_source.description.feature_vertices[:3]:
        partial = cut_ball(full, int(tip), 0.12)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshWarning)
            cut = analyze_mesh(partial.mesh, config)
        assert rim_distance(partial)[cut.description.feature_vertices].min() > config.rims.clearance
        correspondence = match_shapes(cut.description, whole_target.description)
        score = score_matches(cut.shape, whole_target.shape, correspondence, partial_truth(truth, partial))
        assert len(score) >= 3 and score.correct == len(score), f"cut at {tip}: {score.summary()}"


@pytest.mark.parametrize("changes", [{"min_length": -1}, {"clearance": float("nan")}])
def test_rim_settings_are_checked(changes):
    with pytest.raises(ConfigError, match="CutRims"):
        DarcyanConfig().updated({"rims": changes})
