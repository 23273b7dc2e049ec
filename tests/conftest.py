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

from darcyan import DarcyanConfig
from darcyan.dense.config import DenseConfig
from darcyan.geometry import synthetic
from darcyan.geometry.mesh import Mesh
from darcyan.io.mesh_files import save_mesh
from darcyan.method.pipeline import Correspondence, analyze_mesh, match_shapes

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


# ----------------------------------------------------------------------------------------------
# Dense maps (tests/test_dense_*.py)

# A lighter dense stage than the default, so the tests take seconds (same method).
FAST_DENSE = DenseConfig(zoomout_samples=1000, basis_size=40)
DENSE_SCORED = 300  # source vertices scored per map
# Measured on figure pose 0 -> 1 with FAST_DENSE: 1.000 within 0.05, mean error 0.007 (the default
# DenseConfig: 1.000 and 0.005); the floors leave a margin.
DENSE_MIN_RATE, DENSE_MAX_MEAN = 0.9, 0.02


@pytest.fixture(scope="session")
def figure_pair():
    """The figure in poses 0 and 1, analysed, and their default matches."""
    config = DarcyanConfig()
    shape_1, shape_2 = (analyze_mesh(synthetic.figure(pose), config) for pose in (0, 1))
    return shape_1, shape_2, match_shapes(shape_1, shape_2, config)


def tip_correspondence(source_tips, target_tips):
    """A correspondence of the given tip vertices, pairwise, without alternatives."""
    n = len(source_tips)
    return Correspondence(np.asarray(source_tips), np.asarray(target_tips), np.zeros(n), None)


@pytest.fixture
def small_pose_files(tmp_path, monkeypatch):
    """The figure in poses 0 and 1 as small OFF files, with a private cache."""
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))
    paths = []
    for pose in (0, 1):
        path = tmp_path / f"figure{pose}.off"
        save_mesh(synthetic.figure(pose, subdivisions=4), path)
        paths.append(path)
    return paths


def moved_and_mirrored_tip_fields(mesh, seed: int):
    """``[(name, shape, fields)]`` for ``mesh`` as is, moved rigidly (a seeded rotation and a shift)
    and mirrored: each prepared, with its distances ``(n, 3)`` to three of the figure's tips."""
    from darcyan.geometry.shape import prepare_shape

    rotation, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    copies = {"as is": mesh, "moved": Mesh(mesh.vertices @ rotation.T + 5.0, mesh.faces),
              "mirrored": Mesh(mesh.vertices * [-1, 1, 1], mesh.faces[:, ::-1])}
    tips = synthetic.figure_tips()[:3]
    out = []
    for name, copy in copies.items():
        shape = prepare_shape(copy)
        out.append((name, shape, np.stack([shape.solver.distance(int(t)) for t in tips], axis=1)))
    return out


def faust_pair(faust, source: str, target: str):
    """Two FAUST shapes prepared, their default matches and the .vts ground truth between them."""
    from darcyan.method.pipeline import describe_shape, load_shape

    config = DarcyanConfig()
    files = faust / f"{source}.off", faust / f"{target}.off"
    correspondence = match_shapes(*[describe_shape(f, config) for f in files], config)
    return [load_shape(f, config, warn=False) for f in files], correspondence, vts_truth(faust, source, target)
