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

from ..errors import DarcyanError, MeshError
from ..geometry.geodesics import GeodesicSolver
from ..geometry.mesh import Mesh

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


# ---------------------------------------------------------------------------------------------
# Ground truth on meshes whose numbering differs from the file's (prepared meshes)


def nearest_samples(solver: GeodesicSolver, vertices: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """``(k,)`` for each of ``vertices`` the position in ``samples`` of the geodesically nearest
    sample; both given as vertex indices of the solver's mesh (one fast-marching field each)."""
    samples = np.asarray(samples, dtype=np.int64)
    out = np.empty(len(vertices), dtype=np.int64)
    for i, p in enumerate(np.asarray(vertices, dtype=np.int64)):
        out[i] = int(np.argmin(solver.distance(int(p))[samples]))
    return out


def input_to_mesh_index(mesh: Mesh, input_vertices: np.ndarray, input_positions: np.ndarray | None = None) -> np.ndarray:
    """``(k,)`` indices into ``mesh`` of vertices given in the input file's numbering.

    ``mesh.input_index`` maps each vertex of ``mesh`` to the file; a file vertex that preparation
    left out (a small component, an unreferenced vertex) is sent to the mesh vertex nearest its
    position ``input_positions[v]`` (``(n_input, 3)``, in ``mesh``'s coordinates), or refused
    without positions.
    """
    input_vertices = np.asarray(input_vertices, dtype=np.int64)
    size = int(max(mesh.input_index.max(initial=-1), input_vertices.max(initial=-1))) + 1
    inverse = np.full(size, -1, dtype=np.int64)
    inverse[mesh.input_index] = np.arange(mesh.n_vertices)
    out = inverse[input_vertices]
    missing = out < 0
    if missing.any():
        if input_positions is None:
            raise MeshError(mesh.name, f"vertex {int(input_vertices[missing][0])} of the file is not on the prepared mesh")
        from scipy.spatial import cKDTree

        _, nearest = cKDTree(mesh.vertices).query(np.asarray(input_positions)[input_vertices[missing]])
        out[missing] = nearest
    return out


# ---------------------------------------------------------------------------------------------
# Scores of one pair and their aggregation


@dataclass(frozen=True)
class PairScore:
    """The matches of one source shape to one target, scored.

    Attributes:
        features: source feature points considered.
        errors: ``(k,)`` geodesic error of each match, sqrt(area) units (k = matches).
        errors_sym: ``(k,)`` the same against the mirror ground truth (``NaN`` without one).
        repeatable: ``(features,) bool``: some target feature point lies within the threshold of
            the true correspondent of the source feature point (detection succeeded there).
        repeatable_sym: the same for the mirror correspondent (or the strict one).
    """

    features: int
    errors: np.ndarray
    errors_sym: np.ndarray
    repeatable: np.ndarray
    repeatable_sym: np.ndarray


def score_pair(target_solver: GeodesicSolver, matched: np.ndarray, truth: np.ndarray,
               truth_sym: np.ndarray | None, target_features: np.ndarray, threshold: float = DEFAULT_THRESHOLD,
               match_rows: np.ndarray | None = None, fields: dict | None = None) -> PairScore:
    """Score matches on a target mesh of area 1 (all indices are vertices of the solver's mesh).

    Args:
        matched: ``(k,)`` target vertex of each match.
        truth: ``(f,)`` true correspondent of each source feature point; ``truth_sym`` its mirror
            image (``None``: no mirror ground truth).
        target_features: ``(t,)`` the target's feature points (for repeatability).
        match_rows: ``(k,)`` which source feature each match starts from (default: match i from
            feature i).
        fields: a dict reused across calls on the same target to keep distance fields.
    """
    fields = {} if fields is None else fields
    scale = np.sqrt(target_solver.mesh.area())

    def field(v: int) -> np.ndarray:
        if v not in fields:
            fields[v] = target_solver.distance(v) / scale
        return fields[v]

    matched = np.asarray(matched, dtype=np.int64)
    truth = np.asarray(truth, dtype=np.int64)
    rows = np.arange(len(matched)) if match_rows is None else np.asarray(match_rows, dtype=np.int64)
    target_features = np.asarray(target_features, dtype=np.int64)
    errors = np.array([field(int(truth[r]))[q] for r, q in zip(rows, matched)], dtype=np.float64)
    repeatable = np.array([len(target_features) > 0 and field(int(t))[target_features].min() <= threshold
                           for t in truth], dtype=bool)
    if truth_sym is None:
        errors_sym = np.full(len(matched), np.nan)
        repeatable_sym = repeatable
    else:
        truth_sym = np.asarray(truth_sym, dtype=np.int64)
        errors_sym = np.array([field(int(truth_sym[r]))[q] for r, q in zip(rows, matched)], dtype=np.float64)
        repeatable_sym = repeatable | np.array(
            [len(target_features) > 0 and field(int(t))[target_features].min() <= threshold for t in truth_sym],
            dtype=bool)
    return PairScore(len(truth), errors, errors_sym, repeatable, repeatable_sym)


def flip_tolerant_errors(errors: np.ndarray, errors_sym: np.ndarray) -> np.ndarray:
    """Per match the smaller of the strict and mirror errors (the strict one without mirror)."""
    errors = np.asarray(errors, dtype=np.float64)
    errors_sym = np.asarray(errors_sym, dtype=np.float64)
    return np.where(np.isfinite(errors_sym), np.fmin(errors, errors_sym), errors)


SUMMARY_KEYS = ("pairs", "features", "matches", "correct", "correct_sym", "rate", "rate_sym", "recall",
                "recall_sym", "repeatability", "repeatability_sym", "mean_error")


def summarize(scores: list, threshold: float = DEFAULT_THRESHOLD, taus: np.ndarray = CURVE_TAUS) -> dict:
    """Pooled statistics of several :class:`PairScore` (or dicts with the same fields).

    ``rate = correct / matches`` and ``rate_sym`` pool every match of the pairs given;
    ``recall = correct / features`` counts per source feature point (lower than the rate when a
    matcher leaves points unmatched);
    ``repeatability`` pools their source feature points; ``curve``/``curve_sym`` are the shares of
    matches with (flip-tolerant) error <= each of ``taus``. Rates of an empty set are ``None``.
    """
    def get(s, name):
        return getattr(s, name) if not isinstance(s, dict) else s[name]

    errors = np.concatenate([np.asarray(get(s, "errors"), dtype=np.float64) for s in scores]) if scores else np.zeros(0)
    errors_sym = (np.concatenate([np.asarray(get(s, "errors_sym"), dtype=np.float64) for s in scores])
                  if scores else np.zeros(0))
    tolerant = flip_tolerant_errors(errors, errors_sym)
    features = int(sum(int(get(s, "features")) for s in scores))
    repeatable = int(sum(int(np.sum(get(s, "repeatable"))) for s in scores))
    repeatable_sym = int(sum(int(np.sum(get(s, "repeatable_sym"))) for s in scores))
    matches = len(errors)
    correct = int((errors <= threshold).sum())
    correct_sym = int((tolerant <= threshold).sum())

    def share(a, b):
        return a / b if b else None

    return {
        "pairs": len(scores), "features": features, "matches": matches, "correct": correct,
        "correct_sym": correct_sym, "rate": share(correct, matches), "rate_sym": share(correct_sym, matches),
        "recall": share(correct, features), "recall_sym": share(correct_sym, features),
        "repeatability": share(repeatable, features), "repeatability_sym": share(repeatable_sym, features),
        "mean_error": float(errors.mean()) if matches else None,
        "curve": cumulative_curve(errors, taus).tolist(), "curve_sym": cumulative_curve(tolerant, taus).tolist(),
    }


# ---------------------------------------------------------------------------------------------
# A mirror (left-right) map derived from the geometry, for data without .sym.vts

MIRROR_ITERATIONS = 12  # plane refinements (reflect, nearest neighbours, refit)


@dataclass(frozen=True)
class MirrorMap:
    """A reflective self-map of one mesh: ``vertices (n,)`` the mirror image of each vertex,
    ``residual`` the mean distance from a reflected vertex to its image (sqrt(area) units; 0 for
    an exactly symmetric mesh), ``normal (3,)`` and ``offset`` the plane ``normal . x = offset``."""

    vertices: np.ndarray
    residual: float
    normal: np.ndarray
    offset: float


def reflection_symmetry(mesh: Mesh, iterations: int = MIRROR_ITERATIONS) -> MirrorMap:
    """The mirror map of the best reflection plane of ``mesh``.

    Each principal axis of the area-weighted vertex cloud starts a plane through the centroid; the
    plane is refined by iterating: reflect the vertices, pair each with the nearest vertex to its
    reflection, refit the normal as the principal direction of the pairs' differences and the
    offset from their midpoints. The plane with the smallest residual wins. This is extrinsic:
    it holds on a pose that is (nearly) symmetric, and for shapes sharing its vertex numbering.
    """
    from scipy.spatial import cKDTree

    from ..geometry.operators import mixed_voronoi_area

    scale = np.sqrt(mesh.area())
    x = mesh.vertices / scale
    w = mixed_voronoi_area(mesh) / scale**2
    w = w / w.sum()
    centre = w @ x
    x = x - centre
    tree = cKDTree(x)
    _, axes = np.linalg.eigh((x * w[:, None]).T @ x)
    best = None
    for normal in axes.T:
        offset = 0.0
        for _ in range(iterations):
            reflected = x - 2.0 * (x @ normal - offset)[:, None] * normal
            dist, image = tree.query(reflected)
            diff = x - x[image]
            _, vecs = np.linalg.eigh((diff * w[:, None]).T @ diff)
            new = vecs[:, -1] * (1.0 if vecs[:, -1] @ normal >= 0 else -1.0)
            normal = new
            offset = float(w @ ((x + x[image]) / 2.0 @ normal))
        reflected = x - 2.0 * (x @ normal - offset)[:, None] * normal
        dist, image = tree.query(reflected)
        residual = float(w @ dist)
        if best is None or residual < best.residual:
            best = MirrorMap(np.asarray(image, dtype=np.int64), residual, normal.copy(),
                             offset + float(normal @ centre))
    return best


def mirror_agreement(solver: GeodesicSolver, mirror: np.ndarray, samples: np.ndarray,
                     sym_samples: np.ndarray) -> np.ndarray:
    """``(k,)`` geodesic distance (sqrt(area) units) on the solver's mesh between the derived
    mirror image ``mirror[samples[i]]`` and the listed one ``sym_samples[i]`` (``.sym.vts``),
    to validate a derived mirror map."""
    scale = np.sqrt(solver.mesh.area())
    out = np.empty(len(samples))
    fields: dict = {}
    for i, (s, m) in enumerate(zip(samples, sym_samples)):
        if int(m) not in fields:
            fields[int(m)] = solver.distance(int(m))
        out[i] = fields[int(m)][int(mirror[int(s)])] / scale
    return out


# ---------------------------------------------------------------------------------------------
# The matches of one pair against a ground truth given on the command line


def read_truth(spec: str, source_vertices: int | None = None, target_vertices: int | None = None) -> GroundTruth:
    """Ground truth from a command-line spec: ``identity`` (the two files share one vertex
    numbering: refused when their vertex counts differ), or ``A.vts,B.vts`` (line i of both files
    is the same body point; 1-based indices, checked against the vertex counts when given)."""
    spec = str(spec).strip()
    if spec == "identity":
        if source_vertices is not None and target_vertices is not None and source_vertices != target_vertices:
            raise DarcyanError(f"--truth identity: the source has {source_vertices} vertices and the target "
                               f"{target_vertices}; identity needs one vertex numbering (give SOURCE.vts,TARGET.vts)")
        return GroundTruth.identity()
    parts = [p for p in spec.split(",") if p]
    if len(parts) != 2:
        raise DarcyanError(f"--truth: expected 'identity' or 'SOURCE.vts,TARGET.vts', got {spec!r}")
    a, b = read_vts(parts[0], source_vertices), read_vts(parts[1], target_vertices)
    if len(a) != len(b):
        raise MeshError(parts[1], f"{len(b)} samples but {parts[0]} has {len(a)}: the lists must correspond line by line")
    return GroundTruth(a, b)


@dataclass(frozen=True)
class MatchScore:
    """Errors of a pair's matches against a ground truth.

    Attributes:
        errors: ``(k,)`` geodesic distance on the area-1 target from each matched point to the
            true one (a true correspondent the preparation left out counts at the prepared vertex
            nearest it, as in ``darcyan bench``).
        true_points: ``(k,)`` the true correspondents as vertices of the prepared target.
        threshold: a match is correct when its error is at most this.
    """

    errors: np.ndarray
    true_points: np.ndarray
    threshold: float = DEFAULT_THRESHOLD

    @property
    def correct(self) -> int:
        return int((self.errors <= self.threshold).sum())

    def __len__(self) -> int:
        return len(self.errors)

    def summary(self) -> str:
        """``"k of n matches correct (error <= 0.05 sqrt(area))"``."""
        unknown = int(np.isnan(self.errors).sum())
        tail = f"; {unknown} without a known true correspondent" if unknown else ""
        return f"{self.correct} of {len(self)} matches correct (error <= {self.threshold:g} sqrt(area){tail})"


def score_matches(source, target, correspondence, truth: GroundTruth,
                  threshold: float = DEFAULT_THRESHOLD) -> MatchScore:
    """Score ``correspondence`` (vertices in the files' numbering) from prepared shape ``source``
    to ``target`` (:class:`~darcyan.geometry.shape.Shape`) against ``truth``. The true
    correspondent of a matched source point is, for ``.vts`` truth, that of the geodesically
    nearest listed source sample (the same rule as ``darcyan bench``)."""
    if truth.source_samples is None:
        if source.n_input_vertices != target.n_input_vertices:
            raise MeshError(target.name, f"identity ground truth needs one vertex numbering: the source has "
                                         f"{source.n_input_vertices} vertices, this file {target.n_input_vertices}")
        true_input = np.asarray(correspondence.source_vertex, dtype=np.int64)
    else:
        for samples, shape in ((truth.source_samples, source), (truth.target_samples, target)):
            if len(samples) and int(samples.max()) >= shape.n_input_vertices:
                raise MeshError(shape.name, f"ground-truth vertex {int(samples.max()) + 1} (1-based) out of range "
                                            f"1..{shape.n_input_vertices}")
        # as darcyan bench does: a listed vertex the preparation left out counts at its nearest
        listed = source.mesh_index(truth.source_samples, nearest=True)
        points = source.mesh_index(correspondence.source_vertex)
        true_input = truth.target_samples[nearest_samples(source.solver, points, listed)]
    true_points = target.mesh_index(true_input, nearest=True)
    matched = target.mesh_index(correspondence.target_vertex)
    errors = np.full(len(true_points), np.nan)
    scale = np.sqrt(target.mesh.area())
    for i, (q, q_true) in enumerate(zip(matched, true_points)):
        if q_true >= 0 and q >= 0:
            errors[i] = target.solver.distance(int(q_true))[q] / scale
    return MatchScore(errors, true_points, threshold)
