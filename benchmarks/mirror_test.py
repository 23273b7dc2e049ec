"""Study of the mirror test (darcyan.method.symmetry.orientation_agreement): how often the true matching wins.

For each pair, the candidate matchings of ``consistent`` matching are scored with the mirror test
under several settings (sample points, neighbours per test triangle, weight of the curvature
signature in the coarse map); a pair counts as won when the chosen matching sends every matched
source feature point to the target feature point nearest (Euclidean) to its true correspondent.
Ground truth: ``corres/{shape}.vts`` when present (nearest listed sample), else the identity.

    python benchmarks/mirror_test.py ../shared/data/tosca-5k --pairs ../shared/data/tosca-5k/test_pairs.txt

prints one row per setting: pairs won per class and in all. The defaults of darcyan.method.symmetry are
marked; the first row is the first version of the test (200 samples, one triangle per sample).
Descriptions come from the per-shape cache ($DARCYAN_CACHE), so a second run is quick.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from darcyan import DarcyanConfig, load_mesh
from darcyan.bench.datasets import default_pairs, discover_dataset, read_pairs, shape_class
from darcyan.errors import DarcyanError
from darcyan.eval.metrics import read_vts
from darcyan.io.cache import ShapeCache
from darcyan.method import symmetry
from darcyan.method.matching import consistent_candidates
from darcyan.method.pipeline import describe_shape

# (samples, neighbours, signature weight); neighbours 2 = one triangle per sample.
SETTINGS = [(200, 2, 0.3), (200, 6, 0.3), (400, 6, 0.3), (800, 6, 0.3), (200, 6, 0.9), (400, 6, 0.9),
            (800, 6, 0.9), (1600, 6, 0.9), (800, 10, 0.9), (800, 6, 0.6), (800, 6, 1.8)]


def oracle(root: Path, source: str, target: str, description_1, description_2) -> np.ndarray:
    """For each source feature point, the index of the target feature point nearest its truth."""
    mesh_1, mesh_2 = load_mesh(description_1.name), load_mesh(description_2.name)
    vts_1, vts_2 = root / "corres" / f"{source}.vts", root / "corres" / f"{target}.vts"
    if vts_1.exists() and vts_2.exists():
        samples_1, samples_2 = read_vts(vts_1), read_vts(vts_2)
        line = cKDTree(mesh_1.vertices[samples_1]).query(mesh_1.vertices[description_1.feature_vertices])[1]
        truth = mesh_2.vertices[samples_2[line]]
    else:
        truth = mesh_2.vertices[description_1.feature_vertices]
    features_2 = mesh_2.vertices[description_2.feature_vertices]
    return np.linalg.norm(truth[:, None] - features_2[None], axis=2).argmin(axis=1)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dataset")
    parser.add_argument("--pairs")
    parser.add_argument("--settings", nargs="*", metavar="SAMPLES,NEIGHBOURS,WEIGHT",
                        help="settings to try instead of the built-in list, e.g. 800,6,0.9")
    args = parser.parse_args(argv)
    settings = SETTINGS if not args.settings else [
        (int(a), int(b), float(c)) for a, b, c in (item.split(",") for item in args.settings)]
    root = Path(args.dataset)
    dataset = discover_dataset(root)
    pairs = read_pairs(args.pairs, dataset) if args.pairs else default_pairs(dataset)
    config, cache = DarcyanConfig(), ShapeCache()
    cases = []
    for source, target in pairs:
        d1, d2 = (describe_shape(dataset.shapes[name], config, cache=cache) for name in (source, target))
        candidates = consistent_candidates(d1.descriptors, d2.descriptors, d1.feature_geodesics, d2.feature_geodesics)
        cases.append((shape_class(source), d1, d2, candidates, oracle(root, source, target, d1, d2)))
    classes = sorted({c[0] for c in cases})
    print("| samples | neighbours | signature weight | " + " | ".join(classes) + " | all |")
    print("| ---: | ---: | ---: | " + " | ".join("---:" for _ in classes) + " | ---: |")
    defaults = config.mirror
    default = (defaults.samples, defaults.neighbours, defaults.signature_weight)
    for samples, neighbours, weight in settings:
        # the mirror test alone (no handedness), through the method's own choice
        test = dataclasses.replace(defaults, samples=samples, neighbours=neighbours, signature_weight=weight,
                                   handedness_weight=0.0)
        won, count = defaultdict(int), defaultdict(int)
        for cls, d1, d2, candidates, truth in cases:
            best = symmetry.choose_orientation(candidates, d1.surface, d2.surface, test)
            won[cls] += bool(np.all(truth[best.source] == best.target))
            count[cls] += 1
        mark = " (default)" if (samples, neighbours, weight) == default else ""
        cells = [f"{won[c]}/{count[c]}" for c in classes]
        print(f"| {samples}{mark} | {neighbours} | {weight} | " + " | ".join(cells)
              + f" | {sum(won.values())}/{len(cases)} |", flush=True)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except DarcyanError as error:  # a missing dataset or pair: one line, not a traceback
        sys.exit(f"{Path(sys.argv[0]).name}: error: {error}")
