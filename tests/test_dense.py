"""Dense maps seeded by the sparse matches: accuracy on the synthetic figure, numbering, contracts."""

import csv
import dataclasses
import io
import warnings

import numpy as np
import pytest
from conftest import vts_truth

from darcyan import DarcyanConfig
from darcyan.cli import main
from darcyan.dense.config import DenseConfig
from darcyan.dense.landmarks import MAX_EXHAUSTIVE_LANDMARKS, consistent_landmarks
from darcyan.dense.maps import UNMAPPED, dense_map, dense_map_to_csv
from darcyan.errors import ConfigError, DarcyanError
from darcyan.eval.dense_scores import evaluate_dense
from darcyan.eval.metrics import GroundTruth
from darcyan.geometry import synthetic
from darcyan.geometry.mesh import Mesh
from darcyan.io.mesh_files import load_mesh, save_mesh
from darcyan.method.pipeline import Correspondence, analyze_mesh, match_shapes

# A lighter dense stage than the default, so the tests take seconds (same method).
FAST = DenseConfig(zoomout_samples=1000, basis_size=40)
SCORED = 300  # source vertices scored per map
# Measured on figure pose 0 -> 1 with FAST: 1.000 within 0.05, mean error 0.007 (the default
# DenseConfig: 1.000 and 0.005); the floors leave a margin.
MIN_RATE, MAX_MEAN = 0.9, 0.02


@pytest.fixture(scope="module")
def figure_pair():
    config = DarcyanConfig()
    shape_1, shape_2 = (analyze_mesh(synthetic.figure(pose), config) for pose in (0, 1))
    return shape_1, shape_2, match_shapes(shape_1, shape_2, config)


def tip_correspondence(source_tips, target_tips):
    n = len(source_tips)
    return Correspondence(np.asarray(source_tips), np.asarray(target_tips), np.zeros(n), None)


@pytest.mark.slow
def test_dense_map_on_the_figure_is_mostly_within_the_threshold(figure_pair):
    shape_1, shape_2, matches = figure_pair
    result = dense_map(shape_1, shape_2, matches, FAST)
    n = synthetic.figure(0).n_vertices
    assert result.target.shape == (n,) and result.target.dtype == np.int64
    assert result.target.min() >= 0 and result.target.max() < n
    assert len(result.landmarks) >= 3 and set(result.timings) == {"landmarks", "basis", "zoomout"}
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, sample=SCORED, target_solver=shape_2.solver)
    assert len(score.errors) == SCORED
    assert score.rate >= MIN_RATE and score.mean <= MAX_MEAN
    assert score.curve()[-1] == 1.0  # every sampled vertex lands within 0.25 sqrt(area)


def test_a_wrong_match_is_left_out_of_the_landmarks(figure_pair):
    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()
    wrong_target = np.concatenate([tips, [tips[0]]])  # a sixth match: tip 3 -> tip 0
    wrong_source = np.concatenate([tips, [tips[3]]])
    result = dense_map(shape_1, shape_2, tip_correspondence(wrong_source, wrong_target), FAST)
    assert sorted(map(tuple, result.landmarks.tolist())) == sorted(zip(tips.tolist(), tips.tolist()))


@pytest.mark.slow
def test_an_alternative_with_the_same_landmarks_is_not_a_rival_seed(figure_pair):
    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()
    right = tip_correspondence(tips, tips)
    # the same matches plus one that the consistency test drops (tip 3 -> tip 0), reordered
    same = tip_correspondence(np.concatenate([tips[::-1], [tips[3]]]), np.concatenate([tips[::-1], [tips[0]]]))
    swapped = tip_correspondence(tips, np.roll(tips, 1))  # other landmarks: a seed of its own
    result = dense_map(shape_1, shape_2, dataclasses.replace(right, alternatives=(same, swapped)), FAST)
    assert result.check["seeds"] == 2 and sorted(result.check["signatures"]) == [0, 2]
    assert result.check["seed"] == 0 and result.check["clear"]


@pytest.mark.slow
def test_landmarks_decide_the_map(figure_pair):
    """Matching every tip to the wrong tip gives a wrong map: the landmarks are what it follows."""
    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()
    rolled = tip_correspondence(tips, np.roll(tips, 1))
    result = dense_map(shape_1, shape_2, rolled, dataclasses.replace(FAST, landmarks="all"))
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, sample=SCORED, target_solver=shape_2.solver)
    assert score.rate < 0.5


@pytest.mark.slow
def test_input_numbering_and_left_out_vertices():
    """A renumbered target and a source with a stray component: the map speaks the files' numbering."""
    config = DarcyanConfig()
    pose_0, pose_1 = synthetic.figure(0), synthetic.figure(1)
    n = pose_0.n_vertices
    # Source: the figure plus a small tetrahedron far away (left out by preparation).
    tet_v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * 0.1 + 10.0
    tet_f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]) + n
    source = Mesh(np.vstack([pose_0.vertices, tet_v]), np.vstack([pose_0.faces, tet_f]), "figure+tet")
    # Target: pose 1 with its vertices renumbered: new vertex i is old vertex perm[i].
    perm = np.random.default_rng(3).permutation(n)
    new_index = np.argsort(perm)
    target = Mesh(pose_1.vertices[perm], new_index[pose_1.faces], "figure1-renumbered")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        shape_1 = analyze_mesh(source, config)
    shape_2 = analyze_mesh(target, config)
    result = dense_map(shape_1, shape_2, match_shapes(shape_1, shape_2, config), FAST)
    assert result.target.shape == (n + 4,)
    assert np.all(result.target[n:] == UNMAPPED) and np.all(result.target[:n] >= 0)
    truth = GroundTruth(np.arange(n), new_index)  # source vertex v is target vertex new_index[v]
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, truth, sample=SCORED,
                           target_solver=shape_2.solver)
    assert score.rate >= MIN_RATE and score.mean <= MAX_MEAN
    # Read in the wrong numbering, the same map is mostly wrong: the test can tell.
    wrong = evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, GroundTruth(), sample=SCORED,
                           target_solver=shape_2.solver)
    assert wrong.rate < 0.2


@pytest.mark.slow
def test_a_renumbered_target_gets_the_same_map(figure_pair):
    """Farthest-point ZoomOut samples depend on where the vertices are, not on their numbering:
    the map to a renumbered copy of the target is the map to the target, renumbered (a random
    draw of samples changes a fifth of it)."""
    config = DarcyanConfig()
    shape_1, shape_2, matches = figure_pair
    pose_1 = synthetic.figure(1)
    perm = np.random.default_rng(3).permutation(pose_1.n_vertices)  # new vertex i is old vertex perm[i]
    renumbered = analyze_mesh(Mesh(pose_1.vertices[perm], np.argsort(perm)[pose_1.faces], "figure1-renumbered"),
                              config)
    renumbered_matches = match_shapes(shape_1, renumbered, config)
    assert np.array_equal(perm[renumbered_matches.target_vertex], matches.target_vertex)
    agreement = {}
    for sampling in ("farthest", "random"):
        dense = dataclasses.replace(FAST, sampling=sampling)
        direct = dense_map(shape_1, shape_2, matches, dense).target
        agreement[sampling] = float((perm[dense_map(shape_1, renumbered, renumbered_matches, dense).target]
                                     == direct).mean())
    assert agreement["farthest"] >= 0.99 and agreement["random"] < 0.95, agreement


def test_evaluate_dense_identity_and_shift(figure_pair):
    shape_1, shape_2, _ = figure_pair
    n = shape_1.n_input_vertices
    exact = evaluate_dense(shape_1.mesh, shape_2.mesh, np.arange(n), sample=50, target_solver=shape_2.solver)
    assert exact.rate == 1.0 and exact.mean == 0.0
    again = evaluate_dense(shape_1.mesh, shape_2.mesh, np.arange(n), sample=50, target_solver=shape_2.solver)
    assert np.array_equal(exact.source_vertices, again.source_vertices)  # a fixed sample
    far = np.full(n, int(synthetic.figure_tips()[0]))  # everything to one tip
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, far, sample=50, target_solver=shape_2.solver)
    assert score.rate < 0.2 and score.mean > 0.1


def test_consistent_landmarks_keeps_the_largest_agreeing_set():
    # Four points on a line at 0, 1, 2, 4; the fourth match lands at 9 on the target.
    x1, x2 = np.array([0.0, 1, 2, 4]), np.array([0.0, 1, 2, 9])
    d1, d2 = np.abs(x1[:, None] - x1), np.abs(x2[:, None] - x2)
    assert consistent_landmarks(d1, d2, 0.1, 0.0).tolist() == [0, 1, 2]
    assert consistent_landmarks(d1, d1, 0.1, 0.0).tolist() == [0, 1, 2, 3]
    assert len(consistent_landmarks(np.zeros((0, 0)), np.zeros((0, 0)), 0.1, 0.0)) == 0
    # Above the exhaustive limit, the greedy search drops the one disagreeing match too.
    x1 = np.arange(MAX_EXHAUSTIVE_LANDMARKS + 6, dtype=float)
    x2 = x1.copy()
    x2[7] = 1000.0
    d1, d2 = np.abs(x1[:, None] - x1), np.abs(x2[:, None] - x2)
    assert consistent_landmarks(d1, d2, 0.1, 0.0).tolist() == [i for i in range(len(x1)) if i != 7]


def test_errors_name_the_problem(figure_pair):
    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()
    with pytest.raises(DarcyanError, match="at least 3"):
        dense_map(shape_1, shape_2, tip_correspondence(tips[:2], tips[:2]), FAST)
    record = dataclasses.replace(shape_1.description, name="cached.off")  # as read from the cache
    with pytest.raises(DarcyanError, match="cached.off.*prepared shapes"):
        dense_map(record, shape_2, tip_correspondence(tips, tips), FAST)
    with pytest.raises(ConfigError, match="landmarks"):
        DenseConfig(landmarks="some")
    with pytest.raises(ConfigError, match="basis_start"):
        DenseConfig(basis_start=50, basis_size=20)


def test_dense_csv_format():
    assert dense_map_to_csv(np.array([2, 0, -1])) == "source_vertex,target_vertex\n0,2\n1,0\n2,-1\n"


@pytest.fixture
def small_pose_files(tmp_path, monkeypatch):
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))
    paths = []
    for pose in (0, 1):
        path = tmp_path / f"figure{pose}.off"
        save_mesh(synthetic.figure(pose, subdivisions=4), path)
        paths.append(path)
    return paths


@pytest.mark.slow
def test_cli_dense_writes_one_row_per_source_vertex(small_pose_files, tmp_path, capsys):
    out_file = tmp_path / "map.csv"
    code = main(["match", *map(str, small_pose_files), "--dense", "-o", str(out_file)])
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(out_file.read_text())))
    n = synthetic.figure(0, subdivisions=4).n_vertices
    assert list(rows[0]) == ["source_vertex", "target_vertex"] and len(rows) == n
    source = np.array([int(r["source_vertex"]) for r in rows])
    target = np.array([int(r["target_vertex"]) for r in rows])
    assert np.array_equal(source, np.arange(n)) and target.min() >= 0 and target.max() < n
    # Pose 0 -> 1 shares the numbering: the map is mostly right (identity truth).
    shape_1, shape_2 = (analyze_mesh(synthetic.figure(p, subdivisions=4), DarcyanConfig()) for p in (0, 1))
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, target, sample=SCORED, target_solver=shape_2.solver)
    assert score.rate >= MIN_RATE
    # Without --dense, the sparse contract is unchanged.
    assert main(["match", *map(str, small_pose_files), "--no-cache"]) == 0
    assert capsys.readouterr().out.splitlines()[0] == "source_vertex,target_vertex,distance"


@pytest.mark.slow
def test_cli_verify_writes_the_verified_matches(small_pose_files, tmp_path, capsys):
    source, target = small_pose_files
    out = tmp_path / "m.csv"
    assert main(["match", str(source), str(target), "--verify", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "verified:" in err  # the verdict, on stderr even when it keeps the feature matches
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert rows and set(rows[0]) == {"source_vertex", "target_vertex", "distance"}


def test_cli_dense_error_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    assert main(["match", str(bad), str(bad), "--dense"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("darcyan: error:") and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_pyfm_method_with_darcyan_landmarks():
    """Approach (a): pyFM's functional map with the matches as landmarks, refined by its ZoomOut.

    Measured on the 2,562-vertex figure, pose 0 -> 1: 1.000 within 0.05, mean error 0.0024."""
    pytest.importorskip("pyFM", reason="pyfmaps is not installed (pip install 'darcyan[pyfm]')")
    config = DarcyanConfig()
    shape_1, shape_2 = (analyze_mesh(synthetic.figure(p, subdivisions=4), config) for p in (0, 1))
    result = dense_map(shape_1, shape_2, match_shapes(shape_1, shape_2, config), DenseConfig(method="pyfm"))
    assert result.target.shape == (shape_1.n_input_vertices,) and "pyfm" in result.timings
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, sample=SCORED, target_solver=shape_2.solver)
    assert score.rate >= MIN_RATE and score.mean <= MAX_MEAN


# ---------------------------------------------------------------------------------------------
# Orientation coordinates: which way a vertex turns from one landmark to another


def _disc_shape():
    from darcyan.geometry.shape import prepare_shape

    return prepare_shape(synthetic.flat_disc(radius=1.0, rings=30))


def test_orientation_coordinates_are_the_area_weighted_sines_of_numpys_cross_products(figure_poses):
    """The same bits as the definition written with numpy.cross (the function spells the cross
    product out for speed), with the shape's kept face frame or without one."""
    import types

    from darcyan.dense.landmarks import orientation_coordinates
    from darcyan.geometry.operators import face_gradients
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    rng = np.random.default_rng(3)
    fields = np.stack([shape.solver.distance(v) for v in rng.choice(shape.n_vertices, 4, replace=False)], axis=1)
    others = rng.normal(size=(shape.n_vertices, 2)).cumsum(axis=0)
    v, f = shape.mesh.vertices, shape.mesh.faces
    normal = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(normal, axis=1)
    unit = normal / area[:, None]
    for extra in (None, others):
        both = fields if extra is None else np.hstack([fields, extra])
        a, b = np.triu_indices(4, k=1) if extra is None else (np.repeat(np.arange(4), 2), 4 + np.tile(np.arange(2), 4))
        grads = face_gradients(shape.mesh, both)
        norm = np.linalg.norm(grads, axis=1)
        sine = (np.einsum("mi,mip->mp", unit, np.cross(grads[:, :, a], grads[:, :, b], axis=1))
                / np.maximum(norm[:, a] * norm[:, b], 1e-12))
        expected = np.zeros((shape.n_vertices, sine.shape[1]))
        weight = np.zeros(shape.n_vertices)
        for corner in range(3):
            np.add.at(expected, f[:, corner], area[:, None] * sine)
            np.add.at(weight, f[:, corner], area)
        expected /= weight[:, None]
        for holder in (shape, types.SimpleNamespace(mesh=shape.mesh)):
            got = orientation_coordinates(holder, fields, extra)
            assert got.shape == expected.shape
            np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
        assert np.array_equal(orientation_coordinates(shape, fields, extra),
                              orientation_coordinates(types.SimpleNamespace(mesh=shape.mesh), fields, extra))


def test_orientation_coordinates_on_a_plane_are_the_sine_between_the_landmark_directions():
    # On a plane the distance to a point grows along the direction away from it, so the turn from
    # landmark a's gradient to landmark b's about the normal is sin of the angle between x - a and
    # x - b: positive on one side of the line ab, negative on the other (analytic, not the code's).
    from darcyan.dense.landmarks import orientation_coordinates

    shape = _disc_shape()
    v = shape.mesh.vertices
    a, b = int(np.argmin(np.linalg.norm(v - [-0.3, 0, 0], axis=1))), int(np.argmin(np.linalg.norm(v - [0.3, 0, 0], axis=1)))
    fields = np.stack([shape.solver.distance(a), shape.solver.distance(b)], axis=1)
    turns = orientation_coordinates(shape, fields)[:, 0]
    da, db = v - v[a], v - v[b]
    normal = shape.normals.mean(axis=0) / np.linalg.norm(shape.normals.mean(axis=0))
    expected = np.cross(da, db) @ normal / (np.linalg.norm(da, axis=1) * np.linalg.norm(db, axis=1) + 1e-12)
    away = (np.linalg.norm(da, axis=1) > 0.15) & (np.linalg.norm(db, axis=1) > 0.15) & \
        (np.linalg.norm(v[:, :2], axis=1) < 0.8 * np.abs(v[:, :2]).max())
    error = np.abs(turns[away] - expected[away])  # fast marching's gradients: a few % off
    assert np.median(error) < 0.03 and np.quantile(error, 0.95) < 0.1
    assert (np.sign(turns[away & (np.abs(expected) > 0.2)]) == np.sign(expected[away & (np.abs(expected) > 0.2)])).all()


def test_turns_to_other_fields_on_a_plane_are_the_sine_from_the_landmark_direction():
    # The distance to a grows along (x - a) / |x - a|, the field y along (0, 1, 0): the turn from
    # the first to the second about the normal is the sine of the angle between them.
    from darcyan.dense.landmarks import orientation_coordinates

    shape = _disc_shape()
    v = shape.mesh.vertices
    a = int(np.argmin(np.linalg.norm(v - [-0.3, 0.1, 0], axis=1)))
    turns = orientation_coordinates(shape, shape.solver.distance(a)[:, None], v[:, 1:2])
    assert turns.shape == (shape.n_vertices, 1)
    da = v - v[a]
    normal = shape.normals.mean(axis=0) / np.linalg.norm(shape.normals.mean(axis=0))
    expected = np.cross(da, [0.0, 1.0, 0.0]) @ normal / (np.linalg.norm(da, axis=1) + 1e-12)
    away = (np.linalg.norm(da, axis=1) > 0.15) & (np.linalg.norm(v[:, :2], axis=1) < 0.8 * np.abs(v[:, :2]).max())
    error = np.abs(turns[away, 0] - expected[away])
    assert np.median(error) < 0.03 and np.quantile(error, 0.95) < 0.1


def test_turns_to_other_fields_are_the_pairwise_turns_in_the_documented_columns(figure_poses):
    from darcyan.dense.landmarks import orientation_coordinates
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    fields = np.stack([shape.solver.distance(int(t)) for t in synthetic.figure_tips()[:5]], axis=1)
    pairwise = orientation_coordinates(shape, fields)  # columns: pairs a < b in triu order
    pairs = list(zip(*np.triu_indices(5, k=1)))
    crossed = orientation_coordinates(shape, fields[:, :2], fields[:, 2:])  # column a * 3 + b: field a to other b
    for a in range(2):
        for b in range(3):
            assert np.allclose(crossed[:, a * 3 + b], pairwise[:, pairs.index((a, 2 + b))])


def _moved_and_mirrored_tip_fields(mesh, seed: int):
    """``[(name, shape, fields)]`` for ``mesh`` as is, moved rigidly (a seeded rotation and a shift)
    and mirrored: each prepared, with its distances ``(n, 3)`` to three of the figure's tips."""
    from darcyan.geometry.shape import prepare_shape

    rotation, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    copies = {"as is": mesh, "moved": Mesh(mesh.vertices @ rotation.T + 5.0, mesh.faces),
              "mirrored": Mesh(mesh.vertices * [-1, 1, 1], mesh.faces[:, ::-1])}
    tips = synthetic.figure_tips()[:3]
    out = []
    for name, copy in copies.items():
        shape = prepare_shape(copy)
        out.append((name, shape, np.stack([shape.solver.distance(int(t)) for t in tips], axis=1)))
    return out


def test_signature_turns_flip_in_a_mirror_stay_under_rigid_motion_and_scale_with_the_weight(figure_poses):
    from darcyan.dense.signatures import point_signature, signature_turn_coordinates

    turns = {}
    for name, shape, fields in _moved_and_mirrored_tip_fields(figure_poses[0], seed=4):
        turns[name] = signature_turn_coordinates(shape, shape, DenseConfig(signature_turns=2.0), fields, fields)[0]
        if name == "as is":
            once = signature_turn_coordinates(shape, shape, DenseConfig(signature_turns=1.0), fields, fields)[0]
            assert turns[name].shape == (shape.n_vertices, 3 * len(point_signature(shape, DenseConfig())[0]))
            assert np.allclose(turns[name], 2.0 * once)
            assert signature_turn_coordinates(shape, shape, DenseConfig(signature_turns=0), fields, fields) == (None, None)
    assert np.abs(turns["as is"]).max() > 0.5  # not vacuous: the turns are not all zero
    assert np.allclose(turns["moved"], turns["as is"], atol=1e-6)
    assert np.allclose(turns["mirrored"], -turns["as is"], atol=1e-6)
    with pytest.raises(ConfigError, match="signature_turns"):
        DenseConfig(signature_turns=-1)


def test_orientation_coordinates_flip_in_a_mirror_and_stay_under_rigid_motion(figure_poses):
    from darcyan.dense.landmarks import orientation_coordinates

    turns = {name: orientation_coordinates(shape, fields)
             for name, shape, fields in _moved_and_mirrored_tip_fields(figure_poses[0], seed=3)}
    assert np.allclose(turns["moved"], turns["as is"], atol=1e-6)
    assert np.allclose(turns["mirrored"], -turns["as is"], atol=1e-6)


def _faust_pair(faust, source: str, target: str):
    """Two FAUST shapes prepared, their default matches and the .vts ground truth between them."""
    from darcyan.method.pipeline import describe_shape, load_shape

    config = DarcyanConfig()
    files = faust / f"{source}.off", faust / f"{target}.off"
    correspondence = match_shapes(*[describe_shape(f, config) for f in files], config)
    return [load_shape(f, config, warn=False) for f in files], correspondence, vts_truth(faust, source, target)


@pytest.mark.slow
def test_a_person_front_and_back_are_not_swapped(faust):
    # FAUST person 2, poses 3 -> 8: with distances to the five landmarks alone the dense map put
    # the front of the body on its back over a third of it (0.42 of the vertices within 0.05,
    # orientation check -0.5); the turns between landmarks hold it (0.97, check > 0.8), and so do
    # the turns from the landmark directions to the curvature's alone (a reflection flips both).
    shapes, correspondence, truth = _faust_pair(faust, "tr_reg_023", "tr_reg_028")
    distances_only = DenseConfig(orientation_weight=0, landmark_weight=0, signature_turns=0)
    maps = {"turns": dense_map(*shapes, correspondence),
            "distances only": dense_map(*shapes, correspondence, distances_only),
            "signature turns": dense_map(*shapes, correspondence,
                                         dataclasses.replace(distances_only, signature_turns=2.0))}
    scores = {name: evaluate_dense(shapes[0].mesh, shapes[1].mesh, m.target, truth, target_solver=shapes[1].solver)
              for name, m in maps.items()}
    assert scores["turns"].rate >= 0.9 and scores["turns"].mean <= 0.025
    assert maps["turns"].check["orientation"] > 0.7
    assert scores["signature turns"].rate >= 0.9
    # the check sees the flip of the distances-only map
    assert scores["distances only"].rate < 0.6 and maps["distances only"].check["orientation"] < 0


@pytest.mark.slow
def test_a_mirrored_seed_is_replaced_by_the_alternative_that_keeps_the_body(faust):
    # FAUST person 3, poses 2 -> 3: the sparse stage swaps a hand and a foot (3 of 5 right); the
    # map it seeds keeps the swapped landmarks' orientation by turning the body round (~1% within
    # 0.05). Its alternatives include the right matching, whose first map keeps the curvature
    # signature (face, chest) better: the dense map takes it. (Measured: 0.29 within 0.05 seeded by
    # the sparse matches, 0.94 by the alternative.)
    shapes, correspondence, truth = _faust_pair(faust, "tr_reg_032", "tr_reg_033")
    assert correspondence.alternatives  # the orientation test weighed others
    maps = {"seeds": dense_map(*shapes, correspondence),
            "sparse only": dense_map(*shapes, correspondence, DenseConfig(candidates=1))}
    scores = {name: evaluate_dense(shapes[0].mesh, shapes[1].mesh, m.target, truth, target_solver=shapes[1].solver)
              for name, m in maps.items()}
    assert scores["sparse only"].rate < 0.5  # the case is still what it was
    assert maps["seeds"].check["seed"] > 0 and maps["sparse only"].check["seed"] == 0
    assert scores["seeds"].rate >= 0.9 and scores["seeds"].mean <= 0.03
    assert maps["seeds"].check["signature"] < maps["seeds"].check["runner_up"]
    # the scores the map chose by, without making it
    from darcyan.dense import seed_scores

    assert seed_scores(*shapes, correspondence) == maps["seeds"].check["signatures"]
    # the same choice as sparse matches: all right, where the sparse stage's were not
    from darcyan.dense import verified_matches
    from darcyan.eval.metrics import score_matches

    verified, about = verified_matches(*shapes, correspondence)
    assert about["seed"] == maps["seeds"].check["seed"]
    # scored on a spectrum of the short ZoomOuts' size: the same scores within a percent
    assert about["signatures"].keys() == maps["seeds"].check["signatures"].keys()
    for rank, score in maps["seeds"].check["signatures"].items():
        assert about["signatures"][rank] == pytest.approx(score, rel=0.01)
    # on the dense map's own basis (before a dense map): its scores exactly
    on_full_basis = verified_matches(*shapes, correspondence, full_basis=True)[1]
    assert on_full_basis["signatures"] == maps["seeds"].check["signatures"]
    before, after = score_matches(*shapes, correspondence, truth), score_matches(*shapes, verified, truth)
    assert before.correct < len(correspondence) and after.correct == len(verified) >= 5
    assert any(m is correspondence for m in verified.alternatives)  # the sparse matching stays an alternative


def test_merged_zoomout_terms_measure_the_same_distances():
    # The bijectivity and orthogonality terms share one block of columns and one extra column:
    # squared distances between the embeddings must equal the sum of the four terms.
    from darcyan.dense.zoomout import map_embeddings

    rng = np.random.default_rng(0)
    b_a, b_b = rng.normal(size=(40, 12)), rng.normal(size=(50, 12))
    c_ab, c_ba = rng.normal(size=(12, 12)), rng.normal(size=(12, 12))
    f_a, f_b = rng.normal(size=(40, 4)), rng.normal(size=(50, 4))
    for config in (DenseConfig(), DenseConfig(bijectivity=0.5, orthogonality=2.0), DenseConfig(bijectivity=0.0)):
        q, r = map_embeddings(b_a, b_b, c_ab, c_ba, config, f_a, f_b)
        got = ((q[:, None] - r[None]) ** 2).sum(-1)

        def term(x, y):
            return ((x[:, None] - y[None]) ** 2).sum(-1)

        want = (term(b_a @ c_ab, b_b) + config.bijectivity**2 * term(b_a, b_b @ c_ba)
                + config.orthogonality**2 * term(b_a, b_b @ c_ab.T) + config.landmark_weight**2 * term(f_a, f_b))
        assert np.allclose(got, want, rtol=1e-10, atol=1e-9)


def test_rectangular_zoomout_terms_measure_the_same_distances():
    # With a margin the maps are (p, k): each term compares the columns the docstring names.
    from darcyan.dense.zoomout import map_embeddings

    rng = np.random.default_rng(1)
    p, k = 15, 12
    b_a, b_b = rng.normal(size=(40, 18)), rng.normal(size=(50, 18))
    c_ab, c_ba = rng.normal(size=(p, k)), rng.normal(size=(p, k))
    f_a, f_b = rng.normal(size=(40, 4)), rng.normal(size=(50, 4))
    config = DenseConfig(bijectivity=0.5, orthogonality=2.0)
    q, r = map_embeddings(b_a, b_b, c_ab, c_ba, config, f_a, f_b)

    def term(x, y):
        return ((x[:, None] - y[None]) ** 2).sum(-1)

    want = (term(b_a[:, :p] @ c_ab, b_b[:, :k]) + 0.25 * term(b_a[:, :k], b_b[:, :p] @ c_ba)
            + 4.0 * term(b_a[:, :k], b_b[:, :k] @ c_ab[:k].T) + config.landmark_weight**2 * term(f_a, f_b))
    assert np.allclose(((q[:, None] - r[None]) ** 2).sum(-1), want, rtol=1e-10, atol=1e-9)


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
    dense_map(shape_1, shape_2, matches, FAST)
    want_1 = zoomout_module.dense_eigenvalues(shape_1.shape, FAST)
    want_2 = zoomout_module.dense_eigenvalues(shape_2.shape, FAST)
    assert seen and all(a is want_1 and b is want_2 or a is want_2 and b is want_1 for a, b in seen)
    seen.clear()
    dense_map(shape_1, shape_2, matches, dataclasses.replace(FAST, commutativity=0.0))
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


def test_dense_config_rejects_a_bad_commutativity():
    for bad in (-1.0, float("nan"), True, "3"):
        with pytest.raises(ConfigError, match="dense: commutativity must be non-negative"):
            DenseConfig(commutativity=bad)


def test_dense_config_rejects_a_bad_margin():
    for bad in (dict(basis_margin=-1), dict(margin_from=2.5), dict(basis_margin="10")):
        with pytest.raises(ConfigError, match=f"dense: {next(iter(bad))} must be a non-negative integer"):
            DenseConfig(**bad)


def test_dense_config_rejects_bad_seed_settings():
    with pytest.raises(ConfigError, match="candidates"):
        DenseConfig(candidates=0)
    with pytest.raises(ConfigError, match="signature_lengths"):
        DenseConfig(signature_lengths=(0.1, -1))
    with pytest.raises(ConfigError, match="trust_orientation"):
        DenseConfig(trust_orientation=2)
    with pytest.raises(ConfigError, match="signature_lengths"):
        DenseConfig(signature_lengths=(True,))
    with pytest.raises(ConfigError, match="seed_margin"):
        DenseConfig(seed_margin=1.0)
    assert DenseConfig(signature_lengths=[0.1]).signature_lengths == (0.1,)


def test_functional_map_fits_equal_least_squares_with_fewer_samples_than_columns_too():
    from darcyan.dense.zoomout import _Fitter

    rng = np.random.default_rng(2)
    for samples in (40, 6):  # QR once; fewer samples than columns: least squares each time
        basis, mapped = rng.normal(size=(samples, 10)), rng.normal(size=(samples, 7))
        expected = np.linalg.lstsq(basis[:, :7], mapped, rcond=None)[0]
        assert np.allclose(_Fitter(basis).fit(mapped), expected, atol=1e-10)
        wider = np.linalg.lstsq(basis[:, :9], mapped, rcond=None)[0]  # a margin: (9, 7)
        assert np.allclose(_Fitter(basis).fit(mapped, 9), wider, atol=1e-10)


def test_landmark_coordinates_follow_the_vertices_of_a_moved_and_renumbered_copy(figure_poses):
    from darcyan.dense.landmarks import landmark_coordinates
    from darcyan.geometry.shape import prepare_shape

    mesh = figure_poses[0]
    order = np.random.default_rng(5).permutation(mesh.n_vertices)  # copy vertex i is mesh vertex order[i]
    rotation, _ = np.linalg.qr(np.random.default_rng(6).normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    position = np.argsort(order)  # mesh vertex v is copy vertex position[v]
    copy = Mesh(mesh.vertices[order] @ rotation.T - 2.0, position[mesh.faces])
    tips = np.asarray(synthetic.figure_tips())
    shape_1, shape_2 = prepare_shape(mesh), prepare_shape(copy)
    coords_1, coords_2 = landmark_coordinates(shape_1, shape_2, tip_correspondence(tips, position[tips]))
    assert coords_1.shape == (mesh.n_vertices, len(tips) + len(tips) * (len(tips) - 1) // 2)
    assert np.allclose(coords_2[position], coords_1, atol=1e-6)
    with pytest.raises(DarcyanError, match="fewer than 3 consistent"):
        landmark_coordinates(shape_1, shape_2, tip_correspondence(tips[:2], position[tips[:2]]))


@pytest.mark.slow
def test_a_matching_in_doubt_is_verified_by_default(faust, tmp_path, monkeypatch, capsys):
    """tr_reg_016 -> tr_reg_049 (two people): the orientation test prefers a mirrored matching
    by a margin of 0.05 (1 of 5 matches right by the vts ground truth); in doubt, the short dense
    maps choose the right one (5 of 5). --no-verify keeps the test's choice."""
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))
    source, target = faust / "tr_reg_016.off", faust / "tr_reg_049.off"
    truth = f"{faust / 'corres' / 'tr_reg_016.vts'},{faust / 'corres' / 'tr_reg_049.vts'}"
    config = DarcyanConfig()
    first, second = (analyze_mesh(load_mesh(p), config) for p in (source, target))
    correspondence = match_shapes(first, second, config)
    assert correspondence.in_doubt and correspondence.margin < config.mirror.verify_below
    never = config.replace(mirror=dataclasses.replace(config.mirror, verify_below=0.0))
    assert not match_shapes(first, second, never).in_doubt
    for flag, correct, name in (([], "5 of 5", "verified"), (["--no-verify"], "1 of 5", "unverified")):
        assert main(["match", str(source), str(target), "--truth", truth, "-o", str(tmp_path / f"{name}.csv"),
                     *flag]) == 0
        err = capsys.readouterr().err
        assert f"{correct} matches correct" in err
        assert ("verified (in doubt" in err) == (not flag)
    # Again: the verification's outcome comes from the cache, no shape is prepared, the same matches.
    monkeypatch.setattr("darcyan.method.pipeline.load_shape", lambda *a, **k: pytest.fail("a shape was prepared"))
    assert main(["match", str(source), str(target), "-o", str(tmp_path / "again.csv")]) == 0
    assert "verified (in doubt: the orientation test's margin 0.05 < 0.25) (cached)" in capsys.readouterr().err
    again = (tmp_path / "again.csv").read_text()
    assert again == (tmp_path / "verified.csv").read_text() != (tmp_path / "unverified.csv").read_text()
    with pytest.raises(SystemExit) as stop:  # argparse's usage error
        main(["match", str(source), str(target), "--verify", "--no-verify"])
    assert stop.value.code == 2 and "not allowed with" in capsys.readouterr().err


@pytest.mark.slow
def test_coarse_coordinates_steer_only_the_zoomout_steps_up_to_signature_until(figure_poses):
    # A renumbered copy: the true map is known. ZoomOut from a random first map cannot find it
    # with 20 eigenfunctions alone; coordinates that correspond (here the positions), in the
    # coarse steps, lead it there; and steps above signature_until ignore them exactly.
    from darcyan.dense.zoomout import map_embeddings, zoomout
    from darcyan.geometry.knn import nearest_rows
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
        q, r = map_embeddings(basis_1, basis_2, c_12, c_21, config)
        image = nearest_rows(r, q)
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


def test_signature_coordinates_have_the_configured_spread(figure_poses):
    from darcyan.dense.signatures import point_signature, signature_coordinates
    from darcyan.geometry.shape import prepare_shape

    shape_1, shape_2 = (prepare_shape(mesh) for mesh in figure_poses[:2])
    everywhere = np.arange(shape_1.n_vertices), np.arange(shape_2.n_vertices)
    config = DenseConfig(signature_weight=2.0)
    coarse_1, coarse_2 = signature_coordinates(shape_1, shape_2, config, *everywhere)
    assert np.allclose(np.concatenate([coarse_1, coarse_2]).std(axis=0), 2.0)
    ratio = coarse_1 / point_signature(shape_1, config)  # each length scaled by one number
    assert np.allclose(ratio, ratio[0], rtol=1e-9)
    assert signature_coordinates(shape_1, shape_2, DenseConfig(signature_weight=0), *everywhere) == (None, None)
    with pytest.raises(ConfigError, match="signature_weight"):
        DenseConfig(signature_weight=-1)
    with pytest.raises(ConfigError, match="signature_until"):
        DenseConfig(signature_until=-1)


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


@pytest.mark.slow
def test_an_ensemble_maps_the_figure_at_least_as_well_as_one_run(figure_pair):
    shape_1, shape_2, matches = figure_pair
    one = dense_map(shape_1, shape_2, matches, FAST)
    three = dense_map(shape_1, shape_2, matches, dataclasses.replace(FAST, ensemble=3))
    scores = [evaluate_dense(shape_1.mesh, shape_2.mesh, m.target, sample=SCORED, target_solver=shape_2.solver)
              for m in (one, three)]
    assert scores[1].rate >= MIN_RATE and scores[1].mean <= MAX_MEAN
    assert scores[1].mean <= scores[0].mean * 1.05
    assert not np.array_equal(one.target, three.target)  # the other members took part
    # Fewer than three members, or every vertex in each run: one run, the same map byte for byte.
    two = dense_map(shape_1, shape_2, matches, dataclasses.replace(FAST, ensemble=2))
    assert np.array_equal(two.target, one.target)
    everywhere = dataclasses.replace(FAST, zoomout_samples=0, basis_size=20)
    assert np.array_equal(dense_map(shape_1, shape_2, matches, dataclasses.replace(everywhere, ensemble=3)).target,
                          dense_map(shape_1, shape_2, matches, everywhere).target)


def test_cli_ensemble_is_checked_before_any_work(small_pose_files, tmp_path, monkeypatch, capsys):
    import darcyan.method.pipeline as pipeline

    def no_work(*args, **kwargs):
        raise AssertionError("shapes described before the options were checked")

    monkeypatch.setattr(pipeline, "describe_shapes", no_work)
    folder = tmp_path / "maps"
    assert main(["match", *map(str, small_pose_files), str(small_pose_files[1]), "--dense", "--ensemble", "0",
                 "-o", str(folder)]) != 0
    assert not folder.exists()
    capsys.readouterr()
    assert main(["match", *map(str, small_pose_files), "--dense", "--ensemble", "0", "--no-cache"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--ensemble" in err[0] and "ensemble must be a positive integer" in err[0]
    assert main(["match", *map(str, small_pose_files), "--ensemble", "3", "--no-cache"]) != 0
    assert "--dense maps only" in capsys.readouterr().err


def test_bad_sampling_is_a_config_error():
    with pytest.raises(ConfigError, match="sampling"):
        DenseConfig(sampling="poisson")


@pytest.mark.slow
def test_cli_farthest_sampling_maps_a_renumbered_file_alike(small_pose_files, tmp_path, capsys):
    source, target = small_pose_files
    pose_1 = load_mesh(target)
    perm = np.random.default_rng(8).permutation(pose_1.n_vertices)  # renumbered vertex i is vertex perm[i]
    renumbered = tmp_path / "figure1-renumbered.off"
    save_mesh(Mesh(pose_1.vertices[perm], np.argsort(perm)[pose_1.faces]), renumbered)
    maps = []
    for path in (target, renumbered):
        out = tmp_path / f"{path.stem}.csv"
        assert main(["match", str(source), str(path), "--dense", "--sampling", "farthest", "-o", str(out),
                     "--quiet"]) == 0
        maps.append(np.loadtxt(out, delimiter=",", skiprows=1, dtype=np.int64)[:, 1])
    assert np.array_equal(perm[maps[1]], maps[0])
    capsys.readouterr()
    assert main(["match", str(source), str(target), "--sampling", "farthest", "--no-cache"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--sampling applies to --dense maps only" in err[0]


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


def test_a_verification_is_kept_per_pair_of_files_and_settings(small_pose_files, tmp_path, monkeypatch):
    """The outcome read back from the cache is the one computed (seed, scores, the matching of
    that seed); other files, preparation, matchings or dense settings are verified anew."""
    import darcyan.dense.verify as verify_module
    from darcyan.dense.seeds import matching_of_seed
    from darcyan.io.cache import ShapeCache
    from darcyan.method.pipeline import describe_shapes, load_shape

    class Miss(Exception):
        pass

    config, cache = DarcyanConfig(), ShapeCache(tmp_path / "verify-cache")
    source, target = small_pose_files
    matched = match_shapes(*describe_shapes([source, target], config), config)
    others = (tip_correspondence([1, 2, 3], [1, 2, 3]), tip_correspondence([4, 5, 6], [4, 5, 6]))
    correspondence = dataclasses.replace(matched, alternatives=others)

    def verify(shapes, matching=correspondence, dense_config=DenseConfig(), files=(source, target), **changes):
        return verify_module.verified_file_matches(*files, matching, shapes, changes.get("config", config),
                                                   dense_config, changes.get("repair", False), cache,
                                                   full_basis=changes.get("full_basis", False))

    def refuse():
        raise Miss

    # computed once (a stand-in outcome choosing alternative 2), then read back without the shapes
    about = {"seed": 2, "seeds": 3, "signature": 0.5, "runner_up": 0.75, "signatures": {0: 0.75, 1: 0.8, 2: 0.5},
             "clear": True}
    monkeypatch.setattr(verify_module, "verified_matches",
                        lambda s1, s2, c, d, full: (matching_of_seed(c, 2), dict(about)))
    first, computed = verify(lambda: (None, None))
    monkeypatch.undo()
    again, cached = verify(refuse)
    assert not computed["cached"] and cached["cached"]
    assert {k: v for k, v in cached.items() if k != "cached"} == about
    assert again.source_vertex.tolist() == first.source_vertex.tolist() == [4, 5, 6]
    assert again.alternatives[0] is correspondence  # the sparse matching first among the others
    for changed in ({"dense_config": DenseConfig(seed_margin=0.1)}, {"files": (target, source)},
                    {"repair": True}, {"matching": matched}, {"full_basis": True},
                    {"config": config.replace(denoise_area_ratio=config.denoise_area_ratio + 0.1)}):
        with pytest.raises(Miss):
            verify(refuse, **changed)
    # a real verification of the figure pair is kept too
    shapes = [load_shape(p, config) for p in (source, target)]
    real, real_about = verify(lambda: shapes, matching=matched)
    assert verify(refuse, matching=matched)[1]["seed"] == real_about["seed"]


def test_the_matching_of_a_seed_keeps_the_others_as_alternatives():
    from darcyan.dense.seeds import matching_of_seed

    others = tuple(tip_correspondence([i], [i + 1]) for i in range(3))
    sparse = dataclasses.replace(tip_correspondence([9], [9]), alternatives=others)
    assert matching_of_seed(sparse, 0) is sparse
    chosen = matching_of_seed(sparse, 2)
    assert chosen.source_vertex.tolist() == [1] and chosen.alternatives == (sparse, others[0], others[2])
    with pytest.raises(DarcyanError, match="seed 4: the matching has 3 alternatives"):
        matching_of_seed(sparse, 4)
