"""Parameter study: the strict correspondence rate against each parameter of the method.

Each parameter is varied alone around the defaults (``DarcyanConfig()``); every setting is a
full ``darcyan bench`` run (per-shape work cached by content and parameters, so reruns and
settings that share the features are cheap). Prints a table, writes ``sweep.json`` and one plot
per parameter in ``--out``.

    python benchmarks/sweep.py ../shared/data/tosca-5k --pairs ../shared/data/tosca-5k/test_pairs.txt \\
        --out sweep-5k --jobs 2
    python benchmarks/sweep.py ../shared/data/tosca-hires --pairs PAIRS --out sweep-hires --only radius levels

Both ``consistent`` matching (the default) and the paper's ``nearest`` matching are measured.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from darcyan import DarcyanConfig
from darcyan.bench.runner import run_bench

# Values tried for each parameter (the default is added to each list).
GRID = {
    "radius": [0.03, 0.05, 0.08, 0.12, 0.16],
    "levels": [2, 4, 6, 8, 12],
    "radial_lines": [4, 8, 16, 32],
    "interpolation": [1, 2, 4],
    "curvature_smoothing": [0, 2, 4, 8],
    "agd_sources": [8, 16, 24, 48],
    "agd_smoothing": [0.0, 0.04, 0.07, 0.1, 0.14, 0.2, 0.3],
    "extremity_radius": [0.15, 0.25, 0.35],
    "min_agd_quantile": [0.0, 0.3, 0.5],
}
MATCHINGS = ("consistent", "nearest")


def class_mean(results: dict, key: str) -> float:
    classes = results["methods"]["darcyan"]["classes"]
    values = [c[key] for c in classes.values() if c.get(key) is not None]
    return sum(values) / len(values) if values else float("nan")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dataset")
    parser.add_argument("--pairs", help="tab-separated source/target pairs (default: all within-class pairs)")
    parser.add_argument("--out", default="sweep-out")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--only", nargs="*", choices=sorted(GRID), help="parameters to sweep (default: all)")
    parser.add_argument("--values", nargs="*", type=float, help="with one --only parameter: these values instead of the grid's")
    parser.add_argument("--matchings", nargs="*", choices=MATCHINGS, default=list(MATCHINGS))
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    base = DarcyanConfig()
    rows = []
    store = out / "sweep.json"
    if store.exists():
        rows = json.loads(store.read_text())
    done = {(r["param"], r["value"], r["matching"]) for r in rows}
    for name in args.only or GRID:
        values = sorted(set(args.values or GRID[name]) | {getattr(base, name)})
        kind = type(getattr(base, name))
        for value in map(kind, values):
            for matching in args.matchings:
                if (name, value, matching) in done:
                    continue
                config = base.replace(**{name: value, "matching": matching})
                run_dir = out / "runs" / f"{name}={value}-{matching}"
                result = run_bench(args.dataset, run_dir, ("darcyan",), args.pairs, config=config, jobs=args.jobs,
                                   resume=True, plots=False, progress=False)
                row = {"param": name, "value": value, "matching": matching, "default": value == getattr(base, name),
                       "rate": class_mean(result.results, "rate"),
                       "rate_per_feature": _per_feature(result.results),
                       "rate_sym": class_mean(result.results, "rate_sym"),
                       "repeatability": class_mean(result.results, "repeatability"),
                       "seconds": result.seconds}
                rows.append(row)
                store.write_text(json.dumps(rows, indent=1))
                print(f"{name:>20} = {value!s:<6} {matching:<10} rate {row['rate']:.3f}  per feature "
                      f"{row['rate_per_feature']:.3f}  sym {row['rate_sym']:.3f}  rep {row['repeatability']:.3f}",
                      flush=True)
    plot(rows, out)
    (out / "sweep.md").write_text(markdown(rows))
    return 0


def markdown(rows: list) -> str:
    """The study as a Markdown table: one row per parameter value, both matchings."""
    lines = ["| parameter | value | consistent: rate per feature | rate_sym | nearest: rate per feature | rate_sym | repeatability |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    keyed = {(r["param"], r["value"], r["matching"]): r for r in rows}
    for name, value in sorted({(r["param"], r["value"]) for r in rows}):
        c, n = keyed.get((name, value, "consistent")), keyed.get((name, value, "nearest"))
        default = " (default)" if (c or n)["default"] else ""
        cells = [f"{r[k]:.3f}" if r else "" for r in (c,) for k in ("rate_per_feature", "rate_sym")]
        cells += [f"{r[k]:.3f}" if r else "" for r in (n,) for k in ("rate_per_feature", "rate_sym")]
        rep = (c or n)["repeatability"]
        lines.append(f"| {name} | {value}{default} | " + " | ".join(cells) + f" | {rep:.3f} |")
    return "\n".join(lines) + "\n"


def _per_feature(results: dict) -> float:
    """Class mean of correct matches per source feature point (unmatched points count as misses)."""
    classes = results["methods"]["darcyan"]["classes"].values()
    values = [c["correct"] / c["features"] for c in classes if c.get("features")]
    return sum(values) / len(values) if values else float("nan")


def plot(rows: list, out: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plots", file=sys.stderr)
        return
    names = sorted({r["param"] for r in rows})
    columns = min(4, len(names))
    lines = -(-len(names) // columns)
    fig, axes = plt.subplots(lines, columns, figsize=(3.2 * columns, 2.8 * lines), squeeze=False)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    for ax, name in zip(axes.ravel(), names):
        for matching, style in zip(MATCHINGS, ("-o", "--s")):
            sel = sorted((r for r in rows if r["param"] == name and r["matching"] == matching), key=lambda r: r["value"])
            ax.plot([r["value"] for r in sel], [r["rate_per_feature"] for r in sel], style, label=matching)
            for r in sel:
                if r["default"]:
                    ax.axvline(r["value"], color="grey", lw=0.8, ls=":")
        ax.set_title(name, fontsize=9)
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    for row in axes:
        row[0].set_ylabel("strict rate per source feature")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "sweep.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
