"""The Laplace-Beltrami spectrum (darcyan.geometry.spectral) against a sphere's, whichever way its
shift-invert steps are solved, and the curvature signature's columns (darcyan.geometry.heat) made
once per shape."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg

from darcyan.geometry import heat, spectral, synthetic
from darcyan.geometry.mesh import Mesh, normalize_mesh
from darcyan.geometry.shape import prepare_shape

# On a sphere of area 1 (radius 1/sqrt(4 pi)) the eigenvalues are l (l + 1) 4 pi, multiplicity 2 l + 1.
SPHERE_VALUES = np.repeat([degree * (degree + 1) * 4 * np.pi for degree in range(4)], [2 * degree + 1 for degree in range(4)])
K = len(SPHERE_VALUES)


@pytest.fixture(scope="module")
def unit_sphere():
    """An icosphere with its vertices moved a little along the sphere: an icosahedron's symmetry
    makes some eigenvalues exactly equal, and one Lanczos start vector can miss one of those."""
    mesh = synthetic.icosphere(subdivisions=4)  # radius 1, edges about 0.08 long
    moved = mesh.vertices + 0.01 * np.random.default_rng(0).standard_normal(mesh.vertices.shape)
    moved /= np.linalg.norm(moved, axis=1, keepdims=True)
    return normalize_mesh(Mesh(moved, mesh.faces, name="moved icosphere"))[0]


@pytest.mark.parametrize("lanczos", [0.0, 1.5])
@pytest.mark.parametrize("cholesky, shift", [(False, spectral.SHIFT), (True, spectral.SHIFT), (True, -1e-8),
                                             (True, 0.5)])  # 0.5: not positive definite, LU after all
def test_the_spectrum_is_the_spheres_whatever_the_factorization_and_lanczos_vectors(unit_sphere, cholesky, shift,
                                                                                      lanczos, monkeypatch):
    asked = {}
    real_eigsh = scipy.sparse.linalg.eigsh

    def eigsh(*args, **kwargs):
        asked.update(kwargs)
        return real_eigsh(*args, **kwargs)

    monkeypatch.setattr(scipy.sparse.linalg, "eigsh", eigsh)
    spectrum = spectral.laplace_beltrami_spectrum(unit_sphere, k=K, tol=1e-6, shift=shift, lanczos=lanczos,
                                                  cholesky=cholesky)
    assert (asked["OPinv"] is not None) == (cholesky and shift < 0)
    assert asked["ncv"] == (None if lanczos == 0 else int(lanczos * K))
    assert abs(spectrum.values[0]) < 1e-6
    np.testing.assert_allclose(spectrum.values[1:], SPHERE_VALUES[1:], rtol=0.02)
    gram = spectrum.vectors.T @ (spectrum.mass[:, None] * spectrum.vectors)
    np.testing.assert_allclose(gram, np.eye(K), atol=1e-6)


def test_the_cholesky_and_lu_spectra_span_the_same_eigenspaces(unit_sphere):
    by_cholesky = spectral.laplace_beltrami_spectrum(unit_sphere, k=K, tol=1e-8, shift=-1e-3, cholesky=True)
    by_lu = spectral.laplace_beltrami_spectrum(unit_sphere, k=K, tol=1e-8, shift=-1e-3)
    np.testing.assert_allclose(by_cholesky.values, by_lu.values, rtol=1e-8, atol=1e-8)
    overlap = by_cholesky.vectors.T @ (by_cholesky.mass[:, None] * by_lu.vectors)
    np.testing.assert_allclose(np.linalg.svd(overlap, compute_uv=False), 1.0, atol=1e-6)


def test_a_failed_cholesky_factorization_falls_back_to_lu_silently(unit_sphere, monkeypatch, capfd):
    import cholespy

    def refuses(*args):
        raise ValueError("Matrix is not positive definite!")

    monkeypatch.setattr(cholespy, "CholeskySolverD", refuses)
    spectrum = spectral.laplace_beltrami_spectrum(unit_sphere, k=K, tol=1e-6, shift=-1e-3, cholesky=True)
    np.testing.assert_allclose(spectrum.values[1:], SPHERE_VALUES[1:], rtol=0.02)
    assert capfd.readouterr().out == ""


def test_the_shifted_inverse_solves_its_system_and_declines_what_is_not_positive_definite(unit_sphere, capfd):
    stiffness, mass = spectral.laplacian_operators(unit_sphere)
    b = np.random.default_rng(0).standard_normal(len(mass))
    inverse = spectral.shifted_inverse(stiffness, mass, -1e-3)
    for rhs in (b, b[:, None]):  # eigsh hands a vector or a column
        x = inverse.matvec(rhs).ravel()
        np.testing.assert_allclose((stiffness + 1e-3 * sp.diags(mass)) @ x, b, atol=1e-8 * np.abs(b).max())
    assert spectral.shifted_inverse(stiffness, mass, 0.0) is None  # singular: the constant vector
    assert spectral.shifted_inverse(stiffness, mass, 2.0) is None
    print("before", flush=True)
    indefinite = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    assert spectral.shifted_inverse(indefinite, np.ones(2), -1e-3) is None
    print("after", flush=True)
    assert capfd.readouterr().out == "before\nafter\n"  # CHOLMOD's warning kept off the standard output


def test_factorizations_in_several_threads_give_the_standard_output_back(capfd):
    import threading

    indefinite = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    threads = [threading.Thread(target=lambda: [spectral.shifted_inverse(indefinite, np.ones(2), -1e-3)
                                                for _ in range(20)]) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    print("still here", flush=True)
    assert capfd.readouterr().out == "still here\n"


def test_the_dense_basis_is_solved_by_cholesky_with_its_lanczos_vectors(figure_poses, monkeypatch):
    from darcyan.dense.config import DenseConfig
    from darcyan.dense.zoomout import dense_spectrum

    asked = []
    real = spectral.laplace_beltrami_spectrum
    monkeypatch.setattr("darcyan.geometry.shape.laplace_beltrami_spectrum",
                        lambda *a, **k: asked.append((a, k)) or real(*a, **k))
    config = DenseConfig(basis_size=20, basis_margin=4, basis_lanczos=1.75)
    dense_spectrum(prepare_shape(figure_poses[0]), config)
    (args, kwargs), = asked
    assert args[-2:] == (1.75, True)  # lanczos, cholesky


def test_the_signatures_columns_are_made_once_per_shape_and_length(figure_poses, monkeypatch):
    shape = prepare_shape(figure_poses[0])  # 10k vertices: with proxies of 2,000, on a proxy
    mirror, dense = (0.05, 0.1, 0.2), (0.02, 0.05, 0.1)
    alone = [heat.curvature_signature(shape.mesh, shape.curvatures(1).mean, lengths, 4) for lengths in (mirror, dense)]
    proxy = shape.proxy(2000)
    on_proxy = [proxy.to_full(heat.curvature_signature(proxy.mesh, heat.principal_curvatures(proxy.mesh, 1).mean,
                                                        lengths, 4)) for lengths in (mirror, dense)]
    diffused = []
    original = heat.heat_diffuse
    monkeypatch.setattr(heat, "heat_diffuse", lambda *a, **k: diffused.append((len(a[0].vertices), a[2])) or
                        original(*a, **k))
    for proxy_vertices, expected in ((0, alone), (2000, on_proxy)):
        shared = [heat.shape_signature(shape, proxy_vertices, lengths, 4, 1) for lengths in (mirror, dense)]
        for one, other in zip(expected, shared):
            np.testing.assert_array_equal(one, other)
    n, m = shape.mesh.n_vertices, proxy.mesh.n_vertices
    assert sorted(diffused) == sorted((size, length) for size in (n, m) for length in (0.02, 0.05, 0.1, 0.2))
    heat.shape_signature(shape, 0, dense, 8, 1)  # other steps: other columns
    assert len(diffused) == 11


def test_the_curvature_signature_does_not_depend_on_where_the_vertices_crowd():
    # The same torus meshed twice: evenly around its tube, and with twice the rings on its
    # outer third, where the mean curvature is largest. At the vertices both meshes share the
    # signatures agree (to 2e-4): each column is scaled by its mean magnitude over the area,
    # which the crowding does not change (over the vertices it would: 6.6% and 3.5% apart).
    even = 2 * np.pi * np.arange(60) / 60
    extra = even[(even < np.pi / 3) | (even >= 5 * np.pi / 3)] + np.pi / 60  # midpoints there
    crowded = np.sort(np.concatenate([even, extra]))
    meshes = [synthetic.torus(nu=120, rings=rings) for rings in (even, crowded)]
    lengths = (0.5, 1.0)
    signatures = [heat.curvature_signature(mesh, heat.principal_curvatures(mesh).mean, lengths, 4)
                  for mesh in meshes]
    shared = np.flatnonzero(np.isin(crowded, even))
    at_even = signatures[1].reshape(120, len(crowded), 2)[:, shared].reshape(-1, 2)
    np.testing.assert_allclose(at_even, signatures[0], rtol=1e-3, atol=1e-3)
    # the crowding is strong enough that a mean over the vertices would show it
    plain = [np.abs(heat.heat_diffuse(mesh, heat.principal_curvatures(mesh).mean, 0.5, 4)).mean() for mesh in meshes]
    assert plain[1] / plain[0] > 1.05
