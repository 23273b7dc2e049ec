"""Where a dense map loses accuracy: the seeds, ZoomOut, or the basis (a diagnostic).

    python benchmarks/dense_oracle.py faust-5k benchmarks/faust5k_test_pairs_groups.txt 40 --sizes 100 140 200

For each of N pairs drawn (seed 0) from PAIRS (``source<TAB>target[<TAB>group]``, a dataset with
``.vts`` ground truth), these maps are scored on the same 1000 source vertices:

* ``default``: :func:`darcyan.dense.maps.dense_map` with the defaults;
* ``zoomout from truth``: the same ZoomOut (same samples, sizes, terms and landmark coordinates
  of the chosen seed), started from the true correspondence instead of the seed's first map;
* ``last steps from truth``: only ZoomOut's last iterations (sizes ``basis_size - 10`` to
  ``basis_size``, one by one), started from the true correspondence: what the iterations at
  the final size do to a right map;
* ``last steps from truth, NAME`` (with ``--last-steps '{"NAME": {fields}}'``): the same
  last iterations with those fields of :class:`~darcyan.dense.config.DenseConfig` changed
  (which term of ZoomOut holds a right map away from the truth);
* ``best at k``: no iteration at all: the functional maps of size k (from k + ``basis_margin``
  eigenfunctions of the other shape, like the dense map's own) fitted by plain least squares
  (without the commutativity shrinkage of the dense map's fits) to the true correspondence of
  every listed vertex, read out by the dense map's own final step
  (:func:`darcyan.dense.zoomout.read_out_map`). No map read out of k eigenfunctions does much
  better: it bounds what ZoomOut could reach with this basis (and the ground truth's own
  rounding to vertices sets a floor under all).

With ``--distortion N``, each map's geodesic distortion is printed as well, beside the ground
truth's own: for N listed source vertices (seed 1) and their images, the mean over pairs of
vertices of ``|d_1(x, y) - d_2(f(x), f(y))|`` (sqrt(area) units). A method that minimizes
distortion cannot come closer to a truth that is less isometric than its own map.

If ``default`` is near ``zoomout from truth``, the seeds are not what is lost; the gap between
``last steps from truth`` and ``best at k`` is what ZoomOut's iterations lose even from a right
map; the ``best at k`` column across sizes is what a larger basis could win. Prints per group
and overall the mean over pairs of the share within 0.05 and of the mean error (errors capped at
1); ``--out`` keeps every pair's figures. Two worker processes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import warnings
from pathlib import Path

import numpy as np
from dense_variants import DATA, add_sample_arguments, prepared_pair, read_pair_lines, read_variants  # the sibling script

from darcyan.dense.config import DenseConfig
from darcyan.dense.landmarks import landmark_coordinates
from darcyan.dense.maps import DENSE_FAILURES, dense_map, input_map
from darcyan.dense.signatures import signature_coordinates, signature_turn_coordinates, signature_turn_weight
from darcyan.dense.zoomout import dense_basis, dense_eigenvalues, fit_width, read_out_map, zoomout, zoomout_samples
from darcyan.errors import DarcyanError
from darcyan.eval.dense_scores import evaluate_dense_maps
from darcyan.geometry.knn import nearest_rows
from darcyan.parallel import process_map

LAST_STEPS = 10  # "last steps from truth": ZoomOut's iterations at sizes basis_size - 10 .. basis_size
DISTORTION_SEED = 1  # numpy.random.default_rng seed of the --distortion vertices


def true_pairs(shape_1, shape_2, truth) -> tuple:
    """``(source, target)`` local vertex pairs of the ground truth (listed samples on both meshes)."""
    source = shape_1.mesh_index(truth.source_samples)
    target = shape_2.mesh_index(truth.target_samples)
    kept = (source >= 0) & (target >= 0)
    return source[kept], target[kept]


def true_sample_maps(shape_1, shape_2, samples: tuple, source: np.ndarray, target: np.ndarray) -> tuple:
    """The true correspondence between ZoomOut's samples in both directions: each sample's listed
    true image (that of its nearest listed vertex in space), then the sample nearest to it."""
    maps = []
    for (shape_a, shape_b), (sample_a, sample_b), (from_a, to_b) in (
            ((shape_1, shape_2), samples, (source, target)), ((shape_2, shape_1), samples[::-1], (target, source))):
        listed = nearest_rows(shape_a.mesh.vertices[from_a], shape_a.mesh.vertices[sample_a])
        image = shape_b.mesh.vertices[to_b[listed]]
        maps.append(nearest_rows(shape_b.mesh.vertices[sample_b], image))
    return maps[0], maps[1]


def distortions(shape_1, shape_2, source: np.ndarray, target: np.ndarray, maps: dict, count: int) -> dict:
    """name -> mean ``|d_1(x, y) - d_2(f(x), f(y))|`` over pairs of ``count`` listed source vertices
    (local ``source``, drawn with seed :data:`DISTORTION_SEED`) for each map (input numbering) and
    for the ground truth (``"truth"``: their listed images ``target``); geodesic distances by fast
    marching, over the square root of each mesh's area."""
    rows = np.random.default_rng(DISTORTION_SEED).choice(len(source), min(count, len(source)), replace=False)
    chosen = source[rows]
    images = {"truth": target[rows]}
    for name, mapped in maps.items():
        local = shape_2.mesh_index(mapped[shape_1.mesh.input_index[chosen]])
        if (local >= 0).all():
            images[name] = local
    upper = np.triu_indices(len(chosen), k=1)
    d_1 = np.array([shape_1.solver.distance(int(v))[chosen] for v in chosen])[upper] / np.sqrt(shape_1.mesh.area())
    scale = np.sqrt(shape_2.mesh.area())
    return {name: float(np.abs(d_1 - np.array([shape_2.solver.distance(int(v))[image] for v in image])[upper]
                               / scale).mean()) for name, image in images.items()}


def score_pair(task: tuple) -> dict:
    dataset, source_name, target_name, group, sizes, distortion, last_variants = task
    warnings.simplefilter("ignore")
    (shape_1, shape_2), correspondence, truth = prepared_pair(dataset, source_name, target_name)
    config = DenseConfig()
    try:
        made = dense_map(shape_1, shape_2, correspondence, config)
    except DENSE_FAILURES as exc:  # no dense map for this pair: reported, the others go on
        return {"pair": f"{source_name}->{target_name}", "group": group, "failed": str(exc)}
    if made.check.start != "matches":  # a start without the matches: its landmarks are the map's
        from types import SimpleNamespace

        matching = SimpleNamespace(source_vertex=made.landmarks[:, 0], target_vertex=made.landmarks[:, 1])
    else:
        matching = ([correspondence] + list(correspondence.alternatives))[made.check.seed]
    coords_1, coords_2 = landmark_coordinates(shape_1, shape_2, matching, config)
    source, target = true_pairs(shape_1, shape_2, truth)
    maps = {"default": made.target}

    basis_1, basis_2 = dense_basis(shape_1, config), dense_basis(shape_2, config)
    samples = zoomout_samples(shape_1, shape_2, config)  # as dense_map draws them
    first_12, first_21 = true_sample_maps(shape_1, shape_2, samples, source, target)
    (s_1, s_2) = samples
    # The coarse steps' signature and every step's signature turns, as dense_map adds them.
    everywhere = np.arange(shape_1.mesh.n_vertices), np.arange(shape_2.mesh.n_vertices)
    coarse = signature_coordinates(shape_1, shape_2, config, *everywhere)
    k_landmarks = len(made.landmarks)  # coords: the distances to the landmarks first, then their turns
    turns = signature_turn_weight(k_landmarks, correspondence.feature_counts, config)  # as dense_map weighs them
    steady = signature_turn_coordinates(shape_1, shape_2, config, coords_1[:, :k_landmarks], coords_2[:, :k_landmarks],
                                        turns)
    extra = [None if c is None else c[s] for pair in (coarse, steady) for c, s in zip(pair, samples)]
    values = dense_eigenvalues(shape_1, config), dense_eigenvalues(shape_2, config)  # the commutativity term's

    def read_out(c_12, c_21, b_1, b_2):  # the dense map's own final step, in input numbering
        local = read_out_map(shape_2, b_1, b_2, c_12, c_21, config, coords_1, coords_2, s_2, *steady)
        return input_map(shape_1, shape_2, local)

    last_steps = dataclasses.replace(config, basis_start=max(config.basis_size - LAST_STEPS, 1), basis_step=1)
    for name, schedule in (("zoomout from truth", config), ("last steps from truth", last_steps)):
        c_12, c_21 = zoomout(basis_1[s_1], basis_2[s_2], first_12, first_21, schedule, coords_1[s_1], coords_2[s_2],
                             *extra, *values)
        maps[name] = read_out(c_12, c_21, basis_1, basis_2)
    for name, changes in last_variants.items():  # the last steps with some terms changed
        changed = dataclasses.replace(last_steps, **changes)
        weight = signature_turn_weight(k_landmarks, correspondence.feature_counts, changed)
        turned = signature_turn_coordinates(shape_1, shape_2, changed, coords_1[:, :k_landmarks],
                                            coords_2[:, :k_landmarks], weight)
        terms = [None if c is None else c[s] for pair in (coarse, turned) for c, s in zip(pair, samples)]
        c_12, c_21 = zoomout(basis_1[s_1], basis_2[s_2], first_12, first_21, changed, coords_1[s_1], coords_2[s_2],
                             *terms, *values)
        local = read_out_map(shape_2, basis_1, basis_2, c_12, c_21, changed, coords_1, coords_2, s_2, *turned)
        maps[f"last steps from truth, {name}"] = input_map(shape_1, shape_2, local)

    for size in sizes:
        sized = dataclasses.replace(config, basis_size=size)
        b_1, b_2 = dense_basis(shape_1, sized), dense_basis(shape_2, sized)
        k = min(size, b_1.shape[1], b_2.shape[1])
        p = fit_width(k, config, min(b_1.shape[1], b_2.shape[1]))  # as wide as dense_map's own maps
        c_12 = np.linalg.lstsq(b_1[source, :p], b_2[target, :k], rcond=None)[0]
        c_21 = np.linalg.lstsq(b_2[target, :p], b_1[source, :k], rcond=None)[0]
        maps[f"best at {size}"] = read_out(c_12, c_21, b_1, b_2)
    scores = evaluate_dense_maps(shape_1.mesh, shape_2.mesh, maps, truth, target_solver=shape_2.solver)
    result = {"pair": f"{source_name}->{target_name}", "group": group,
              **{name: {"rate": score.rate, "mean": float(np.minimum(score.errors, 1.0).mean())}
                 for name, score in scores.items()}}
    if distortion:
        result["distortion"] = distortions(shape_1, shape_2, source, target, maps, distortion)
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_sample_arguments(parser)
    parser.add_argument("--sizes", type=int, nargs="+", default=[100], help="basis sizes of the 'best at k' maps")
    parser.add_argument("--distortion", type=int, default=0, metavar="N",
                        help="also each map's geodesic distortion, and the ground truth's, on N listed vertices")
    parser.add_argument("--last-steps", default="{}", metavar="JSON",
                        help='also the last steps from the truth with DenseConfig fields changed: {"name": {fields}}')
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    try:
        last_variants = read_variants(args.last_steps, "--last-steps")
        if any(size < 1 for size in args.sizes):
            raise DarcyanError(f"--sizes must be positive, got {args.sizes}")
        if args.distortion < 0 or args.distortion == 1:
            raise DarcyanError(f"--distortion needs at least 2 vertices, got {args.distortion}")
        if args.count < 1:
            raise DarcyanError(f"count must be at least 1, got {args.count}")
        if args.out and not args.out.parent.is_dir():
            raise DarcyanError(f"--out {args.out}: no such folder {args.out.parent}")
        pairs = read_pair_lines(args.pairs, args.dataset, args.count)
        if not pairs:
            raise DarcyanError(f"{args.pairs}: no pairs")
        for source, target, _ in pairs:
            for name in (source, target):
                if not (DATA / args.dataset / "corres" / f"{name}.vts").is_file():
                    raise DarcyanError(f"{DATA / args.dataset / 'corres' / (name + '.vts')}: no such ground truth "
                                       f"(this diagnostic needs the dataset's .vts files)")
        tasks = [(args.dataset, source, target, group, args.sizes, args.distortion, last_variants)
                 for source, target, group in pairs]
        results = list(process_map(score_pair, tasks, 2, ordered=True))
    except (OSError, DarcyanError) as exc:  # one line, no traceback (OSError names its file)
        print(f"dense_oracle.py: error: {exc}", file=sys.stderr)
        return 2
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))
    for failed in (r for r in results if "failed" in r):
        print(f"dense_oracle.py: {failed['pair']}: left out, no dense map: {failed['failed']}", file=sys.stderr)
    results = [r for r in results if "failed" not in r]
    if not results:
        print("dense_oracle.py: error: no pair has a dense map", file=sys.stderr)
        return 2
    names = [name for name in results[0] if name not in ("pair", "group", "distortion")]
    print("| group | pairs | " + " | ".join(names) + " |")
    print("| --- | ---: |" + " ---: |" * len(names))
    for group in sorted({r["group"] for r in results}) + ["all"]:
        rows = [r for r in results if group in ("all", r["group"])]
        cells = [f"{np.mean([r[name]['rate'] for r in rows]):.3f} / {np.mean([r[name]['mean'] for r in rows]):.4f}"
                 for name in names]
        print(f"| {group} | {len(rows)} | " + " | ".join(cells) + " |")
    print("(share of sampled vertices within 0.05 / mean geodesic error, sqrt(area) units, means over pairs)")
    if args.distortion:
        print_distortions(results)
    return 0


def print_distortions(results: list) -> None:
    """The ``--distortion`` table: per group the mean distortion of the truth and of each map, and
    in how many pairs the default map is less distorted than the truth."""
    names = [name for name in results[0]["distortion"]]
    print("\n| group | pairs | " + " | ".join(names) + " | default below truth |")
    print("| --- | ---: |" + " ---: |" * (len(names) + 1))
    for group in sorted({r["group"] for r in results}) + ["all"]:
        rows = [r for r in results if group in ("all", r["group"])]
        cells = [f"{np.mean([r['distortion'].get(name, np.nan) for r in rows]):.4f}" for name in names]
        below = sum(r["distortion"].get("default", np.inf) < r["distortion"]["truth"] for r in rows)
        print(f"| {group} | {len(rows)} | " + " | ".join(cells) + f" | {below} of {len(rows)} |")
    print("(geodesic distortion: mean |d1(x, y) - d2(f(x), f(y))| over pairs of listed vertices, sqrt(area) units)")


if __name__ == "__main__":
    sys.exit(main())
