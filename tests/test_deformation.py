"""As-rigid-as-possible fits (:mod:`darcyan.geometry.deformation`) against what ARAP must do:
keep a rigid motion, filter what is not one, turn with its targets, follow them when stiff."""

import numpy as np
import pytest
from conftest import random_rotation

from darcyan.geometry import synthetic
from darcyan.geometry.deformation import ArapDeformation
from darcyan.geometry.shape import prepare_shape


@pytest.fixture(scope="module")
def cylinder():
    shape = prepare_shape(synthetic.cylinder(sections=48, rings=49))
    return shape, ArapDeformation(shape.mesh.vertices, shape.laplacian, shape.vertex_areas, 0.035)


def test_a_rigid_motion_of_the_rest_shape_is_a_fixed_point(cylinder):
    shape, arap = cylinder
    moved = shape.mesh.vertices @ random_rotation(3).T + [0.5, -2.0, 1.0]
    assert np.abs(arap.fit(moved, 4) - moved).max() < 1e-9


def test_noise_on_the_targets_is_filtered_and_a_stiff_pull_follows_them(cylinder):
    shape, arap = cylinder
    rest = shape.mesh.vertices
    noise = 0.01 * np.random.default_rng(0).normal(size=rest.shape)
    fitted = arap.fit(rest + noise, 6)
    # The rest shape keeps its one-rings: most of the noise (an edge's length: 0.05) is gone.
    assert np.sqrt(((fitted - rest) ** 2).sum(1).mean()) < 0.35 * np.sqrt((noise ** 2).sum(1).mean())
    stiff = ArapDeformation(rest, shape.laplacian, shape.vertex_areas, 1e-4).fit(rest + noise, 6)
    assert np.abs(stiff - (rest + noise)).max() < 1e-3


def test_the_fit_turns_with_its_targets_and_follows_the_numbering(cylinder):
    shape, arap = cylinder
    rest = shape.mesh.vertices
    targets = rest + 0.01 * np.random.default_rng(1).normal(size=rest.shape)
    rotation = random_rotation(4)
    fitted = arap.fit(targets, 5)
    assert np.allclose(arap.fit(targets @ rotation.T, 5), fitted @ rotation.T, atol=1e-9)
    order = np.random.default_rng(2).permutation(len(rest))
    laplacian = shape.laplacian[order][:, order]  # the same mesh, its vertices renumbered
    other = ArapDeformation(rest[order], laplacian, shape.vertex_areas[order], 0.035)
    assert np.allclose(other.fit(targets[order], 5), fitted[order], atol=1e-9)


def test_a_bent_shape_is_followed_where_a_smooth_displacement_would_not_be():
    # A cylinder bent by 90 degrees about its middle: ARAP turns each one-ring, so a fit to the
    # bent shape plus noise comes back near the bent shape, not near the straight rest shape.
    shape = prepare_shape(synthetic.cylinder(radius=0.25, height=8.0, sections=24, rings=193))
    rest = shape.mesh.vertices
    axis = np.argmax(np.ptp(rest, axis=0))
    t = rest[:, axis] - np.median(rest[:, axis])
    other = [a for a in range(3) if a != axis]
    radius_of_bend = 2 * np.ptp(t) / np.pi  # a quarter circle through the length
    angle = t / radius_of_bend
    bent = rest.copy()
    r = radius_of_bend - rest[:, other[0]]
    bent[:, axis] = r * np.sin(angle)
    bent[:, other[0]] = radius_of_bend - r * np.cos(angle)
    noise = 0.01 * np.random.default_rng(3).normal(size=rest.shape)
    fitted = ArapDeformation(rest, shape.laplacian, shape.vertex_areas, 0.035).fit(bent + noise, 8)
    error = np.sqrt(((fitted - bent) ** 2).sum(1).mean())
    assert error < 0.35 * np.sqrt((noise ** 2).sum(1).mean())


def test_each_one_ring_gets_the_rotation_of_a_rigid_motion_never_a_reflection(cylinder):
    shape, arap = cylinder
    rest = shape.mesh.vertices
    rotation = random_rotation(5)
    rotations = arap._rotations(rest @ rotation.T + 1.0)
    assert np.abs(rotations - rotation).max() < 1e-9
    mirrored = arap._rotations(rest * [-1.0, 1.0, 1.0])  # no rotation makes a mirror image
    assert np.allclose(np.linalg.det(mirrored), 1.0)
    assert np.allclose(np.einsum("nab,ncb->nac", mirrored, mirrored), np.eye(3), atol=1e-9)


def test_a_laplacian_of_the_wrong_sign_is_refused(cylinder):
    shape, _ = cylinder
    with pytest.raises(ValueError, match="no positive off-diagonal"):
        ArapDeformation(shape.mesh.vertices, -shape.laplacian, shape.vertex_areas, 0.035)
