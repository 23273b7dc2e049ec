"""Dense-map settings side by side on a seeded sample of a dataset's pairs (how the dense
defaults were chosen, ``docs/parameters.md``).

    python benchmarks/dense_variants.py faust-5k benchmarks/faust5k_test_pairs_groups.txt 40 \\
        '{"before": {"orientation_weight": 0, "landmark_weight": 0}, "default": {}}' --out variants.json

For each of N pairs drawn (seed 0) from PAIRS (``source<TAB>target[<TAB>group]``), the shapes are
described and matched once with darcyan's defaults, and a dense map is made with each variant of
:class:`darcyan.dense.config.DenseConfig` (a JSON object: name -> fields to change). Each map is
scored on the same 1000 source vertices (the dataset's ``.vts`` ground truth, else the identity).
Prints, per group and overall, the mean over pairs of the share within 0.05, of the mean error
(errors capped at 1) and of the seconds of the dense stage; ``--out`` keeps every pair's figures
and the maps' own checks. Two worker processes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from darcyan import DarcyanConfig
from darcyan.dense.config import DenseConfig
from darcyan.dense.maps import dense_map
from darcyan.errors import DarcyanError
from darcyan.eval.dense_scores import evaluate_dense_maps
from darcyan.eval.metrics import GroundTruth, read_vts
from darcyan.io.cache import ShapeCache
from darcyan.method.pipeline import describe_shapes, load_shape, match_shapes
from darcyan.parallel import process_map

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("DARCYAN_DATA", REPO.parent / "shared" / "data"))


def prepared_pair(dataset: str, source: str, target: str, repair: bool = False) -> tuple:
    """``(shapes, correspondence, truth)``: both shapes described (cached), matched with the
    defaults and prepared (``repair``: as ``--repair`` does), and the dataset's ``.vts`` ground
    truth (else the identity)."""
    config = DarcyanConfig()
    files = [DATA / dataset / f"{source}.off", DATA / dataset / f"{target}.off"]
    correspondence = match_shapes(*describe_shapes(files, config, repair=repair, cache=ShapeCache()), config)
    shapes = [load_shape(f, config, repair=repair, warn=False) for f in files]
    vts = [DATA / dataset / "corres" / f"{name}.vts" for name in (source, target)]
    truth = GroundTruth(read_vts(vts[0]), read_vts(vts[1])) if vts[0].exists() else GroundTruth()
    return shapes, correspondence, truth


def read_pair_lines(path: Path, dataset: str, count: int) -> list:
    """``[(source, target, group), ...]``: ``count`` lines drawn (seed 0) from a pairs file
    (``source<TAB>target[<TAB>group]``; group defaults to the dataset). Raises DarcyanError or
    OSError naming the file."""
    lines = [line.split("\t") for line in path.read_text().splitlines() if line.strip() and not line.startswith("#")]
    for number, line in enumerate(lines, 1):
        if len(line) < 2:
            raise DarcyanError(f"{path}: pair {number}: 'source<TAB>target[<TAB>group]' expected")
    if not (DATA / dataset).is_dir():
        raise DarcyanError(f"{DATA / dataset}: no such dataset folder (set DARCYAN_DATA)")
    if count < len(lines):
        lines = [lines[i] for i in sorted(np.random.default_rng(0).choice(len(lines), count, replace=False))]
    return [(line[0].strip(), line[1].strip(), line[2].strip() if len(line) > 2 else dataset) for line in lines]


def add_sample_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments naming a sample of pairs (see :func:`read_pair_lines`)."""
    parser.add_argument("dataset", help="a folder of DARCYAN_DATA (default ../shared/data), e.g. faust-5k")
    parser.add_argument("pairs", type=Path, help="source<TAB>target[<TAB>group] lines")
    parser.add_argument("count", type=int, help="pairs drawn from them (seed 0)")


def score_pair(task: tuple) -> dict:
    dataset, source, target, group, variants, repair = task
    warnings.simplefilter("ignore")
    shapes, correspondence, truth = prepared_pair(dataset, source, target, repair)
    maps, seconds, checks = {}, {}, {}
    for name, changes in variants.items():
        start = time.perf_counter()
        try:
            made = dense_map(*shapes, correspondence, DenseConfig(**changes))
            maps[name], checks[name] = made.target, made.check.as_dict()
        except DarcyanError:  # too few landmarks: every vertex unmapped
            maps[name], checks[name] = np.full(shapes[0].n_input_vertices, -1), {}
        seconds[name] = time.perf_counter() - start
    scores = evaluate_dense_maps(shapes[0].mesh, shapes[1].mesh, maps, truth, target_solver=shapes[1].solver)
    return {"pair": f"{source}->{target}", "group": group,
            **{name: {"rate": scores[name].rate, "mean": float(np.minimum(scores[name].errors, 1.0).mean()),
                      "seconds": seconds[name], "check": checks[name]} for name in variants}}


def read_variants(text: str, what: str = "variants") -> dict:
    """name -> DenseConfig changes, each checked by building its DenseConfig (``what``: the
    argument's name in the messages)."""
    try:
        variants = json.loads(text)
    except ValueError as exc:
        raise DarcyanError(f"{what}: not JSON ({exc})") from None
    if not isinstance(variants, dict) or not all(isinstance(v, dict) for v in variants.values()):
        raise DarcyanError(f'{what}: a JSON object of name -> {{field: value}}, e.g. {{"default": {{}}}}')
    for name, changes in variants.items():
        try:
            DenseConfig(**changes)
        except TypeError as exc:  # an unknown field
            raise DarcyanError(f"variant {name!r}: {exc}") from None
    return variants


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_sample_arguments(parser)
    parser.add_argument("variants", help="JSON: name -> DenseConfig fields to change")
    parser.add_argument("--out", type=Path)
    parser.add_argument("--repair", action="store_true", help="prepare the meshes as --repair does")
    args = parser.parse_args(argv)
    try:
        variants = read_variants(args.variants)
        pairs = read_pair_lines(args.pairs, args.dataset, args.count)
    except (OSError, DarcyanError) as exc:  # one line, no traceback (OSError names its file)
        print(f"dense_variants.py: error: {exc}", file=sys.stderr)
        return 2
    tasks = [(args.dataset, source, target, group, variants, args.repair) for source, target, group in pairs]
    results = list(process_map(score_pair, tasks, 2, ordered=True))
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))
    for group in sorted({r["group"] for r in results}) + ["all"]:
        rows = [r for r in results if group in ("all", r["group"])]
        cells = [f"{name}: {np.mean([r[name]['rate'] for r in rows]):.3f} within 0.05, mean "
                 f"{np.mean([r[name]['mean'] for r in rows]):.4f}, {np.mean([r[name]['seconds'] for r in rows]):.1f} s"
                 for name in variants]
        print(f"{group} ({len(rows)} pairs) | " + " | ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
