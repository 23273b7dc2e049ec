"""Scoring matches against ground truth (kept apart from the method).

The error of a match p -> q on target T is ``d_T(q, q*) / sqrt(area(T))``, the fast-marching
geodesic distance between q and p's true correspondent q*, over the square root of T's area
(Kim, Lipman and Funkhouser, *Blended Intrinsic Maps*, 2011). A match is correct when its error
is at most the threshold (0.05 by convention).

Ground truth comes as a :class:`GroundTruth`: the identity on vertex indices (meshes of one
class in ``tosca-hires``), or ``.vts`` sample lists (line i of A.vts and of B.vts are the same
body point; ``.sym.vts`` its mirror image), where p's correspondent is that of the listed sample
nearest to p.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import MeshError
from .geodesics import GeodesicSolver
from .mesh import Mesh

DEFAULT_THRESHOLD = 0.05
CURVE_TAUS = np.linspace(0.0, 0.25, 51)


def read_vts(path: str | Path, n_vertices: int | None = None) -> np.ndarray:
    """``(k,) int64`` 0-based vertex indices from a ``.vts`` file of 1-based indices."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise MeshError(path, f"cannot read ground truth ({exc.strerror or exc})") from None
    try:
        values = np.array([int(float(line.split()[0])) for line in text.splitlines() if line.strip()], dtype=np.int64)
    except ValueError:
        raise MeshError(path, "ground truth must hold one integer vertex index per line") from None
    if len(values) == 0 or values.min() < 1 or (n_vertices is not None and values.max() > n_vertices):
        raise MeshError(path, f"vertex indices out of range 1..{n_vertices}")
    return values - 1


@dataclass(frozen=True)
class GroundTruth:
    """Corresponding samples: ``source_samples[i]`` on the source is ``target_samples[i]`` on the
    target. ``None`` samples mean the identity on vertex indices."""

    source_samples: np.ndarray | None = None
    target_samples: np.ndarray | None = None

    @classmethod
    def identity(cls) -> "GroundTruth":
        return cls()

    def true_targets(self, source_vertices: np.ndarray, source_solver: GeodesicSolver | None = None) -> np.ndarray:
        """True correspondents on the target of ``source_vertices`` (input numbering)."""
        source_vertices = np.asarray(source_vertices, dtype=np.int64)
        if self.source_samples is None:
            return source_vertices
        out = np.empty(len(source_vertices), dtype=np.int64)
        for i, p in enumerate(source_vertices):
            hit = np.flatnonzero(self.source_samples == p)
            if len(hit):
                out[i] = self.target_samples[hit[0]]
            else:  # nearest listed sample along the surface
                d = source_solver.distance(int(p))
                out[i] = self.target_samples[int(np.argmin(d[self.source_samples]))]
        return out


def geodesic_errors(target_mesh: Mesh, target_solver: GeodesicSolver, matched: np.ndarray,
                    truth: np.ndarray) -> np.ndarray:
    """``(k,)`` errors ``d_T(matched_i, truth_i) / sqrt(area(T))``.

    ``matched`` and ``truth`` are vertex indices of ``target_mesh`` as given to the solver.
    """
    scale = np.sqrt(target_mesh.area())
    errors = np.empty(len(matched))
    fields: dict = {}
    for i, (q, q_true) in enumerate(zip(matched, truth)):
        if int(q_true) not in fields:
            fields[int(q_true)] = target_solver.distance(int(q_true))
        errors[i] = fields[int(q_true)][int(q)] / scale
    return errors


def cumulative_curve(errors: np.ndarray, taus: np.ndarray = CURVE_TAUS) -> np.ndarray:
    """Share of ``errors`` at or below each threshold in ``taus``."""
    errors = np.asarray(errors)
    if len(errors) == 0:
        return np.zeros(len(taus))
    return (errors[None, :] <= taus[:, None]).mean(axis=1)
