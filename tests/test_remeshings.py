"""The remeshed copies that ``benchmarks/robustness.py`` benches darcyan on are the meshes it says
(half the faces, ground truth at the vertex nearest the original one; four times the faces on the
same surface, numbering and ground truth kept)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from darcyan.geometry import synthetic
from darcyan.geometry.mesh import Mesh
from darcyan.io.mesh_files import load_mesh, save_mesh

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "robustness.py"


@pytest.fixture(scope="module")
def robustness():
    spec = importlib.util.spec_from_file_location("robustness_bench", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """An ellipsoid (widest along x) with a ground-truth file of every 7th vertex (one-based)."""
    folder = tmp_path_factory.mktemp("source")
    sphere = synthetic.icosphere(subdivisions=4)
    save_mesh(Mesh(sphere.vertices * [1.5, 1.0, 1.0], sphere.faces), folder / "egg.off")
    (folder / "corres").mkdir()
    lines = np.arange(0, sphere.n_vertices, 7)
    np.savetxt(folder / "corres" / "egg.vts", lines + 1, fmt="%d")
    return folder


def copy(robustness, dataset, tmp_path, condition):
    robustness.perturbed_dataset(dataset, tmp_path, condition)
    return load_mesh(tmp_path / "egg.off"), np.loadtxt(tmp_path / "corres" / "egg.vts", dtype=np.int64) - 1


def test_decimated_copy_has_half_the_faces_and_truth_at_the_nearest_vertex(robustness, dataset, tmp_path):
    original = load_mesh(dataset / "egg.off")
    mesh, truth = copy(robustness, dataset, tmp_path, "decimated")
    assert abs(mesh.n_faces / original.n_faces - 0.5) < 0.02
    lines = np.loadtxt(dataset / "corres" / "egg.vts", dtype=np.int64) - 1
    gaps = np.linalg.norm(mesh.vertices[None, :, :] - original.vertices[lines][:, None, :], axis=2)
    assert np.array_equal(truth, gaps.argmin(axis=1))


def test_subdivided_copy_keeps_the_surface_and_the_numbering(robustness, dataset, tmp_path):
    original = load_mesh(dataset / "egg.off")
    mesh, truth = copy(robustness, dataset, tmp_path, "subdivided")
    assert mesh.n_faces == 4 * original.n_faces
    assert np.array_equal(mesh.vertices[:original.n_vertices], original.vertices)
    # every new vertex is the midpoint of an edge of the original mesh: the same surface
    e = original.edges()
    midpoints = 0.5 * (original.vertices[e[:, 0]] + original.vertices[e[:, 1]])
    new = mesh.vertices[original.n_vertices:]
    assert len(new) == len(e)
    gaps = cKDTree(midpoints).query(new)[0]
    assert gaps.max() < 1e-6  # the OFF file rounds coordinates; edges are about 0.05 long
    assert np.isclose(mesh.area(), original.area())
    assert np.array_equal(truth, np.loadtxt(dataset / "corres" / "egg.vts", dtype=np.int64) - 1)


def _euler(mesh: Mesh) -> int:
    edges = np.unique(np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    return mesh.n_vertices - len(edges) + mesh.n_faces


def test_marching_cubes_copy_of_a_thin_part_is_one_closed_sphere_at_the_offset(robustness):
    # A disc 3% as thick as it is wide: where a part is this thin, the side of the nearest
    # sample's normal (the first copies' sign) put grid points on the wrong side and cut handles.
    sphere = synthetic.icosphere(subdivisions=4)
    disc = Mesh(sphere.vertices * [1.5, 1.0, 0.03], sphere.faces)
    step, offset = robustness.LEVEL_SETS["marching-cubes"]
    copy_ = robustness.level_set_copy(disc, step, offset)
    assert _euler(copy_) == 2  # genus 0, closed
    assert abs(copy_.n_vertices - disc.n_vertices) <= 0.01 * disc.n_vertices
    import igl

    distance = igl.signed_distance(copy_.vertices, disc.vertices, disc.faces.astype(np.int64))[0]
    scale = np.sqrt(disc.area())
    assert np.all(distance > 0)  # outside the input
    assert abs(np.median(distance) / scale - offset) < step  # at the offset, within a grid step


def test_glued_copy_fuses_parts_closer_than_twice_the_offset(robustness):
    step, offset = robustness.LEVEL_SETS["glued"]
    sphere = synthetic.icosphere(subdivisions=3)
    area_one = np.sqrt(2 * sphere.area())  # two spheres: the pair's sqrt(area)
    for gap, parts in ((0.5 * offset, 1), (4 * offset, None)):
        shift = 2.0 + gap * area_one
        pair = Mesh(np.vstack([sphere.vertices, sphere.vertices + [shift, 0, 0]]),
                    np.vstack([sphere.faces, sphere.faces + sphere.n_vertices]))
        copy_ = robustness.level_set_copy(pair, step, offset)
        spans = copy_.vertices[:, 0].max() - copy_.vertices[:, 0].min()
        if parts == 1:  # one surface around both: it spans both spheres
            assert spans > shift + 1.5 and _euler(copy_) == 2
        else:  # the copy keeps the larger part only: one sphere
            assert spans < 2.5
