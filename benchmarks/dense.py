"""Dense maps on TOSCA pairs: darcyan's landmark-seeded map against pyFM's own pipeline.

For each pair SOURCE->TARGET of ``tosca-hires`` (identity ground truth), prints the share of a
fixed random sample of source vertices (1000, seed 0, the same for both methods) within 0.05 of
the truth, the mean error (geodesic / sqrt(area)) and the seconds taken:

- darcyan: describe both shapes, match the feature points, :func:`darcyan.dense.dense_map`
  (the time of the dense stage and of the whole run are reported apart);
- pyFM (``pip install pyfmaps``, optional): WKS descriptors, a 50 x 50 functional map with
  Laplacian and descriptor commutativity, ZoomOut from 50 to 200 (its README's pipeline),
  without darcyan's landmarks (:func:`darcyan.dense.pyfm_own_map`, also behind
  ``darcyan bench --dense``).

    python benchmarks/dense.py cat0:cat1 wolf0:wolf1 [--no-pyfm] [--data ../shared/data]

Set OMP_NUM_THREADS (e.g. 1) to compare the two on equal terms.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from darcyan import DarcyanConfig
from darcyan.dense.config import DenseConfig
from darcyan.dense.maps import dense_map, pyfm_own_map
from darcyan.eval.dense_scores import evaluate_dense_maps
from darcyan.io.mesh_files import load_mesh
from darcyan.method.pipeline import analyze_mesh, match_shapes

REPO = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pairs", nargs="+", help="SOURCE:TARGET names in tosca-hires, e.g. cat0:cat1")
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data"))
    parser.add_argument("--no-pyfm", action="store_true", help="skip pyFM's pipeline")
    parser.add_argument("--sample", type=int, default=1000)
    args = parser.parse_args(argv)
    root = Path(args.data) / "tosca-hires"
    config = DarcyanConfig()
    print("pair | method | within 0.05 | mean error | dense stage s | total s | landmarks")
    for pair in args.pairs:
        a, b = pair.split(":")
        files = root / f"{a}.off", root / f"{b}.off"
        start = time.perf_counter()
        shape_1, shape_2 = (analyze_mesh(load_mesh(f), config) for f in files)
        correspondence = match_shapes(shape_1, shape_2, config)
        t = time.perf_counter()
        result = dense_map(shape_1, shape_2, correspondence, DenseConfig())
        dense_s, total_s = time.perf_counter() - t, time.perf_counter() - start
        maps = {"darcyan": result.target}
        if not args.no_pyfm:  # pyFM's own pipeline (darcyan.dense.pyfm_own_map), no darcyan landmarks
            pyfm = pyfm_own_map(shape_1.mesh, shape_2.mesh, shape_1.n_input_vertices)
            maps["pyfm"] = pyfm.target
        scores = evaluate_dense_maps(shape_1.mesh, shape_2.mesh, maps, sample=args.sample,
                                     target_solver=shape_2.solver)
        score = scores["darcyan"]
        print(f"{a}->{b} | darcyan | {score.rate:.3f} | {score.mean:.4f} | {dense_s:.1f} | {total_s:.1f} | "
              f"{len(result.landmarks)} of {len(correspondence)} matches", flush=True)
        if not args.no_pyfm:
            score, pyfm_s = scores["pyfm"], pyfm.timings["pyfm"]
            print(f"{a}->{b} | pyFM WKS+ZoomOut | {score.rate:.3f} | {score.mean:.4f} | {pyfm_s:.1f} | "
                  f"{pyfm_s:.1f} | -", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
