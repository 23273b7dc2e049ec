"""Scores of dense maps against ground truth on a fixed random sample of source vertices."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.geodesics import GeodesicSolver, LocalGeodesicSolver
from ..geometry.mesh import Mesh, local_index
from .metrics import DEFAULT_THRESHOLD, GroundTruth, cumulative_curve

DENSE_SAMPLE = 1000  # source vertices scored by evaluate_dense
DENSE_SEED = 0  # its numpy.random.default_rng seed
# A target of more vertices than this is scored through geodesic balls around each true
# correspondent (the same errors bit for bit, see _distances_at): on TOSCA's 52k-vertex meshes a
# whole fast marching per sampled vertex made scoring most of a benchmark's time.
BALL_SCORING_ABOVE = 20_000
# The balls' radius (sqrt(area) units): errors up to it (most of a right map's) are read on the
# ball, larger ones on the whole mesh's field. Their margin (a share of the radius) over the
# Euclidean distance that cuts them. The cut's own check (every vertex on the cut beyond the
# radius) makes the values exact; Euclidean distance, a lower bound of the geodesic one, only
# keeps the check from failing and the margin from doubling. Measured once on 30 random vertices
# of tosca-hires david11 (52k vertices): a ball of 0.05 holds 13% of the vertices and costs a
# third of a whole fast marching (33 ms against 104 ms; 0.1: 21%, 55 ms).
BALL_SCORING_RADIUS = 0.05
BALL_SCORING_MARGIN = 0.2



@dataclass(frozen=True)
class DenseEvaluation:
    """Errors of a dense map on a sample of source vertices.

    ``source_vertices (s,)`` input numbering; ``errors (s,)`` geodesic error / sqrt(target area).
    """

    source_vertices: np.ndarray
    errors: np.ndarray
    threshold: float = DEFAULT_THRESHOLD

    @property
    def rate(self) -> float:
        """Share of sampled vertices within ``threshold``."""
        return float((self.errors <= self.threshold).mean()) if len(self.errors) else 0.0

    @property
    def mean(self) -> float:
        return float(self.errors.mean()) if len(self.errors) else float("nan")

    def curve(self, taus=None) -> np.ndarray:
        return cumulative_curve(self.errors) if taus is None else cumulative_curve(self.errors, taus)


def evaluate_dense(source_mesh: Mesh, target_mesh: Mesh, target: np.ndarray, truth: GroundTruth = GroundTruth(),
                   sample: int = DENSE_SAMPLE, seed: int = DENSE_SEED, target_solver: GeodesicSolver | None = None,
                   threshold: float = DEFAULT_THRESHOLD) -> DenseEvaluation:
    """Score the dense map ``target`` (source input vertex -> target input vertex).

    ``source_mesh``/``target_mesh`` are the analysed meshes (``input_index`` relates them to the
    files; errors are measured on ``target_mesh`` and divided by the square root of its area).
    With identity ``truth`` the sample is drawn from the source vertices; with ``.vts`` truth
    from the listed source samples (their correspondents are known exactly). ``sample`` vertices
    are drawn with ``numpy.random.default_rng(seed)`` (all when fewer), so two maps of the same
    pair are scored on the same vertices. Unmapped sampled vertices get an infinite error.
    """
    return evaluate_dense_maps(source_mesh, target_mesh, {"map": target}, truth, sample, seed, target_solver,
                               threshold)["map"]


def evaluate_dense_maps(source_mesh: Mesh, target_mesh: Mesh, targets: dict, truth: GroundTruth = GroundTruth(),
                        sample: int = DENSE_SAMPLE, seed: int = DENSE_SEED,
                        target_solver: GeodesicSolver | None = None,
                        threshold: float = DEFAULT_THRESHOLD) -> dict:
    """:func:`evaluate_dense` of several maps of one pair (``targets``: name -> map) at once: the
    same sampled source vertices for all, one fast-marching field per true correspondent read
    for every map (memory O(V); on a target of more than ``BALL_SCORING_ABOVE`` vertices a
    geodesic ball around it, the whole field only for images beyond the ball: the same values).
    Returns name -> :class:`DenseEvaluation`."""
    if truth.source_samples is None:
        candidates = source_mesh.input_index
        true_targets = candidates
    else:
        candidates = np.asarray(truth.source_samples, dtype=np.int64)
        true_targets = np.asarray(truth.target_samples, dtype=np.int64)
    targets = {name: np.asarray(t, dtype=np.int64) for name, t in targets.items()}
    shortest = min((len(t) for t in targets.values()), default=0)
    in_source = local_index(source_mesh, candidates) >= 0
    true_local = local_index(target_mesh, true_targets)
    usable = np.flatnonzero(in_source & (true_local >= 0) & (candidates < shortest))
    if len(usable) > sample:
        usable = np.sort(np.random.default_rng(seed).choice(usable, size=sample, replace=False))
    sources = candidates[usable]
    truth_local = true_local[usable]
    mapped = {name: local_index(target_mesh, t[sources]) for name, t in targets.items()}
    errors = {name: np.full(len(sources), np.inf) for name in targets}
    solver = target_solver or GeodesicSolver(target_mesh)
    scale = np.sqrt(target_mesh.area())
    balls = None
    if target_mesh.n_vertices > BALL_SCORING_ABOVE:
        positions = target_mesh.vertices
        balls = LocalGeodesicSolver(solver, BALL_SCORING_RADIUS * scale,
                                    lambda v: np.linalg.norm(positions - positions[v], axis=1), BALL_SCORING_MARGIN)
    unique, inverse, counts = np.unique(truth_local, return_inverse=True, return_counts=True)
    groups = np.split(np.argsort(inverse, kind="stable"), np.cumsum(counts)[:-1])
    for q_true, rows in zip(unique, groups):
        wanted = [(name, rows[m[rows] >= 0]) for name, m in mapped.items()]
        if not any(len(r) for _, r in wanted):
            continue
        images = np.unique(np.concatenate([mapped[name][r] for name, r in wanted]))
        distances = _distances_at(solver, balls, int(q_true), images)
        for name, r in wanted:
            errors[name][r] = distances[np.searchsorted(images, mapped[name][r])] / scale
    return {name: DenseEvaluation(sources, errors[name], threshold) for name in targets}


def _distances_at(solver: GeodesicSolver, balls: LocalGeodesicSolver | None, source: int,
                  vertices: np.ndarray) -> np.ndarray:
    """``(k,)`` ``solver.distance(source)[vertices]`` (mesh units) for ``vertices (k,)``: with
    ``balls``, read on the geodesic ball around ``source`` where they lie within its radius
    (fast marching there gives the whole mesh's values bit for bit,
    :class:`~darcyan.geometry.geodesics.LocalGeodesicSolver`), and on the whole mesh's field
    only when one lies beyond."""
    if balls is None:
        return solver.distance(source)[vertices]
    ball = balls.ball(source, keep=False)
    if ball.distance is None:  # the ball is the whole mesh
        return solver.distance(source)[vertices]
    near = ball.distance
    in_ball = np.full(solver.mesh.n_vertices, -1, dtype=np.int64)
    in_ball[ball.vertices] = np.arange(len(ball.vertices))
    at = in_ball[vertices]
    out = np.where(at >= 0, near[np.maximum(at, 0)], np.inf)
    beyond = ~(out <= balls.radius)
    if beyond.any():
        out[beyond] = solver.distance(source)[vertices[beyond]]
    return out
