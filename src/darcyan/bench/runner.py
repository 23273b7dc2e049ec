"""The evaluation harness behind ``darcyan bench``: correspondence rates on a folder of meshes.

A dataset is a folder of meshes with their ground truth, and its pairs every ordered pair
within a class or the lines of a pairs file (:mod:`darcyan.bench.datasets`).

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
share the target's distance fields), both in :mod:`darcyan.bench.work`. Each finished pair is
appended to ``pairs.jsonl`` in the output folder at once, and the summaries (``results.json``, ``pairs.csv``, ``report.md``) are
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
``report.md`` and ``dense_curve.png`` (:mod:`darcyan.bench.report`, :mod:`darcyan.bench.plots`).
"""

from __future__ import annotations

import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import DarcyanConfig
from ..errors import DarcyanError, require
from ..eval.dense_scores import DENSE_SAMPLE
from ..eval.metrics import DEFAULT_THRESHOLD
from ..geometry import spectral as lbo
from ..io.cache import ShapeCache
from ..parallel import process_map
from . import METHODS
from .datasets import TRUTH_FOLDER, Dataset, default_pairs, discover_dataset, pose_key, read_pairs, shape_class
from .plots import write_plots
from .records import DENSE, record_kind
from .report import clock, save_json, write_outputs
from .settings import BenchSettings, comparable
from .work import class_mirror, pair_task, shape_task, validate_mirror

WRITE_INTERVAL = 2.0  # seconds between rewrites of the summaries while pairs finish
PROGRESS_INTERVAL = 30.0  # seconds between progress lines when stderr is not a terminal
JOURNAL = "pairs.jsonl"
SETTINGS = "run.json"


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
                f"{clock(elapsed)} elapsed, {clock(left)} left")


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
    done = {(record_kind(r), r["method"], r["source"], r["target"]) for r in journal}
    wanted = {"sparse": methods, DENSE: settings.dense_methods}
    pending = [(s, t, [m for m in methods if ("sparse", m, s, t) not in done],
                [m for m in settings.dense_methods if (DENSE, m, s, t) not in done]) for s, t in pairs]
    pending = [(s, t, ms, ds) for s, t, ms, ds in pending if ms or ds]
    reused = sum(1 for r in journal if r["method"] in wanted[record_kind(r)] and (r["source"], r["target"]) in pair_set)
    common = {"settings": settings, "cache_dir": None if cache_dir is None else str(cache_dir), "no_cache": no_cache}
    cache = None if no_cache else ShapeCache(cache_dir)
    info = _load_info(out)
    info.setdefault("mirror", {})

    # Phase 1: per-shape work.
    names = sorted({n for s, t, _, _ in pending for n in (s, t)}, key=pose_key)
    shape_tasks = [dict(common, name=n, path=str(dataset.shapes[n]),
                        vts=str(dataset.vts(n)) if dataset.truth == "vts" else None) for n in names]
    shapes: dict = {}
    bar = Progress(len(shape_tasks), "shapes", progress)
    for rec in run_tasks(shape_task, shape_tasks, jobs, scheduler):
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
    save_json(out / SETTINGS, info)

    # Phase 2: per-pair work, grouped by target so each worker reuses its prepared target.
    pair_jobs = []
    for s, t, ms, ds in sorted(pending, key=lambda p: (pose_key(p[1]), pose_key(p[0]))):
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
            for answer in run_tasks(pair_task, pair_jobs, jobs, scheduler):
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
        if before is not None and info.get("dataset") != str(dataset.root.resolve()):
            raise DarcyanError(f"{out}: the results there were made on another dataset ({info.get('dataset')}); "
                               f"use another --out, or run without --resume to start again")
        now = json.loads(json.dumps(settings.as_dict()))  # as run.json keeps it (lists, not tuples)
        # A setting the earlier run did not have (a darcyan before it) counts as different: its
        # results were made without it, whatever its default does now.
        changed = [] if before is None else _differences(comparable(before), comparable(now))
        if changed:
            raise DarcyanError(f"{out}: the results there were made with other settings ({_listed(changed)}); "
                               f"use another --out, or run without --resume to start again")
        earlier_dense = (before or {}).get("dense")
        now_dense = now.get("dense")
        if earlier_dense and now_dense and earlier_dense != now_dense:
            raise DarcyanError(f"{out}: the dense results there were made with other dense settings "
                               f"({_listed(_differences(earlier_dense, now_dense, 'dense.'))}); use another "
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
    save_json(out / SETTINGS, info)
    return records


def _differences(before, now, prefix: str = "") -> list:
    """Dotted names of the settings that differ between an earlier run's ``before`` and ``now``
    (as ``run.json`` keeps them), ``name (new)`` for one the earlier run did not have and
    ``name (gone)`` for one it had that no longer exists."""
    if not (isinstance(before, dict) and isinstance(now, dict)):
        return [] if before == now else [prefix.rstrip(".") or "settings"]
    out = []
    for key in sorted(set(before) | set(now), key=str):
        name = f"{prefix}{key}"
        if key not in before:
            out.append(f"{name} (new)")
        elif key not in now:
            out.append(f"{name} (gone)")
        else:
            out.extend(_differences(before[key], now[key], name + "."))
    return out


def _listed(names: list, most: int = 4) -> str:
    """``names`` for a message: the first ``most``, then how many more."""
    if not names:
        return "settings"
    more = f" and {len(names) - most} more" if len(names) > most else ""
    return ", ".join(names[:most]) + more


def _load_info(out: Path) -> dict:
    try:
        return json.loads((out / SETTINGS).read_text())
    except (OSError, json.JSONDecodeError):
        return {}
