"""One Markdown table from several ``darcyan bench`` runs: per class, each run's methods side by side.

    python benchmarks/results_table.py default=bench-hires paper=bench-hires-paper

Each argument is ``LABEL=FOLDER`` (a ``darcyan bench --out`` folder). Cells read
``strict / with flips / repeatability`` (rates at the run's threshold, pooled over the class's
pairs); the last rows are the unweighted mean over classes, the coverage (matches per source
feature point, all pairs) and the wall time of each run.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        print(__doc__)
        return 2
    columns, classes = [], []
    for item in argv:
        label, _, folder = item.partition("=")
        results = json.loads((Path(folder) / "results.json").read_text())
        for method, data in results["methods"].items():
            columns.append((f"{method} ({label})", data, results.get("wall_seconds")))
            classes += [c for c in data["classes"] if c not in classes]
    print("| class | " + " | ".join(name for name, _, _ in columns) + " |")
    print("| --- | " + " | ".join("---" for _ in columns) + " |")

    def cell(stats):
        if not stats:
            return ""
        return " / ".join(f"{100 * stats[k]:.0f}%" if stats.get(k) is not None else "-"
                          for k in ("rate", "rate_sym", "repeatability"))

    for cls in classes:
        print(f"| {cls} | " + " | ".join(cell(data["classes"].get(cls)) for _, data, _ in columns) + " |")
    means = []
    for _, data, _ in columns:
        rows = list(data["classes"].values())
        mean = {k: sum(r[k] for r in rows) / len(rows) for k in ("rate", "rate_sym", "repeatability")}
        means.append(cell(mean))
    print("| **mean over classes** | " + " | ".join(means) + " |")
    coverage = [f"{100 * data['overall']['matches'] / data['overall']['features']:.0f}%" for _, data, _ in columns]
    print("| coverage (matches / source feature points) | " + " | ".join(coverage) + " |")
    walls = [f"{wall / 60:.1f} min" if wall else "" for _, _, wall in columns]
    print("| wall time of the run (all its methods) | " + " | ".join(walls) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
