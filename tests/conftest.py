"""Shared fixtures: analytic meshes built by the package, and the TOSCA data when present."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from darcyan import synthetic

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
