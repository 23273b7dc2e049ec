"""How faithful a large mesh's coarse copy is: fast marching on the copy from each feature point,
read at every full vertex, against fast marching on the full mesh (median / 99th percentile /
largest absolute error, sqrt(area) units), for three ways of making the copy: fast-simplification
at aggressiveness 7 with each vertex read at its closest point (darcyan before 2026-12-07), at 3
likewise, and at 3 with a vertex whose closest point lies on another part read on its own part
(darcyan now; how many in brackets). Behind "The coarse copy keeps its parts apart" in
``docs/decisions/features.md``.

Usage (from the repository root; the data at ../shared/data or $DARCYAN_DATA)::

    python benchmarks/proxy_check.py tosca-hires michael14 michael10 cat10
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path

import numpy as np

DATA = Path(os.environ.get("DARCYAN_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data"))
VARIANTS = ((7.0, False), (3.0, False), (3.0, True))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", help="a folder of DATA (or a path) holding NAME.off")
    parser.add_argument("names", nargs="+", help="mesh names (without .off)")
    parser.add_argument("--proxy-vertices", type=int, default=6000)
    args = parser.parse_args(argv)

    import darcyan.geometry.proxy as proxy_module
    from darcyan.config import DarcyanConfig
    from darcyan.errors import DarcyanError
    from darcyan.method.pipeline import describe_shape, load_shape

    folder = Path(args.dataset) if Path(args.dataset).is_dir() else DATA / args.dataset
    missing = [n for n in args.names if not (folder / f"{n}.off").is_file()]
    if missing:
        print(f"proxy_check: {folder / (missing[0] + '.off')}: no such file", file=sys.stderr)
        return 2
    warnings.simplefilter("ignore")
    config = DarcyanConfig()
    own_part = proxy_module.CoarseProxy._keep_on_own_part
    aggressiveness = proxy_module.DECIMATION_AGGRESSIVENESS
    print("| mesh | vertices | agg 7, closest point | agg 3, closest point | agg 3, own part (moved) |")
    print("| --- | ---: | --- | --- | --- |")
    try:
        for name in args.names:
            path = folder / f"{name}.off"
            feature_vertices = describe_shape(path, config).feature_vertices
            row = [name]
            for agg, own in VARIANTS:
                proxy_module.DECIMATION_AGGRESSIVENESS = agg
                proxy_module.CoarseProxy._keep_on_own_part = (own_part if own else
                                                              lambda self, positions, into: setattr(self, "strays", 0))
                shape = load_shape(path, config, warn=False)
                copy = shape.proxy(args.proxy_vertices)
                if copy is None:
                    row.append("no copy")
                    continue
                errors = np.array([np.abs(copy.distance(int(v)) - shape.solver.distance(int(v)))
                                   for v in shape.mesh_index(feature_vertices)])
                if len(row) == 1:
                    row.append(f"{shape.n_vertices:,}")
                row.append(f"{np.median(errors):.4f} / {np.percentile(errors, 99):.3f} / {errors.max():.3f}"
                           + (f" ({copy.strays})" if own else ""))
            print("| " + " | ".join(row) + " |", flush=True)
    except DarcyanError as exc:  # a mesh that cannot be read or used: one line, the file and the problem
        print(f"proxy_check: {exc}", file=sys.stderr)
        return 2
    finally:
        proxy_module.CoarseProxy._keep_on_own_part = own_part
        proxy_module.DECIMATION_AGGRESSIVENESS = aggressiveness
    return 0


if __name__ == "__main__":
    sys.exit(main())
