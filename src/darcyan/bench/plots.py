"""The pictures of a ``darcyan bench`` run: rates per class, cumulative curves (sparse, per group,
dense)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .report import group_report, percent

GROUP_LINESTYLES = ("-", "--", ":", "-.")


def write_plots(results: dict, out: Path) -> list:
    """rates.png and curve.png (and dense_curve.png with dense results) in ``out``; nothing (and
    a note on stderr) without matplotlib."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        print("darcyan: note: rates.png and curve.png need matplotlib: pip install 'darcyan[plot]'", file=sys.stderr)
        return []
    written = []
    if results["methods"]:
        written += [plot_rates(results, out / "rates.png"), plot_curves(results, out / "curve.png")]
    if results.get("dense"):
        written.append(plot_dense_curves(results, out / "dense_curve.png"))
    if group_report(results):
        written.append(plot_group_curves(results, out / "group_curves.png"))
    return written


def plot_group_curves(results: dict, path: Path) -> Path:
    """Cumulative error per group of pairs, one colour per method and one line style per group:
    the sparse matches on the left, the dense maps (when the run has them) on the right."""
    from ..viz import style

    taus = np.asarray(results["taus"])
    parts = [("sparse matches", results["methods"], "matches")]
    if results.get("dense"):
        parts.append(("dense maps", results["dense"], "sampled vertices"))
    with style.context():
        fig, _ = style.figure((6.0 * len(parts), 4.0))
        fig.clf()  # one panel per part
        axes = [fig.add_subplot(1, len(parts), i + 1) for i in range(len(parts))]
        for ax, (title, methods, what) in zip(axes, parts):
            groups = sorted({g for m in methods.values() for g in m.get("groups", {})})
            for name, m in methods.items():
                for i, group in enumerate(groups):
                    g = m.get("groups", {}).get(group)
                    if g is None:
                        continue
                    ax.plot(taus, np.asarray(g["curve"]) * 100, color=style.method_colour(name),
                            linestyle=GROUP_LINESTYLES[i % len(GROUP_LINESTYLES)],
                            label=f"{name}, {group} ({percent(g['rate'])})")
            _curve_axes(ax, results, taus, f"{what} with error <= threshold (%)",
                        f"{Path(results['dataset']).name}: {title} per group")
        style.save(fig, path)
    return path


def plot_rates(results: dict, path: Path) -> Path:
    """Bars per class (and the mean over classes): strict rate solid, with symmetric flips
    hatched on top, one colour per method (the paper's Fig. 8 side by side)."""
    from ..viz import style

    methods = results["methods"]
    classes = sorted({c for m in methods.values() for c in m["classes"]})
    labels = classes + ["mean"]
    width = 0.8 / len(methods)
    with style.context():
        fig, ax = style.figure((max(6.0, 1.1 * len(labels) + 2), 4.0))
        for i, (name, m) in enumerate(methods.items()):
            strict = [(m["classes"].get(c) or {}).get("rate") or 0.0 for c in classes] + [m["overall"]["rate_class_mean"] or 0.0]
            sym = [(m["classes"].get(c) or {}).get("rate_sym") or 0.0 for c in classes] + [m["overall"]["rate_sym_class_mean"] or 0.0]
            x = np.arange(len(labels)) - 0.4 + width * (i + 0.5)
            colour = style.method_colour(name)
            ax.bar(x, np.array(sym) * 100, width * 0.9, color="white", edgecolor=colour, hatch="///", linewidth=0.8,
                   label=f"{name} (with flips)")
            ax.bar(x, np.array(strict) * 100, width * 0.9, color=colour, label=f"{name}")
        ax.set_xticks(np.arange(len(labels)), labels)
        ax.set_ylim(0, 100)
        ax.set_ylabel(f"correspondence rate (%), error <= {results['threshold']}")
        ax.set_title(f"{Path(results['dataset']).name}: rate per class")
        ax.legend(ncol=2, fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0))
        style.save(fig, path)
    return path


def plot_curves(results: dict, path: Path) -> Path:
    """Cumulative curve per method: share of matches with error <= tau (solid strict, dashed
    with symmetric flips)."""
    from ..viz import style

    taus = np.asarray(results["taus"])
    with style.context():
        fig, ax = style.figure()
        for name, m in results["methods"].items():
            colour = style.method_colour(name)
            ax.plot(taus, np.asarray(m["overall"]["curve"]) * 100, color=colour, label=name)
            ax.plot(taus, np.asarray(m["overall"]["curve_sym"]) * 100, color=colour, linestyle="--",
                    label=f"{name} (with flips)")
        _curve_axes(ax, results, taus, "matches with error <= threshold (%)",
                    f"{Path(results['dataset']).name}: cumulative error")
        style.save(fig, path)
    return path


def plot_dense_curves(results: dict, path: Path) -> Path:
    """Cumulative curve of the dense maps, one line per method: share of the sampled source
    vertices with error <= tau, pooled over the pairs."""
    from ..viz import style

    taus = np.asarray(results["taus"])
    samples = ((results.get("settings") or {}).get("dense") or {}).get("samples")
    with style.context():
        fig, ax = style.figure()
        for name, m in results["dense"].items():
            o = m["overall"]
            ax.plot(taus, np.asarray(o["curve"]) * 100, color=style.method_colour(name),
                    label=f"{name} ({percent(o['rate'])} within {results['threshold']}, {o['pairs']} pairs)")
        _curve_axes(ax, results, taus, "sampled source vertices with error <= threshold (%)",
                    f"{Path(results['dataset']).name}: dense maps, cumulative error"
                    + (f" ({samples} vertices per pair)" if samples else ""))
        style.save(fig, path)
    return path


def _curve_axes(ax, results: dict, taus: np.ndarray, ylabel: str, title: str) -> None:
    """What every cumulative-error panel shares: the threshold's line, the axes' ranges and
    labels, the title and the legend."""
    from ..viz import style

    ax.axvline(results["threshold"], color=style.NEUTRAL["edge"], linewidth=0.8, linestyle=":")
    ax.set_xlim(taus[0], taus[-1])
    ax.set_ylim(0, 100)
    ax.set_xlabel("geodesic error / sqrt(area)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize="small", loc="lower right")
