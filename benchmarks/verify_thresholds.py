"""Which matchings should short dense maps verify? The sparse rate at each verification threshold.

Each darcyan record of ``darcyan bench`` carries the orientation test's ``margin``, and a
pair's verification does not depend on the threshold that called for it. So two runs of one
set, one as it was run (``DEFAULT``) and one with every matching verified (``VERIFIED``: ``--config``
holding ``{"mirror": {"verify_below": 100}}``), give the matches of any threshold T: the
verified run's for the pairs whose margin is below T, the default run's for the others (for
T at least the default run's own threshold, below which both verified alike).

    python benchmarks/verify_thresholds.py out/faust-default out/faust-all [--thresholds 0.25 0.5 0.75 1]

Prints per threshold the strict rate (correct / matches) and the pairs verified, then the pairs
whose matches change between the smallest and the largest threshold given, each with its margin.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def sparse_records(folder: Path, method: str = "darcyan") -> dict:
    """``(source, target) -> record``: the sparse records of ``method`` in one bench folder."""
    path = folder / "pairs.jsonl"
    try:
        rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    except ValueError as exc:
        raise ValueError(f"{path}: not a bench journal ({exc})") from None
    return {(r["source"], r["target"]): r for r in rows
            if r.get("method") == method and r.get("kind", "sparse") == "sparse" and "correct" in r}


def at_threshold(default: dict, verified: dict, threshold: float) -> tuple:
    """``(correct, matches, pairs verified)`` over the pairs of ``default`` when the matchings
    whose margin is below ``threshold`` take ``verified``'s matches."""
    correct = matches = count = 0
    for pair, record in default.items():
        other = verified[pair]
        margin = other.get("margin")
        use = other if margin is not None and margin < threshold else record
        count += use is other
        correct += use["correct"]
        matches += use["matches"]
    return correct, matches, count


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("default", type=Path, help="a bench output folder, run as it was")
    parser.add_argument("verified", type=Path, help="the same set with every matching verified")
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.25, 0.5, 0.75, 1.0])
    args = parser.parse_args(argv)
    try:
        default, verified = sparse_records(args.default), sparse_records(args.verified)
    except (OSError, ValueError, KeyError) as exc:
        print(f"verify_thresholds: {exc}", file=sys.stderr)
        return 2
    missing = sorted(set(default) - set(verified))
    if missing:
        print(f"verify_thresholds: {args.verified}: {len(missing)} pairs of {args.default} missing, e.g. "
              f"{missing[0][0]} -> {missing[0][1]}", file=sys.stderr)
        return 2
    thresholds = sorted(args.thresholds)
    print(f"{args.default.name} ({len(default)} pairs)")
    print("| threshold | strict rate | correct / matches | pairs verified |\n| ---: | ---: | ---: | ---: |")
    for threshold in thresholds:
        correct, matches, count = at_threshold(default, verified, threshold)
        print(f"| {threshold:g} | {100 * correct / max(matches, 1):.2f}% | {correct} / {matches} | {count} |")
    if len(thresholds) > 1:
        low, high = thresholds[0], thresholds[-1]
        print(f"\nPairs whose matches change from {low:g} to {high:g}:")
        for pair, record in sorted(default.items()):
            other = verified[pair]
            margin = other.get("margin")
            if margin is not None and low <= margin < high and (other["correct"], other["matches"]) != (
                    record["correct"], record["matches"]):
                print(f"  {pair[0]} -> {pair[1]}: margin {margin:.2f}, {record['correct']} of {record['matches']} "
                      f"-> {other['correct']} of {other['matches']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
