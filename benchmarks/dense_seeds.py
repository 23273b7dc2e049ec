"""Which seed should a dense map start from? (how ``DenseConfig.seed_margin`` was chosen,
``docs/parameters.md``).

    python benchmarks/dense_seeds.py faust-5k benchmarks/faust5k_test_pairs_groups.txt 97 --out seeds.jsonl

For each of N pairs drawn (seed 0) from PAIRS (``source<TAB>target[<TAB>group]``): the shapes are
described and matched with darcyan's defaults; one dense map with the defaults gives every
seed's score (``DenseMap.check.verdict.signatures``: the sparse matching is seed 0, its alternatives
1, 2, ...); then each seed alone (``candidates=1``) makes a dense map, scored on the same 300
source vertices against the dataset's ground truth. Prints, for each margin, how many pairs the
rule "an alternative replaces the sparse matching when its score is lower by the margin" fixes
(its map at least 0.15 more within 0.05 than the sparse seed's) and breaks (0.15 less). Results
go to ``--out`` as they come (one JSON line per pair) and a re-run resumes from them. Two
worker processes.

``--seed-basis 30 60`` also scores the seeds with short ZoomOuts of those sizes
(``DenseConfig.seed_basis``; the seeds' maps, made with the full ZoomOut, are the same) and
prints the table for each: which size picks the better seeds.

    python benchmarks/dense_seeds.py tosca-5k ../shared/data/tosca-5k/test_pairs.txt 203 --seed-basis 30 60

``--statistics median mean`` likewise scores them with each ``DenseConfig.seed_statistic``.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from dense_variants import add_sample_arguments, prepared_pair, read_pair_lines  # the sibling script

from darcyan.dense.config import DenseConfig
from darcyan.dense.maps import dense_map
from darcyan.dense.seeds import chosen_seed, seed_scores
from darcyan.errors import DarcyanError
from darcyan.eval.dense_scores import evaluate_dense_maps
from darcyan.parallel import process_map

MARGINS = (0.0, 0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.1)
CLEAR = 0.15  # a seed's map is clearly better or worse than another's by this share within 0.05
SAMPLES = 300


def score_pair(task: tuple) -> dict:
    """One pair's seeds, scores and maps' rates; a pair that fails is recorded with its error."""
    try:
        return _score_pair(task)
    except (DarcyanError, OSError) as exc:
        return {"pair": f"{task[1]}->{task[2]}", "group": task[3], "failed": str(exc), "seeds": []}


def _score_pair(task: tuple) -> dict:
    dataset, source, target, group, sizes, statistics, repair = task
    warnings.simplefilter("ignore")
    shapes, correspondence, truth = prepared_pair(dataset, source, target, repair)
    default = dense_map(*shapes, correspondence)
    signatures = {int(rank): score for rank, score in default.check.verdict.signatures.items()}
    matchings = [correspondence] + list(correspondence.alternatives)
    # A spectral start (no matching with three consistent landmarks) is one seed past the matchings.
    signatures = {rank: score for rank, score in signatures.items() if rank < len(matchings)}
    # Each seed's own map: no rival start for a map in doubt (start_in_doubt off) and no landmark
    # pair left out (landmark_contradiction 0), or it would not be the seed's.
    alone = DenseConfig(candidates=1, start_in_doubt=False, landmark_contradiction=0.0)
    maps = {rank: dense_map(*shapes, matchings[rank], alone).target for rank in signatures}
    maps["default"] = default.target
    scores = evaluate_dense_maps(shapes[0].mesh, shapes[1].mesh, maps, truth, SAMPLES, target_solver=shapes[1].solver)
    by_size = {size: seed_scores(*shapes, correspondence, DenseConfig(seed_basis=size)) for size in sizes}
    by_statistic = {name: seed_scores(*shapes, correspondence, DenseConfig(seed_statistic=name)) for name in statistics}
    return {"pair": f"{source}->{target}", "group": group, "default_seed": default.check.seed,
            "trusted": default.check.trusted, "default_rate": scores["default"].rate,
            "orientation": default.check.orientation, "distortion": default.check.distortion,
            "start": default.check.start, "margin": float(correspondence.margin),
            "seeds": [{"rank": rank, "signature": signatures[rank], "rate": scores[rank].rate,
                       "by_seed_basis": {str(size): by_size[size].get(rank) for size in sizes},
                       "by_statistic": {name: by_statistic[name].get(rank) for name in statistics}}
                      for rank in signatures]}


def pick(seeds: list, margin: float, size: int | None = None, statistic: str | None = None) -> dict:
    """The rule of :func:`darcyan.dense.maps.dense_map` with ``seed_margin = margin`` (and the
    scores of short ZoomOuts of ``size`` eigenfunctions, or summed by ``statistic``, when given)."""
    return seeds[chosen_seed([s["signature"] if size is None and statistic is None else
                              s["by_statistic"][statistic] if statistic else s["by_seed_basis"][str(size)]
                              for s in seeds], margin)]


def summary(results: list, size: int | None = None, statistic: str | None = None) -> list:
    lines = ["| margin | picks the sparse seed | fixes | breaks | picks clearly below the best seed |",
             "| ---: | ---: | ---: | ---: | --- |"]
    if size is not None:  # the pairs scored at that size (a journal may hold older lines)
        results = [r for r in results if all(str(size) in s.get("by_seed_basis", {}) for s in r["seeds"])]
        lines.insert(0, f"seed_basis {size} ({len(results)} pairs):")
    if statistic is not None:
        results = [r for r in results if all(statistic in s.get("by_statistic", {}) for s in r["seeds"])]
        lines.insert(0, f"seed_statistic {statistic} ({len(results)} pairs):")
    for margin in MARGINS:
        chosen = [(r, pick(r["seeds"], margin, size, statistic)) for r in results if r["seeds"]]
        kept = sum(1 for r, s in chosen if s is r["seeds"][0])
        fixed = sum(1 for r, s in chosen if s["rate"] >= r["seeds"][0]["rate"] + CLEAR)
        broken = sum(1 for r, s in chosen if s["rate"] <= r["seeds"][0]["rate"] - CLEAR)
        below = [r["pair"] for r, s in chosen if s["rate"] <= max(x["rate"] for x in r["seeds"]) - CLEAR]
        lines.append(f"| {margin:g} | {kept} | {fixed} | {broken} | {', '.join(below[:6])}"
                     f"{' ...' if len(below) > 6 else ''} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_sample_arguments(parser)
    parser.add_argument("--out", type=Path, default=Path("dense-seeds.jsonl"))
    parser.add_argument("--seed-basis", type=int, nargs="+", default=[], metavar="N",
                        help="also score the seeds with short ZoomOuts of these sizes")
    parser.add_argument("--statistics", nargs="+", default=[], choices=("median", "mean"),
                        help="also score the seeds with these DenseConfig.seed_statistic")
    parser.add_argument("--repair", action="store_true", help="prepare the meshes as --repair does (e.g. the "
                        "decimated copies of benchmarks/robustness.py, with DARCYAN_DATA at their folder)")
    args = parser.parse_args(argv)
    try:
        for size in args.seed_basis:  # a bad size fails here, before any work, not in every pair
            DenseConfig(seed_basis=size)
        pairs = read_pair_lines(args.pairs, args.dataset, args.count)
        done = [json.loads(line) for line in args.out.read_text().splitlines()] if args.out.exists() else []
        options = {"dataset": args.dataset, "repair": args.repair}
        if any(r.get("options", options) != options for r in done):  # a resumed journal of another run
            raise DarcyanError(f"{args.out}: made with other options than {options}; give another --out")
    except (OSError, ValueError, DarcyanError) as exc:  # one line, no traceback (OSError names its file)
        print(f"dense_seeds.py: error: {exc}", file=sys.stderr)
        return 2
    finished = {r["pair"] for r in done}
    tasks = [(args.dataset, source, target, group, tuple(args.seed_basis), tuple(args.statistics), args.repair)
             for source, target, group in pairs
             if f"{source}->{target}" not in finished]
    with args.out.open("a") as journal:
        for result in (process_map(score_pair, tasks, 2) if tasks else []):
            journal.write(json.dumps({**result, "options": options}) + "\n")
            journal.flush()
            done.append(result)
            print(f"{len(done)}/{len(pairs)} {result['pair']}: " + (
                f"failed: {result['failed']}" if "failed" in result else
                f"seed {result['default_seed']}, {result['default_rate']:.2f} within 0.05"), file=sys.stderr)
    print("\n".join(summary(done)))
    for size in args.seed_basis:
        print()
        print("\n".join(summary(done, size)))
    for statistic in args.statistics:
        print()
        print("\n".join(summary(done, statistic=statistic)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
