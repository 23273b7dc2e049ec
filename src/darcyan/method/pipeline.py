"""The method end to end: describe a shape, match two shapes.

:func:`analyze_shape` runs, for one prepared :class:`~darcyan.geometry.shape.Shape` (see
:func:`~darcyan.geometry.shape.prepare_shape`): Meyer curvatures, AGD, extremities, a Darcyan
grid around each and its curvature descriptor, and what the mirror test needs. Its
:class:`ShapeAnalysis` keeps every intermediate result; the :class:`ShapeDescription` inside it is
the record matching needs, the one :func:`describe_shape` caches on disk. :func:`match_shapes`
matches two descriptions. Feature vertices are always reported in the numbering of the input file.
"""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import DarcyanConfig
from ..errors import MeshError
from ..geometry.curvature import Curvatures
from ..geometry.geodesics import LocalGeodesicSolver
from ..geometry.mesh import Mesh, MeshWarning
from ..geometry.shape import Shape, prepare_shape
from ..io.cache import ShapeCache, code_digest, file_digest
from ..io.mesh_files import load_mesh
from ..parallel import owns_threads, process_map, process_pool
from .descriptors import angular_profiles, curvature_descriptors
from .features import (
    AGD,
    FeaturePoints,
    average_geodesic_distance,
    cut_rim_zone,
    extremities,
    heat_diffuse,
    heat_kernel_diagonal,
    sharpest_tips,
)
from .grid import darcyan_grids, grid_reach
from .matching import (
    Matches,
    consistent_candidates,
    descriptor_distances,
    drop_dissimilar,
    match_descriptors,
    median_distance,
)
from .symmetry import OrientedSurface, shape_signature, weigh_orientations


@dataclass(frozen=True)
class ShapeDescription:
    """What matching needs of one shape: the record that the cache stores.

    Attributes:
        name: the file (or mesh name) described.
        n_input_vertices: vertex count of the input, for range checks of results.
        feature_vertices: ``(k,) int64`` feature points as 0-based vertex indices of the input file.
        feature_agd: ``(k,)`` their AGD, in units of sqrt(area).
        descriptors: ``(k, 2n)`` ``[k1max, k1min, ...]`` per feature point, 1/sqrt(area) units.
        feature_geodesics: ``(k, k)`` geodesic distances between the feature points (sqrt(area)).
        surface: what the mirror test needs (positions, normals, feature distance fields, a point
            signature) on the prepared mesh; see :mod:`darcyan.method.symmetry`.
        changes: repairs applied to the input (empty without ``repair``).
        timings: seconds per stage (``{"cache": 0.0}`` when read from the cache).
    """

    name: str
    n_input_vertices: int
    feature_vertices: np.ndarray
    feature_agd: np.ndarray
    descriptors: np.ndarray
    feature_geodesics: np.ndarray
    surface: OrientedSurface | None = None
    changes: tuple = ()
    timings: dict = field(default_factory=dict, compare=False)

    def __len__(self) -> int:
        return len(self.feature_vertices)

    def arrays(self) -> dict:
        """The record as named arrays (what the cache stores)."""
        arrays = {"feature_vertices": self.feature_vertices, "feature_agd": self.feature_agd,
                  "descriptors": self.descriptors, "feature_geodesics": self.feature_geodesics,
                  "n_input_vertices": np.array(self.n_input_vertices),
                  "changes": np.array(list(self.changes), dtype=str)}
        if self.surface is not None:
            arrays.update({f"surface_{k}": v for k, v in vars(self.surface).items() if v is not None})
        return arrays

    @classmethod
    def from_arrays(cls, name: str, stored: dict) -> "ShapeDescription":
        """The record of :meth:`arrays` (as read from the cache) under ``name``."""
        return cls(
            name=name, n_input_vertices=int(stored["n_input_vertices"]),
            feature_vertices=stored["feature_vertices"], feature_agd=stored["feature_agd"],
            descriptors=stored["descriptors"], feature_geodesics=stored["feature_geodesics"],
            surface=OrientedSurface(stored["surface_points"], stored["surface_normals"],
                                    stored["surface_landmark_distances"], stored.get("surface_signature"),
                                    stored.get("surface_areas"), stored.get("surface_profiles")),
            changes=tuple(str(c) for c in stored["changes"]), timings={"cache": 0.0})


@dataclass(frozen=True, eq=False)
class ShapeAnalysis:
    """A :class:`ShapeDescription` with the prepared :class:`~darcyan.geometry.shape.Shape` and the
    intermediate results that made it (in memory only; see :func:`analyze_shape`).

    Attributes:
        shape: the prepared shape (mesh, solver, curvatures, ... on the area-1 mesh).
        description: the record matching needs.
        curvatures: the smoothed Meyer curvatures the descriptors sample.
        agd: the AGD field; features: the feature points (prepared mesh's numbering);
        grids: one :class:`~darcyan.method.grid.DarcyanGrid` per feature point.
        timings: seconds per stage.
    """

    shape: Shape
    description: ShapeDescription
    curvatures: Curvatures
    agd: AGD
    features: FeaturePoints
    grids: list
    timings: dict = field(default_factory=dict)

    # The record's fields and the shape's, read through (matching and dense maps take either).
    name = property(lambda self: self.description.name)
    n_input_vertices = property(lambda self: self.description.n_input_vertices)
    feature_vertices = property(lambda self: self.description.feature_vertices)
    feature_agd = property(lambda self: self.description.feature_agd)
    descriptors = property(lambda self: self.description.descriptors)
    feature_geodesics = property(lambda self: self.description.feature_geodesics)
    surface = property(lambda self: self.description.surface)
    changes = property(lambda self: self.description.changes)
    mesh = property(lambda self: self.shape.mesh)
    solver = property(lambda self: self.shape.solver)
    normalization = property(lambda self: self.shape.normalization)

    def __len__(self) -> int:
        return len(self.description)


@dataclass(frozen=True)
class Correspondence:
    """Matches from shape 1 to shape 2: for each matched feature point of shape 1, one of shape 2.

    ``source_vertex (k,)`` and ``target_vertex (k,)`` are 0-based vertex indices of the input
    files; ``distance (k,)`` the descriptor L2 distances; ``matches_12`` the same as indices into
    the two feature sets; ``alternatives`` the other matchings the orientation test weighed (best
    first). ``margin``: how far the matching's total in the orientation test stands above the
    runner-up's (exact below the larger of ``config.mirror.verify_below`` and
    ``verify_sparse_below``, ``inf`` without a runner-up); ``in_doubt``: below
    ``verify_below``, so that short dense maps should decide (:func:`darcyan.dense.verified_matches`;
    ``darcyan match`` and ``darcyan bench`` do), and a dense map reads it; ``to_verify``: in
    doubt or below ``verify_sparse_below``: feature matches that no dense map follows are
    verified (:func:`darcyan.api.verification_wanted`).
    ``feature_counts``: ``(k1, k2)`` the feature points of each shape, matched or not (empty:
    not known), which tells a dense map whether every extremity of the shape with fewer is
    anchored by a landmark (:func:`darcyan.dense.signatures.signature_turn_weight`).
    """

    source_vertex: np.ndarray
    target_vertex: np.ndarray
    distance: np.ndarray
    matches_12: Matches
    alternatives: tuple = ()
    margin: float = np.inf
    in_doubt: bool = False
    feature_counts: tuple = ()
    to_verify: bool = False

    def __len__(self) -> int:
        return len(self.source_vertex)

    def to_csv(self) -> str:
        lines = ["source_vertex,target_vertex,distance"]
        lines += [f"{s},{t},{d:.6g}" for s, t, d in zip(self.source_vertex, self.target_vertex, self.distance)]
        return "\n".join(lines) + "\n"


@owns_threads
def analyze_mesh(mesh: Mesh, config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
                 progress=None) -> ShapeAnalysis:
    """Prepare ``mesh`` (:func:`~darcyan.geometry.shape.prepare_shape`) and :func:`analyze_shape` it."""
    start = time.perf_counter()
    if progress:
        progress("prepare")
    shape = prepare_shape(mesh, config, repair)
    return analyze_shape(shape, config, progress, {"prepare": time.perf_counter() - start})


@owns_threads
def analyze_shape(shape: Shape, config: DarcyanConfig = DarcyanConfig(), progress=None,
                  timings: dict | None = None) -> ShapeAnalysis:
    """Describe a prepared shape (see the module docstring); keeps every intermediate result."""
    timings = dict(timings or {})
    say = progress or (lambda stage: None)

    def stage(name):
        timings[name] = time.perf_counter()
        say(name)

    def done(name):
        timings[name] = time.perf_counter() - timings[name]

    normalized = shape.mesh
    edges = normalized.edges()
    mean_edge = float(np.linalg.norm(normalized.vertices[edges[:, 0]] - normalized.vertices[edges[:, 1]], axis=1).mean())
    if mean_edge > config.radius:
        raise MeshError(shape.name, f"mesh too small or coarse for a Darcyan grid of radius {config.radius}: "
                                    f"its mean edge is {mean_edge:.3g} (lengths in sqrt(area) units; "
                                    f"{normalized.n_vertices} vertices)")
    solver = shape.solver
    stage("curvature")
    curvatures = shape.curvatures(config.curvature_smoothing)
    done("curvature")
    stage("agd")
    proxy = shape.proxy(config.proxy_vertices)
    if proxy is None:
        agd = average_geodesic_distance(normalized, solver, config.agd_sources, config.agd_smoothing,
                                        config.heat.diffusion_steps)
    else:
        # The distances on the proxy, the diffusion on the full mesh: diffused on the proxy, the
        # field's maxima would sit on proxy vertices, which decimation places differently in
        # every pose (feature repeatability on michael, tosca-hires: 0.88 there, 1.00 here).
        coarse = average_geodesic_distance(proxy.mesh, proxy.solver, config.agd_sources)
        values = proxy.to_full(coarse.values)
        if config.agd_smoothing > 0:
            values = heat_diffuse(normalized, values, config.agd_smoothing, config.heat.diffusion_steps)
        agd = AGD(values, coarse.sources)
    done("agd")
    stage("features")
    # Exact geodesics only where extremities and grids look; beyond, the proxy's estimate.
    # An extremity's top beyond this radius (up to tip_radius) is read on that estimate too:
    # exact geodesics that far made every ball and grid about 40% dearer on the 52k humans.
    local = LocalGeodesicSolver(solver, max(config.extremity_radius, grid_reach(config)),
                                None if proxy is None else proxy.distance, config.margins.ball)
    distances: dict = {}
    near_rim, rims = cut_rim_zone(normalized, solver, config)
    features = extremities(normalized, local, agd, config, distances, near_rim)
    if features.at_rims:
        warnings.warn(f"{shape.name}: an open surface ({rims} boundary loop{'s' if rims > 1 else ''} at least "
                      f"{config.rims.min_length:g} sqrt(area) long: a partial shape?); {features.at_rims} "
                      f"extremit{'ies' if features.at_rims > 1 else 'y'} at the rim of a cut left out",
                      MeshWarning, stacklevel=2)
    if len(features) == 0:
        raise MeshError(shape.name, "no feature points found (no extremity stands out on this shape)")
    if config.tip_gain > 0 and config.agd_smoothing > 0:
        heat = _heat_kernel(shape, proxy, config)
        features = sharpest_tips(features, agd.values, heat, distances, config, near_rim)
    done("features")
    stage("descriptors")
    centre_vertex = int(np.argmin(agd.values))
    centre = solver.distance(centre_vertex) if proxy is None else proxy.distance(centre_vertex)
    grids = darcyan_grids(normalized, local, features.vertices, config, distances, toward=centre, normals=shape.normals)
    if proxy is None:  # the feature points' exact fields (the grids made those of moved tips): kept for later stages
        for vertex in features.vertices:
            shape.keep_distance_field(vertex, distances[int(vertex)])
    descriptors = curvature_descriptors(normalized, grids, curvatures)
    if not np.isfinite(descriptors).any(axis=1).any():
        raise MeshError(shape.name, f"mesh too small to carry a Darcyan grid of radius {config.radius} "
                                    f"(in sqrt(area) units)")
    done("descriptors")
    stage("layout")
    geodesics = feature_geodesics(features.vertices, distances)
    surface = OrientedSurface(
        normalized.vertices.astype(np.float32), shape.normals.astype(np.float32),
        np.array([distances[int(v)] for v in features.vertices], dtype=np.float32),
        _signature(shape, config).astype(np.float32), curvatures.area.astype(np.float32),
        angular_profiles(normalized, grids, curvatures, config.mirror.profile_levels).astype(np.float32))
    done("layout")
    description = ShapeDescription(
        name=shape.name, n_input_vertices=shape.n_input_vertices,
        feature_vertices=normalized.input_index[features.vertices], feature_agd=features.agd,
        descriptors=descriptors, feature_geodesics=geodesics, surface=surface,
        changes=tuple(shape.changes), timings=timings)
    return ShapeAnalysis(shape, description, curvatures, agd, features, grids, timings)


def _heat_kernel(shape: Shape, proxy, config: DarcyanConfig) -> np.ndarray:
    """``(n,)`` heat kernel diagonal at the AGD diffusion's scale, on the proxy when it has at
    least ``config.heat.vertices`` vertices, else on a copy of that size or the mesh itself."""
    if proxy is None or proxy.mesh.n_vertices < config.heat.vertices:
        proxy = shape.proxy(config.heat.vertices)
    if proxy is None:
        return heat_kernel_diagonal(shape.mesh, config.agd_smoothing, config.heat)
    return proxy.to_full(heat_kernel_diagonal(proxy.mesh, config.agd_smoothing, config.heat))


def _signature(shape: Shape, config: DarcyanConfig) -> np.ndarray:
    """The mirror test's point signature, on the coarse proxy when there is one."""
    return shape_signature(shape, config.proxy_vertices, config.mirror.signature_lengths, config.heat.diffusion_steps,
                           config.curvature_smoothing)


def feature_geodesics(vertices: np.ndarray, distances: dict) -> np.ndarray:
    """``(k, k)`` geodesic distances between feature ``vertices``, from their distance fields."""
    geodesics = np.array([[distances[int(b)][int(a)] for b in vertices] for a in vertices]).reshape(len(vertices), -1)
    return 0.5 * (geodesics + geodesics.T)  # fast marching is not exactly symmetric


@owns_threads
def load_shape(path: str | os.PathLike, config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
               warn: bool = True) -> Shape:
    """The :class:`~darcyan.geometry.shape.Shape` of a mesh file, prepared exactly as
    :func:`describe_shape` prepares it (``warn=False``: without saying again what a description
    of the same file already said)."""
    with warnings.catch_warnings():
        if not warn:
            warnings.simplefilter("ignore", MeshWarning)
        return prepare_shape(load_mesh(path), config, repair)


@owns_threads
def describe_shape(source: str | os.PathLike | Mesh, config: DarcyanConfig = DarcyanConfig(),
                   repair: bool = False, cache: ShapeCache | None = None, progress=None) -> ShapeDescription:
    """The :class:`ShapeDescription` of a mesh file (or :class:`Mesh`); with ``cache``, reuse
    earlier work on the same file content and parameters. (:func:`analyze_mesh` keeps the
    intermediate results too.)"""
    if isinstance(source, Mesh):
        return analyze_mesh(source, config, repair, progress).description
    path = Path(source)
    key = _cache_key(cache, path, config, repair)
    stored = _cached(cache, key, path)
    if stored is not None:
        return stored
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MeshWarning)
        description = analyze_mesh(load_mesh(path), config, repair, progress).description
    said = _reemit(caught)
    if cache is not None:
        cache.save(key, {**description.arrays(), "warnings": np.array(said, dtype=str)})
    return description


@owns_threads
def describe_shapes(sources: list, config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
                    cache: ShapeCache | None = None, jobs: int = 1) -> list:
    """:func:`describe_shape` each file of ``sources``; with ``jobs > 1``, the files not found in
    the cache are described at once in up to ``jobs`` worker processes. A description made in a
    worker holds only the cacheable part, as one read from the cache."""
    return _descriptions(sources, config, repair, cache, jobs)[0]


@owns_threads
def describe_keeping_first(sources: list, config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
                           cache: ShapeCache | None = None, jobs: int = 1) -> tuple:
    """``(descriptions, shape)``: :func:`describe_shapes`, and the first file's prepared
    :class:`~darcyan.geometry.shape.Shape` when this process prepared it anyway, beside workers
    describing the others (``None`` otherwise: its description came from the cache, or was made
    in turn or in a worker). Kept at no cost, so that a verification of the first file's matches
    (``darcyan match``'s source) does not prepare it again (0.3 s of a 52k pair in doubt)."""
    return _descriptions(sources, config, repair, cache, jobs, keep_first=True)


def _descriptions(sources: list, config: DarcyanConfig, repair: bool, cache: ShapeCache | None, jobs: int,
                  keep_first: bool = False) -> tuple:
    """``(descriptions, first shape or None)`` of :func:`describe_keeping_first`."""
    paths = [Path(s) for s in sources]
    keys = [_cache_key(cache, p, config, repair) for p in paths]
    results = [_cached(cache, k, p) for k, p in zip(keys, paths)]
    todo = [i for i, r in enumerate(results) if r is None]
    if jobs <= 1 or len(todo) <= 1:
        return [r if r is not None else describe_shape(p, config, repair, cache) for r, p in zip(results, paths)], None
    described = _describe_files(paths, keys, results, config, repair, cache, jobs, keep_first=keep_first)
    return [description for description, _ in described], described[0][1]


@owns_threads
def describe_and_prepare(sources: list, config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
                         cache: ShapeCache | None = None, jobs: int = 1, extra=None) -> list:
    """``[(description, shape)]``: for each file of ``sources`` its :func:`describe_shape`
    description (from ``cache`` when there) and its prepared :class:`~darcyan.geometry.shape.Shape`
    (as :func:`load_shape` makes it), on which ``extra(shape, feature_vertices)`` (the
    description's, input numbering), when given, has been called: what it builds on the shape
    (e.g. a dense map's basis, its feature points' distance fields) is kept with it. With ``jobs > 1``
    the files are prepared, described and extended at once in up to ``jobs`` worker processes,
    and each shape comes back with what was built on it
    (:meth:`~darcyan.geometry.shape.Shape.__getstate__`). ``extra`` must be picklable then (a
    module-level function or a ``functools.partial`` of one)."""
    paths = [Path(s) for s in sources]
    keys = [_cache_key(cache, p, config, repair) for p in paths]
    results = [_cached(cache, k, p) for k, p in zip(keys, paths)]
    return _describe_files(paths, keys, results, config, repair, cache, jobs, keep_shapes=True, extra=extra)


def _describe_files(paths: list, keys: list, results: list, config: DarcyanConfig, repair: bool, cache,
                    jobs: int, keep_shapes: bool = False, extra=None, keep_first: bool = False) -> list:
    """``[(description, shape or None)]`` of :func:`describe_shapes` and :func:`describe_and_prepare`:
    the files whose description ``results`` lacks (``None``) described, and, with ``keep_shapes``,
    every file prepared (``extra(shape, feature_vertices)`` called on it) and its shape returned
    (with ``keep_first``, the first file's when it is described in this process: no pickling);
    the work spread over processes by :func:`_across_processes`, the new descriptions saved
    under ``keys``."""
    run = [i for i, described in enumerate(results) if keep_shapes or described is None]
    here = _first_runs_here(len(run), jobs)
    # A known description travels as its feature points alone: all that extra reads of it.
    tasks = [(paths[i], config, repair, None if results[i] is None else results[i].feature_vertices,
              keep_shapes or (keep_first and here and i == 0), extra) for i in run]
    shapes = [None] * len(paths)
    for i, (arrays, said, shape) in zip(run, _across_processes(_prepared, tasks, jobs)):
        shapes[i] = shape
        if results[i] is None:
            for message in said:
                warnings.warn(message, MeshWarning, stacklevel=3)
            if cache is not None:
                cache.save(keys[i], {**arrays, "warnings": np.array(said, dtype=str)})
            results[i] = _from_arrays(paths[i], arrays)
    return list(zip(results, shapes))


def _first_runs_here(tasks: int, jobs: int) -> bool:
    """Whether :func:`_across_processes` runs the first of ``tasks`` tasks in this process."""
    return jobs <= 1 or tasks <= jobs


def _across_processes(function, tasks: list, jobs: int) -> list:
    """``[function(task) for task in tasks]`` in order: here with ``jobs`` 1 or a single task;
    this process beside workers when the tasks fit in ``jobs`` (:func:`_beside_workers`); else
    in ``jobs`` worker processes (:func:`_first_runs_here` tells which)."""
    if jobs <= 1 or len(tasks) <= 1:
        return [function(task) for task in tasks]
    if _first_runs_here(len(tasks), jobs):
        return _beside_workers(function, tasks)
    import scipy.sparse.csgraph  # noqa: F401  (imported lazily by the mesh checks: once, before the workers fork)

    return list(process_map(function, tasks, jobs, ordered=True))


def _beside_workers(function, tasks: list) -> list:
    """``[function(task) for task in tasks]``: the first in this process, the others at the same
    time in worker processes (one process fewer to start; the first result needs no pickling,
    and the imports it makes serve what follows)."""
    with process_pool(len(tasks) - 1) as pool:
        others = [pool.submit(function, task) for task in tasks[1:]]
        first = function(tasks[0])
        return [first, *(future.result() for future in others)]


def _prepared(task: tuple) -> tuple:
    """``(arrays, warnings, shape)`` of :func:`_describe_files` for one file (``arrays``: ``None``
    when its description was already known, from the cache, and the task carries its feature
    points; ``shape``: ``None`` unless kept, so that a worker sends back only the description);
    in a worker process or not."""
    path, config, repair, known_features, keep_shape, extra = task
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MeshWarning)
        shape = prepare_shape(load_mesh(path), config, repair)
        arrays = None
        if known_features is None:
            description = analyze_shape(shape, config).description
            arrays, known_features = description.arrays(), description.feature_vertices
    said = [str(w.message) for w in caught if issubclass(w.category, MeshWarning)]
    for w in caught:  # the others (a library's own) are said here, in whichever process
        if not issubclass(w.category, MeshWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if extra is not None:
        extra(shape, known_features)
    return arrays, said, shape if keep_shape else None


def _cache_key(cache: ShapeCache | None, path: Path, config: DarcyanConfig, repair: bool) -> str | None:
    if cache is None:
        return None
    return cache.key(file_digest(path), config.describe_fingerprint(), f"repair={repair}", f"code={code_digest()}")


def _cached(cache: ShapeCache | None, key: str | None, path: Path) -> ShapeDescription | None:
    """The description stored under ``key``, its warnings said again; ``None`` on a miss."""
    stored = None if cache is None else cache.load(key)
    if stored is None or not _CACHED_KEYS <= stored.keys():
        return None
    for message in stored.get("warnings", ()):
        warnings.warn(str(message), MeshWarning, stacklevel=3)  # a cache hit says what a run said
    return _from_arrays(path, stored)


def _from_arrays(path: Path, stored: dict) -> ShapeDescription:
    return ShapeDescription.from_arrays(str(path), stored)


def _reemit(caught: list) -> list:
    """Warn again what a recorded block warned; the messages of its mesh warnings."""
    said = []
    for w in caught:
        if issubclass(w.category, MeshWarning):
            said.append(str(w.message))
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return said


# What a cache entry must hold to be used (older entries without them are recomputed).
_CACHED_KEYS = {"feature_vertices", "feature_agd", "descriptors", "feature_geodesics", "n_input_vertices",
                "changes", "surface_points", "surface_normals", "surface_landmark_distances", "surface_areas",
                "surface_profiles"}


@owns_threads
def match_shapes(shape_1: ShapeDescription, shape_2: ShapeDescription,
                 config: DarcyanConfig = DarcyanConfig()) -> Correspondence:
    """Match the feature points of ``shape_1`` to those of ``shape_2`` by descriptor distance."""
    alternatives: list = []
    margin = np.inf
    if config.matching == "consistent":
        candidates = consistent_candidates(shape_1.descriptors, shape_2.descriptors, shape_1.feature_geodesics,
                                           shape_2.feature_geodesics, config.consistency)
        matches, margin = weigh_orientations(candidates, shape_1.surface, shape_2.surface, config.mirror,
                                             near=max(config.mirror.verify_below, config.mirror.verify_sparse_below))
        alternatives = [m for _, m in candidates[:config.mirror.candidates] if m is not matches]
    else:
        matches = match_descriptors(shape_1.descriptors, shape_2.descriptors, config.matching)

    median = median_distance(descriptor_distances(shape_1.descriptors, shape_2.descriptors))
    feature_counts = (len(shape_1.feature_vertices), len(shape_2.feature_vertices))

    def correspondence(matches: Matches, alternatives=(), margin=np.inf) -> Correspondence:
        matches = drop_dissimilar(matches, shape_1.descriptors, shape_2.descriptors, config.max_match_distance,
                                  median)
        doubt = bool(margin < config.mirror.verify_below and alternatives)
        return Correspondence(shape_1.feature_vertices[matches.source], shape_2.feature_vertices[matches.target],
                              matches.distance, matches, tuple(alternatives), float(margin), doubt, feature_counts,
                              doubt or bool(margin < config.mirror.verify_sparse_below and alternatives))

    return correspondence(matches, [correspondence(m) for m in alternatives], margin)


@owns_threads
def match_files(source, target, config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
                cache: ShapeCache | None = None, jobs: int = 1) -> Correspondence:
    """:func:`describe_shapes` both files (in ``jobs`` processes) and :func:`match_shapes` them."""
    return match_shapes(*describe_shapes([source, target], config, repair, cache, jobs), config)
