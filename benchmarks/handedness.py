"""Study of handedness (darcyan.method.symmetry.handedness): its weight and trust against the mirror test alone.

For each pair, the candidate matchings of ``consistent`` matching are scored as ``darcyan`` does
(descriptor similarity and layout, plus the mirror test's orientation agreement at its defaults),
plus ``weight`` times the summed handedness of their matches, the handedness computed with trust
``agreement`` (``inf``: every profile pair fully trusted). The chosen matching then loses the
matches whose descriptors disagree (``max_match_distance`` at its default), as in ``match_shapes``.

    python benchmarks/handedness.py ../shared/data/tosca-5k --pairs ../shared/data/tosca-5k/test_pairs.txt
    cat benchmarks/mirror_pairs_hires_*.txt > hires_pairs.txt
    python benchmarks/handedness.py ../shared/data/tosca-hires --pairs hires_pairs.txt

prints one row per setting, per class: pairs won (every kept match goes to the target feature
point nearest its true correspondent, as in ``mirror_test.py``) and the share of kept matches
that do. Weight 0 is darcyan without handedness; the default is marked. Descriptions come from
the per-shape cache ($DARCYAN_CACHE).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from mirror_test import oracle

from darcyan import DarcyanConfig
from darcyan.bench.datasets import default_pairs, discover_dataset, read_pairs, shape_class
from darcyan.errors import DarcyanError
from darcyan.io.cache import ShapeCache
from darcyan.method import symmetry
from darcyan.method.matching import consistent_candidates, drop_dissimilar
from darcyan.method.pipeline import describe_shape

WEIGHTS = (0.0, 0.5, 1.0, 2.0, 4.0)
AGREEMENTS = (0.6, 0.8, 1.0, np.inf)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dataset")
    parser.add_argument("--pairs")
    parser.add_argument("--weights", nargs="*", type=float, default=WEIGHTS)
    parser.add_argument("--agreements", nargs="*", type=float, default=AGREEMENTS)
    args = parser.parse_args(argv)
    root = Path(args.dataset)
    dataset = discover_dataset(root)
    pairs = read_pairs(args.pairs, dataset) if args.pairs else default_pairs(dataset)
    config, cache = DarcyanConfig(), ShapeCache()
    cases, described = [], {}
    for number, (source, target) in enumerate(pairs, 1):
        for name in (source, target):
            if name not in described:
                described[name] = describe_shape(dataset.shapes[name], config, cache=cache)
        d1, d2 = described[source], described[target]
        candidates = consistent_candidates(d1.descriptors, d2.descriptors, d1.feature_geodesics,
                                           d2.feature_geodesics, config.consistency)
        cases.append((shape_class(source), d1, d2, candidates, oracle(root, source, target, d1, d2)))
        print(f"\r{number}/{len(pairs)} pairs", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    classes = sorted({c[0] for c in cases})
    print("| weight | agreement | " + " | ".join(classes) + " | all |")
    print("| ---: | ---: | " + " | ".join("---:" for _ in classes) + " | ---: |")
    for agreement in args.agreements:
        for weight in args.weights:
            if weight == 0 and agreement != args.agreements[0]:
                continue  # the same row for every agreement
            # the method's own choice (mirror test plus handedness) with these two settings
            test = dataclasses.replace(config.mirror, handedness_weight=weight, profile_agreement=agreement)
            won, count, right, kept = (defaultdict(int) for _ in range(4))
            for cls, d1, d2, candidates, truth in cases:
                chosen = symmetry.choose_orientation(candidates, d1.surface, d2.surface, test)
                chosen = drop_dissimilar(chosen, d1.descriptors, d2.descriptors, config.max_match_distance)
                good = truth[chosen.source] == chosen.target
                won[cls] += bool(good.all())
                count[cls] += 1
                right[cls] += int(good.sum())
                kept[cls] += len(good)
            default = weight == config.mirror.handedness_weight and agreement == config.mirror.profile_agreement
            cells = [f"{won[c]}/{count[c]} ({right[c] / max(kept[c], 1):.3f})" for c in classes]
            total = f"{sum(won.values())}/{len(cases)} ({sum(right.values()) / max(sum(kept.values()), 1):.3f})"
            label = "-" if weight == 0 else f"{agreement:g}"
            print(f"| {weight:g}{' (default)' if default else ''} | {label} | " + " | ".join(cells) + f" | {total} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except DarcyanError as error:  # a missing dataset or pair: one line, not a traceback
        sys.exit(f"{Path(sys.argv[0]).name}: error: {error}")
