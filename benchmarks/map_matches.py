"""Feature matches three ways, scored against the ground truth: the sparse stage's (unverified),
those ``darcyan match --dense`` writes (:func:`darcyan.api.matches_of_map`: the alternative
matching that seeded the map, or read from the map where it was started without the matches
or left a landmark pair out), and those read from every map
(:func:`darcyan.dense.maps.matching_of_map`, trusted maps too): whether a dense map should
correct the sparse matching more often than it does.

    python benchmarks/map_matches.py ../shared/data/faust-5k --pairs benchmarks/faust5k_test_pairs_groups.txt
    python benchmarks/map_matches.py COPIES/isotropic --pairs PAIRS --repair --out rows.jsonl

A match is right when its target lies within 0.05 sqrt(area) of the true correspondent of its
source, scored as ``darcyan bench`` scores matches (:func:`darcyan.eval.metrics.score_matches`).
Each pair's row is written to ``--out`` as it is done (a pair without a map as a row with its
error), and a run with the same ``--out`` goes on from there.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from pair_sets import pair_set_parser, pair_truth, run_reporting_errors  # benchmarks/pair_sets.py

WAYS = ("sparse", "written", "every map")


def main(argv=None) -> int:
    parser = pair_set_parser(__doc__)
    parser.add_argument("--out", type=Path, help="the pairs' rows (JSON lines), kept and resumed from")
    return run_reporting_errors("map_matches", _run, parser.parse_args(argv))


def _run(args) -> int:
    import darcyan
    from darcyan.bench.datasets import discover_dataset, read_pairs
    from darcyan.dense.maps import matching_of_map
    from darcyan.errors import DarcyanError
    from darcyan.eval.metrics import score_matches

    dataset = discover_dataset(args.dataset)
    pairs = read_pairs(args.pairs, dataset)
    out = args.out or Path(tempfile.mkdtemp(prefix="map_matches-")) / "rows.jsonl"
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = [json.loads(line) for line in out.read_text().splitlines()] if out.exists() else []
    done = {(row["source"], row["target"]) for row in rows}
    cache = darcyan.ShapeCache(Path(tempfile.gettempdir()) / "darcyan-map-matches-cache")
    with out.open("a") as written:
        def keep(row: dict) -> None:  # written as it comes: a stopped run resumes from it
            written.write(json.dumps(row) + "\n")
            written.flush()
            rows.append(row)

        for source, target in pairs:
            if (source, target) in done:
                continue
            files = [dataset.shapes[name] for name in (source, target)]
            sparse = darcyan.correspond(*files, repair=args.repair, cache=cache, verify=False)
            try:
                result = darcyan.correspond(*files, dense=True, repair=args.repair, cache=cache).pairs[0]
            except DarcyanError as exc:  # no map: said, kept, and the next pair
                keep({"source": source, "target": target, "error": str(exc)})
                print(f"{source} -> {target}: {exc}", flush=True)
                continue
            shape_1, shape_2 = result.shapes
            read = matching_of_map(sparse.pairs[0].matches, result.dense, *sparse.descriptions, shape_2)
            truth = pair_truth(dataset, source, target)
            row = {"source": source, "target": target, "trusted": bool(result.dense.check.trusted)}
            for way, matches in zip(WAYS, (sparse.pairs[0].matches, result.matches, read)):
                score = score_matches(shape_1, shape_2, matches, truth)
                row[way] = [score.correct, int(np.isfinite(score.errors).sum())]  # right / matches with a truth
            keep(row)
            print(f"{source} -> {target}: " + ", ".join(f"{w} {row[w][0]}/{row[w][1]}" for w in WAYS), flush=True)
    mapped = [r for r in rows if "error" not in r]
    if len(rows) > len(mapped):
        print(f"\n{len(rows) - len(mapped)} pair(s) without a map, left out of the table")
    print(f"\nrows: {out}\n\n| maps | n | " + " | ".join(f"{w}: right / matches" for w in WAYS) + " |")
    print("| --- | ---: |" + " ---: |" * len(WAYS))
    for name, chosen in (("all", mapped), ("trusted", [r for r in mapped if r["trusted"]])):
        cells = []
        for way in WAYS:
            right, n = sum(r[way][0] for r in chosen), sum(r[way][1] for r in chosen)
            cells.append(f"{right} / {n} ({100 * right / max(n, 1):.1f}%)")
        print(f"| {name} | {len(chosen)} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
