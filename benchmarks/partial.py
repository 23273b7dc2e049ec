"""Partial shapes: cut a part away from one shape of a pair and match it to the other, whole.

For a seeded sample of each dataset's test pairs (source, target), the source is cut in several
ways (``darcyan.eval.partial``; lengths in sqrt(area) units of the full source):

- ``tip``: an extremity cut away (a geodesic disc of radius 0.12 around a feature point: a
  hand, a foot, a muzzle);
- ``plane``: a plane cut through a limb, 0.25 along it from its tip;
- ``limb``: a whole limb gone (a disc of radius 0.35 around a feature point);
- ``hole``: a hole where a scanner saw nothing (a disc of radius 0.08 around a point at least
  0.3 from every feature point);
- ``none``: the uncut pair (the control).

Each cut shape is matched in both directions: ``partial->full`` (the cut source to the whole
target) and ``full->partial``. The feature points to cut at are the full source's own (darcyan's
description of it), chosen at random, seeded per pair and cut. A match is correct within 0.05
geodesic error (ground truth: the dataset's ``.vts``, samples cut away left out). Reported per
dataset, cut and direction:

- **rate**: correct matches / matches made;
- **coverage**: correct matches / extremities that can be matched (feature points of the whole
  shape whose true correspondent is on the cut shape, 0.05 or more from the cut's rim);
- **rim**: matches whose point on the cut shape lies within 0.05 of the rim (a cut taken for an
  extremity and matched);
- **to missing**: matches of a point whose true correspondent was cut away (or lies within
  0.05 of the rim) -- these should stay unmatched.

Usage (from the repository root; data at ../shared/data or $DARCYAN_DATA)::

    python benchmarks/partial.py --out partial-run            # tosca-5k and faust-5k, 10 pairs each
    python benchmarks/partial.py --pairs 4 --datasets tosca-5k --out quick
    python benchmarks/partial.py --config norims.json --out partial-norims   # {"rims": {"min_length": 0}}

Cases are appended to ``--out/cases.jsonl`` as they finish; a second run resumes from it (the
code's digest and the settings are part of each case's key: a changed method recomputes). ``--out/partial.md``
holds the table.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
import zlib
from pathlib import Path

import numpy as np

from darcyan import DarcyanConfig, load_mesh
from darcyan.errors import ConfigError, DarcyanError
from darcyan.eval.metrics import GroundTruth, nearest_samples, read_vts, score_matches
from darcyan.eval.partial import PartialMesh, cut_ball, cut_plane, partial_truth, rim_distance
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import MeshWarning
from darcyan.io.cache import ShapeCache, code_digest
from darcyan.method.pipeline import analyze_mesh, describe_shape, load_shape, match_shapes

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("DARCYAN_DATA", REPO.parent / "shared" / "data"))
DATASETS = ("tosca-5k", "faust-5k")
CUTS = {  # kind -> (cut, length in sqrt(area) units)
    "tip": ("ball", 0.12),
    "plane": ("plane", 0.25),
    "limb": ("ball", 0.35),
    "hole": ("hole", 0.08),
}
HOLE_CLEARANCE = 0.3  # a hole's centre is at least this far from every feature point
THRESHOLD = 0.05
SEED = 0


def sample_pairs(dataset: Path, count: int, seed: int) -> list:
    lines = [line.split("\t")[:2] for line in (dataset / "test_pairs.txt").read_text().splitlines() if line.strip()]
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(lines), size=min(count, len(lines)), replace=False)
    return [tuple(lines[i]) for i in sorted(chosen)]


def make_cut(mesh, solver, features: np.ndarray, kind: str, rng) -> PartialMesh | None:
    """The cut ``kind`` of the full ``mesh`` (input numbering) at a feature point drawn by ``rng``."""
    how, length = CUTS[kind]
    if how == "hole":
        near = np.min([solver.distance(int(f)) for f in features], axis=0) / np.sqrt(mesh.area())
        far = np.flatnonzero(near >= HOLE_CLEARANCE)
        if len(far) == 0:
            return None
        return cut_ball(mesh, int(rng.choice(far)), length, kind, solver)
    tip = int(rng.choice(features))
    if how == "plane":
        return cut_plane(mesh, tip, length, kind, solver)
    return cut_ball(mesh, tip, length, kind, solver)


def score_direction(partial: PartialMesh, partial_shape, rim: np.ndarray, partial_features: np.ndarray,
                    full_shape, full_description, correspondence, truth: GroundTruth, partial_is_source: bool) -> dict:
    """Counts of one matched direction (see the module docstring). ``truth`` relates the full
    source and the full target, oriented as the match is; ``rim (n,)``: each partial vertex's
    distance to the cut's rim; ``partial_features``: the cut shape's feature points."""
    carried = partial_truth(truth, partial, partial_is_source)
    if partial_is_source:
        score = score_matches(partial_shape, full_shape, correspondence, carried, THRESHOLD)
        partial_side, full_side = correspondence.source_vertex, correspondence.target_vertex
    else:
        score = score_matches(full_shape, partial_shape, correspondence, carried, THRESHOLD)
        partial_side, full_side = correspondence.target_vertex, correspondence.source_vertex
    # A point of the whole shape has its counterpart on the cut one when the uncut truth sends it
    # to a vertex that was kept, at least the threshold away from the rim.
    full_samples = truth.target_samples if partial_is_source else truth.source_samples
    cut_samples = truth.source_samples if partial_is_source else truth.target_samples
    listed = full_shape.mesh_index(full_samples, nearest=True)

    def counterpart_kept(full_vertices) -> np.ndarray:
        nearest = nearest_samples(full_shape.solver, full_shape.mesh_index(full_vertices), listed)
        on_cut = partial.from_full(cut_samples[nearest])
        return (on_cut >= 0) & (rim[np.maximum(on_cut, 0)] >= THRESHOLD)

    matchable = counterpart_kept(full_description.feature_vertices)
    kept = counterpart_kept(full_side)
    correct = (score.errors <= THRESHOLD) & kept
    return {"matches": len(score), "correct": int(correct.sum()), "matchable": int(matchable.sum()),
            "rim": int((rim[partial_side] < THRESHOLD).sum()), "to_missing": int((~kept).sum()),
            "rim_features": int((rim[partial_features] < THRESHOLD).sum())}


def run_case(dataset: Path, source: str, target: str, kind: str, seed: int, config: DarcyanConfig,
             cache: ShapeCache) -> list:
    rng = np.random.default_rng([seed, zlib.crc32(f"{source}/{target}/{kind}".encode())])
    source_path, target_path = dataset / f"{source}.off", dataset / f"{target}.off"
    full_source = load_mesh(source_path)
    source_description = describe_shape(source_path, config, cache=cache)
    target_description = describe_shape(target_path, config, cache=cache)
    target_shape = load_shape(target_path, config, warn=False)
    truth = GroundTruth(read_vts(dataset / "corres" / f"{source}.vts"), read_vts(dataset / "corres" / f"{target}.vts"))
    solver = GeodesicSolver(full_source)
    if kind == "none":
        partial = PartialMesh(full_source, np.arange(full_source.n_vertices), np.zeros(full_source.n_vertices, bool),
                              "none")
    else:
        partial = make_cut(full_source, solver, source_description.feature_vertices, kind, rng)
        if partial is None:
            return []
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        try:
            analysis = analyze_mesh(partial.mesh, config)
        except DarcyanError as exc:
            print(f"  {source} {kind}: {exc}", file=sys.stderr)
            return [{"dataset": dataset.name, "source": source, "target": target, "kind": kind,
                     "direction": d, "error": str(exc)} for d in ("partial->full", "full->partial")]
    seconds = time.perf_counter() - start
    partial_shape = analysis.shape
    # the rim distance on the partial mesh as given (input numbering of the partial mesh)
    rim = rim_distance(partial)
    records = []
    for direction, pair in (("partial->full", (analysis.description, target_description)),
                            ("full->partial", (target_description, analysis.description))):
        correspondence = match_shapes(*pair, config)
        partial_is_source = direction == "partial->full"
        # truth from the full source to the target; for full->partial the target is the truth's source
        oriented = truth if partial_is_source else GroundTruth(truth.target_samples, truth.source_samples)
        counts = score_direction(partial, partial_shape, rim, analysis.description.feature_vertices, target_shape,
                                 target_description, correspondence, oriented, partial_is_source)
        records.append({"dataset": dataset.name, "source": source, "target": target, "kind": kind,
                        "direction": direction, "removed": int(full_source.n_vertices - partial.mesh.n_vertices),
                        "seconds": round(seconds, 2), **counts})
    return records


def table(records: list) -> str:
    rows = ["| dataset | cut | direction | cases | matches | rate | coverage | rim matches | to missing |",
            "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    keys = sorted({(r["dataset"], r["kind"], r["direction"]) for r in records},
                  key=lambda k: (k[0], list(CUTS).index(k[1]) if k[1] in CUTS else -1, k[2]))
    for key in keys:
        group = [r for r in records if (r["dataset"], r["kind"], r["direction"]) == key and "error" not in r]
        failed = sum(1 for r in records if (r["dataset"], r["kind"], r["direction"]) == key and "error" in r)
        total = lambda name, group=group: sum(r[name] for r in group)  # noqa: E731
        matches, correct, matchable = total("matches"), total("correct"), total("matchable")
        rate = f"{correct / matches:.1%}" if matches else "-"
        coverage = f"{min(correct, matchable) / matchable:.1%}" if matchable else "-"
        cases = f"{len(group)}" + (f" (+{failed} refused)" if failed else "")
        rows.append(f"| {key[0]} | {key[1]} | {key[2]} | {cases} | {matches} | {rate} | {coverage} | "
                    f"{total('rim')} | {total('to_missing')} |")
    return "\n".join(rows) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("partial-run"))
    parser.add_argument("--datasets", nargs="+", default=list(DATASETS))
    parser.add_argument("--pairs", type=int, default=10, help="test pairs sampled per dataset (default 10)")
    parser.add_argument("--cuts", nargs="+", default=["none", *CUTS], choices=["none", *CUTS])
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--config", type=Path, help="a JSON file of settings, as darcyan's --config "
                        '(e.g. {"rims": {"min_length": 0}}: without the cut-rim rule)')
    args = parser.parse_args(argv)
    try:
        return run(args)
    except (OSError, DarcyanError) as exc:  # one line, no traceback (OSError names its file)
        print(f"partial.py: error: {exc}", file=sys.stderr)
        return 2


def read_settings(path: Path | None) -> DarcyanConfig:
    """darcyan's defaults, changed by the JSON file ``path`` (as ``darcyan --config``)."""
    if path is None:
        return DarcyanConfig()
    try:
        changes = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DarcyanError(f"{path}: cannot read settings ({exc})") from None
    if not isinstance(changes, dict):
        raise DarcyanError(f"{path}: settings must be a JSON object")
    try:
        return DarcyanConfig().updated(changes, str(path))
    except ConfigError as exc:
        raise DarcyanError(f"{path}: {exc}") from None


def run(args) -> int:
    config = read_settings(args.config)
    for name in args.datasets:
        if not (DATA / name / "test_pairs.txt").is_file():
            raise DarcyanError(f"{DATA / name}: no test_pairs.txt (set DARCYAN_DATA to the folder holding {name})")
    args.out.mkdir(parents=True, exist_ok=True)
    journal = args.out / "cases.jsonl"
    digest = code_digest()
    done = {}
    if journal.exists():
        for line in journal.read_text().splitlines():
            record = json.loads(line)
            done.setdefault(record["key"], []).append(record)
    cache = ShapeCache(Path(os.environ.get("DARCYAN_CACHE", args.out / "cache")))
    records = []
    cases = [(name, s, t, kind) for name in args.datasets
             for s, t in sample_pairs(DATA / name, args.pairs, args.seed) for kind in args.cuts]
    start = time.perf_counter()
    for i, (name, source, target, kind) in enumerate(cases, 1):
        key = f"{name}/{source}/{target}/{kind}/{args.seed}/{digest}/{config.fingerprint()}"
        if key not in done:
            made = run_case(DATA / name, source, target, kind, args.seed, config, cache)
            with journal.open("a") as out:
                for record in made:
                    out.write(json.dumps({"key": key, **record}) + "\n")
            done[key] = made
        records += done[key]
        print(f"\r[{i}/{len(cases)}] {name} {source}->{target} {kind:6s} {time.perf_counter() - start:6.0f} s",
              end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    text = table(records)
    (args.out / "partial.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
