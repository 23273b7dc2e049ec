"""Feature points at extremities known by construction."""

import numpy as np
import pytest

from darcyan import DarcyanConfig
from darcyan.errors import ConfigError
from darcyan.geometry import synthetic
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import normalize_mesh
from darcyan.geometry.operators import mixed_voronoi_area
from darcyan.geometry.repair import prepare_mesh
from darcyan.method.features import (
    FeaturePoints,
    average_geodesic_distance,
    extremities,
    heat_kernel_diagonal,
    sharpest_tips,
)


@pytest.mark.parametrize("pose", [0, 1, 2])
def test_figure_extremities_are_its_limb_tips(pose):
    mesh, _ = prepare_mesh(synthetic.figure(pose))
    mesh, _ = normalize_mesh(mesh)
    solver = GeodesicSolver(mesh)
    config = DarcyanConfig()
    agd = average_geodesic_distance(mesh, solver, config.agd_sources)
    features = extremities(mesh, solver, agd, config)
    tips = synthetic.figure_tips()
    assert len(features) == len(tips)
    # Each tip has exactly one feature point on it (the tip apex is a small cap: 0.03 sqrt(area)).
    dist = np.array([solver.distance(t)[features.vertices] for t in tips])
    assert (dist.min(axis=1) < 0.03).all()
    assert sorted(np.argmin(dist, axis=0)) == list(range(len(tips)))


def test_agd_is_close_to_exact_average_on_sphere(sphere):
    # On a sphere of radius r every point has mean geodesic distance pi * r / 2.
    mesh, _ = prepare_mesh(sphere)
    agd = average_geodesic_distance(mesh, GeodesicSolver(mesh), 16)
    np.testing.assert_allclose(agd.values, np.pi * 2.0 / 2, rtol=0.05)


def test_sphere_has_no_standing_out_extremity_beyond_noise(sphere):
    """Every point of a sphere is alike: the maxima found there are discretization noise, their
    AGD within 1% of the exact pi r / 2, and (the extremity rule) no two closer than the
    extremity radius, measured along exact great circles."""
    mesh, _ = prepare_mesh(sphere)
    mesh, _ = normalize_mesh(mesh)  # area 1: radius 1 / sqrt(4 pi)
    r = 1 / np.sqrt(4 * np.pi)
    solver = GeodesicSolver(mesh)
    config = DarcyanConfig()
    features = extremities(mesh, solver, average_geodesic_distance(mesh, solver, 16), config)
    assert len(features) >= 1
    np.testing.assert_allclose(features.agd, np.pi * r / 2, rtol=0.01)
    unit = mesh.vertices[features.vertices] / np.linalg.norm(mesh.vertices[features.vertices], axis=1, keepdims=True)
    arcs = r * np.arccos(np.clip(unit @ unit.T, -1, 1))
    assert (arcs[~np.eye(len(features), dtype=bool)] > config.extremity_radius).all()


# The figure's limbs, longest first (synthetic.LIMBS: 1.9, 1.7, 1.5, 1.3 and the head's 1.1): the
# farther a tip reaches, the larger its mean distance to the rest of the body.
LIMBS_BY_LENGTH = [int(i) for i in np.argsort([-limb.length for limb in synthetic.LIMBS], kind="stable")]


@pytest.mark.parametrize("pose", [0, 1, 2])
def test_max_features_keeps_the_tips_reaching_farthest(pose):
    """With a cap of k, the feature points are the tips of the k longest limbs (the two longest,
    1.9 and 1.7, nearly tie in AGD, so k starts at 2), which are also the k tips of largest
    exact AGD (the area-weighted mean of a whole distance field, no sampling, no smoothing)."""
    mesh, _ = normalize_mesh(prepare_mesh(synthetic.figure(pose))[0])
    solver = GeodesicSolver(mesh)
    config = DarcyanConfig()
    agd = average_geodesic_distance(mesh, solver, config.agd_sources)
    tips = synthetic.figure_tips()
    area = mixed_voronoi_area(mesh)
    exact = np.array([solver.distance(int(t)) @ area for t in tips]) / area.sum()
    for cap in (2, 3, 4):
        features = extremities(mesh, solver, agd, config.replace(max_features=cap))
        dist = np.array([solver.distance(int(t))[features.vertices] for t in tips])
        assert (dist.min(axis=0) < 0.03).all(), (cap, dist.min(axis=0))  # each on a tip
        on = sorted(np.argmin(dist, axis=0).tolist())
        assert on == sorted(LIMBS_BY_LENGTH[:cap]), (cap, on)
        assert on == sorted(np.argsort(-exact)[:cap].tolist()), (cap, on, exact)


def test_short_front_legs_of_the_hires_cat_are_extremities(tosca):
    """Diffusion lowers the AGD peak of a short limb most: in cat2 of tosca-hires one front paw's
    diffused AGD lies just below the median (0.523 against 0.527), and a floor at the median
    dropped that paw. The front paws, by the data: the lowest vertex of each side in the front
    40% of the standing pose cat0 (same vertex numbering in every pose)."""
    from darcyan import load_mesh
    from darcyan.method.pipeline import analyze_mesh

    standing = load_mesh(tosca / "tosca-hires" / "cat0.off").vertices
    front = standing[:, 1] < np.percentile(standing[:, 1], 40)
    paws = []
    for side in (standing[:, 0] < 0, standing[:, 0] > 0):
        candidates = np.flatnonzero(front & side)
        paws.append(int(candidates[np.argmin(standing[candidates, 2])]))
    description = analyze_mesh(load_mesh(tosca / "tosca-hires" / "cat2.off"))
    for paw in paws:
        analysed = int(np.flatnonzero(description.mesh.input_index == paw)[0])  # file -> analysed numbering
        to_features = description.solver.distance(analysed)[description.features.vertices]
        assert to_features.min() < 0.1, f"front paw vertex {paw}: nearest feature point at {to_features.min():.3f}"


def test_heat_kernel_diagonal_on_sphere_is_the_spherical_harmonics_sum(sphere):
    """On a sphere of area 1 (radius 1/sqrt(4 pi)) the eigenvalues are 4 pi l (l + 1), each
    2l + 1 times, and by symmetry k_t(x, x) = sum_l (2l + 1) exp(-4 pi l (l + 1) t) everywhere."""
    mesh, _ = prepare_mesh(sphere)
    mesh, _ = normalize_mesh(mesh)
    length = DarcyanConfig().agd_smoothing
    t = length**2 / 2
    degree = np.arange(200)
    exact = float(((2 * degree + 1) * np.exp(-4 * np.pi * degree * (degree + 1) * t)).sum())
    heat = heat_kernel_diagonal(mesh, length)
    np.testing.assert_allclose(heat, exact, rtol=0.02)
    assert heat.std() < 0.005 * heat.mean()


def _tips_case(**changes):
    """Two feature points 0 and 5 on a path of 8 vertices spaced 0.1 apart (distance fields by
    hand); AGD falls away from each, heat rises toward vertex 2 and toward vertex 7."""
    x = np.arange(8) * 0.1
    distances = {0: np.abs(x - x[0]), 5: np.abs(x - x[5])}
    values = np.array([1.00, 0.99, 0.98, 0.90, 0.95, 0.99, 0.985, 0.98])
    heat = np.array([1.0, 1.1, 1.3, 5.0, 1.0, 1.0, 1.05, 2.0])
    config = DarcyanConfig(extremity_radius=0.15, tip_radius=0.25, tip_agd_drop=0.03).replace(**changes)
    features = FeaturePoints(np.array([0, 5]), values[[0, 5]])
    return sharpest_tips(features, values, heat, distances, config)


def test_sharpest_tips_moves_to_the_clearly_sharper_vertex_of_the_top_only():
    # Feature 0: its top within 0.25 and 0.03 of its AGD is vertices 0-2 (vertex 3 is sharper but
    # lower): it moves to 2 (1.3 >= 1.1 x 1.0). Feature 5: its top 4-7 (vertex 7 at 0.2, AGD
    # 0.98): 2.0 >= 1.1, and 7 lies 0.7 from feature 0: it moves there.
    assert sorted(_tips_case().vertices.tolist()) == [2, 7]
    # Not sharper by the gain: both stay.
    assert sorted(_tips_case(tip_gain=2.5).vertices.tolist()) == [0, 5]
    # An AGD drop of 0.005 leaves vertex 7 (0.98 against 0.99) out of feature 5's top, whose
    # sharpest is then 6 (1.05 < 1.1), and feature 0's top is itself: both stay. With 0.015
    # feature 0's top is vertices 0 and 1 (1.1 >= 1.1 x 1.0): it moves to 1.
    assert sorted(_tips_case(tip_agd_drop=0.005).vertices.tolist()) == [0, 5]
    assert sorted(_tips_case(tip_agd_drop=0.015).vertices.tolist()) == [1, 7]


def test_sharpest_tips_does_not_move_a_point_onto_another_extremity():
    # With an extremity radius of 0.35, vertex 2 (0.3 from feature 5) counts as feature 5's
    # extremity: feature 0 stays; vertex 7 is 0.7 from feature 0: feature 5 still moves.
    assert sorted(_tips_case(extremity_radius=0.35).vertices.tolist()) == [0, 7]


@pytest.mark.parametrize("changes, message", [({"tip_gain": 0.5}, "tip_gain"), ({"tip_gain": -1}, "tip_gain"),
                                              ({"tip_radius": 0.0}, "tip_radius"),
                                              ({"tip_agd_drop": -0.01}, "tip_agd_drop")])
def test_tip_settings_are_checked(changes, message):
    with pytest.raises(ConfigError, match=message):
        DarcyanConfig(**changes)
    assert DarcyanConfig.paper().tip_gain == 0  # the paper's feature points are the AGD's maxima


@pytest.mark.slow
def test_cat_head_point_repeats_across_poses_on_its_nose(tosca, tmp_path):
    """tosca-5k cat: the diffused AGD's head maximum lies on an ear in some poses (1, 2, 4, 5)
    and on the nose in others (0, 3, 7, 8): the body stretches from pose to pose, and so does
    the AGD of its tips. Moved to the sharpest tip of the head, the feature points repeat."""
    from darcyan.bench.runner import run_bench

    pairs = tmp_path / "pairs.txt"
    pairs.write_text("cat1\tcat0\ncat2\tcat3\ncat4\tcat7\ncat5\tcat8\ncat0\tcat2\n")
    repeatability = {}
    for gain in (0.0, DarcyanConfig().tip_gain):
        result = run_bench(tosca / "tosca-5k", tmp_path / f"out{gain}", pairs_file=pairs, progress=False,
                           plots=False, config=DarcyanConfig(tip_gain=gain), no_cache=True)
        repeatability[gain] = result.results["methods"]["darcyan"]["overall"]["repeatability"]
    assert repeatability[0.0] < 0.9, repeatability
    assert repeatability[DarcyanConfig().tip_gain] >= 0.95, repeatability
