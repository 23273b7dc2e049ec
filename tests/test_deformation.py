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


def test_targets_at_points_of_a_coarse_copy_move_it_rigidly_and_follow_a_stiff_pull():
    # The fine cylinder's vertices lie on the coarse one (every other section and ring), so
    # each is a barycentric combination of coarse vertices: targets given there pull the copy.
    import scipy.sparse as sp
    import scipy.sparse.linalg  # noqa: F401  (sp.linalg)

    from darcyan.geometry.geodesics import GeodesicSolver

    fine = prepare_shape(synthetic.cylinder(sections=48, rings=49))
    coarse = prepare_shape(synthetic.cylinder(sections=24, rings=25))
    faces, bary = GeodesicSolver(coarse.mesh).locate(fine.mesh.vertices)
    rows = np.repeat(np.arange(fine.mesh.n_vertices), 3)
    sampling = sp.csr_matrix((bary.ravel(), (rows, coarse.mesh.faces[faces].ravel())),
                             shape=(fine.mesh.n_vertices, coarse.mesh.n_vertices))
    on_copy = sampling @ coarse.mesh.vertices
    arap = ArapDeformation(coarse.mesh.vertices, coarse.laplacian, fine.vertex_areas, 0.035, sampling=sampling)
    rotation, shift = random_rotation(6), np.array([0.5, -2.0, 1.0])
    moved = coarse.mesh.vertices @ rotation.T + shift
    fitted = arap.fit(on_copy @ rotation.T + shift, 4, start=moved)
    assert np.abs(fitted - moved).max() < 1e-9
    assert np.abs(arap.rotations(fitted) - rotation).max() < 1e-9
    # From its default start (each vertex at the mean target of the points it carries) it gets there.
    assert np.abs(arap.fit(on_copy @ rotation.T + shift, 4) - moved).max() < 1e-3
    assert np.abs(arap.fit(on_copy @ rotation.T + shift, 30) - moved).max() < 1e-8
    # Noise on the targets: filtered as on the mesh itself, and followed by a stiff pull as far
    # as the copy can carry it (a least-squares fit of its vertices to the fine points).
    noise = 0.01 * np.random.default_rng(7).normal(size=on_copy.shape)
    soft = arap.fit(on_copy + noise, 6)
    assert np.sqrt(((soft - coarse.mesh.vertices) ** 2).sum(1).mean()) < 0.35 * np.sqrt((noise ** 2).sum(1).mean())
    stiff = ArapDeformation(coarse.mesh.vertices, coarse.laplacian, fine.vertex_areas, 1e-4, sampling=sampling)
    weights = sp.diags(fine.vertex_areas)
    best = sp.linalg.spsolve((sampling.T @ weights @ sampling).tocsc(), sampling.T @ weights @ (on_copy + noise))
    assert np.abs(stiff.fit(on_copy + noise, 6) - best).max() < 1e-3


def test_a_sampling_of_the_wrong_shape_is_refused(cylinder):
    import scipy.sparse as sp

    shape, _ = cylinder
    n = shape.mesh.n_vertices
    with pytest.raises(ValueError, match="sampling must be"):
        ArapDeformation(shape.mesh.vertices, shape.laplacian, np.ones(n - 1), 0.035, sampling=sp.eye(n))


def test_a_vertex_no_sample_reaches_follows_its_neighbours_wherever_the_targets_lie(cylinder):
    import scipy.sparse as sp

    shape, _ = cylinder
    rest = shape.mesh.vertices
    n = len(rest)
    # targets at every vertex but the first: that one is held by its one-ring (and a faint floor)
    sampling = sp.eye(n, format="csr")[1:]
    arap = ArapDeformation(rest, shape.laplacian, shape.vertex_areas[1:], 0.035, sampling=sampling)
    rotation, shift = random_rotation(9), np.array([3.0, -1.0, 2.0])
    moved = rest @ rotation.T + shift
    fitted = arap.fit(moved[1:], 6, start=moved)
    # the floor pulls it towards the others' mean move, not its own turn: a faint pull, so a few
    # 1e-4 off at most (measured: 3e-4)
    assert np.abs(fitted - moved).max() < 1e-3
    # where the targets lie does not matter (the default start included)
    far = np.array([50.0, 20.0, -40.0])
    assert np.allclose(arap.fit(moved[1:] + far, 6), arap.fit(moved[1:], 6) + far, atol=1e-9)


@pytest.mark.parametrize("scale", [1.1, 0.9])
def test_a_stretch_lets_the_one_rings_follow_a_scaled_copy_within_its_range(cylinder, scale):
    # A similarity (turned and scaled by 1.1, or 0.9) is an exact fit when one-rings may scale
    # by 20% either way: every one-ring's best scale is the copy's. Kept rigid, or held within 5%,
    # the one-rings cannot reach it, and the fit stays short of the targets.
    shape, _ = cylinder
    rest = shape.mesh.vertices
    moved = scale * rest @ random_rotation(5).T + [0.3, 0.0, -1.0]

    def gap(stretch):
        arap = ArapDeformation(rest, shape.laplacian, shape.vertex_areas, 0.035, stretch=stretch)
        return np.abs(arap.fit(moved, 6) - moved).max()

    assert gap(0.2) < 1e-9
    assert gap(0.0) > 1e-3 and gap(0.05) > 1e-3
    assert gap(0.05) < gap(0.0)


def test_a_bad_stretch_is_refused(cylinder):
    shape, _ = cylinder
    for bad in (-0.1, float("nan")):
        with pytest.raises(ValueError, match="stretch"):
            ArapDeformation(shape.mesh.vertices, shape.laplacian, shape.vertex_areas, 0.035, stretch=bad)
