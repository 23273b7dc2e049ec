"""How far each landmark pair of a dense map's seed is contradicted by the others (the check
behind ``DenseConfig.landmark_contradiction``), against the ground truth: prints, per pair of
shapes, each landmark pair's displacement and error, then a table of the displacements of right
and wrong pairs.

    python benchmarks/landmark_check.py ../shared/data/tosca-5k --pairs benchmarks/sweep_pairs_tosca5k.txt

Every map is checked here, trusted or not, as it was made with all its pairs (``dense_map``
checks only the maps in doubt, and goes on without the pair it finds). A pair
is right when its target lies within 0.05 sqrt(area) (the scores' threshold) of the true correspondent of its source
(``.vts`` ground truth, or the identity where a dataset has one numbering; pairs whose source
has no listed correspondent are "unknown").
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a folder of meshes with corres/*.vts")
    parser.add_argument("--pairs", type=Path, required=True, help="a file of 'source<TAB>target[<TAB>group]' lines")
    parser.add_argument("--repair", action="store_true")
    args = parser.parse_args(argv)

    import darcyan
    from darcyan.bench.datasets import discover_dataset, read_pairs
    from darcyan.dense.config import DenseConfig
    from darcyan.dense.landmarks import landmark_set
    from darcyan.dense.seeds import Seed, landmark_displacements
    from darcyan.dense.zoomout import dense_basis, zoomout_samples
    from darcyan.eval.metrics import DEFAULT_THRESHOLD, GroundTruth, read_vts

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
        matched = _Pairs(landmarks[:, 0], landmarks[:, 1])
        seed = Seed(0, *landmark_set(shape_1, shape_2, matched, every, ({}, {})), 0.0)
        samples = zoomout_samples(shape_1, shape_2, config)
        bases = dense_basis(shape_1, config), dense_basis(shape_2, config)
        moved = landmark_displacements(shape_1, shape_2, seed, config, samples, bases)
        truth = GroundTruth.identity() if dataset.truth == "identity" else \
            GroundTruth(read_vts(dataset.vts(source)), read_vts(dataset.vts(target)))
        errors = _errors(shape_1, shape_2, seed, truth)
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


@dataclasses.dataclass(frozen=True)
class _Pairs:
    source_vertex: np.ndarray
    target_vertex: np.ndarray

    @property
    def distance(self) -> np.ndarray:
        return np.zeros(len(self.source_vertex))


def _errors(shape_1, shape_2, seed, truth) -> np.ndarray:
    """``(k,)`` each landmark pair's error (geodesic, sqrt(area)) against ``truth``, NaN where
    its source has no listed correspondent."""
    identity = truth.source_samples is None  # one vertex numbering (tosca-hires within a class)
    listed = {} if identity else {int(v): i for i, v in enumerate(truth.source_samples)}
    scale = np.sqrt(shape_2.mesh.area())
    out = np.full(len(seed.source), np.nan)
    for i, (s, t) in enumerate(zip(seed.source, seed.target)):
        source_input = int(shape_1.mesh.input_index[s])
        row = listed.get(source_input)
        true_input = np.array([source_input]) if identity else None if row is None else truth.target_samples[row:row + 1]
        if true_input is not None:
            true = shape_2.mesh_index(true_input, nearest=True)[0]
            out[i] = shape_2.solver.distance(int(true))[int(t)] / scale
    return out


if __name__ == "__main__":
    sys.exit(main())
