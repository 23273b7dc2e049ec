"""One Markdown table from several ``darcyan bench`` runs: per class, each run's methods side by side.

    python benchmarks/results_table.py default=bench-hires paper=bench-hires-paper [--plot rates.png]

Each argument is ``LABEL=FOLDER`` (a ``darcyan bench --out`` folder). Cells read
``strict / with flips / repeatability`` (rates at the run's threshold, pooled over the class's
pairs); the last rows are the unweighted mean over classes, the coverage (matches per source
feature point, all pairs) and the wall time of each run. ``--plot FILE`` also draws the strict
rate per class (solid) and the rate with flips (hatched) of every column, in darcyan's style.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    plot = None
    if "--plot" in argv:
        at = argv.index("--plot")
        plot = argv[at + 1]
        del argv[at:at + 2]
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
    if plot:
        draw(columns, classes, plot)
    return 0


def draw(columns: list, classes: list, path: str) -> None:
    import numpy as np

    from darcyan.viz import style

    labels = classes + ["mean"]
    width = 0.8 / len(columns)
    with style.context():
        fig, ax = style.figure((max(6.0, 1.3 * len(labels) + 3), 4.0))
        for i, (name, data, _) in enumerate(columns):
            rows = [data["classes"].get(c) or {} for c in classes]
            strict = [r.get("rate") or 0.0 for r in rows]
            sym = [r.get("rate_sym") or 0.0 for r in rows]
            strict.append(float(np.mean(strict)))
            sym.append(float(np.mean(sym)))
            x = np.arange(len(labels)) - 0.4 + width * (i + 0.5)
            colour = style.PALETTE[i % len(style.PALETTE)]
            ax.bar(x, np.array(sym) * 100, width * 0.9, color="white", edgecolor=colour, hatch="///", linewidth=0.8)
            ax.bar(x, np.array(strict) * 100, width * 0.9, color=colour, label=name)
        ax.set_xticks(np.arange(len(labels)), labels)
        ax.set_ylim(0, 100)
        ax.set_ylabel("correspondence rate (%), error <= 0.05")
        ax.set_title("strict rate (solid) and with symmetric flips (hatched)")
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))
        style.save(fig, path)


if __name__ == "__main__":
    sys.exit(main())
