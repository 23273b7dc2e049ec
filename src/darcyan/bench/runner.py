"""The evaluation harness behind ``darcyan bench``: correspondence rates on a folder of meshes.

A dataset is a folder of meshes named ``{class}{pose}.off|.ply|.obj`` (the class is the name
without its trailing digits). Ground truth comes from ``corres/{shape}.vts`` when that folder
exists (line i of A.vts and B.vts are the same body point, 1-based; ``corres/{shape}.sym.vts``
its mirror image), else it is the identity on vertex indices within a class (which needs equal
vertex counts). Pairs are every ordered pair within a class, or the ``source<TAB>target`` lines
of a pairs file.

Every method is evaluated at darcyan's own feature points of the source shape, on the same
targets and with the same metric (:mod:`darcyan.eval.metrics`), so the tables compare
descriptors, not set-ups:

- ``darcyan``: the Darcyan curvature descriptor, matched by :func:`darcyan.match_shapes` with
  the run's configuration (``config.matching``);
- ``hks`` / ``wks``: heat / wave kernel signatures (:mod:`darcyan.eval.baselines`) at the same
  feature points, matched by the same function (the descriptors swapped in);
- ``pyfm``: pyfmaps' dense functional map read at the source feature points.

The run has two phases, both parallel (``jobs`` local processes, or a ``dask.distributed``
scheduler): per-shape work (description, spectra, nearest ground-truth samples, cached on disk
by file content and parameters) and per-pair work (matching and scoring; all methods of a pair
share the target's distance fields). Each finished pair is appended to ``pairs.jsonl`` in the
output folder at once, and the summaries (``results.json``, ``pairs.csv``, ``report.md``) are
rewritten as pairs finish, so an interrupted run loses nothing and ``resume`` skips what is done.

With ``dense=True`` (``darcyan bench --dense``) each pair also gets dense maps, scored on a fixed
random sample of source vertices (``dense_samples``, default 1000, ``numpy.random.default_rng(0)``,
the same vertices for every method; for vts data the sample is drawn among the listed
``corres/*.vts`` samples, whose correspondents are exact) with the same metric:

- ``darcyan``: :func:`darcyan.dense.dense_map` (default :class:`~darcyan.dense.DenseConfig`)
  seeded by darcyan's sparse matches;
- ``pyfm`` (when ``pyfm`` is among the methods): pyFM's own pipeline without darcyan's landmarks
  (:func:`darcyan.dense.pyfm_own_map`: WKS, a 50 x 50 functional map, ZoomOut to 200).

They go to ``results.json`` under ``dense.<method>.overall|classes|pairs``, a section of
``report.md`` and ``dense_curve.png``.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import sys
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import DarcyanConfig
from ..dense import pyfm
from ..errors import DarcyanError, require
from ..eval.dense_scores import DENSE_SAMPLE, DENSE_SEED
from ..eval.metrics import (
    CURVE_TAUS,
    DEFAULT_THRESHOLD,
    mirror_agreement,
    nearest_samples,
    read_vts,
    reflection_symmetry,
    score_pair,
    summarize,
)
from ..geometry import spectral as lbo
from ..geometry.shape import Shape
from ..io.cache import ShapeCache, code_digest, file_digest
from ..parallel import process_map
from . import DENSE_METHODS, METHODS

DENSE = "dense"  # the "kind" of a dense record in the journal (sparse records have no kind)
MESH_SUFFIXES = (".off", ".ply", ".obj")
TRUTH_FOLDER = "corres"
MIRROR_MAX_RESIDUAL = 0.005  # a pose whose best reflection leaves more (sqrt(area) units) is not symmetric
MIRROR_VALIDATION_SAMPLES = 200  # .sym.vts samples compared with a derived mirror map
WRITE_INTERVAL = 2.0  # seconds between rewrites of the summaries while pairs finish
PROGRESS_INTERVAL = 30.0  # seconds between progress lines when stderr is not a terminal
PREPARED_MEMO = 3  # prepared meshes kept per worker process (tasks come grouped by target)
RATE_DEFINITION = (
    "rate = correct / matches, pooled over every match of the class's pairs (with nearest-descriptor "
    "matching every source feature point gets one match); 'all' pools every match of the run; 'mean over classes' is the unweighted mean "
    "of the class rates (the paper's Fig. 8 reports one rate per class). recall = correct / source "
    "feature points: it differs from the rate only when a matcher leaves feature points unmatched.")
DENSE_DEFINITION = (
    "Dense maps: each method maps every source vertex; per pair a fixed random sample of source vertices "
    "(numpy.random.default_rng(seed), the same vertices for every method; with vts ground truth drawn among the "
    "listed corres/*.vts samples, whose correspondents are exact; with identity ground truth among all vertices) "
    "is scored by geodesic error / sqrt(target area). rate = sampled vertices within the threshold / sampled "
    "vertices, pooled over the pairs (a pair whose map failed counts as 0 within); mean_error pools the mapped "
    "samples; seconds = the dense stage only (darcyan: dense_map after the sparse matches; pyfm: its whole "
    "pipeline, its spectra included).")

JOURNAL = "pairs.jsonl"
SETTINGS = "run.json"


# ---------------------------------------------------------------------------------------------
# Datasets and pairs


def shape_class(name: str) -> str:
    """The class of a shape: its name without trailing digits (``cat10`` -> ``cat``)."""
    return re.sub(r"\d+$", "", name) or name


def _pose_key(name: str):
    match = re.search(r"(\d+)$", name)
    return (shape_class(name), int(match.group(1)) if match else -1, name)


@dataclass(frozen=True)
class Dataset:
    """A folder of meshes: ``shapes`` name -> file, ``classes`` class -> names (by pose number),
    ``truth`` ``"vts"`` (``corres/*.vts``) or ``"identity"``."""

    root: Path
    shapes: dict
    classes: dict
    truth: str

    def vts(self, name: str, mirror: bool = False) -> Path:
        return self.root / TRUTH_FOLDER / (f"{name}.sym.vts" if mirror else f"{name}.vts")


def discover_dataset(root: str | os.PathLike) -> Dataset:
    """Read a dataset folder (see the module docstring); clear errors for an unusable one."""
    root = Path(root)
    if not root.is_dir():
        raise DarcyanError(f"{root}: not a folder")
    shapes: dict = {}
    for path in sorted(root.iterdir()):
        if path.suffix.lower() not in MESH_SUFFIXES or not path.is_file():
            continue
        if path.stem in shapes:
            raise DarcyanError(f"{root}: two meshes named {path.stem} ({shapes[path.stem].name}, {path.name})")
        shapes[path.stem] = path
    if not shapes:
        raise DarcyanError(f"{root}: no meshes ({', '.join(MESH_SUFFIXES)}) in this folder")
    names = sorted(shapes, key=_pose_key)
    shapes = {n: shapes[n] for n in names}
    classes: dict = {}
    for n in names:
        classes.setdefault(shape_class(n), []).append(n)
    truth_dir = root / TRUTH_FOLDER
    truth = "vts" if truth_dir.is_dir() and any(truth_dir.glob("*.vts")) else "identity"
    if truth == "vts":
        missing = [n for n in names if not (truth_dir / f"{n}.vts").is_file()]
        if missing:
            raise DarcyanError(f"{truth_dir / (missing[0] + '.vts')}: ground truth missing "
                               f"({len(missing)} shape(s) without .vts)")
    return Dataset(root, shapes, classes, truth)


def default_pairs(dataset: Dataset) -> list:
    """Every ordered pair of distinct shapes within each class."""
    return [(a, b) for names in dataset.classes.values() for a in names for b in names if a != b]


def read_pairs(path: str | os.PathLike, dataset: Dataset, groups: dict | None = None) -> list:
    """``source<TAB>target[<TAB>group]`` lines (blank lines and ``#`` comments skipped; names with
    or without the mesh suffix). A third column names the pair's group (e.g. ``same`` and
    ``two people`` for FAUST), recorded in ``groups`` ``{(source, target): group}``; results are
    then also given per group (a pair without one is in its class's group)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot read ({exc.strerror or exc})") from None
    pairs = []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split("\t") if "\t" in line else line.split(maxsplit=2)
        if len(parts) not in (2, 3) or not all(p.strip() for p in parts):
            raise DarcyanError(f"{path}: line {number}: expected 'source<TAB>target[<TAB>group]', got {line!r}")
        names = []
        for part in parts[:2]:
            name = part.strip()
            stem = Path(name).stem if Path(name).suffix.lower() in MESH_SUFFIXES else name
            if stem not in dataset.shapes:
                raise DarcyanError(f"{path}: line {number}: no mesh named {name!r} in {dataset.root}")
            names.append(stem)
        pairs.append(tuple(names))
        if len(parts) == 3 and groups is not None:
            groups[tuple(names)] = parts[2].strip()
    if not pairs:
        raise DarcyanError(f"{path}: no pairs in this file")
    return pairs


# ---------------------------------------------------------------------------------------------
# Settings of a run


@dataclass(frozen=True)
class BenchSettings:
    """What a run computes; results of runs with other settings are never mixed."""

    methods: tuple
    threshold: float = DEFAULT_THRESHOLD
    config: DarcyanConfig = field(default_factory=DarcyanConfig)
    laplacian: str = "cotangent"
    repair: bool = False
    dense: bool = False
    dense_samples: int = DENSE_SAMPLE
    dense_seed: int = DENSE_SEED

    @property
    def dense_methods(self) -> tuple:
        """The dense maps of a pair: darcyan's, and pyFM's own when ``pyfm`` is a method."""
        return tuple(m for m in DENSE_METHODS if m == "darcyan" or m in self.methods) if self.dense else ()

    def dense_settings(self) -> dict | None:
        """What the dense results depend on (``None`` without ``dense``)."""
        if not self.dense:
            return None
        import dataclasses

        from ..dense import maps as dense

        return {"samples": self.dense_samples, "seed": self.dense_seed,
                "config": dataclasses.asdict(dense.DenseConfig()),
                "pyfm": dataclasses.asdict(pyfm.DENSE_PIPELINE)}

    def as_dict(self) -> dict:
        import dataclasses

        from ..eval import baselines

        return {"methods": list(self.methods), "threshold": self.threshold, "config": self.config.as_dict(),
                "laplacian": self.laplacian, "repair": self.repair, "dense": self.dense_settings(),
                "baselines": {"spectrum_size": lbo.SPECTRUM_SIZE,
                              "signature_samples": baselines.SIGNATURE_SAMPLES,
                              "pyfm": dataclasses.asdict(pyfm.README_PIPELINE)}}

    def comparable(self) -> dict:
        """The settings that must match for resumed results to be reused (not the method list;
        the dense settings are compared apart, when both runs have them)."""
        d = self.as_dict()
        d.pop("methods")
        d.pop("dense")
        return d


# ---------------------------------------------------------------------------------------------
# Per-shape work (runs in workers)


_MEMO: OrderedDict = OrderedDict()


def prepared_shape(path: str | os.PathLike, repair: bool = False, config: DarcyanConfig = DarcyanConfig()) -> Shape:
    """The :class:`~darcyan.geometry.shape.Shape` of ``path``, prepared exactly as the description
    was (:func:`~darcyan.geometry.shape.prepare_shape`), memoized for the last few files of this
    process (with the operators built on it)."""
    key = (str(path), repair, config.prepare_fingerprint())
    if key in _MEMO:
        _MEMO.move_to_end(key)
        return _MEMO[key]
    from ..method.pipeline import load_shape

    item = load_shape(path, config, repair, warn=False)  # the description already said what it changed
    _MEMO[key] = item
    while len(_MEMO) > PREPARED_MEMO:
        _MEMO.popitem(last=False)
    return item


def _cache_of(task: dict) -> ShapeCache | None:
    return None if task["no_cache"] else ShapeCache(task["cache_dir"])


def _cached(cache: ShapeCache | None, key_parts: tuple, compute):
    """``compute()`` (a dict of arrays) through ``cache``; returns (arrays, computed?)."""
    if cache is not None:
        key = cache.key("bench", f"code={code_digest()}", *key_parts)
        stored = cache.load(key)
        if stored is not None:
            return stored, False
    arrays = compute()
    if cache is not None:
        cache.save(key, arrays)
    return arrays, True


def _shape_task(task: dict) -> dict:
    """Per-shape work; returns a small dict (or ``{"error": message}``)."""
    try:
        return _shape_work(task)
    except DarcyanError as exc:  # sent back as text: the package's exceptions need not pickle
        return {"error": str(exc), "name": task["name"]}


def _shape_work(task: dict) -> dict:
    from ..eval import baselines
    from ..method.pipeline import describe_shape

    settings: BenchSettings = task["settings"]
    path, repair = Path(task["path"]), settings.repair
    cache = _cache_of(task)
    digest = file_digest(path)
    seconds: dict = {}
    start = time.perf_counter()
    description = describe_shape(path, settings.config, repair, cache)
    seconds["darcyan"] = time.perf_counter() - start
    features = np.asarray(description.feature_vertices, dtype=np.int64)
    record = {"name": task["name"], "n_input_vertices": int(description.n_input_vertices),
              "features": features, "description": description,
              "descriptors": {"darcyan": description.descriptors}, "seconds": seconds}
    feature_key = file_digest_bytes(features.tobytes())

    spectral = [m for m in settings.methods if m in baselines.SPECTRAL_METHODS]
    if spectral:
        start = time.perf_counter()
        spectrum_arrays, _ = _cached(
            cache, (digest, "spectrum", settings.laplacian, str(lbo.SPECTRUM_SIZE), f"repair={repair}", settings.config.prepare_fingerprint()),
            lambda: _spectrum_arrays(prepared_shape(path, repair, settings.config), settings.laplacian))
        spectrum = lbo.Spectrum(spectrum_arrays["values"], spectrum_arrays["vectors"].astype(np.float64),
                                      spectrum_arrays["mass"])
        # Feature points lie on the prepared mesh: its input_index (cached with the spectrum) finds them.
        inverse = np.full(description.n_input_vertices, -1, dtype=np.int64)
        inverse[spectrum_arrays["input_index"]] = np.arange(len(spectrum_arrays["input_index"]))
        at = inverse[features]
        for method in spectral:
            record["descriptors"][method] = baselines.spectral_descriptors(method, spectrum, at)
            seconds[method] = time.perf_counter() - start
    if "pyfm" in settings.methods and cache is not None:
        start = time.perf_counter()
        _cached(cache, (digest, "pyfm-spectrum", str(pyfm.README_PIPELINE.spectrum), f"repair={repair}",
                        settings.config.prepare_fingerprint()),
                lambda: _pyfm_spectrum_arrays(prepared_shape(path, repair, settings.config).mesh))
        seconds["pyfm"] = time.perf_counter() - start
    if task.get("vts"):
        arrays, _ = _cached(
            cache, (digest, "nearest-samples", file_digest(task["vts"]), feature_key, f"repair={repair}",
                   settings.config.prepare_fingerprint()),
            lambda: {"nearest": _nearest_samples(path, repair, settings.config, features, task["vts"], description.n_input_vertices)})
        record["nearest_sample"] = arrays["nearest"]
    return record


def file_digest_bytes(data: bytes) -> str:
    import hashlib

    return hashlib.sha1(data).hexdigest()


def _spectrum_arrays(shape: Shape, laplacian: str) -> dict:
    s = shape.spectrum(lbo.SPECTRUM_SIZE, laplacian=laplacian)
    return {"values": s.values, "vectors": s.vectors.astype(np.float32), "mass": s.mass,
            "input_index": shape.mesh.input_index}


def _pyfm_spectrum_arrays(mesh) -> dict:
    values, vectors = pyfm.pyfm_spectrum(mesh, pyfm.README_PIPELINE.spectrum)
    return {"values": values, "vectors": vectors.astype(np.float32)}


def _nearest_samples(path, repair, config, features, vts_path, n_input) -> np.ndarray:
    shape = prepared_shape(path, repair, config)
    samples = read_vts(vts_path, n_input)
    return nearest_samples(shape.solver, shape.mesh_index(features, nearest=True), shape.mesh_index(samples, nearest=True))


# ---------------------------------------------------------------------------------------------
# Mirror ground truth for identity data, and its validation where .sym.vts exists


def class_mirror(dataset: Dataset, cls: str, repair: bool = False, cache: ShapeCache | None = None,
                 config: DarcyanConfig = DarcyanConfig()) -> dict:
    """The mirror map of a class with identity ground truth.

    All poses of such a class share one vertex numbering, so a mirror map found on one pose holds
    for all: the poses are tried in pose order and the first whose best reflection plane leaves a
    residual of at most ``MIRROR_MAX_RESIDUAL`` (a symmetric rest pose) gives the map
    (:func:`darcyan.eval.metrics.reflection_symmetry`, in input numbering). Returns
    ``{"shape", "residual", "vertices"}`` (``vertices`` ``None`` when no pose is symmetric: then
    no symmetric flip is counted for this class).
    """
    best = {"shape": None, "residual": None, "vertices": None}
    for name in dataset.classes[cls]:
        path = dataset.shapes[name]
        arrays, _ = _cached(cache, (file_digest(path), "mirror", f"repair={repair}", config.prepare_fingerprint()),
                            lambda: _mirror_arrays(path, repair, config))
        residual = float(arrays["residual"])
        if best["residual"] is None or residual < best["residual"]:
            best = {"shape": name, "residual": residual, "vertices": None}
        if residual <= MIRROR_MAX_RESIDUAL:
            best["vertices"] = arrays["vertices"]
            break
    return best


def _mirror_arrays(path, repair, config: DarcyanConfig) -> dict:
    shape = prepared_shape(path, repair, config)
    mirror = reflection_symmetry(shape.mesh)
    vertices = np.full(shape.n_input_vertices, -1, dtype=np.int64)
    vertices[shape.mesh.input_index] = shape.mesh.input_index[mirror.vertices]
    missing = vertices < 0  # file vertices left out by preparation: the image of their nearest vertex
    if missing.any():
        vertices[missing] = shape.mesh.input_index[mirror.vertices[shape.mesh_index(np.flatnonzero(missing), nearest=True)]]
    return {"vertices": vertices, "residual": np.array(mirror.residual)}


def validate_mirror(dataset: Dataset, cls: str, repair: bool = False, cache: ShapeCache | None = None,
                    config: DarcyanConfig = DarcyanConfig(),
                    samples: int = MIRROR_VALIDATION_SAMPLES) -> dict | None:
    """Check the derived mirror map against ``.sym.vts`` on a class of a vts dataset.

    On the first pose of ``cls`` with a ``.sym.vts``: derive the mirror map as for identity data
    and measure, at ``samples`` evenly spread lines of the ``.vts``, the geodesic distance
    (sqrt(area) units) between the derived mirror image and the listed one. Returns
    ``{"shape", "residual", "median_error", "within_threshold"}`` or ``None`` without ``.sym.vts``.
    """
    for name in dataset.classes[cls]:
        sym = dataset.vts(name, mirror=True)
        if not sym.is_file():
            continue
        path = dataset.shapes[name]
        arrays, _ = _cached(cache, (file_digest(path), "mirror", f"repair={repair}", config.prepare_fingerprint()),
                            lambda: _mirror_arrays(path, repair, config))
        shape = prepared_shape(path, repair, config)
        listed = read_vts(dataset.vts(name), shape.n_input_vertices)
        listed_sym = read_vts(sym, shape.n_input_vertices)
        pick = np.linspace(0, len(listed) - 1, min(samples, len(listed))).astype(np.int64)
        errors = mirror_agreement(shape.solver, _prepared_mirror(shape, arrays["vertices"]),
                                  shape.mesh_index(listed[pick], nearest=True), shape.mesh_index(listed_sym[pick], nearest=True))
        return {"shape": name, "residual": float(arrays["residual"]), "median_error": float(np.median(errors)),
                "within_threshold": float((errors <= DEFAULT_THRESHOLD).mean()), "samples": int(len(pick))}
    return None


def _prepared_mirror(shape: Shape, mirror_input: np.ndarray) -> np.ndarray:
    """A mirror map in input numbering as a map between prepared-mesh vertices."""
    return shape.mesh_index(mirror_input[shape.mesh.input_index], nearest=True)


# ---------------------------------------------------------------------------------------------
# Per-pair work (runs in workers)


def _pair_task(job: dict) -> dict:
    """Match and score one pair for its pending methods: ``{"records": [...]}`` or ``{"error"}``."""
    try:
        return {"records": _pair_work(job)}
    except DarcyanError as exc:
        return {"error": str(exc), "name": f"{job['source']} -> {job['target']}"}


def _pair_work(job: dict) -> list:
    target = prepared_shape(job["target_path"], job["settings"].repair, job["settings"].config)
    records = _sparse_records(job, target) if job["methods"] else []
    if job.get("dense_methods"):
        records += _dense_records(job, target)
    return records


def _sparse_records(job: dict, target: Shape) -> list:
    from dataclasses import replace

    from ..method.pipeline import match_shapes

    settings: BenchSettings = job["settings"]
    src, tgt = job["source_rec"], job["target_rec"]
    features = np.asarray(src["features"], dtype=np.int64)
    true_input, true_t, sym_t, target_features = _feature_truth(job, target)
    fields: dict = {}
    records = []
    for method in job["methods"]:
        start = time.perf_counter()
        if method == "pyfm":
            source = prepared_shape(job["source_path"], settings.repair, settings.config)
            point_map = _pyfm_map(job, source, target)
            rows = np.arange(len(features))
            matched = point_map[source.mesh_index(features, nearest=True)]
            distance = np.full(len(rows), np.nan)
        else:
            # The same matcher as darcyan's (match_shapes with the run's config), other descriptors;
            # max_match_distance was measured on the curvature descriptor, so other descriptors
            # keep every match.
            config = settings.config if method == "darcyan" else settings.config.replace(max_match_distance=0.0)
            correspondence = match_shapes(replace(src["description"], descriptors=src["descriptors"][method]),
                                          replace(tgt["description"], descriptors=tgt["descriptors"][method]), config)
            unverified = correspondence
            if method == "darcyan" and correspondence.in_doubt:  # as `darcyan match` does
                correspondence, verified = _verified(job, target, correspondence)
            m = correspondence.matches_12
            rows, matched, distance = m.source, target_features[m.target], m.distance
        seconds = time.perf_counter() - start
        score = score_pair(target.solver, matched, true_t, sym_t, target_features, settings.threshold,
                           match_rows=rows, fields=fields)
        records.append({
            "method": method, "class": job["cls"], "group": job["group"], "source": job["source"], "target": job["target"],
            "features": score.features, "matches": len(matched),
            "correct": int((score.errors <= settings.threshold).sum()),
            "source_vertex": features[rows].tolist(), "target_vertex": target.mesh.input_index[matched].tolist(),
            "true_vertex": np.asarray(true_input)[rows].tolist(),
            "descriptor_distance": _json_floats(distance), "errors": _json_floats(score.errors),
            "errors_sym": _json_floats(score.errors_sym), "repeatable": score.repeatable.tolist(),
            "repeatable_sym": score.repeatable_sym.tolist(), "seconds": seconds,
            **({"margin": _json_floats([unverified.margin])[0]} if method == "darcyan" else {}),
            **(verified if method == "darcyan" and unverified.in_doubt else {})})
        if method == "darcyan" and unverified.in_doubt and unverified is not correspondence:
            m = unverified.matches_12  # what the sparse matching alone would have scored
            before = score_pair(target.solver, target_features[m.target], true_t, sym_t, target_features,
                                settings.threshold, match_rows=m.source, fields=fields)
            records[-1].update(unverified_matches=len(m.source),
                               unverified_correct=int((before.errors <= settings.threshold).sum()))
    return records


def _verified(job: dict, target: Shape, correspondence) -> tuple:
    """A matching in doubt verified by short dense maps, as ``darcyan match`` does
    (:func:`darcyan.dense.verify.verified_file_matches`: kept in the run's cache): the matching
    and what the record says of it (``verified``: the seed's rank, 0 for the sparse matching;
    ``verify_failed`` when it could not be verified, the matching kept)."""
    from ..dense.config import DenseConfig
    from ..dense.maps import DENSE_FAILURES
    from ..dense.verify import verified_file_matches

    settings: BenchSettings = job["settings"]

    def shapes():
        return prepared_shape(job["source_path"], settings.repair, settings.config), target

    try:
        chosen, about = verified_file_matches(job["source_path"], job["target_path"], correspondence, shapes,
                                              settings.config, DenseConfig(), settings.repair, _cache_of(job))
    except DENSE_FAILURES as exc:
        return correspondence, {"verify_failed": str(exc) if isinstance(exc, DarcyanError)
                                else f"{type(exc).__name__}: {exc}"}
    return chosen, {"verified": about["seed"], "verify_clear": about["clear"]}


def _feature_truth(job: dict, target: Shape) -> tuple:
    """For the source's feature points: their true correspondents (input numbering, and on the
    target's mesh), their mirror images' (or ``None``), and the target's feature points on its mesh."""
    src, tgt, truth = job["source_rec"], job["target_rec"], job["truth"]
    features = np.asarray(src["features"], dtype=np.int64)
    if truth["kind"] == "identity":
        true_input = features
        sym_input = None if truth["mirror"] is None else np.asarray(truth["mirror"])[features]
    else:
        nearest = np.asarray(src["nearest_sample"], dtype=np.int64)
        true_input = read_vts(truth["target_vts"], target.n_input_vertices)[nearest]
        sym_input = None if truth["target_sym"] is None else read_vts(truth["target_sym"], target.n_input_vertices)[nearest]
    true_t = target.mesh_index(true_input, nearest=True)
    sym_t = None if sym_input is None else target.mesh_index(sym_input, nearest=True)
    return true_input, true_t, sym_t, target.mesh_index(tgt["features"], nearest=True)


def _seed_score(job: dict, target: Shape, correspondence, seed: int) -> dict:
    """The sparse score of the matching that seeded darcyan's dense map (the sparse matches, or
    the alternative the dense stage preferred): ``seed_features``, ``seed_matches``, ``seed_correct``."""
    settings: BenchSettings = job["settings"]
    _, true_t, sym_t, target_features = _feature_truth(job, target)
    matches = ([correspondence] + list(correspondence.alternatives))[seed].matches_12
    score = score_pair(target.solver, target_features[matches.target], true_t, sym_t, target_features,
                       settings.threshold, match_rows=matches.source)
    return {"seed_features": score.features, "seed_matches": len(matches.source),
            "seed_correct": int((score.errors <= settings.threshold).sum())}




def _dense_records(job: dict, target: Shape) -> list:
    """The dense maps of one pair (``job["dense_methods"]``), scored on the same sampled vertices."""
    from ..dense.config import DenseConfig
    from ..dense.maps import DENSE_FAILURES, UNMAPPED, dense_map, pyfm_own_map
    from ..eval.dense_scores import evaluate_dense_maps
    from ..eval.metrics import GroundTruth
    from ..method.pipeline import match_shapes

    settings: BenchSettings = job["settings"]
    source = prepared_shape(job["source_path"], settings.repair, settings.config)
    truth = job["truth"]
    if truth["kind"] == "identity":
        ground_truth = GroundTruth()
    else:
        ground_truth = GroundTruth(read_vts(truth["source_vts"], source.n_input_vertices),
                                   read_vts(truth["target_vts"], target.n_input_vertices))
    maps, about = {}, {}
    for method in job["dense_methods"]:
        start = time.perf_counter()
        info: dict = {}
        try:
            if method == "darcyan":
                # The cached descriptions' matches, on the prepared shapes (solvers, spectra).
                correspondence = match_shapes(job["source_rec"]["description"], job["target_rec"]["description"],
                                              settings.config)
                info["matches"] = len(correspondence)
                start = time.perf_counter()  # the dense stage only
                result = dense_map(source, target, correspondence, DenseConfig())
            else:
                result = pyfm_own_map(source.mesh, target.mesh, source.n_input_vertices)
            seconds = time.perf_counter() - start
            maps[method] = result.target
            info["timings"] = {k: float(v) for k, v in result.timings.items()}
            if method == "darcyan":
                info["landmarks"] = len(result.landmarks)
                info["check"] = result.check
                # how right the seed was (scored after the timing: it reads the ground truth)
                info.update(_seed_score(job, target, correspondence, result.check["seed"]))
        except DENSE_FAILURES as exc:
            seconds = time.perf_counter() - start
            if method not in maps:
                maps[method] = np.full(source.n_input_vertices, UNMAPPED, dtype=np.int64)
            info["failed" if "timings" not in info else "seed_failed"] = (
                str(exc) if isinstance(exc, DarcyanError) else f"{type(exc).__name__}: {exc}")
        about[method] = (seconds, info)
    scores = evaluate_dense_maps(source.mesh, target.mesh, maps, ground_truth, settings.dense_samples,
                                 settings.dense_seed, target.solver, settings.threshold)
    records = []
    for method, score in scores.items():
        seconds, info = about[method]
        errors = score.errors
        mapped = np.isfinite(errors)
        records.append({
            "kind": DENSE, "method": method, "class": job["cls"], "group": job["group"], "source": job["source"],
            "target": job["target"],
            "samples": int(len(errors)), "within": int((errors <= settings.threshold).sum()), "rate": score.rate,
            "mapped": int(mapped.sum()), "mean_error": float(errors[mapped].mean()) if mapped.any() else None,
            "curve": score.curve().tolist(), "seconds": seconds, **info})
    return records


def _kind(record: dict) -> str:
    """``"dense"`` for a dense record of the journal, ``"sparse"`` for the others."""
    return record.get("kind", "sparse")


def _pyfm_map(job: dict, source: Shape, target: Shape) -> np.ndarray:
    from ..eval import baselines

    cache = _cache_of(job)
    spectra = []
    for name, shape in ((job["source_path"], source), (job["target_path"], target)):
        arrays, _ = _cached(cache, (file_digest(name), "pyfm-spectrum", str(pyfm.README_PIPELINE.spectrum),
                                    f"repair={job['settings'].repair}", job["settings"].config.prepare_fingerprint()),
                            lambda: _pyfm_spectrum_arrays(shape.mesh))
        spectra.append((arrays["values"], arrays["vectors"]))
    return baselines.pyfm_point_map(source.mesh, target.mesh, spectra[0], spectra[1])


def _json_floats(values) -> list:
    """Floats for JSON: NaN and infinities become ``None``."""
    return [float(v) if np.isfinite(v) else None for v in np.asarray(values, dtype=np.float64)]


def _array(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64)


# ---------------------------------------------------------------------------------------------
# Running tasks: inline, local processes, or a dask.distributed cluster


def run_tasks(function, tasks: list, jobs: int = 1, scheduler: str | None = None):
    """Yield ``function(task)`` for every task as each finishes (in any order).

    ``scheduler``: the address of a ``dask.distributed`` scheduler (its workers need darcyan and
    the dataset's files at the same paths); else ``jobs`` local processes (1: in this process).
    """
    if not tasks:
        return
    if scheduler:
        distributed = require("distributed", "dask")
        try:
            client = distributed.Client(scheduler, timeout="30s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise DarcyanError(f"{scheduler}: cannot reach the dask scheduler ({exc})") from None
        try:
            futures = client.map(function, tasks, pure=False)
            for future in distributed.as_completed(futures):
                yield future.result()
        finally:
            client.close()
        return
    if jobs <= 1:
        for task in tasks:
            yield function(task)
        return
    yield from process_map(function, tasks, jobs)


class Progress:
    """A progress line on stderr: done / total, elapsed and estimated time left."""

    def __init__(self, total: int, label: str, enabled: bool = True, stream=None):
        self.total, self.label, self.enabled = total, label, enabled and total > 0
        self.stream = stream or sys.stderr
        self.done = 0
        self.start = time.perf_counter()
        self.last = 0.0
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()

    def update(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if not self.enabled:
            return
        if self.tty or self.done == self.total or now - self.last >= PROGRESS_INTERVAL:
            self.last = now
            self.stream.write(("\r" if self.tty else "") + self.line(now) + ("" if self.tty else "\n"))
            if self.tty and self.done == self.total:
                self.stream.write("\n")
            self.stream.flush()

    def line(self, now: float | None = None) -> str:
        now = time.perf_counter() if now is None else now
        elapsed = now - self.start
        width = 24
        filled = int(width * self.done / self.total)
        left = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        return (f"{self.label} [{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} "
                f"{_clock(elapsed)} elapsed, {_clock(left)} left")


def _clock(seconds: float) -> str:
    if not np.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


# ---------------------------------------------------------------------------------------------
# The run


@dataclass
class BenchResult:
    """What :func:`run_bench` did: ``results`` (the content of results.json), ``computed`` and
    ``reused`` (method x pair results computed in this run / taken from an earlier one),
    ``seconds`` (wall time of this run)."""

    out: Path
    results: dict
    computed: int
    reused: int
    seconds: float


def run_bench(dataset_dir: str | os.PathLike, out: str | os.PathLike, methods=("darcyan",),
              pairs_file: str | os.PathLike | None = None, threshold: float = DEFAULT_THRESHOLD,
              config: DarcyanConfig = DarcyanConfig(), jobs: int = 1, scheduler: str | None = None,
              resume: bool = False, repair: bool = False, laplacian: str = "cotangent",
              cache_dir: str | os.PathLike | None = None, no_cache: bool = False, plots: bool = True,
              progress: bool = True, dense: bool = False, dense_samples: int = DENSE_SAMPLE) -> BenchResult:
    """Benchmark ``methods`` on a dataset folder and write the results to ``out``.

    Writes ``out/results.json``, ``pairs.csv``, ``report.md`` (as pairs finish), ``pairs.jsonl``
    (one line per finished method x pair), ``run.json`` (the settings) and, with matplotlib,
    ``rates.png`` and ``curve.png`` at the end. ``resume`` keeps the finished pairs of an earlier
    run with the same settings and computes only the others.

    ``dense``: also a dense map per pair (darcyan's, and pyFM's own pipeline when ``pyfm`` is a
    method), scored on ``dense_samples`` source vertices drawn with seed 0 (see the module
    docstring); results under ``dense`` in results.json, and ``dense_curve.png``.
    """
    wall = time.perf_counter()
    methods = tuple(dict.fromkeys(methods))
    unknown = [m for m in methods if m not in METHODS]
    if unknown or not methods:
        raise DarcyanError(f"method must be among {', '.join(METHODS)}, got {', '.join(unknown) or 'none'}")
    if "pyfm" in methods:
        require("pyFM", "pyfm")
    if laplacian not in lbo.LAPLACIANS:
        raise DarcyanError(f"laplacian must be one of {', '.join(lbo.LAPLACIANS)}, got {laplacian!r}")
    if not 0 < threshold < 1:
        raise DarcyanError(f"threshold must be in (0, 1) (sqrt(area) units), got {threshold}")
    if jobs < 1:
        raise DarcyanError(f"jobs must be at least 1, got {jobs}")
    if dense and not (isinstance(dense_samples, (int, np.integer)) and dense_samples >= 1):
        raise DarcyanError(f"dense samples must be a positive integer, got {dense_samples}")
    dataset = discover_dataset(dataset_dir)
    groups: dict = {}
    pairs = read_pairs(pairs_file, dataset, groups) if pairs_file else default_pairs(dataset)
    if not pairs:
        raise DarcyanError(f"{dataset.root}: no pairs (every class has a single shape)")
    settings = BenchSettings(methods, float(threshold), config, laplacian, repair, bool(dense), int(dense_samples))
    out = Path(out)
    journal = _open_run(out, dataset, settings, resume)
    pair_set = set(pairs)
    done = {(_kind(r), r["method"], r["source"], r["target"]) for r in journal}
    wanted = {"sparse": methods, DENSE: settings.dense_methods}
    pending = [(s, t, [m for m in methods if ("sparse", m, s, t) not in done],
                [m for m in settings.dense_methods if (DENSE, m, s, t) not in done]) for s, t in pairs]
    pending = [(s, t, ms, ds) for s, t, ms, ds in pending if ms or ds]
    reused = sum(1 for r in journal if r["method"] in wanted[_kind(r)] and (r["source"], r["target"]) in pair_set)
    common = {"settings": settings, "cache_dir": None if cache_dir is None else str(cache_dir), "no_cache": no_cache}
    cache = None if no_cache else ShapeCache(cache_dir)
    info = _load_info(out)
    info.setdefault("mirror", {})

    # Phase 1: per-shape work.
    names = sorted({n for s, t, _, _ in pending for n in (s, t)}, key=_pose_key)
    shape_tasks = [dict(common, name=n, path=str(dataset.shapes[n]),
                        vts=str(dataset.vts(n)) if dataset.truth == "vts" else None) for n in names]
    shapes: dict = {}
    bar = Progress(len(shape_tasks), "shapes", progress)
    for rec in run_tasks(_shape_task, shape_tasks, jobs, scheduler):
        if "error" in rec:
            raise DarcyanError(rec["error"])
        shapes[rec["name"]] = rec
        bar.update()

    # Ground truth: identity needs equal vertex counts; mirror maps per class.
    classes = sorted({shape_class(s) for s, _, _, _ in pending})
    for s, t, _, _ in pending:
        if dataset.truth == "identity" and shapes[s]["n_input_vertices"] != shapes[t]["n_input_vertices"]:
            raise DarcyanError(f"{dataset.shapes[s]} and {dataset.shapes[t]}: identity ground truth needs the same "
                               f"vertex count ({shapes[s]['n_input_vertices']} vs {shapes[t]['n_input_vertices']}); "
                               f"give {TRUTH_FOLDER}/*.vts files")
    mirrors: dict = {}
    for cls in classes:
        if dataset.truth == "identity":
            found = class_mirror(dataset, cls, repair, cache, config)
            mirrors[cls] = found["vertices"]
            info["mirror"][cls] = {"source": "derived reflection", "shape": found["shape"],
                                   "residual": found["residual"], "used": found["vertices"] is not None}
        else:
            check = validate_mirror(dataset, cls, repair, cache, config)
            info["mirror"][cls] = {"source": ".sym.vts", "validation_of_derived_map": check}
    _save_json(out / SETTINGS, info)

    # Phase 2: per-pair work, grouped by target so each worker reuses its prepared target.
    pair_jobs = []
    for s, t, ms, ds in sorted(pending, key=lambda p: (_pose_key(p[1]), _pose_key(p[0]))):
        if dataset.truth == "identity":
            truth = {"kind": "identity", "mirror": mirrors.get(shape_class(s))}
        else:
            sym = dataset.vts(t, mirror=True)
            truth = {"kind": "vts", "target_vts": str(dataset.vts(t)), "target_sym": str(sym) if sym.is_file() else None,
                     "source_vts": str(dataset.vts(s))}
        pair_jobs.append(dict(common, source=s, target=t, cls=shape_class(s), group=groups.get((s, t), shape_class(s)),
                              methods=ms, dense_methods=ds,
                              source_path=str(dataset.shapes[s]), target_path=str(dataset.shapes[t]),
                              source_rec=_slim(shapes[s]), target_rec=_slim(shapes[t]), truth=truth))
    computed = 0
    bar = Progress(len(pair_jobs), "pairs", progress)
    last_write = time.perf_counter()
    results = None
    try:
        with open(out / JOURNAL, "a") as fh:
            for answer in run_tasks(_pair_task, pair_jobs, jobs, scheduler):
                if "error" in answer:
                    raise DarcyanError(answer["error"])
                for record in answer["records"]:
                    fh.write(json.dumps(record) + "\n")
                    journal.append(record)
                    computed += 1
                fh.flush()
                os.fsync(fh.fileno())
                bar.update()
                if time.perf_counter() - last_write >= WRITE_INTERVAL:
                    write_outputs(out, dataset, settings, info, journal, pairs, time.perf_counter() - wall, groups)
                    last_write = time.perf_counter()
    finally:
        results = write_outputs(out, dataset, settings, info, journal, pairs, time.perf_counter() - wall, groups)
    if plots:
        write_plots(results, out)
    return BenchResult(out, results, computed, reused, time.perf_counter() - wall)


def _slim(shape: dict) -> dict:
    """What a pair needs of a shape record."""
    return {k: shape[k] for k in ("features", "description", "descriptors", "nearest_sample") if k in shape}


def _open_run(out: Path, dataset: Dataset, settings: BenchSettings, resume: bool) -> list:
    """Prepare the output folder; return the journal records to keep (resume) or none."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DarcyanError(f"{out}: cannot create the output folder ({exc.strerror or exc})") from None
    journal_path = out / JOURNAL
    records: list = []
    info = _load_info(out) if resume else {}
    if resume and journal_path.exists():
        before = info.get("settings")
        if before is not None and (_comparable(before) != settings.comparable()
                                   or info.get("dataset") != str(dataset.root.resolve())):
            raise DarcyanError(f"{out}: the results there were made with other settings or another dataset; "
                               f"use another --out, or run without --resume to start again")
        earlier_dense = (before or {}).get("dense")
        now_dense = json.loads(json.dumps(settings.dense_settings()))
        if earlier_dense and now_dense and earlier_dense != now_dense:
            raise DarcyanError(f"{out}: the dense results there were made with other dense settings "
                               f"({earlier_dense['samples']} samples, seed {earlier_dense['seed']}); use another "
                               f"--out, or run without --resume to start again")
        dense_settings = now_dense or earlier_dense
        text = journal_path.read_text()
        if text and not text.endswith("\n"):  # a line cut by an interruption: drop it
            text = text[: text.rfind("\n") + 1]
            journal_path.write_text(text)
        for line in text.splitlines():
            try:
                records.append(json.loads(line))
            except json.JSONDecodeError:
                continue
        methods = tuple(dict.fromkeys(list(before["methods"] if before else []) + list(settings.methods)))
    else:
        dense_settings = settings.dense_settings()
        if journal_path.exists():
            journal_path.unlink()
        methods = settings.methods
    journal_path.touch()
    stored = settings.as_dict()
    stored["methods"] = list(methods)
    stored["dense"] = dense_settings
    info = {"dataset": str(dataset.root.resolve()), "ground_truth": dataset.truth, "settings": stored,
            "mirror": info.get("mirror", {})}
    _save_json(out / SETTINGS, info)
    return records


def _comparable(stored: dict) -> dict | None:
    """The comparable settings of an earlier run (``None`` when they no longer make a config)."""
    try:
        return BenchSettings(tuple(stored["methods"]), stored["threshold"], DarcyanConfig(**stored["config"]),
                             stored["laplacian"], stored["repair"]).comparable()
    except (KeyError, TypeError, DarcyanError):
        return None


def _load_info(out: Path) -> dict:
    try:
        return json.loads((out / SETTINGS).read_text())
    except (OSError, json.JSONDecodeError):
        return {}


def _save_json(path: Path, data) -> None:
    _write_atomic(path, json.dumps(data, indent=1))


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot write ({exc.strerror or exc})") from None


# ---------------------------------------------------------------------------------------------
# Summaries: results.json, pairs.csv, report.md


def _by_method(records: list, known: tuple) -> dict:
    """``{method: [records]}``, the ``known`` methods first in their order, then the others."""
    by_method: dict = {}
    for r in records:
        by_method.setdefault(r["method"], []).append(r)
    order = [m for m in known if m in by_method] + sorted(set(by_method) - set(known))
    return {m: by_method[m] for m in order}


def _split(rows: list, key) -> dict:
    """``{key(row): [positions in rows]}``, keys sorted."""
    parts: dict = {}
    for i, r in enumerate(rows):
        parts.setdefault(key(r), []).append(i)
    return dict(sorted(parts.items()))


def _class(record: dict) -> str:
    return record["class"]


def _group(record: dict) -> str:
    return record.get("group", record["class"])  # journals written before groups existed


def summarize_records(records: list, threshold: float) -> dict:
    """``{method: {"overall": {...}, "classes": {class: {...}}, "groups": {group: {...}}}}`` from
    pair records."""
    methods = {}
    for method, rows in _by_method(records, METHODS).items():
        scores = [{"features": r["features"], "errors": _array(r["errors"]), "errors_sym": _array(r["errors_sym"]),
                   "repeatable": r["repeatable"], "repeatable_sym": r["repeatable_sym"]} for r in rows]
        classes = {}
        for cls, at in _split(rows, _class).items():
            classes[cls] = summarize([scores[i] for i in at], threshold)
            classes[cls]["pair_seconds"] = float(sum(rows[i]["seconds"] for i in at))
        overall = summarize(scores, threshold)
        for key in ("rate", "rate_sym", "recall", "recall_sym", "repeatability"):
            values = [c[key] for c in classes.values() if c[key] is not None]
            overall[f"{key}_class_mean"] = float(np.mean(values)) if values else None
        overall["pair_seconds"] = float(sum(r["seconds"] for r in rows))
        if any("margin" in r for r in rows):  # darcyan: the matchings in doubt, verified by dense maps
            overall["verified_pairs"] = sum("verified" in r for r in rows)
            overall["verify_changed"] = sum(r.get("verified", 0) != 0 for r in rows)
            overall["verify_failed"] = sum("verify_failed" in r for r in rows)
            overall["correct_unverified"] = sum(r.get("unverified_correct", r["correct"]) for r in rows)
            overall["matches_unverified"] = sum(r.get("unverified_matches", r["matches"]) for r in rows)
        groups = {g: summarize([scores[i] for i in at], threshold) for g, at in _split(rows, _group).items()}
        methods[method] = {"overall": overall, "classes": classes, "groups": groups}
    return methods


def summarize_dense(records: list) -> dict:
    """``{method: {"overall", "classes": {class: ...}, "groups": {group: ...}, "pairs": [...]}}``
    from dense pair records.

    Per class, group and overall: ``pairs``, ``failed`` (pairs without a map), ``samples``,
    ``within``, ``rate`` (within / samples, pooled), ``mean_error`` (over the mapped samples),
    ``curve`` (pooled cumulative curve over ``CURVE_TAUS``), ``seconds`` (sum of the dense
    stages), ``seconds_per_pair``, ``untrusted`` (maps whose own check doubts them) and
    ``seed_rate`` (strict rate of the matchings that seeded darcyan's maps); overall also
    ``rate_class_mean``.
    """
    out = {}
    for method, rows in _by_method(records, DENSE_METHODS).items():
        classes = {c: _pool_dense([rows[i] for i in at]) for c, at in _split(rows, _class).items()}
        overall = _pool_dense(rows)
        overall["rate_class_mean"] = float(np.mean([c["rate"] for c in classes.values()])) if classes else None
        groups = {g: _pool_dense([rows[i] for i in at]) for g, at in _split(rows, _group).items()}
        out[method] = {"overall": overall, "classes": classes, "groups": groups, "pairs": rows}
    return out


def _pool_dense(rows: list) -> dict:
    samples = sum(r["samples"] for r in rows)
    within = sum(r["within"] for r in rows)
    mapped = sum(r["mapped"] for r in rows)
    error_sum = sum(r["mean_error"] * r["mapped"] for r in rows if r["mapped"])
    curve = sum(np.asarray(r["curve"]) * r["samples"] for r in rows) / samples if samples else np.zeros(len(CURVE_TAUS))
    seconds = float(sum(r["seconds"] for r in rows))
    seeded = [r for r in rows if "seed_matches" in r]
    seed_matches = sum(r["seed_matches"] for r in seeded)  # the sparse rate's definition: correct / matches
    return {"seed_rate": sum(r["seed_correct"] for r in seeded) / seed_matches if seed_matches else None,
            "pairs": len(rows), "failed": sum(1 for r in rows if r.get("failed")),
            "untrusted": sum(1 for r in rows if (r.get("check") or {}).get("trusted") is False), "samples": samples,
            "within": within, "rate": within / samples if samples else None,
            "mean_error": error_sum / mapped if mapped else None, "curve": np.asarray(curve).tolist(),
            "seconds": seconds, "seconds_per_pair": seconds / len(rows) if rows else None}


def write_outputs(out: Path, dataset: Dataset, settings: BenchSettings, info: dict, journal: list, pairs: list,
                  wall_seconds: float, groups: dict | None = None) -> dict:
    """Rewrite results.json, pairs.csv and report.md from the journal (the pairs of this run;
    ``groups`` ``{(source, target): group}``, else each pair in its class's group)."""
    pair_set = set(pairs)
    groups = groups or {}
    records = [dict(r, group=groups.get((r["source"], r["target"]), r["class"]))  # this run's groups
               for r in journal if (r["source"], r["target"]) in pair_set]
    order = {p: i for i, p in enumerate(pairs)}
    method_order = {m: i for i, m in enumerate(METHODS)}
    records.sort(key=lambda r: (method_order.get(r["method"], len(METHODS)), order[(r["source"], r["target"])]))
    dense = [r for r in records if _kind(r) == DENSE]
    records = [r for r in records if _kind(r) != DENSE]
    results = {
        "dataset": str(dataset.root.resolve()), "ground_truth": dataset.truth, "threshold": settings.threshold,
        "taus": CURVE_TAUS.tolist(), "settings": info.get("settings", settings.as_dict()),
        "rate_definition": RATE_DEFINITION, "mirror": info.get("mirror", {}), "pairs_expected": len(pairs),
        "wall_seconds": wall_seconds, "methods": summarize_records(records, settings.threshold), "pairs": records,
    }
    if dense or settings.dense:
        results["dense_definition"] = DENSE_DEFINITION
        results["dense"] = summarize_dense(dense)
    _write_atomic(out / "results.json", json.dumps(results, indent=None, separators=(",", ":")))
    _write_atomic(out / "pairs.csv", pairs_csv(records, settings.threshold))
    _write_atomic(out / "report.md", report_markdown(results))
    return results


PAIR_COLUMNS = ("method", "class", "source", "target", "features", "matches", "correct", "correct_sym",
                "repeatable", "rate", "rate_sym", "mean_error", "seconds")


def pairs_csv(records: list, threshold: float) -> str:
    """One row per method x pair."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(PAIR_COLUMNS)
    for r in records:
        s = summarize([{"features": r["features"], "errors": _array(r["errors"]), "errors_sym": _array(r["errors_sym"]),
                        "repeatable": r["repeatable"], "repeatable_sym": r["repeatable_sym"]}], threshold)
        writer.writerow([r["method"], r["class"], r["source"], r["target"], r["features"], r["matches"], s["correct"],
                         s["correct_sym"], int(np.sum(r["repeatable"])), _fmt(s["rate"]), _fmt(s["rate_sym"]),
                         _fmt(s["mean_error"]), f"{r['seconds']:.3f}"])
    return buffer.getvalue()


def _fmt(value, digits: int = 3) -> str:
    return "" if value is None else f"{value:.{digits}f}"


def _pct(value) -> str:
    return "–" if value is None else f"{100 * value:.0f}%"


def report_markdown(results: dict) -> str:
    """The tables of a run as Markdown."""
    methods = results["methods"]
    lines = [f"# darcyan bench: {Path(results['dataset']).name}", ""]
    lines.append(f"Dataset `{results['dataset']}`, ground truth: "
                 + ("`corres/*.vts` (p's true correspondent at the geodesically nearest listed sample)"
                    if results["ground_truth"] == "vts" else "identity on vertex indices within a class")
                 + f". Threshold {results['threshold']} (geodesic error / sqrt(target area)). "
                 f"{sum(m['overall']['pairs'] for m in methods.values())} method x pair results of "
                 f"{results['pairs_expected']} pairs x {len(methods)} method(s); wall time of the last run "
                 f"{_clock(results['wall_seconds'])}.")
    lines += ["", RATE_DEFINITION + " rate_sym also counts a match correct under the mirror ground truth "
              "(a left-right flip); repeatability is the share of source feature points with some target "
              "feature point within the threshold of their true correspondent (detection), whatever the "
              "match (description).", ""]
    if methods:
        class_names = sorted({c for m in methods.values() for c in m["classes"]})
        lines += ["## Side by side: strict rate / with symmetric flips / repeatability", ""]
        lines.append("| class | " + " | ".join(methods) + " |")
        lines.append("| --- |" + " --- |" * len(methods))
        for cls in class_names:
            cells = []
            for m in methods.values():
                c = m["classes"].get(cls)
                cells.append("" if c is None else f"{_pct(c['rate'])} / {_pct(c['rate_sym'])} / {_pct(c['repeatability'])}")
            lines.append(f"| {cls} | " + " | ".join(cells) + " |")
        lines.append("| **mean over classes** | " + " | ".join(
            f"{_pct(m['overall']['rate_class_mean'])} / {_pct(m['overall']['rate_sym_class_mean'])} / "
            f"{_pct(m['overall']['repeatability_class_mean'])}" for m in methods.values()) + " |")
        lines.append("| **all matches pooled** | " + " | ".join(
            f"{_pct(m['overall']['rate'])} / {_pct(m['overall']['rate_sym'])} / {_pct(m['overall']['repeatability'])}"
            for m in methods.values()) + " |")
        for name, m in methods.items():
            lines += ["", f"## {name}", "",
                      "| class | pairs | features | matches | correct | rate | rate_sym | recall | recall_sym "
                      "| repeatability | mean error | s/pair |",
                      "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
            for cls, c in list(m["classes"].items()) + [("**all**", m["overall"])]:
                lines.append(f"| {cls} | {c['pairs']} | {c['features']} | {c['matches']} | {c['correct']} | "
                             f"{_fmt(c['rate'])} | {_fmt(c['rate_sym'])} | {_fmt(c['recall'])} | "
                             f"{_fmt(c['recall_sym'])} | {_fmt(c['repeatability'])} | "
                             f"{_fmt(c['mean_error'])} | {c['pair_seconds'] / max(c['pairs'], 1):.2f} |")
            lines.append(f"\nMean over classes: rate {_fmt(m['overall']['rate_class_mean'])}, rate_sym "
                         f"{_fmt(m['overall']['rate_sym_class_mean'])}, recall "
                         f"{_fmt(m['overall']['recall_class_mean'])}, recall_sym "
                         f"{_fmt(m['overall']['recall_sym_class_mean'])}, repeatability "
                         f"{_fmt(m['overall']['repeatability_class_mean'])}. 's/pair' is the mean matching time "
                         f"of a pair (for pyfm the whole functional-map pipeline; per-shape work is cached and not counted).")
            o = m["overall"]
            if "verified_pairs" in o:
                lines.append(f"\nMatchings in doubt (the orientation test's margin below `mirror.verify_below`), "
                             f"verified by short dense maps: {o['verified_pairs']} pairs, {o['verify_changed']} "
                             f"changed" + (f", {o['verify_failed']} could not be verified" if o["verify_failed"] else "")
                             + f". Without it: {o['correct_unverified']} of {o['matches_unverified']} matches "
                             f"correct; with it: {o['correct']} of {o['matches']} (the rates above).")
    lines += _dense_report(results)
    lines += _group_report(results)
    mirror = results.get("mirror", {})
    if mirror:
        lines += ["", "## Mirror ground truth", ""]
        if results["ground_truth"] == "identity":
            lines.append(f"Derived per class from the first pose whose best reflection plane leaves a mean "
                         f"residual <= {MIRROR_MAX_RESIDUAL} (sqrt(area) units); the map holds for every pose "
                         f"of the class, which share one vertex numbering.")
            lines += ["", "| class | pose | residual | used |", "| --- | --- | ---: | --- |"]
            for cls, m in sorted(mirror.items()):
                lines.append(f"| {cls} | {m['shape']} | {_fmt(m['residual'], 4)} | {'yes' if m['used'] else 'no (no symmetric pose: rate_sym = rate)'} |")
        else:
            lines.append("From `corres/*.sym.vts`. Check of the map darcyan derives for identity data (reflection "
                         "of the first pose) against `.sym.vts`: geodesic distance between the derived and the "
                         "listed mirror image at evenly spread samples.")
            lines += ["", "| class | pose | residual | samples | median error | within threshold |",
                      "| --- | --- | ---: | ---: | ---: | ---: |"]
            for cls, m in sorted(mirror.items()):
                v = m.get("validation_of_derived_map")
                if v:
                    lines.append(f"| {cls} | {v['shape']} | {_fmt(v['residual'], 4)} | {v['samples']} | "
                                 f"{_fmt(v['median_error'], 4)} | {_pct(v['within_threshold'])} |")
    return "\n".join(lines) + "\n"


def _group_report(results: dict) -> list:
    """Sparse and dense figures per group of pairs (``--pairs`` third column), when the groups
    are not simply the classes."""
    methods, dense = results["methods"], results.get("dense") or {}
    names = sorted({g for m in list(methods.values()) + list(dense.values()) for g in m.get("groups", {})})
    classes = {c for m in methods.values() for c in m["classes"]}
    if not names or set(names) <= classes:
        return []
    lines = ["", "## Per group", "",
             ("Sparse: strict rate, rate allowing flips, mean geodesic error of the matches (sqrt(area) units); "
              "dense: share of sampled vertices within the threshold and their mean geodesic error; seed "
              "rate: the strict rate of the matchings that seeded the dense maps (the sparse matches, or the "
              "alternative the dense stage preferred)."), "",
             ("| group | method | pairs | sparse rate | rate_sym | sparse mean error | dense within | dense mean error "
              "| seed rate |"),
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for group in names:
        for name in dict.fromkeys(list(methods) + list(dense)):
            s = methods.get(name, {}).get("groups", {}).get(group)
            d = dense.get(name, {}).get("groups", {}).get(group)
            if s is None and d is None:
                continue
            pairs = s["pairs"] if s else d["pairs"]
            lines.append(f"| {group} | {name} | {pairs} | {_pct(s['rate']) if s else ''} | "
                         f"{_pct(s['rate_sym']) if s else ''} | {_fmt(s['mean_error']) if s else ''} | "
                         f"{_pct(d['rate']) if d else ''} | {_fmt(d['mean_error']) if d else ''} | "
                         f"{_pct(d['seed_rate']) if d and d.get('seed_rate') is not None else ''} |")
    return lines


def _dense_report(results: dict) -> list:
    """The report's section on dense maps (none when the run has no dense results)."""
    dense = results.get("dense")
    if dense is None:
        return []
    chosen = (results.get("settings") or {}).get("dense") or {}
    lines = ["", f"## Dense maps: within {results['threshold']} / mean error / seconds per pair", ""]
    lines.append(f"{chosen.get('samples', '?')} source vertices per pair (seed {chosen.get('seed', '?')}). "
                 "darcyan: the dense map seeded by darcyan's sparse matches, or by an alternative matching "
                 "whose short ZoomOut map keeps the curvature signature clearly better (geodesic landmark coordinates "
                 "refined by ZoomOut; 'not trusted': the map's own check doubts it); pyfm: pyFM's own pipeline (WKS, 50 x 50 functional map, ZoomOut to "
                 "200) without darcyan's landmarks. " + results.get("dense_definition", DENSE_DEFINITION))
    if not dense:
        return lines + ["", "No dense results yet."]
    methods = list(dense)
    lines += ["", "| class | " + " | ".join(methods) + " |", "| --- |" + " --- |" * len(methods)]

    def cell(c):
        if c is None:
            return ""
        failed = f" ({c['failed']} failed)" if c["failed"] else ""
        untrusted = f" ({c['untrusted']} not trusted)" if c.get("untrusted") else ""
        return f"{_pct(c['rate'])} / {_fmt(c['mean_error'])} / {c['seconds_per_pair']:.1f} s{failed}{untrusted}"

    for cls in sorted({c for m in dense.values() for c in m["classes"]}):
        lines.append(f"| {cls} | " + " | ".join(cell(dense[m]["classes"].get(cls)) for m in methods) + " |")
    lines.append("| **mean over classes** | " + " | ".join(_pct(dense[m]["overall"]["rate_class_mean"])
                                                          for m in methods) + " |")
    lines.append("| **all samples pooled** | " + " | ".join(cell(dense[m]["overall"]) for m in methods) + " |")
    lines.append("| pairs / samples | " + " | ".join(f"{dense[m]['overall']['pairs']} / {dense[m]['overall']['samples']}"
                                                     for m in methods) + " |")
    return lines


# ---------------------------------------------------------------------------------------------
# Plots (matplotlib optional)


def write_plots(results: dict, out: Path) -> list:
    """rates.png and curve.png (and dense_curve.png with dense results) in ``out``; nothing (and
    a note on stderr) without matplotlib."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("darcyan: note: rates.png and curve.png need matplotlib: pip install 'darcyan[plot]'", file=sys.stderr)
        return []
    written = []
    if results["methods"]:
        written += [plot_rates(results, out / "rates.png"), plot_curves(results, out / "curve.png")]
    if results.get("dense"):
        written.append(plot_dense_curves(results, out / "dense_curve.png"))
    if _group_report(results):
        written.append(plot_group_curves(results, out / "group_curves.png"))
    return written


GROUP_LINESTYLES = ("-", "--", ":", "-.")


def plot_group_curves(results: dict, path: Path) -> Path:
    """Cumulative error per group of pairs, one colour per method and one line style per group:
    the sparse matches on the left, the dense maps (when the run has them) on the right."""
    from ..viz import style

    taus = np.asarray(results["taus"])
    parts = [("sparse matches", results["methods"], "matches")]
    if results.get("dense"):
        parts.append(("dense maps", results["dense"], "sampled vertices"))
    with style.context():
        fig, _ = style.figure((6.0 * len(parts), 4.0))
        fig.clf()  # one panel per part
        axes = [fig.add_subplot(1, len(parts), i + 1) for i in range(len(parts))]
        for ax, (title, methods, what) in zip(axes, parts):
            groups = sorted({g for m in methods.values() for g in m.get("groups", {})})
            for name, m in methods.items():
                for i, group in enumerate(groups):
                    g = m.get("groups", {}).get(group)
                    if g is None:
                        continue
                    ax.plot(taus, np.asarray(g["curve"]) * 100, color=style.method_colour(name),
                            linestyle=GROUP_LINESTYLES[i % len(GROUP_LINESTYLES)],
                            label=f"{name}, {group} ({_pct(g['rate'])})")
            ax.axvline(results["threshold"], color=style.NEUTRAL["edge"], linewidth=0.8, linestyle=":")
            ax.set_xlim(taus[0], taus[-1])
            ax.set_ylim(0, 100)
            ax.set_xlabel("geodesic error / sqrt(area)")
            ax.set_ylabel(f"{what} with error <= threshold (%)")
            ax.set_title(f"{Path(results['dataset']).name}: {title} per group")
            ax.legend(fontsize="small", loc="lower right")
        style.save(fig, path)
    return path


def plot_rates(results: dict, path: Path) -> Path:
    """Bars per class (and the mean over classes): strict rate solid, with symmetric flips
    hatched on top, one colour per method (the paper's Fig. 8 side by side)."""
    from ..viz import style

    methods = results["methods"]
    classes = sorted({c for m in methods.values() for c in m["classes"]})
    labels = classes + ["mean"]
    width = 0.8 / len(methods)
    with style.context():
        fig, ax = style.figure((max(6.0, 1.1 * len(labels) + 2), 4.0))
        for i, (name, m) in enumerate(methods.items()):
            strict = [(m["classes"].get(c) or {}).get("rate") or 0.0 for c in classes] + [m["overall"]["rate_class_mean"] or 0.0]
            sym = [(m["classes"].get(c) or {}).get("rate_sym") or 0.0 for c in classes] + [m["overall"]["rate_sym_class_mean"] or 0.0]
            x = np.arange(len(labels)) - 0.4 + width * (i + 0.5)
            colour = style.method_colour(name)
            ax.bar(x, np.array(sym) * 100, width * 0.9, color="white", edgecolor=colour, hatch="///", linewidth=0.8,
                   label=f"{name} (with flips)")
            ax.bar(x, np.array(strict) * 100, width * 0.9, color=colour, label=f"{name}")
        ax.set_xticks(np.arange(len(labels)), labels)
        ax.set_ylim(0, 100)
        ax.set_ylabel(f"correspondence rate (%), error <= {results['threshold']}")
        ax.set_title(f"{Path(results['dataset']).name}: rate per class")
        ax.legend(ncol=2, fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))
        style.save(fig, path)
    return path


def plot_curves(results: dict, path: Path) -> Path:
    """Cumulative curve per method: share of matches with error <= tau (solid strict, dashed
    with symmetric flips)."""
    from ..viz import style

    taus = np.asarray(results["taus"])
    with style.context():
        fig, ax = style.figure()
        for name, m in results["methods"].items():
            colour = style.method_colour(name)
            ax.plot(taus, np.asarray(m["overall"]["curve"]) * 100, color=colour, label=name)
            ax.plot(taus, np.asarray(m["overall"]["curve_sym"]) * 100, color=colour, linestyle="--",
                    label=f"{name} (with flips)")
        ax.axvline(results["threshold"], color=style.NEUTRAL["edge"], linewidth=0.8, linestyle=":")
        ax.set_xlim(taus[0], taus[-1])
        ax.set_ylim(0, 100)
        ax.set_xlabel("geodesic error / sqrt(area)")
        ax.set_ylabel("matches with error <= threshold (%)")
        ax.set_title(f"{Path(results['dataset']).name}: cumulative error")
        ax.legend(fontsize="small", loc="lower right")
        style.save(fig, path)
    return path


def plot_dense_curves(results: dict, path: Path) -> Path:
    """Cumulative curve of the dense maps, one line per method: share of the sampled source
    vertices with error <= tau, pooled over the pairs."""
    from ..viz import style

    taus = np.asarray(results["taus"])
    samples = ((results.get("settings") or {}).get("dense") or {}).get("samples")
    with style.context():
        fig, ax = style.figure()
        for name, m in results["dense"].items():
            o = m["overall"]
            ax.plot(taus, np.asarray(o["curve"]) * 100, color=style.method_colour(name),
                    label=f"{name} ({_pct(o['rate'])} within {results['threshold']}, {o['pairs']} pairs)")
        ax.axvline(results["threshold"], color=style.NEUTRAL["edge"], linewidth=0.8, linestyle=":")
        ax.set_xlim(taus[0], taus[-1])
        ax.set_ylim(0, 100)
        ax.set_xlabel("geodesic error / sqrt(area)")
        ax.set_ylabel("sampled source vertices with error <= threshold (%)")
        ax.set_title(f"{Path(results['dataset']).name}: dense maps, cumulative error"
                     + (f" ({samples} vertices per pair)" if samples else ""))
        ax.legend(fontsize="small", loc="lower right")
        style.save(fig, path)
    return path
