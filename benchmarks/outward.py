"""Which cut surfaces the inside-out test decides, and whether it ever flips a right one
(``Repairing.outward_cap_share``; ``docs/parameters.md``, "Inside-out files").

    python benchmarks/outward.py tosca-5k faust-5k tosca-hires --centres 10

For every shape of each dataset (a folder of ``DARCYAN_DATA``, default ``../shared/data``; at
most ``--shapes`` of each, in name order) and each radius R, ``--centres`` random vertices
(seed 0) give two surfaces: the geodesic disc of radius R about the vertex (``kept``: a patch,
a tip, most of the body as R grows) and the rest (``cut``: a body with a hole, a cut limb).
Each is passed to :func:`darcyan.geometry.repair.orient_outward` as the file has it (outward)
and turned inside out. Printed per dataset, part and R: how many of the surfaces the test
decides (the inside-out copy comes back outward) and how many right ones it flipped (should be
none).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from darcyan.config import Repairing
from darcyan.geometry.geodesics import GeodesicSolver
from darcyan.geometry.mesh import Mesh
from darcyan.geometry.repair import orient_outward, prepare_mesh, submesh
from darcyan.io.mesh_files import load_mesh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from dense_variants import DATA  # noqa: E402  (the sibling script: the data folder)

RADII = (0.1, 0.2, 0.3, 0.5, 0.7, 1.0)  # sqrt(area) units


def check_shape(path: Path, centres: int, share: float) -> dict:
    """(part, R) -> [surfaces, decided, right ones flipped] for one shape file."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh, _ = prepare_mesh(load_mesh(path))
    solver = GeodesicSolver(mesh)
    scale = np.sqrt(mesh.area())
    rng = np.random.default_rng(0)
    counts: dict = {}
    for radius in RADII:
        for _ in range(centres):
            distance = solver.distance(int(rng.integers(mesh.n_vertices))) / scale
            inside = (distance[mesh.faces] < radius).all(axis=1)
            for part, chosen in (("kept", inside), ("cut", ~inside)):
                if chosen.sum() < 10:
                    continue
                surface = submesh(mesh, chosen)
                inside_out = Mesh(surface.vertices, surface.faces[:, ::-1].copy(), surface.name)
                row = counts.setdefault((part, radius), [0, 0, 0])
                row[0] += 1
                row[1] += orient_outward(inside_out, share) is not inside_out
                row[2] += orient_outward(surface, share) is not surface
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("datasets", nargs="+", help="folders of DARCYAN_DATA, e.g. tosca-5k")
    parser.add_argument("--centres", type=int, default=10, help="random disc centres per shape and radius")
    parser.add_argument("--shapes", type=int, default=100, help="at most this many shapes of each dataset")
    parser.add_argument("--share", type=float, default=Repairing().outward_cap_share,
                        help="outward_cap_share to test (default: the config's)")
    args = parser.parse_args(argv)
    for name, value, low in (("--centres", args.centres, 1), ("--shapes", args.shapes, 1), ("--share", args.share, 0)):
        if not value >= low:
            print(f"outward.py: error: {name} must be at least {low}, got {value}", file=sys.stderr)
            return 2
    missing = [d for d in args.datasets if not (DATA / d).is_dir()]
    if missing:
        print(f"outward.py: error: {DATA / missing[0]}: no such dataset folder (set DARCYAN_DATA)", file=sys.stderr)
        return 2
    print(f"outward_cap_share {args.share}; per cell: decided / surfaces, right ones flipped")
    print("| dataset | shapes | part | " + " | ".join(f"R {r}" for r in RADII) + " |")
    print("| --- | ---: | --- |" + " ---: |" * len(RADII))
    for dataset in args.datasets:
        paths = sorted((DATA / dataset).glob("*.off"))[:args.shapes]
        total: dict = {}
        for path in paths:
            for key, row in check_shape(path, args.centres, args.share).items():
                total.setdefault(key, [0, 0, 0])
                total[key] = [a + b for a, b in zip(total[key], row)]
        for part in ("kept", "cut"):
            cells = [f"{total[(part, r)][1]} / {total[(part, r)][0]}, {total[(part, r)][2]}" if (part, r) in total
                     else "-" for r in RADII]
            print(f"| {dataset} | {len(paths)} | {part} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
