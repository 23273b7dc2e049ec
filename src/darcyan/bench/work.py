"""The work of ``darcyan bench`` done in worker processes: per shape (description, spectra,
nearest ground-truth samples, mirror maps; cached on disk by file content and parameters) and
per pair (matching and scoring of every method, dense maps; all methods of a pair share the
target's distance fields)."""

from __future__ import annotations

import os
import time
from collections import OrderedDict
from pathlib import Path

import numpy as np

from ..api import matches_of_map, verification_wanted
from ..config import DarcyanConfig
from ..dense import pyfm
from ..errors import DarcyanError
from ..eval.metrics import (
    DEFAULT_THRESHOLD,
    mirror_agreement,
    nearest_samples,
    read_vts,
    reflection_symmetry,
    score_pair,
)
from ..geometry import spectral as lbo
from ..geometry.shape import Shape
from ..io.cache import ShapeCache, code_digest, file_digest
from .datasets import Dataset
from .records import DENSE, json_floats
from .settings import MIRROR_MAX_RESIDUAL, BenchSettings

PREPARED_MEMO = 3  # prepared meshes kept per worker process (tasks come grouped by target)
MIRROR_VALIDATION_SAMPLES = 200  # .sym.vts samples compared with a derived mirror map
_MEMO: OrderedDict = OrderedDict()  # prepared shapes of this worker process, most recent last


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


def shape_task(task: dict) -> dict:
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
            cache, (digest, "spectrum", settings.laplacian, str(lbo.SPECTRUM_SIZE), f"repair={repair}",
                    settings.config.prepare_fingerprint()),
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
                            lambda path=path: _mirror_arrays(path, repair, config))
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
                            lambda path=path: _mirror_arrays(path, repair, config))
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


def pair_task(job: dict) -> dict:
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
        verified = None  # what the record says of a verification (darcyan's matchings only)
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
            if method == "darcyan" and verification_wanted(correspondence, "auto", dense=False):  # the command's rule
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
            "descriptor_distance": json_floats(distance), "errors": json_floats(score.errors),
            "errors_sym": json_floats(score.errors_sym), "repeatable": score.repeatable.tolist(),
            "repeatable_sym": score.repeatable_sym.tolist(), "seconds": seconds,
            **({"margin": json_floats([unverified.margin])[0]} if method == "darcyan" else {}),
            **(verified or {})})
        if verified is not None and unverified is not correspondence:
            m = unverified.matches_12  # what the sparse matching alone would have scored
            before = score_pair(target.solver, target_features[m.target], true_t, sym_t, target_features,
                                settings.threshold, match_rows=m.source, fields=fields)
            records[-1].update(unverified_matches=len(m.source),
                               unverified_correct=int((before.errors <= settings.threshold).sum()))
    return records


def _verified(job: dict, target: Shape, correspondence) -> tuple:
    """A matching verified by short dense maps (in doubt, or its margin below
    ``mirror.verify_sparse_below``), as ``darcyan match`` does
    (:func:`darcyan.dense.verify.verified_file_matches`: kept in the run's cache): the matching
    and what the record says of it (``verified``: the seed's rank, 0 for the sparse matching;
    ``verify_failed`` when it could not be verified, the matching kept)."""
    from ..dense.maps import DENSE_FAILURES
    from ..dense.verify import verified_file_matches

    settings: BenchSettings = job["settings"]

    def shapes():
        return prepared_shape(job["source_path"], settings.repair, settings.config), target

    try:
        chosen, about = verified_file_matches(job["source_path"], job["target_path"], correspondence, shapes,
                                              settings.config, settings.config.dense_for(), settings.repair,
                                              _cache_of(job))
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


def _seed_score(job: dict, target: Shape, matching) -> dict:
    """The sparse score of the feature matches darcyan's dense map agrees with (the sparse
    matches, the alternative the dense stage preferred, or, for a map started without them,
    the matches it reads, :func:`~darcyan.dense.maps.matching_of_map`): ``seed_features``,
    ``seed_matches``, ``seed_correct``."""
    settings: BenchSettings = job["settings"]
    _, true_t, sym_t, target_features = _feature_truth(job, target)
    matches = matching.matches_12
    score = score_pair(target.solver, target_features[matches.target], true_t, sym_t, target_features,
                       settings.threshold, match_rows=matches.source)
    return {"seed_features": score.features, "seed_matches": len(matches.source),
            "seed_correct": int((score.errors <= settings.threshold).sum())}


def _dense_records(job: dict, target: Shape) -> list:
    """The dense maps of one pair (``job["dense_methods"]``), scored on the same sampled vertices."""
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
                result = dense_map(source, target, correspondence, settings.config.dense_for())
            else:
                result = pyfm_own_map(source.mesh, target.mesh, source.n_input_vertices)
            seconds = time.perf_counter() - start
            maps[method] = result.target
            info["timings"] = {k: float(v) for k, v in result.timings.items()}
            if method == "darcyan":
                info["landmarks"] = len(result.landmarks)
                info["check"] = result.check.as_dict()
                # how right the seed was (scored after the timing: it reads the ground truth)
                # the matches the map agrees with, as darcyan.correspond gives them
                matching = matches_of_map(correspondence, result, job["source_rec"]["description"],
                                          job["target_rec"]["description"], target)
                info.update(_seed_score(job, target, matching))
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


def _pyfm_map(job: dict, source: Shape, target: Shape) -> np.ndarray:
    from ..eval import baselines

    cache = _cache_of(job)
    spectra = []
    for name, shape in ((job["source_path"], source), (job["target_path"], target)):
        arrays, _ = _cached(cache, (file_digest(name), "pyfm-spectrum", str(pyfm.README_PIPELINE.spectrum),
                                    f"repair={job['settings'].repair}", job["settings"].config.prepare_fingerprint()),
                            lambda shape=shape: _pyfm_spectrum_arrays(shape.mesh))
        spectra.append((arrays["values"], arrays["vectors"]))
    return baselines.pyfm_point_map(source.mesh, target.mesh, spectra[0], spectra[1])
