"""What a ``darcyan bench`` run writes: the summaries of its records (``results.json``), the
pairs' table (``pairs.csv``) and the report (``report.md``)."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path

import numpy as np

from ..errors import DarcyanError
from ..eval.metrics import (
    CURVE_TAUS,
    summarize,
)
from . import DENSE_METHODS, METHODS
from .datasets import Dataset
from .records import DENSE, record_array, record_kind
from .settings import MIRROR_MAX_RESIDUAL, BenchSettings

RATE_DEFINITION = (
    "rate = correct / matches, pooled over every match of the class's pairs (with nearest-descriptor "
    "matching every source feature point gets one match); 'all' pools every match of the run; 'mean over classes' is the unweighted mean "
    "of the class rates (the paper's Fig. 8 reports one rate per class). recall = correct / source "
    "feature points: it differs from the rate only when a matcher leaves feature points unmatched.")
DENSE_DEFINITION = (
    "Dense maps: each method maps every source vertex; per pair a fixed random sample of source vertices "
    "(numpy.random.default_rng(seed), the same vertices for every method; with vts ground truth drawn among the "
    "listed corres/*.vts samples, whose correspondents are exact; with identity ground truth among all vertices) "
    "is scored by geodesic error / sqrt(target area). rate = sampled vertices within the threshold / sampled "
    "vertices, pooled over the pairs (a pair whose map failed counts as 0 within); mean_error pools the mapped "
    "samples; seconds = the dense stage only (darcyan: dense_map after the sparse matches; pyfm: its whole "
    "pipeline, its spectra included).")
PAIR_COLUMNS = ("method", "class", "source", "target", "features", "matches", "correct", "correct_sym",
                "repeatable", "rate", "rate_sym", "mean_error", "seconds")


def _by_method(records: list, known: tuple) -> dict:
    """``{method: [records]}``, the ``known`` methods first in their order, then the others."""
    by_method: dict = {}
    for r in records:
        by_method.setdefault(r["method"], []).append(r)
    order = [m for m in known if m in by_method] + sorted(set(by_method) - set(known))
    return {m: by_method[m] for m in order}


def _split(rows: list, key) -> dict:
    """``{key(row): [positions in rows]}``, keys sorted."""
    parts: dict = {}
    for i, r in enumerate(rows):
        parts.setdefault(key(r), []).append(i)
    return dict(sorted(parts.items()))


def _class(record: dict) -> str:
    return record["class"]


def _group(record: dict) -> str:
    return record.get("group", record["class"])  # journals written before groups existed


def summarize_records(records: list, threshold: float) -> dict:
    """``{method: {"overall": {...}, "classes": {class: {...}}, "groups": {group: {...}}}}`` from
    pair records."""
    methods = {}
    for method, rows in _by_method(records, METHODS).items():
        scores = [{"features": r["features"], "errors": record_array(r["errors"]), "errors_sym": record_array(r["errors_sym"]),
                   "repeatable": r["repeatable"], "repeatable_sym": r["repeatable_sym"]} for r in rows]
        classes = {}
        for cls, at in _split(rows, _class).items():
            classes[cls] = summarize([scores[i] for i in at], threshold)
            classes[cls]["pair_seconds"] = float(sum(rows[i]["seconds"] for i in at))
        overall = summarize(scores, threshold)
        for key in ("rate", "rate_sym", "recall", "recall_sym", "repeatability"):
            values = [c[key] for c in classes.values() if c[key] is not None]
            overall[f"{key}_class_mean"] = float(np.mean(values)) if values else None
        overall["pair_seconds"] = float(sum(r["seconds"] for r in rows))
        if any("margin" in r for r in rows):  # darcyan: the matchings to verify (to_verify), verified by dense maps
            overall["verified_pairs"] = sum("verified" in r for r in rows)
            overall["verify_changed"] = sum(r.get("verified", 0) != 0 for r in rows)
            overall["verify_failed"] = sum("verify_failed" in r for r in rows)
            overall["correct_unverified"] = sum(r.get("unverified_correct", r["correct"]) for r in rows)
            overall["matches_unverified"] = sum(r.get("unverified_matches", r["matches"]) for r in rows)
        groups = {g: summarize([scores[i] for i in at], threshold) for g, at in _split(rows, _group).items()}
        methods[method] = {"overall": overall, "classes": classes, "groups": groups}
    return methods


def summarize_dense(records: list) -> dict:
    """``{method: {"overall", "classes": {class: ...}, "groups": {group: ...}, "pairs": [...]}}``
    from dense pair records.

    Per class, group and overall: ``pairs``, ``failed`` (pairs without a map), ``samples``,
    ``within``, ``rate`` (within / samples, pooled), ``mean_error`` (over the mapped samples),
    ``curve`` (pooled cumulative curve over ``CURVE_TAUS``), ``seconds`` (sum of the dense
    stages), ``seconds_per_pair``, ``untrusted`` (maps whose own check doubts them) and
    ``seed_rate`` (strict rate of the feature matches darcyan's maps agree with: the matchings that
    seeded them, or those a map started without them reads); overall also
    ``rate_class_mean``.
    """
    out = {}
    for method, rows in _by_method(records, DENSE_METHODS).items():
        classes = {c: _pool_dense([rows[i] for i in at]) for c, at in _split(rows, _class).items()}
        overall = _pool_dense(rows)
        overall["rate_class_mean"] = float(np.mean([c["rate"] for c in classes.values()])) if classes else None
        groups = {g: _pool_dense([rows[i] for i in at]) for g, at in _split(rows, _group).items()}
        out[method] = {"overall": overall, "classes": classes, "groups": groups, "pairs": rows}
    return out


def _pool_dense(rows: list) -> dict:
    samples = sum(r["samples"] for r in rows)
    within = sum(r["within"] for r in rows)
    mapped = sum(r["mapped"] for r in rows)
    error_sum = sum(r["mean_error"] * r["mapped"] for r in rows if r["mapped"])
    curve = sum(np.asarray(r["curve"]) * r["samples"] for r in rows) / samples if samples else np.zeros(len(CURVE_TAUS))
    seconds = float(sum(r["seconds"] for r in rows))
    seeded = [r for r in rows if "seed_matches" in r]
    seed_matches = sum(r["seed_matches"] for r in seeded)  # the sparse rate's definition: correct / matches
    return {"seed_rate": sum(r["seed_correct"] for r in seeded) / seed_matches if seed_matches else None,
            "pairs": len(rows), "failed": sum(1 for r in rows if r.get("failed")),
            "untrusted": sum(1 for r in rows if (r.get("check") or {}).get("trusted") is False), "samples": samples,
            "within": within, "rate": within / samples if samples else None,
            "mean_error": error_sum / mapped if mapped else None, "curve": np.asarray(curve).tolist(),
            "seconds": seconds, "seconds_per_pair": seconds / len(rows) if rows else None}


def write_outputs(out: Path, dataset: Dataset, settings: BenchSettings, info: dict, journal: list, pairs: list,
                  wall_seconds: float, groups: dict | None = None) -> dict:
    """Rewrite results.json, pairs.csv and report.md from the journal (the pairs of this run;
    ``groups`` ``{(source, target): group}``, else each pair in its class's group)."""
    pair_set = set(pairs)
    groups = groups or {}
    records = [dict(r, group=groups.get((r["source"], r["target"]), r["class"]))  # this run's groups
               for r in journal if (r["source"], r["target"]) in pair_set]
    order = {p: i for i, p in enumerate(pairs)}
    method_order = {m: i for i, m in enumerate(METHODS)}
    records.sort(key=lambda r: (method_order.get(r["method"], len(METHODS)), order[(r["source"], r["target"])]))
    dense = [r for r in records if record_kind(r) == DENSE]
    records = [r for r in records if record_kind(r) != DENSE]
    results = {
        "dataset": str(dataset.root.resolve()), "ground_truth": dataset.truth, "threshold": settings.threshold,
        "taus": CURVE_TAUS.tolist(), "settings": info.get("settings", settings.as_dict()),
        "rate_definition": RATE_DEFINITION, "mirror": info.get("mirror", {}), "pairs_expected": len(pairs),
        "wall_seconds": wall_seconds, "methods": summarize_records(records, settings.threshold), "pairs": records,
    }
    if dense or settings.dense:
        results["dense_definition"] = DENSE_DEFINITION
        results["dense"] = summarize_dense(dense)
    write_atomic(out / "results.json", json.dumps(results, indent=None, separators=(",", ":")))
    write_atomic(out / "pairs.csv", pairs_csv(records, settings.threshold))
    write_atomic(out / "report.md", report_markdown(results))
    return results


def pairs_csv(records: list, threshold: float) -> str:
    """One row per method x pair."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(PAIR_COLUMNS)
    for r in records:
        s = summarize([{"features": r["features"], "errors": record_array(r["errors"]), "errors_sym": record_array(r["errors_sym"]),
                        "repeatable": r["repeatable"], "repeatable_sym": r["repeatable_sym"]}], threshold)
        writer.writerow([r["method"], r["class"], r["source"], r["target"], r["features"], r["matches"], s["correct"],
                         s["correct_sym"], int(np.sum(r["repeatable"])), _fmt(s["rate"]), _fmt(s["rate_sym"]),
                         _fmt(s["mean_error"]), f"{r['seconds']:.3f}"])
    return buffer.getvalue()


def _fmt(value, digits: int = 3) -> str:
    return "" if value is None else f"{value:.{digits}f}"


def percent(value) -> str:
    return "–" if value is None else f"{100 * value:.0f}%"


def report_markdown(results: dict) -> str:
    """The tables of a run as Markdown."""
    methods = results["methods"]
    lines = [f"# darcyan bench: {Path(results['dataset']).name}", ""]
    lines.append(f"Dataset `{results['dataset']}`, ground truth: "
                 + ("`corres/*.vts` (p's true correspondent at the geodesically nearest listed sample)"
                    if results["ground_truth"] == "vts" else "identity on vertex indices within a class")
                 + f". Threshold {results['threshold']} (geodesic error / sqrt(target area)). "
                 f"{sum(m['overall']['pairs'] for m in methods.values())} matchings (method x pair) of "
                 f"{results['pairs_expected']} pairs x {len(methods)} method(s); wall time of the last run "
                 f"{clock(results['wall_seconds'])}.")
    lines += ["", RATE_DEFINITION + " rate_sym also counts a match correct under the mirror ground truth "
              "(a left-right flip); repeatability is the share of source feature points with some target "
              "feature point within the threshold of their true correspondent (detection), whatever the "
              "match (description).", ""]
    if methods:
        class_names = sorted({c for m in methods.values() for c in m["classes"]})
        lines += ["## Side by side: strict rate / with symmetric flips / repeatability", ""]
        lines.append("| class | " + " | ".join(methods) + " |")
        lines.append("| --- |" + " --- |" * len(methods))
        for cls in class_names:
            cells = []
            for m in methods.values():
                c = m["classes"].get(cls)
                cells.append("" if c is None else f"{percent(c['rate'])} / {percent(c['rate_sym'])} / {percent(c['repeatability'])}")
            lines.append(f"| {cls} | " + " | ".join(cells) + " |")
        lines.append("| **mean over classes** | " + " | ".join(
            f"{percent(m['overall']['rate_class_mean'])} / {percent(m['overall']['rate_sym_class_mean'])} / "
            f"{percent(m['overall']['repeatability_class_mean'])}" for m in methods.values()) + " |")
        lines.append("| **all matches pooled** | " + " | ".join(
            f"{percent(m['overall']['rate'])} / {percent(m['overall']['rate_sym'])} / {percent(m['overall']['repeatability'])}"
            for m in methods.values()) + " |")
        for name, m in methods.items():
            lines += ["", f"## {name}", "",
                      "| class | pairs | features | matches | correct | rate | rate_sym | recall | recall_sym "
                      "| repeatability | mean error | s/pair |",
                      "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
            for cls, c in list(m["classes"].items()) + [("**all**", m["overall"])]:
                lines.append(f"| {cls} | {c['pairs']} | {c['features']} | {c['matches']} | {c['correct']} | "
                             f"{_fmt(c['rate'])} | {_fmt(c['rate_sym'])} | {_fmt(c['recall'])} | "
                             f"{_fmt(c['recall_sym'])} | {_fmt(c['repeatability'])} | "
                             f"{_fmt(c['mean_error'])} | {c['pair_seconds'] / max(c['pairs'], 1):.2f} |")
            lines.append(f"\nMean over classes: rate {_fmt(m['overall']['rate_class_mean'])}, rate_sym "
                         f"{_fmt(m['overall']['rate_sym_class_mean'])}, recall "
                         f"{_fmt(m['overall']['recall_class_mean'])}, recall_sym "
                         f"{_fmt(m['overall']['recall_sym_class_mean'])}, repeatability "
                         f"{_fmt(m['overall']['repeatability_class_mean'])}. 's/pair' is the mean matching time "
                         f"of a pair (for pyfm the whole functional-map pipeline; per-shape work is cached and not counted).")
            o = m["overall"]
            if "verified_pairs" in o:
                lines.append(f"\nMatchings whose orientation test's margin is below `mirror.verify_sparse_below` (or, "
                             f"in doubt, `mirror.verify_below`), verified by short dense maps: {o['verified_pairs']} "
                             f"pairs, {o['verify_changed']} "
                             f"changed" + (f", {o['verify_failed']} could not be verified" if o["verify_failed"] else "")
                             + f". Without it: {o['correct_unverified']} of {o['matches_unverified']} matches "
                             f"correct; with it: {o['correct']} of {o['matches']} (the rates above).")
    lines += _dense_report(results)
    lines += group_report(results)
    mirror = results.get("mirror", {})
    if mirror:
        lines += ["", "## Mirror ground truth", ""]
        if results["ground_truth"] == "identity":
            lines.append(f"Derived per class from the first pose whose best reflection plane leaves a mean "
                         f"residual <= {MIRROR_MAX_RESIDUAL} (sqrt(area) units); the map holds for every pose "
                         f"of the class, which share one vertex numbering.")
            lines += ["", "| class | pose | residual | used |", "| --- | --- | ---: | --- |"]
            for cls, m in sorted(mirror.items()):
                used = "yes" if m["used"] else "no (no symmetric pose: rate_sym = rate)"
                lines.append(f"| {cls} | {m['shape']} | {_fmt(m['residual'], 4)} | {used} |")
        else:
            lines.append("From `corres/*.sym.vts`. Check of the map darcyan derives for identity data (reflection "
                         "of the first pose) against `.sym.vts`: geodesic distance between the derived and the "
                         "listed mirror image at evenly spread samples.")
            lines += ["", "| class | pose | residual | samples | median error | within threshold |",
                      "| --- | --- | ---: | ---: | ---: | ---: |"]
            for cls, m in sorted(mirror.items()):
                v = m.get("validation_of_derived_map")
                if v:
                    lines.append(f"| {cls} | {v['shape']} | {_fmt(v['residual'], 4)} | {v['samples']} | "
                                 f"{_fmt(v['median_error'], 4)} | {percent(v['within_threshold'])} |")
    return "\n".join(lines) + "\n"


def group_report(results: dict) -> list:
    """Sparse and dense figures per group of pairs (``--pairs`` third column), when the groups
    are not simply the classes."""
    methods, dense = results["methods"], results.get("dense") or {}
    names = sorted({g for m in list(methods.values()) + list(dense.values()) for g in m.get("groups", {})})
    classes = {c for m in methods.values() for c in m["classes"]}
    if not names or set(names) <= classes:
        return []
    lines = ["", "## Per group", "",
             ("Sparse: strict rate, rate allowing flips, mean geodesic error of the matches (sqrt(area) units); "
              "dense: share of sampled vertices within the threshold and their mean geodesic error; seed "
              "rate: the strict rate of the feature matches the dense maps agree with (the sparse matches, the "
              "alternative the dense stage preferred, or those a map started without them reads)."), "",
             ("| group | method | pairs | sparse rate | rate_sym | sparse mean error | dense within | dense mean error "
              "| seed rate |"),
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for group in names:
        for name in dict.fromkeys(list(methods) + list(dense)):
            s = methods.get(name, {}).get("groups", {}).get(group)
            d = dense.get(name, {}).get("groups", {}).get(group)
            if s is None and d is None:
                continue
            pairs = s["pairs"] if s else d["pairs"]
            lines.append(f"| {group} | {name} | {pairs} | {percent(s['rate']) if s else ''} | "
                         f"{percent(s['rate_sym']) if s else ''} | {_fmt(s['mean_error']) if s else ''} | "
                         f"{percent(d['rate']) if d else ''} | {_fmt(d['mean_error']) if d else ''} | "
                         f"{percent(d['seed_rate']) if d and d.get('seed_rate') is not None else ''} |")
    return lines


def _dense_report(results: dict) -> list:
    """The report's section on dense maps (none when the run has no dense results)."""
    dense = results.get("dense")
    if dense is None:
        return []
    chosen = (results.get("settings") or {}).get("dense") or {}
    lines = ["", f"## Dense maps: within {results['threshold']} / mean error / seconds per pair", ""]
    lines.append(f"{chosen.get('samples', '?')} source vertices per pair (seed {chosen.get('seed', '?')}). "
                 "darcyan: the dense map seeded by darcyan's sparse matches, or by an alternative matching "
                 "whose short ZoomOut map keeps the curvature signature clearly better (geodesic landmark coordinates "
                 "refined by ZoomOut; 'not trusted': the map's own check doubts it); pyfm: pyFM's own pipeline "
                 "(WKS, 50 x 50 functional map, ZoomOut to "
                 "200) without darcyan's landmarks. " + results.get("dense_definition", DENSE_DEFINITION))
    if not dense:
        return lines + ["", "No dense results yet."]
    methods = list(dense)
    lines += ["", "| class | " + " | ".join(methods) + " |", "| --- |" + " --- |" * len(methods)]

    def cell(c):
        if c is None:
            return ""
        failed = f" ({c['failed']} failed)" if c["failed"] else ""
        untrusted = f" ({c['untrusted']} not trusted)" if c.get("untrusted") else ""
        return f"{percent(c['rate'])} / {_fmt(c['mean_error'])} / {c['seconds_per_pair']:.1f} s{failed}{untrusted}"

    for cls in sorted({c for m in dense.values() for c in m["classes"]}):
        lines.append(f"| {cls} | " + " | ".join(cell(dense[m]["classes"].get(cls)) for m in methods) + " |")
    lines.append("| **mean over classes** | " + " | ".join(percent(dense[m]["overall"]["rate_class_mean"])
                                                          for m in methods) + " |")
    lines.append("| **all samples pooled** | " + " | ".join(cell(dense[m]["overall"]) for m in methods) + " |")
    lines.append("| pairs / samples | " + " | ".join(f"{dense[m]['overall']['pairs']} / {dense[m]['overall']['samples']}"
                                                     for m in methods) + " |")
    return lines


def clock(seconds: float) -> str:
    if not np.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def save_json(path: Path, data) -> None:
    write_atomic(path, json.dumps(data, indent=1))


def write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot write ({exc.strerror or exc})") from None
