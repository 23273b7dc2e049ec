"""How far each landmark pair of a dense map's seed is contradicted by the others (the check
behind ``DenseConfig.landmark_contradiction``), against the ground truth: prints, per pair of
shapes, each landmark pair's displacement and error, then a table of the displacements of right
and wrong pairs.

    python benchmarks/landmark_check.py ../shared/data/tosca-5k --pairs benchmarks/sweep_pairs_tosca5k.txt

Every map is checked here, trusted or not, as it was made with all its pairs (``dense_map``
checks only the maps in doubt, and goes on without the pair it finds). A pair
is right when its target lies within 0.05 sqrt(area) (the scores' threshold) of the true
correspondent of its source, scored as ``darcyan bench`` scores matches
(:func:`darcyan.eval.metrics.score_matches`: ``.vts`` ground truth read at the listed sample
nearest the source, or the identity where a dataset has one numbering); "unknown" where the
truth has no correspondent on the prepared target.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np
from pair_sets import pair_set_parser, pair_truth, run_reporting_errors  # benchmarks/pair_sets.py


def main(argv=None) -> int:
    return run_reporting_errors("landmark_check", _check, pair_set_parser(__doc__).parse_args(argv))


def _check(args) -> int:
    import darcyan
    from darcyan.bench.datasets import discover_dataset, read_pairs
    from darcyan.dense.config import DenseConfig
    from darcyan.dense.landmarks import landmark_set
    from darcyan.dense.seeds import Seed, landmark_displacements
    from darcyan.dense.zoomout import dense_basis, zoomout_samples
    from darcyan.eval.metrics import DEFAULT_THRESHOLD, score_matches
    from darcyan.method.pipeline import Correspondence

    config = DenseConfig()
    every = dataclasses.replace(config, landmarks="all")
    unchecked = dataclasses.replace(config, landmark_contradiction=0.0)
    dataset = discover_dataset(args.dataset)
    pairs = read_pairs(args.pairs, dataset)
    rows = {"right": [], "wrong": [], "unknown": []}
    for source, target in pairs:
        files = [args.dataset / f"{name}.off" for name in (source, target)]
        # the seed as it was before any pair was left out: the map made with them all
        result = darcyan.correspond(*files, dense=True, repair=args.repair, cache=False,
                                    dense_config=unchecked).pairs[0]
        shape_1, shape_2 = (getattr(s, "shape", s) for s in result.shapes)
        landmarks = result.dense.landmarks
        matched = Correspondence(landmarks[:, 0], landmarks[:, 1], np.zeros(len(landmarks)), None)
        seed = Seed(0, *landmark_set(shape_1, shape_2, matched, every, ({}, {})), 0.0)
        samples = zoomout_samples(shape_1, shape_2, config)
        bases = dense_basis(shape_1, config), dense_basis(shape_2, config)
        moved = landmark_displacements(shape_1, shape_2, seed, config, samples, bases)
        truth = pair_truth(dataset, source, target)
        kept = Correspondence(shape_1.mesh.input_index[seed.source], shape_2.mesh.input_index[seed.target],
                              np.zeros(len(seed.source)), None)
        errors = score_matches(shape_1, shape_2, kept, truth).errors  # as darcyan bench scores matches
        cells = []
        for i in range(len(seed.source)):
            kind = "unknown" if np.isnan(errors[i]) else "right" if errors[i] <= DEFAULT_THRESHOLD else "wrong"
            if moved is not None:
                rows[kind].append((float(moved[i]), f"{source} -> {target}"))
            cells.append(f"{'-' if moved is None else f'{moved[i]:.3f}'} ({kind})")
        print(f"{source} -> {target}: trusted {result.dense.check.trusted}; " + ", ".join(cells), flush=True)
    print("\n| landmark pairs | n | median | 90% | largest |\n| --- | ---: | ---: | ---: | ---: |")
    for kind, values in rows.items():
        if values:
            d = np.array([v for v, _ in values])
            top = ", ".join(f"{v:.2f} ({name})" for v, name in sorted(values, reverse=True)[:3])
            print(f"| {kind} | {len(d)} | {np.median(d):.3f} | {np.quantile(d, 0.9):.3f} | {top} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
