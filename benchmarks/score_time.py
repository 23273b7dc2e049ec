"""How long scoring a dense map against the ground truth takes, with every sampled vertex's error
read on the whole mesh's fast marching or on geodesic balls (``BALL_SCORING_ABOVE``), and
whether the errors are the same: the measurement behind the ball scoring of large targets.

    darcyan match A.off B.off --dense -o map.csv
    python benchmarks/score_time.py A.off B.off map.csv          # identity ground truth

Both meshes are prepared as darcyan prepares them; the map is read from the CSV that
``darcyan match --dense`` writes; ``evaluate_dense`` scores it (1000 sampled vertices) once each
way in this process. Prints a table: way, seconds, share within 0.05, mean error.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def main(argv: list | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("map", help="the CSV of darcyan match --dense (source_vertex,target_vertex)")
    args = parser.parse_args(argv)
    import darcyan.eval.dense_scores as scores
    from darcyan.config import DarcyanConfig
    from darcyan.errors import DarcyanError
    from darcyan.geometry.shape import prepare_shape
    from darcyan.io.mesh_files import load_mesh

    try:
        shapes = [prepare_shape(load_mesh(path), DarcyanConfig(), False) for path in (args.source, args.target)]
    except DarcyanError as exc:
        print(f"score_time: {exc}", file=sys.stderr)
        return 1
    try:
        rows = np.loadtxt(args.map, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)
    except (OSError, ValueError) as exc:
        print(f"score_time: {args.map}: not a map written by darcyan match --dense ({exc})", file=sys.stderr)
        return 1
    sizes = (shapes[0].n_input_vertices, shapes[1].n_input_vertices)
    if rows.shape[1] != 2:
        print(f"score_time: {args.map}: expected two columns (source_vertex,target_vertex), found "
              f"{rows.shape[1]}", file=sys.stderr)
        return 1
    if ((rows < 0) | (rows >= sizes)).any():
        print(f"score_time: {args.map}: vertex indices out of range for {args.source} and {args.target}",
              file=sys.stderr)
        return 1
    target = np.full(sizes[0], -1, dtype=np.int64)
    target[rows[:, 0]] = rows[:, 1]
    above = scores.BALL_SCORING_ABOVE
    errors = {}
    print("| scored on | seconds | within 0.05 | mean error |")
    print("| --- | ---: | ---: | ---: |")
    for way, threshold in (("geodesic balls", 0), ("whole fast marchings", sys.maxsize)):
        scores.BALL_SCORING_ABOVE = threshold
        start = time.perf_counter()
        scored = scores.evaluate_dense(shapes[0].mesh, shapes[1].mesh, target, target_solver=shapes[1].solver)
        seconds = time.perf_counter() - start
        errors[way] = scored.errors
        print(f"| {way} | {seconds:.1f} | {scored.rate:.3f} | {scored.mean:.4f} |")
    scores.BALL_SCORING_ABOVE = above
    print(f"\nthe same errors bit for bit: {np.array_equal(*errors.values())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
