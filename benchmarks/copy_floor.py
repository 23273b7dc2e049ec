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
  in space, its image, the copy vertex nearest to that), on the copy's truth: what the copy's
  figures would be if darcyan mapped the copy exactly as well as it maps the original;
* ``copy``: darcyan's own dense map of the copy pair (``--repair`` as the sets' runs use it).

The gap between ``original`` and ``carried`` is the rounding of the copy's truth (and of the
carrying); the gap between ``carried`` and ``copy`` is what the copy's meshing costs darcyan
itself. Prints each copy's pooled share within 0.05 and mean error (x100) of the three, and
with ``--out`` keeps every pair's figures (JSON lines). Errors of unmapped samples count as 1.
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
from darcyan.bench.datasets import discover_dataset
from darcyan.errors import DarcyanError
from darcyan.eval.dense_scores import evaluate_dense_maps
from darcyan.method.pipeline import load_shape

ERROR_CAP = 1.0  # an unmapped sample's error (sqrt(area) units)


def carried_map(original_1, original_2, copy_1, copy_2, map_12: np.ndarray) -> np.ndarray:
    """``(n_copy_1,)`` the original's map ``map_12`` (input numbering of the originals) carried to
    the copies: each copy vertex to the nearest original vertex (raw positions, one frame), its
    image, the nearest vertex of ``copy_2``'s prepared mesh (input numbering of the copy)."""
    nearest_original = cKDTree(original_1.vertices).query(copy_1.vertices)[1]
    images = map_12[nearest_original]
    kept_2 = copy_2.mesh.input_index  # vertices the preparation kept
    on_copy = cKDTree(copy_2.raw.vertices[kept_2]).query(original_2.vertices[np.maximum(images, 0)])[1]
    return np.where(images >= 0, kept_2[on_copy], -1)


class _Copy:
    """A copy's prepared shape beside its file's raw mesh."""

    def __init__(self, path: Path, repair: bool):
        self.raw = load_mesh(path)
        self.shape = load_shape(path, repair=repair, warn=False)
        self.mesh = self.shape.mesh
        self.vertices = self.raw.vertices


def _scores(evaluations: dict) -> dict:
    return {name: {"within": int((e.errors <= e.threshold).sum()), "samples": len(e.errors),
                   "mean_error": float(np.minimum(e.errors, ERROR_CAP).mean())} for name, e in evaluations.items()}


def _dense_map(source: Path, target: Path, repair: bool) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return correspond(source, target, dense=True, repair=repair)[0].dense.target


def run(args) -> int:
    original = discover_dataset(args.dataset)
    copies = [discover_dataset(folder) for folder in args.copies]
    lines = [line.split("\t") for line in args.pairs.read_text().splitlines() if line.strip() and not line.startswith("#")]
    if args.count < len(lines):
        lines = [lines[i] for i in sorted(np.random.default_rng(0).choice(len(lines), args.count, replace=False))]
    pairs = [(line[0].strip(), line[1].strip()) for line in lines]
    out = open(args.out, "w") if args.out else None
    pooled = {str(folder): {} for folder in args.copies}
    for number, (a, b) in enumerate(pairs, 1):
        print(f"copy_floor: pair {number}/{len(pairs)} {a} -> {b}", file=sys.stderr)
        path_a, path_b = original.shapes[a], original.shapes[b]
        shape_a, shape_b = load_shape(path_a, warn=False), load_shape(path_b, warn=False)
        map_ab = _dense_map(path_a, path_b, False)
        base = _scores(evaluate_dense_maps(shape_a.mesh, shape_b.mesh, {"original": map_ab},
                                           pair_truth(original, a, b)))
        raw_a, raw_b = load_mesh(path_a), load_mesh(path_b)
        for folder, dataset in zip(args.copies, copies):
            copy_a, copy_b = _Copy(dataset.shapes[a], args.repair), _Copy(dataset.shapes[b], args.repair)
            maps = {"carried": carried_map(raw_a, raw_b, copy_a, copy_b, map_ab),
                    "copy": _dense_map(dataset.shapes[a], dataset.shapes[b], args.repair)}
            scores = {**base, **_scores(evaluate_dense_maps(copy_a.mesh, copy_b.mesh, maps, pair_truth(dataset, a, b)))}
            for name, score in scores.items():
                total = pooled[str(folder)].setdefault(name, {"within": 0, "samples": 0, "error": 0.0})
                total["within"] += score["within"]
                total["samples"] += score["samples"]
                total["error"] += score["mean_error"] * score["samples"]
            if out:
                out.write(json.dumps({"set": str(folder), "source": a, "target": b, **scores}) + "\n")
                out.flush()
    print("| copies | original: within 0.05 / mean error x100 | carried | copy |")
    print("| --- | --- | --- | --- |")
    for folder, totals in pooled.items():
        cells = [f"{100 * t['within'] / t['samples']:.2f}% / {100 * t['error'] / t['samples']:.2f}"
                 for t in (totals["original"], totals["carried"], totals["copy"])]
        print(f"| {folder} ({len(pairs)} pairs) | " + " | ".join(cells) + " |")
    return 0


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
