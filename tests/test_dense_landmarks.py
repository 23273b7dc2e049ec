"""Landmarks of a dense map (:mod:`darcyan.dense.landmarks`): the consistent set, the orientation
coordinates, the landmark coordinates."""

import functools

import numpy as np
import pytest
from conftest import moved_and_mirrored_tip_fields, tip_correspondence

from darcyan.config import DarcyanConfig
from darcyan.dense.landmarks import MAX_EXHAUSTIVE_LANDMARKS, consistent_landmarks
from darcyan.errors import DarcyanError
from darcyan.geometry import synthetic
from darcyan.geometry.mesh import Mesh


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


def test_orientation_coordinates_by_blocks_of_faces_are_the_same_bits(figure_poses, monkeypatch):
    import darcyan.dense.landmarks as landmarks
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    fields = np.stack([shape.solver.distance(v) for v in (0, 500, 1000)], axis=1)
    others = np.stack([shape.mesh.vertices[:, 0] ** 2, shape.mesh.vertices[:, 1]], axis=1)
    assert shape.mesh.n_faces < landmarks.FACE_BLOCK  # one block
    whole = [landmarks.orientation_coordinates(shape, fields, extra) for extra in (None, others)]
    monkeypatch.setattr(landmarks, "FACE_BLOCK", 777)  # many blocks, the last one short
    for extra, expected in zip((None, others), whole):
        assert np.array_equal(landmarks.orientation_coordinates(shape, fields, extra), expected)


def test_turns_kept_by_landmark_pair_are_the_same_bits_in_any_order_and_subset(figure_poses):
    from darcyan.dense.landmarks import orientation_coordinates
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    vertices = np.array([0, 500, 1000, 1500, 2000])
    fields = np.stack([shape.solver.distance(v) for v in vertices], axis=1)
    known = {}
    # A first set, then others that reuse its pairs in another order, a subset and a new vertex:
    # each the same bits as made afresh, and only the new pairs made.
    for order, new_pairs in (([0, 1, 2], 3), ([0, 1, 3], 2), ([0, 2, 3], 1), ([3, 1, 0], 0), ([2, 0], 0),
                             ([4, 2, 1, 0], 3)):
        expected = orientation_coordinates(shape, fields[:, order])
        made = len(known)
        kept = orientation_coordinates(shape, fields[:, order], vertices=vertices[order], known=known)
        assert np.array_equal(kept, expected)
        assert len(known) - made == new_pairs
    assert np.abs(known[(0, 500)]).max() > 0.1  # turns that are there to be mistaken


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


def test_orientation_coordinates_flip_in_a_mirror_and_stay_under_rigid_motion(figure_poses):
    from darcyan.dense.landmarks import orientation_coordinates

    turns = {name: orientation_coordinates(shape, fields)
             for name, shape, fields in moved_and_mirrored_tip_fields(figure_poses[0], seed=3)}
    assert np.allclose(turns["moved"], turns["as is"], atol=1e-6)
    assert np.allclose(turns["mirrored"], -turns["as is"], atol=1e-6)


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


def test_a_shapes_kept_distance_fields_are_the_solvers_and_cross_processes(figure_poses):
    import pickle

    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    tip = int(synthetic.figure_tips()[0])
    assert shape.known_distance_field(tip) is None
    field = shape.distance_field(tip)
    np.testing.assert_array_equal(field, shape.solver.distance(tip))
    assert shape.known_distance_field(tip) is field  # kept, not computed again
    copy = pickle.loads(pickle.dumps(shape))  # what a worker process sends back
    np.testing.assert_array_equal(copy.known_distance_field(tip), field)


def test_the_feature_points_fields_are_made_with_the_shape_and_read_by_the_map(small_pose_files, monkeypatch):
    from darcyan.dense.landmarks import distance_fields
    from darcyan.dense.maps import shape_operators
    from darcyan.geometry.shape import prepare_shape
    from darcyan.io.mesh_files import load_mesh
    from darcyan.method.pipeline import describe_and_prepare

    config = DarcyanConfig()
    both = describe_and_prepare(small_pose_files, config, jobs=2,
                                extra=functools.partial(shape_operators, config=config.dense))
    for description, shape in both:
        features = shape.mesh_index(description.feature_vertices)
        assert len(features) >= 3 and (features >= 0).all()
        for vertex in features:  # made in the worker (the second shape) or here, and brought back
            np.testing.assert_array_equal(shape.known_distance_field(vertex), shape.solver.distance(int(vertex)))
        with monkeypatch.context() as patch:
            def refuse(vertex):
                raise AssertionError(f"vertex {vertex}: computed again, not read from the shape")

            patch.setattr(shape.solver, "distance", refuse)
            read = distance_fields(shape, {}, features)
        np.testing.assert_array_equal(read, np.stack([shape.solver.distance(int(v)) for v in features], axis=1))
        other = int(np.setdiff1d(np.arange(shape.n_vertices), features)[0])
        assert shape.known_distance_field(other) is None
        distance_fields(shape, {}, [other])
        assert shape.known_distance_field(other) is None  # a dense map's other fields are not kept on the shape
    # On a shape prepared without its description (a large mesh's description reads coarse
    # distances), shape_operators makes the feature points' fields itself.
    description, _ = both[0]
    fresh = prepare_shape(load_mesh(small_pose_files[0]), config)
    shape_operators(fresh, description.feature_vertices, config=config.dense)
    for vertex in fresh.mesh_index(description.feature_vertices):
        np.testing.assert_array_equal(fresh.known_distance_field(vertex), fresh.solver.distance(int(vertex)))


def test_a_small_meshs_description_keeps_its_feature_points_exact_fields_and_no_others(figure_poses):
    from darcyan.geometry.shape import prepare_shape
    from darcyan.method.pipeline import analyze_shape

    shape = prepare_shape(figure_poses[0])
    analysis = analyze_shape(shape)
    kept = [v for v in range(shape.n_vertices) if shape.known_distance_field(v) is not None]
    assert sorted(kept) == sorted(int(v) for v in analysis.features.vertices)
    for vertex in kept:
        np.testing.assert_array_equal(shape.known_distance_field(vertex), shape.solver.distance(vertex))


def test_keeping_a_distance_field_refuses_a_wrong_vertex_or_length(figure_poses):
    from darcyan.errors import MeshError
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(figure_poses[0])
    with pytest.raises(MeshError, match="out of range"):
        shape.keep_distance_field(shape.n_vertices, np.zeros(shape.n_vertices))
    with pytest.raises(MeshError, match="expected"):
        shape.keep_distance_field(0, np.zeros(shape.n_vertices - 1))
    with pytest.raises(MeshError, match="out of range"):
        shape.distance_field(-1)
    assert shape.known_distance_field(0) is None
