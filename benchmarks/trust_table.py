"""Is a dense map's ``trusted`` flag honest? Trusted against right, from ``darcyan bench --dense`` runs.

Reads the ``pairs.jsonl`` of each bench output folder given and prints, per folder and pooled: the
pairs, those with no map, those whose map collapsed (fewer than ``--right`` of the sampled vertices
within 0.05: 80%) and those wholly wrong (at most 1%), the pooled share within 0.05 and mean
geodesic error (x100, over mapped samples), how each map was started (``matches``, ``spectral`` when
no matching gave three consistent landmarks, ``left out`` for a map from the matches made without a
landmark pair the others contradicted, ``rival`` when the start without landmarks won over a
map from the matches that was not trusted), and the table of trusted against right: a flag worth
acting on marks no collapsed map trusted. For the maps started without the feature matches, the
sparse stage's matches against those read from the map (``seed_correct`` of the dense record:
:func:`darcyan.dense.maps.matching_of_map`), right within 0.05.

    python benchmarks/trust_table.py out/faust-glued out/tosca-glued [--right 0.8]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def dense_records(folder: Path, method: str = "darcyan") -> list:
    """The dense records of ``method`` in one bench folder (the journal: finished pairs, even of a
    run in progress)."""
    rows = [json.loads(line) for line in (folder / "pairs.jsonl").read_text().splitlines() if line.strip()]
    return [r for r in rows if r.get("kind") == "dense" and r.get("method") == method]


def summary(records: list, right: float, residual_below: float | None = None) -> dict:
    mapped = [r for r in records if not r.get("failed")]
    rates = np.array([r["rate"] for r in mapped])
    within = sum(r["within"] for r in mapped)
    samples = sum(r["samples"] for r in mapped)
    errors = [r["mean_error"] * r["mapped"] for r in mapped if r.get("mean_error") is not None]
    counted = sum(r["mapped"] for r in mapped if r.get("mean_error") is not None)
    trusted = np.array([bool(r.get("check", {}).get("trusted")) for r in mapped])
    residuals = np.array([r.get("check", {}).get("residual", np.nan) for r in mapped], dtype=float)
    if residual_below is not None:  # a candidate condition beside the recorded rule
        trusted &= ~(residuals > residual_below)
    good = rates >= right
    starts: dict = {}
    for r in mapped:
        check = r.get("check", {})
        start = check.get("start", "matches")
        if start == "spectral" and check.get("rival") is not None:
            start = "rival"  # the start without landmarks, taken over a map from the matches in doubt
        elif start == "matches" and check.get("left_out") is not None:
            start = "left out"  # from the matches, without the landmark pair the others contradicted
        starts[start] = starts.get(start, 0) + 1
    return {"pairs": len(records), "no map": len(records) - len(mapped), "collapsed": int((~good).sum()),
            "wholly wrong": int((rates <= 0.01).sum()), "within": within / samples if samples else float("nan"),
            "mean x100": 100 * sum(errors) / counted if counted else float("nan"),
            "trusted right": int((trusted & good).sum()), "trusted collapsed": int((trusted & ~good).sum()),
            "untrusted right": int((~trusted & good).sum()), "untrusted collapsed": int((~trusted & ~good).sum()),
            "starts": starts, "worst": sorted((r["rate"], f"{r['source']} -> {r['target']}") for r in mapped)[:3],
            "residuals": (residuals[good], residuals[~good])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--right", type=float, default=0.8, help="a map is right at this share within 0.05")
    parser.add_argument("--residual-below", type=float, help="also require the alignment's residual (check['residual'], "
                        "sqrt(area)) at most this: a candidate condition of the trust rule, tried on the records")
    args = parser.parse_args(argv)
    pooled = []
    columns = ("pairs", "no map", "collapsed", "wholly wrong", "within", "mean x100", "trusted right",
               "trusted collapsed", "untrusted right", "untrusted collapsed")
    try:  # a missing or unreadable folder: one error line, before any table
        runs = {folder: dense_records(folder) for folder in args.folders}
    except (OSError, ValueError) as exc:
        print(f"trust_table.py: error: {exc}", file=sys.stderr)
        return 2
    print("| set | " + " | ".join(columns) + " | starts | worst |")
    print("| --- " * (len(columns) + 3) + "|")
    for folder in args.folders:
        records = runs[folder]
        pooled += records
        row = summary(records, args.right, args.residual_below)
        print(f"| {folder.name} | " + " | ".join(_cell(row[c]) for c in columns)
              + f" | {row['starts']} | {', '.join(f'{n} {r:.2f}' for r, n in row['worst'])} |")
    if len(args.folders) > 1:
        row = summary(pooled, args.right, args.residual_below)
        print("| pooled | " + " | ".join(_cell(row[c]) for c in columns) + f" | {row['starts']} | |")
    right_residuals, collapsed_residuals = summary(pooled, args.right)["residuals"]
    for name, values in (("right", right_residuals), ("collapsed", collapsed_residuals)):
        values = values[np.isfinite(values)]
        if len(values):
            print(f"\nalignment residual of {name} maps ({len(values)}): min {values.min():.4f}, median "
                  f"{np.median(values):.4f}, 95% {np.quantile(values, 0.95):.4f}, max {values.max():.4f}")
    read_back(args.folders)
    baseline = [(folder, dense_records(folder, "pyfm")) for folder in args.folders]
    if any(records for _, records in baseline):  # pyFM's own pipeline in the same runs, for contrast
        print("\n| set | pyFM pairs | collapsed | wholly wrong | within | mean x100 |\n| --- | --- | --- | --- | --- | --- |")
        for folder, records in baseline:
            if records:
                row = summary(records, args.right)
                print(f"| {folder.name} | {row['pairs']} | {row['collapsed']} | {row['wholly wrong']} | "
                      f"{_cell(row['within'])} | {_cell(row['mean x100'])} |")
    return 0


def read_back(folders: list) -> None:
    """Prints, over the maps started without the feature matches, how many of the sparse stage's
    matches were right and how many of those read from the map (bench records that have them)."""
    sparse_right = sparse_count = read_right = read_count = better = worse = maps = 0
    for folder in folders:
        rows = [json.loads(line) for line in (folder / "pairs.jsonl").read_text().splitlines() if line.strip()]
        sparse = {(r["source"], r["target"]): r for r in rows if r.get("kind") != "dense" and r.get("method") == "darcyan"}
        for r in dense_records(folder):
            first = sparse.get((r["source"], r["target"]))
            if r.get("check", {}).get("start") != "spectral" or "seed_matches" not in r or first is None:
                continue
            maps += 1
            sparse_right, sparse_count = sparse_right + first["correct"], sparse_count + first["matches"]
            read_right, read_count = read_right + r["seed_correct"], read_count + r["seed_matches"]
            before = first["correct"] / first["matches"] if first["matches"] else 0.0
            after = r["seed_correct"] / r["seed_matches"] if r["seed_matches"] else 0.0
            better, worse = better + (after > before), worse + (after < before)
    if maps:
        print(f"\nmaps started without the feature matches ({maps}): the sparse stage's matches {sparse_right} of "
              f"{sparse_count} right, those read from the map {read_right} of {read_count}; pairs with a higher "
              f"share right {better}, lower {worse}")


def _cell(value) -> str:
    return f"{value:.4f}" if isinstance(value, float) and value < 1 else f"{value:.2f}" if isinstance(value, float) \
        else str(value)


if __name__ == "__main__":
    sys.exit(main())
