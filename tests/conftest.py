"""Shared fixtures: analytic meshes built by the package, and the TOSCA data when present.

Markers (declared in pyproject.toml):

* ``data``: added here, at collection, to every test that uses the ``tosca`` fixture, directly or
  through another fixture; that fixture is the only way a test reaches ``../shared/data``
  (tests/test_markers.py checks both). Nothing to write by hand.
* ``slow``: written by hand (``@pytest.mark.slow``) on every test over about ``SLOW_SECONDS``, so
  that ``python -m pytest -q -m "not slow"`` stays under two minutes. A run lists at its end the
  unmarked tests that took longer (setup included): mark them, or make them faster.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from darcyan.geometry import synthetic

REPO = Path(__file__).resolve().parents[1]
SLOW_SECONDS = 5.0


@pytest.hookimpl(tryfirst=True)  # before ``-m`` deselects by marker
def pytest_collection_modifyitems(config, items):
    for item in items:
        if "tosca" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.data)


_UNMARKED_SECONDS: dict = {}  # node id -> setup + call seconds, for tests without the slow marker


def pytest_runtest_makereport(item, call):
    if call.when in ("setup", "call") and item.get_closest_marker("slow") is None:
        _UNMARKED_SECONDS[item.nodeid] = _UNMARKED_SECONDS.get(item.nodeid, 0.0) + call.duration


def pytest_terminal_summary(terminalreporter):
    over = sorted(((s, n) for n, s in _UNMARKED_SECONDS.items() if s > SLOW_SECONDS), reverse=True)
    if over:
        terminalreporter.section(f"over {SLOW_SECONDS:g} s without @pytest.mark.slow (setup included)")
        for seconds, nodeid in over:
            terminalreporter.write_line(f"{seconds:6.1f} s  {nodeid}")


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
def faust(tosca) -> Path:
    """``faust-5k`` beside the TOSCA data (skips when it is not there)."""
    folder = tosca / "faust-5k"
    if not folder.is_dir():
        pytest.skip(f"faust-5k not found at {folder}")
    return folder


def vts_truth(folder: Path, source: str, target: str):
    """The ``.vts`` ground truth from shape ``source`` to ``target`` of a dataset ``folder``."""
    from darcyan.eval.metrics import GroundTruth, read_vts

    return GroundTruth(read_vts(folder / "corres" / f"{source}.vts"), read_vts(folder / "corres" / f"{target}.vts"))


@pytest.fixture(scope="session")
def sphere():
    return synthetic.icosphere(subdivisions=5, radius=2.0)  # 10,242 vertices


@pytest.fixture(scope="session")
def figure_poses():
    return synthetic.figure(0), synthetic.figure(1)


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    """``$DARCYAN_CACHE`` in the test's own folder (a module's tests all take it with
    ``pytestmark = pytest.mark.usefixtures("private_cache")``)."""
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    """``darcyan *argv`` in this process: (exit status, stdout, stderr)."""
    from darcyan.cli import main

    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


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
    pairs, errors = match_errors(folder, a, b, cache, config)
    return int((errors < threshold).sum()), len(pairs)


def match_errors(folder: Path, a: str, b: str, cache, config=None) -> tuple[list, np.ndarray]:
    """The matches of ``a`` -> ``b`` in ``folder`` (tosca-5k) as (source, target) vertex pairs,
    and each one's Euclidean distance to its true counterpart by the vts ground truth (the
    target's vertex on the line of ``a``'s vts nearest the source vertex), over sqrt(area)."""
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
    pairs = [(int(s), int(t)) for s, t in zip(matches.source_vertex, matches.target_vertex)]
    return pairs, error / np.sqrt(mesh_2.area())
