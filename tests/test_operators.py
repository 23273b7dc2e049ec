"""The discrete operators (libigl's, see darcyan.geometry.operators) against truths known
independently of the code, and against the formulas written out face by face."""

import math

import numpy as np
import pytest

from darcyan.geometry import synthetic
from darcyan.geometry.curvature import angle_defect
from darcyan.geometry.geodesics import vertex_normals
from darcyan.geometry.mesh import Mesh
from darcyan.geometry.operators import cotangent_laplacian, mixed_voronoi_area


def jittered_sphere() -> Mesh:
    """A closed unit sphere whose vertices are pushed about: most triangles are obtuse."""
    s = synthetic.icosphere(3)
    v = s.vertices + np.random.default_rng(1).normal(scale=0.06, size=s.vertices.shape)
    return Mesh(v / np.linalg.norm(v, axis=1, keepdims=True), s.faces, name="jittered sphere")


def sheared_strip(flat: bool = False) -> Mesh:
    """A sheared 12 x 9 grid, with boundary: every triangle obtuse; wavy unless ``flat``."""
    u, w = np.meshgrid(np.arange(12.0), np.arange(9.0), indexing="ij")
    z = 0 * u if flat else 0.1 * np.sin(u)
    v = np.stack([u + 1.7 * w, 0.4 * w, z], axis=-1).reshape(-1, 3)
    return Mesh(v, synthetic._grid_faces(12, 9, False, False), name="sheared strip")


def with_degenerate_faces() -> Mesh:
    """A unit square, plus a face on three collinear points, a face with two coincident corners
    and an unreferenced vertex (what a prepared mesh never has)."""
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0, 0], [1, 1, 0], [5, 5, 5]], float)
    return Mesh(v, np.array([[0, 1, 2], [0, 2, 3], [0, 4, 1], [2, 5, 3]]), name="degenerate")


# -- the formulas, one face at a time -----------------------------------------------------------

def _corners(mesh: Mesh, zero_area: bool = False):
    """Per face: its vertices, their positions and the corner angles (0 beside a zero-length
    edge). Zero-area faces are skipped unless ``zero_area``."""
    v = mesh.vertices
    for face in mesh.faces:
        p = [v[i] for i in face]
        if not zero_area and np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0])) == 0:
            continue
        angles = []
        for i in range(3):
            a, b = p[(i + 1) % 3] - p[i], p[(i + 2) % 3] - p[i]
            angles.append(math.atan2(np.linalg.norm(np.cross(a, b)), a @ b))  # atan2(0, 0) = 0
        yield face, p, angles


def reference_laplacian(mesh: Mesh) -> np.ndarray:
    L = np.zeros((mesh.n_vertices, mesh.n_vertices))
    for face, _, angles in _corners(mesh):
        for i in range(3):  # the corner's cotangent weights the edge opposite it
            j, k = face[(i + 1) % 3], face[(i + 2) % 3]
            w = 0.5 / math.tan(angles[i])
            L[j, k] += w
            L[k, j] += w
            L[j, j] -= w
            L[k, k] -= w
    return L


def reference_mixed_area(mesh: Mesh) -> np.ndarray:
    """Meyer et al. 2003, Fig. 4: Voronoi region in a non-obtuse triangle, else 1/2 of the triangle
    to an obtuse corner and 1/4 to the other two (the area by Heron's formula)."""
    area = np.zeros(mesh.n_vertices)
    for face, p, angles in _corners(mesh):
        a, b, c = (np.linalg.norm(p[(i + 1) % 3] - p[(i + 2) % 3]) for i in range(3))
        s = (a + b + c) / 2
        heron = math.sqrt(max(s * (s - a) * (s - b) * (s - c), 0.0))
        for i in range(3):
            if max(angles) > math.pi / 2:
                area[face[i]] += heron / 2 if angles[i] > math.pi / 2 else heron / 4
            else:
                j, k = (i + 1) % 3, (i + 2) % 3  # |P_i P_j|^2 cot(angle k) + |P_i P_k|^2 cot(angle j)
                area[face[i]] += (np.sum((p[j] - p[i]) ** 2) / math.tan(angles[k])
                                  + np.sum((p[k] - p[i]) ** 2) / math.tan(angles[j])) / 8
    return area


def reference_angle_defect(mesh: Mesh) -> np.ndarray:
    edges = {}
    for face in mesh.faces:
        for i in range(3):
            key = tuple(sorted((face[i], face[(i + 1) % 3])))
            edges[key] = edges.get(key, 0) + 1
    boundary = {v for key, count in edges.items() if count == 1 for v in key}
    defect = np.array([math.pi if i in boundary else 2 * math.pi for i in range(mesh.n_vertices)])
    for face, _, angles in _corners(mesh, zero_area=True):  # a collinear face's angles: 0, 0, pi
        for i in range(3):
            defect[face[i]] -= angles[i]
    return defect


def reference_normals(mesh: Mesh) -> np.ndarray:
    normals = np.zeros((mesh.n_vertices, 3))
    v = mesh.vertices
    for face in mesh.faces:
        area_vector = np.cross(v[face[1]] - v[face[0]], v[face[2]] - v[face[0]])  # 2 * area * unit normal
        for i in face:
            normals[i] += area_vector
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.where(length > 0, normals / np.where(length > 0, length, 1), 0.0)


SMALL = {"jittered sphere": jittered_sphere, "sheared strip": sheared_strip, "degenerate": with_degenerate_faces}


@pytest.mark.parametrize("name", SMALL)
def test_operators_equal_the_formulas_written_out(name):
    mesh = SMALL[name]()
    L = cotangent_laplacian(mesh).toarray()
    expected = reference_laplacian(mesh)
    np.testing.assert_allclose(L, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    area = mixed_voronoi_area(mesh)
    assert area.shape == (mesh.n_vertices,)
    np.testing.assert_allclose(area, reference_mixed_area(mesh), rtol=1e-12, atol=1e-15 * area.max())
    np.testing.assert_allclose(angle_defect(mesh), reference_angle_defect(mesh), rtol=0, atol=1e-12)
    np.testing.assert_allclose(vertex_normals(mesh), reference_normals(mesh), rtol=0, atol=1e-14)


def test_laplacian_is_symmetric_negative_semidefinite_with_zero_row_sums():
    for mesh in (synthetic.torus(nu=40, nv=20), jittered_sphere(), sheared_strip()):
        L = cotangent_laplacian(mesh)
        assert (abs(L - L.T)).max() < 1e-12 * abs(L).max()
        np.testing.assert_allclose(np.asarray(L.sum(axis=1)).ravel(), 0, atol=1e-12 * abs(L).max())
        assert (L.diagonal() < 0).all()
        x = np.random.default_rng(0).normal(size=(mesh.n_vertices, 5))
        assert (np.einsum("ij,ij->j", x, L @ x) <= 0).all()


def test_laplacian_of_a_linear_function_is_zero_inside_a_flat_mesh():
    for mesh in (synthetic.flat_disc(), sheared_strip(flat=True)):
        boundary = _boundary(mesh)
        f = mesh.vertices @ np.array([0.3, -1.2, 0.0]) + 0.7
        lf = cotangent_laplacian(mesh) @ f
        scale = abs(cotangent_laplacian(mesh)).max() * np.abs(f).max()
        assert np.abs(lf[~boundary]).max() < 1e-12 * scale
        assert np.abs(lf[boundary]).max() > 1e-3 * scale  # not so on the rim: the test can fail


def test_mixed_areas_sum_to_the_total_area():
    for mesh in (synthetic.icosphere(4), synthetic.cylinder(), synthetic.flat_disc(), jittered_sphere(),
                 sheared_strip()):
        area = mixed_voronoi_area(mesh)
        assert (area > 0).all()
        assert np.isclose(area.sum(), mesh.area(), rtol=1e-12)


@pytest.mark.parametrize("make, euler", [
    (lambda: synthetic.icosphere(4), 2), (jittered_sphere, 2), (synthetic.torus, 0),
    (synthetic.flat_disc, 1), (sheared_strip, 1), (synthetic.cylinder, 0),
])
def test_total_angle_defect_is_two_pi_times_euler_characteristic(make, euler):
    """Gauss-Bonnet; on a mesh with boundary, pi minus the angles at boundary vertices is the
    boundary's turning."""
    assert abs(angle_defect(make()).sum() - 2 * np.pi * euler) < 1e-9


def test_angle_defect_over_area_is_one_over_r_squared_on_a_sphere():
    r = 2.0
    mesh = synthetic.icosphere(5, radius=r)
    np.testing.assert_allclose(angle_defect(mesh) / mixed_voronoi_area(mesh), 1 / r**2, rtol=1e-3)


def test_sphere_normals_point_radially_outward():
    mesh = synthetic.icosphere(4, radius=3.0)
    radial = mesh.vertices / np.linalg.norm(mesh.vertices, axis=1, keepdims=True)
    cosine = np.einsum("ij,ij->i", vertex_normals(mesh), radial)
    assert cosine.min() > math.cos(math.radians(0.5))  # the area weights of unequal faces tilt them a little
    np.testing.assert_allclose(cosine[:12], 1, rtol=1e-14)  # the icosahedron's vertices: symmetric rings
    inward = Mesh(mesh.vertices, mesh.faces[:, ::-1])
    np.testing.assert_allclose(vertex_normals(inward), -vertex_normals(mesh), rtol=0, atol=1e-15)


def test_degenerate_faces_add_nothing_and_unused_vertices_get_zeros():
    mesh = with_degenerate_faces()
    area, normals = mixed_voronoi_area(mesh), vertex_normals(mesh)
    L = cotangent_laplacian(mesh)
    for values in (area, normals, L.toarray(), angle_defect(mesh)):
        assert np.isfinite(values).all()
    square = Mesh(mesh.vertices, mesh.faces[:2])
    np.testing.assert_allclose(L.toarray(), cotangent_laplacian(square).toarray(), atol=1e-15)
    np.testing.assert_allclose(area[:4], 0.25)
    assert (area[4:] == 0).all() and (normals[4:] == 0).all()
    np.testing.assert_allclose(normals[:4], [[0, 0, 1]] * 4)


def _boundary(mesh: Mesh) -> np.ndarray:
    from darcyan.geometry.mesh import boundary_vertices

    return boundary_vertices(mesh)
