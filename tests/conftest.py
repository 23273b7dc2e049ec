"""Shared fixtures: analytic meshes built by the package, and the TOSCA data when present."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from darcyan.geometry import synthetic

REPO = Path(__file__).resolve().parents[1]


def data_dir() -> Path:
    """``$DARCYAN_DATA`` or ``../shared/data`` beside the repository."""
    return Path(os.environ.get("DARCYAN_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def tosca() -> Path:
    root = data_dir()
    if not (root / "tosca-hires").is_dir():
        pytest.skip(f"TOSCA data not found at {root} (set DARCYAN_DATA)")
    return root


@pytest.fixture(scope="session")
def sphere():
    return synthetic.icosphere(subdivisions=5, radius=2.0)  # 10,242 vertices


@pytest.fixture(scope="session")
def figure_poses():
    return synthetic.figure(0), synthetic.figure(1)


def random_rotation(seed: int = 0) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))  # a proper rotation


def noisy_copy(mesh, fraction: float, seed: int = 0):
    """``mesh`` with Gaussian vertex noise of ``fraction`` of its bounding-box diagonal."""
    sigma = fraction * np.linalg.norm(np.ptp(mesh.vertices, axis=0))
    return mesh.with_vertices(mesh.vertices + np.random.default_rng(seed).normal(scale=sigma, size=mesh.vertices.shape))


def correct_matches(folder: Path, a: str, b: str, cache, config=None, threshold: float = 0.1) -> tuple[int, int]:
    """(correct, all) matches of ``a`` -> ``b`` in ``folder`` (tosca-5k) by its vts ground truth:
    Euclidean error under ``threshold`` times sqrt(area) (0.1, about a hand's length: a swapped
    hand or foot is ~10x farther)."""
    from scipy.spatial import cKDTree

    from darcyan import DarcyanConfig, describe_shape, match_shapes
    from darcyan.eval.metrics import read_vts
    from darcyan.io.mesh_files import load_mesh

    config = DarcyanConfig() if config is None else config
    shape_1, shape_2 = (describe_shape(folder / f"{name}.off", config, cache=cache) for name in (a, b))
    matches = match_shapes(shape_1, shape_2, config)
    mesh_1, mesh_2 = load_mesh(folder / f"{a}.off"), load_mesh(folder / f"{b}.off")
    vts_1, vts_2 = read_vts(folder / "corres" / f"{a}.vts"), read_vts(folder / "corres" / f"{b}.vts")
    line = cKDTree(mesh_1.vertices[vts_1]).query(mesh_1.vertices[matches.source_vertex])[1]
    error = np.linalg.norm(mesh_2.vertices[vts_2[line]] - mesh_2.vertices[matches.target_vertex], axis=1)
    return int((error < threshold * np.sqrt(mesh_2.area())).sum()), len(matches)
