"""How much of a copy's dense-map error is its ground truth's rounding (a diagnostic).

    python benchmarks/copy_floor.py ../shared/data/faust-5k COPY [COPY ...] \
        --pairs benchmarks/faust5k_test_pairs_groups.txt --count 20 --repair

The copies of ``benchmarks/robustness.py`` (isotropic remeshes, marching cubes, glued) carry
their ground truth over from the original by moving each listed sample to the copy's nearest
vertex, on the source and on the target: a copy's truth is rounded once more than the
original's. For each of ``--count`` pairs drawn (seed 0) from ``--pairs``, three maps are scored
as ``darcyan bench`` scores them (the same 1,000 sampled source vertices, geodesic error on the
target over sqrt(area)):

* ``original``: darcyan's dense map of the original pair, on the original's truth;
* ``carried``: that same map carried to a copy (each copy vertex to the nearest original vertex
  in space that the map sends somewhere, its image, the copy vertex nearest to that), on the
  copy's truth: about what the copy's figures would be with a map exactly as good as
  darcyan's map of the original;
* ``copy``: darcyan's own dense map of the copy pair (``--repair`` as the sets' runs use it).

The gap between ``original`` and ``carried`` is the rounding of the copy's truth and of the
carrying; the gap between ``carried`` and ``copy`` is what the copy's meshing costs darcyan
itself. Prints each copy's pooled share within 0.05 and mean error (x100) of the three, pooled
as ``darcyan bench`` pools them (the mean error over the mapped samples), and with ``--out``
keeps every pair's figures (JSON lines, written as they come).
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import numpy as np
from pair_sets import pair_set_parser, pair_truth, run_reporting_errors  # the sibling script
from scipy.spatial import cKDTree

from darcyan import correspond, load_mesh
from darcyan.bench.datasets import discover_dataset, read_pairs
from darcyan.errors import DarcyanError
from darcyan.eval.dense_scores import evaluate_dense_maps
from darcyan.method.pipeline import load_shape


def carried_map(original_1, original_2, copy_1, copy_2, map_12: np.ndarray) -> np.ndarray:
    """``(n_copy_1,)`` the original's map ``map_12`` (input numbering of the originals) carried to
    the copies: each copy vertex to the nearest original vertex (raw positions, one frame), its
    image, the nearest vertex of ``copy_2``'s prepared mesh (input numbering of the copy)."""
    mapped = np.flatnonzero(map_12 >= 0)  # original vertices the preparation kept
    nearest_original = mapped[cKDTree(original_1.vertices[mapped]).query(copy_1.raw.vertices)[1]]
    images = map_12[nearest_original]
    kept_2 = copy_2.mesh.input_index  # vertices the preparation kept
    return kept_2[cKDTree(copy_2.raw.vertices[kept_2]).query(original_2.vertices[images])[1]]


class _Copy:
    """A copy's prepared shape beside its file's raw mesh."""

    def __init__(self, path: Path, repair: bool):
        self.raw = load_mesh(path)
        self.shape = load_shape(path, repair=repair, warn=False)
        self.mesh = self.shape.mesh


def _scores(evaluations: dict) -> dict:
    """Each map's figures as ``darcyan bench`` records them: within the threshold, samples,
    mapped samples and the mean error over those."""
    out = {}
    for name, evaluation in evaluations.items():
        errors = evaluation.errors
        mapped = np.isfinite(errors)
        out[name] = {"within": int((errors <= evaluation.threshold).sum()), "samples": len(errors),
                     "mapped": int(mapped.sum()), "mean_error": float(errors[mapped].mean()) if mapped.any() else None}
    return out


def _dense_map(source: Path, target: Path, repair: bool) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return correspond(source, target, dense=True, repair=repair)[0].dense.target


def run(args) -> int:
    original = discover_dataset(args.dataset)
    copies = [discover_dataset(folder) for folder in args.copies]
    if args.count < 1:
        raise DarcyanError(f"--count must be at least 1, got {args.count}")
    pairs = read_pairs(args.pairs, original)
    for dataset in copies:
        read_pairs(args.pairs, dataset)  # every shape of the pairs is in every copy
    if args.count < len(pairs):
        pairs = [pairs[i] for i in sorted(np.random.default_rng(0).choice(len(pairs), args.count, replace=False))]
    pooled = {str(folder): {} for folder in args.copies}
    with open(args.out, "w") if args.out else _Nowhere() as out:
        for number, (a, b) in enumerate(pairs, 1):
            _score_pair(args, original, copies, pooled, out, number, len(pairs), a, b)
    print("| copies | original: within 0.05 / mean error x100 | carried | copy |")
    print("| --- | --- | --- | --- |")
    for folder, totals in pooled.items():
        cells = [f"{100 * t['within'] / t['samples']:.2f}% / {100 * t['error'] / max(t['mapped'], 1):.2f}"
                 for t in (totals["original"], totals["carried"], totals["copy"])]
        print(f"| {folder} ({len(pairs)} pairs) | " + " | ".join(cells) + " |")
    return 0


class _Nowhere:
    """An output that keeps nothing (no ``--out``)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None

    def write(self, text: str) -> None:
        return None

    def flush(self) -> None:
        return None


def _score_pair(args, original, copies: list, pooled: dict, out, number: int, count: int, a: str, b: str) -> None:
    """One pair's three maps on every copy, added to ``pooled`` and written to ``out``."""
    print(f"copy_floor: pair {number}/{count} {a} -> {b}", file=sys.stderr)
    path_a, path_b = original.shapes[a], original.shapes[b]
    shape_a, shape_b = load_shape(path_a, warn=False), load_shape(path_b, warn=False)
    map_ab = _dense_map(path_a, path_b, False)
    base = _scores(evaluate_dense_maps(shape_a.mesh, shape_b.mesh, {"original": map_ab}, pair_truth(original, a, b)))
    raw_a, raw_b = load_mesh(path_a), load_mesh(path_b)
    for folder, dataset in zip(args.copies, copies):
        copy_a, copy_b = _Copy(dataset.shapes[a], args.repair), _Copy(dataset.shapes[b], args.repair)
        maps = {"carried": carried_map(raw_a, raw_b, copy_a, copy_b, map_ab),
                "copy": _dense_map(dataset.shapes[a], dataset.shapes[b], args.repair)}
        scores = {**base, **_scores(evaluate_dense_maps(copy_a.mesh, copy_b.mesh, maps, pair_truth(dataset, a, b)))}
        for name, score in scores.items():
            total = pooled[str(folder)].setdefault(name, {"within": 0, "samples": 0, "mapped": 0, "error": 0.0})
            total["within"] += score["within"]
            total["samples"] += score["samples"]
            total["mapped"] += score["mapped"]
            total["error"] += (score["mean_error"] or 0.0) * score["mapped"]
        out.write(json.dumps({"set": str(folder), "source": a, "target": b, **scores}) + "\n")
        out.flush()


def main(argv=None) -> int:
    parser = pair_set_parser(__doc__)
    parser.add_argument("copies", type=Path, nargs="+", help="folders of copies of DATASET (same names, corres/*.vts)")
    parser.add_argument("--count", type=int, default=20, help="pairs drawn (seed 0) from --pairs")
    parser.add_argument("--out", type=Path, help="keep every pair's figures here (JSON lines)")
    args = parser.parse_args(argv)
    return run_reporting_errors("copy_floor", run, args)


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (DarcyanError, OSError) as exc:
        print(f"copy_floor: error: {exc}", file=sys.stderr)
        sys.exit(2)
