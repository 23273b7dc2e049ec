"""The dense map's last step (:mod:`darcyan.dense.alignment`): the source deformed onto the
target, read out in space, on two poses of the figure whose true map is known (the same vertex)."""

import dataclasses

import numpy as np
import pytest

from darcyan.dense.alignment import aligned_map
from darcyan.dense.config import DenseConfig
from darcyan.errors import ConfigError
from darcyan.geometry import synthetic
from darcyan.geometry.shape import prepare_shape


@pytest.fixture(scope="module")
def poses():
    shape_1, shape_2 = (prepare_shape(synthetic.figure(pose, subdivisions=4)) for pose in (0, 1))
    truth = shape_2.mesh_index(shape_1.mesh.input_index)  # the figure's poses share their vertices
    return shape_1, shape_2, truth


def noisy_map(shape_2, truth: np.ndarray, share: float, seed: int = 0) -> np.ndarray:
    """``truth`` with ``share`` of its images moved to a neighbour of theirs (an edge off)."""
    faces = shape_2.mesh.faces
    rng = np.random.default_rng(seed)
    moved = truth.copy()
    chosen = np.flatnonzero(rng.random(len(truth)) < share)
    corner_faces = {}
    for f, face in enumerate(faces):
        for v in face:
            corner_faces.setdefault(int(v), []).append(f)
    for i in chosen:
        face = faces[rng.choice(corner_faces[int(truth[i])])]
        moved[i] = rng.choice([v for v in face if v != truth[i]])
    return moved


def test_the_true_map_is_kept_and_a_noisy_one_is_mended(poses):
    shape_1, shape_2, truth = poses
    assert np.array_equal(aligned_map(shape_1, shape_2, truth), truth)
    noisy = noisy_map(shape_2, truth, 0.5)
    mended = aligned_map(shape_1, shape_2, noisy)
    # Half the images an edge off; the deformation keeps the source's one-rings, so it puts
    # nearly every vertex back on its own image (measured: 0.5 -> 0.99 exact).
    assert (noisy == truth).mean() < 0.55
    assert (mended == truth).mean() > 0.9
    unaligned = dataclasses.replace(DenseConfig(), alignment_rounds=0)
    assert np.array_equal(aligned_map(shape_1, shape_2, noisy, unaligned), noisy)


def test_the_map_does_not_depend_on_where_the_target_lies(poses):
    shape_1, shape_2, truth = poses
    noisy = noisy_map(shape_2, truth, 0.5, seed=1)
    rotation, _ = np.linalg.qr(np.random.default_rng(5).normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    mesh = shape_2.mesh
    moved = prepare_shape(type(mesh)(mesh.vertices @ rotation.T + 3.0, mesh.faces))
    # the same map but for rounding (a near tie of two target vertices may go either way)
    assert (aligned_map(shape_1, moved, noisy) == aligned_map(shape_1, shape_2, noisy)).mean() > 0.995


@pytest.mark.parametrize("changes, field", [({"alignment_rounds": -1}, "alignment_rounds"),
                                            ({"alignment_length": 0.0}, "alignment_length"),
                                            ({"alignment_length": float("nan")}, "alignment_length"),
                                            ({"alignment_normal_weight": -0.1}, "alignment_normal_weight"),
                                            ({"alignment_iterations": 0}, "alignment_iterations"),
                                            ({"alignment_slack": -0.01}, "alignment_slack"),
                                            ({"alignment_proxy_vertices": -1}, "alignment_proxy_vertices")])
def test_bad_alignment_settings_name_the_field(changes, field):
    with pytest.raises(ConfigError, match=field):
        DenseConfig(**changes)


def test_the_alignment_deforms_with_the_stretch_it_is_given(poses):
    # The stretch reaches the deformation, on the mesh itself and through a coarse copy (its
    # effect: tests/test_deformation.py), and a deformation made for one stretch is not reused
    # for another.
    from darcyan.dense.alignment import _deformation

    shape_1 = poses[0]
    for proxy_vertices in (0, 1000):
        rigid, _ = _deformation(shape_1, 0.035, proxy_vertices)
        stretching, _ = _deformation(shape_1, 0.035, proxy_vertices, 0.2)
        assert rigid._stretch == 0.0 and stretching._stretch == 0.2
        assert _deformation(shape_1, 0.035, proxy_vertices, 0.2)[0] is stretching
        assert (rigid._sampling is None) == (stretching._sampling is None) == (proxy_vertices == 0)


def test_an_image_far_from_its_landmark_distances_is_not_taken(poses):
    shape_1, shape_2, truth = poses
    noisy = noisy_map(shape_2, truth, 0.5, seed=2)
    free = aligned_map(shape_1, shape_2, noisy)
    assert (free != noisy).mean() > 0.2
    # Distances that only the old images fit (0 on them, 1 elsewhere): a move to any other
    # vertex is refused and keeps the old image.
    fields_1 = np.zeros((shape_1.n_vertices, 1))
    fields_2 = np.ones((shape_2.n_vertices, 1))
    fields_2[noisy] = 0.0
    guarded = aligned_map(shape_1, shape_2, noisy, DenseConfig(), fields_1, fields_2)
    fitting = np.isin(free, noisy)
    assert (~fitting).sum() > 10
    assert np.array_equal(guarded, np.where(fitting, free, noisy))
    # Distances that every image fits alike: the guard changes nothing.
    same = aligned_map(shape_1, shape_2, noisy, DenseConfig(), fields_1, np.zeros((shape_2.n_vertices, 1)))
    assert np.array_equal(same, free)
    # The true distances to the figure's tips: the mended map is as exact as without them.
    tips = synthetic.figure_tips(subdivisions=4)[:4]
    fields_1 = np.stack([shape_1.solver.distance(int(shape_1.mesh_index([t])[0])) for t in tips], axis=1)
    fields_2 = np.stack([shape_2.solver.distance(int(shape_2.mesh_index([t])[0])) for t in tips], axis=1)
    guarded = aligned_map(shape_1, shape_2, noisy, DenseConfig(), fields_1, fields_2)
    assert (guarded == truth).mean() >= (free == truth).mean() - 0.01


def test_a_source_deformed_through_its_coarse_copy_moves_rigidly_and_mends_a_noisy_map(poses):
    from darcyan.dense.alignment import _deformation

    shape_1, shape_2, truth = poses
    through_copy = dataclasses.replace(DenseConfig(), alignment_proxy_vertices=1000)  # 2562 vertices -> 1000
    deformation, lift = _deformation(shape_1, through_copy.alignment_length, 1000)
    assert lift.interpolation is not None and deformation.rotations(shape_1.proxy(1000).mesh.vertices).shape == (
        shape_1.proxy(1000).mesh.n_vertices, 3, 3)
    # A rigid motion of the source, its detail included (the offsets turn with the copy).
    rotation, shift = np.linalg.qr(np.random.default_rng(8).normal(size=(3, 3)))[0], np.array([1.0, 2.0, -0.5])
    rotation *= np.sign(np.linalg.det(rotation))
    moved = shape_1.mesh.vertices @ rotation.T + shift
    # As align's rounds do: the first fit pulls the offsets at rest, the next one turned.
    fitted, turns = None, None
    for _ in range(3):
        fitted = deformation.fit(lift.unlifted(moved, turns), 10, start=fitted)
        turns = lift.turns(deformation, fitted)
    largest = np.linalg.norm(lift.offset, axis=1).max()
    assert np.abs(turns - rotation).max() < 1e-4
    assert np.abs(lift.lifted(fitted, turns) - moved).max() < 0.01 * largest
    assert np.abs(lift.lifted(fitted, None) - moved).max() > 0.5 * largest
    # The map: the copy cannot follow the bends below its own edges, so a few images move to a
    # neighbour of the true one (through the full mesh: none; measured 2.0%, 0.0005 on average).
    target = shape_2.mesh.vertices
    for start in (truth, noisy_map(shape_2, truth, 0.5)):
        mapped = aligned_map(shape_1, shape_2, start, through_copy)
        assert (mapped == truth).mean() > 0.97
        assert np.linalg.norm(target[mapped] - target[truth], axis=1).mean() < 0.002


def test_a_small_source_is_deformed_itself():
    from darcyan.dense.alignment import _deformation

    shape = prepare_shape(synthetic.figure(0, subdivisions=3))  # 642 vertices: below twice 6000
    _, lift = _deformation(shape, 0.035, DenseConfig().alignment_proxy_vertices)
    assert lift.interpolation is None
    _, lift = _deformation(shape, 0.035, 0)
    assert lift.interpolation is None


def test_the_alignment_through_a_copy_follows_a_rigid_motion_of_the_source_detail_included(poses):
    from darcyan.dense.alignment import align

    shape_1, _, _ = poses
    rotation, _ = np.linalg.qr(np.random.default_rng(11).normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    mesh = shape_1.mesh
    moved = prepare_shape(type(mesh)(mesh.vertices @ rotation.T + 2.0, mesh.faces))
    identity = moved.mesh_index(shape_1.mesh.input_index)
    through_copy = dataclasses.replace(DenseConfig(), alignment_proxy_vertices=1000)
    aligned = align(shape_1, moved, identity, through_copy)
    assert np.array_equal(aligned.map_12, identity)
    # The residual: the deformed source's distance from the images, which the offsets' turns make
    # small (at rest they would leave about their own length, here up to 0.003)
    offsets = shape_1.mesh.vertices - shape_1.proxy(1000).to_full(shape_1.proxy(1000).mesh.vertices)
    assert aligned.residual < 0.05 * np.linalg.norm(offsets, axis=1).mean()


def test_the_copys_interpolation_matrix_is_its_read_out(poses):
    shape_1, _, _ = poses
    proxy = shape_1.proxy(1000)
    values = np.random.default_rng(12).normal(size=(proxy.mesh.n_vertices, 4))
    assert np.allclose(proxy.interpolation() @ values, proxy.to_full(values), rtol=0, atol=1e-12)
