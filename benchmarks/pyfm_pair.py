"""pyFM's own dense pipeline on one pair, as a whole process: the peer that a dense map's time is
set against (issue 43: "at least 3x faster than pyFM's own pipeline on the same pair").

    python benchmarks/pyfm_pair.py A.off B.off -o map.csv     # needs the [pyfm] extra

Both meshes are read and prepared as darcyan prepares them (checks, largest component, area 1:
a few hundredths of a second), then :func:`darcyan.dense.maps.pyfm_own_map` runs PyPI's
``pyfmaps`` pipeline (its eigenpairs, WKS descriptors, a fitted functional map and ZoomOut to
200, converted to a point map) without darcyan's landmarks; the map is written as
``darcyan match --dense`` writes its own.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("-o", "--output", type=Path, required=True)
    args = parser.parse_args(argv)
    from darcyan.api import write_file
    from darcyan.dense.maps import dense_map_to_csv, pyfm_own_map
    from darcyan.errors import DarcyanError
    from darcyan.method.pipeline import load_shape

    try:
        shape_1, shape_2 = load_shape(args.source), load_shape(args.target)
        # pyFM as its users run it: the libraries' own thread pools
        made = pyfm_own_map(shape_1.mesh, shape_2.mesh, shape_1.n_input_vertices)
        write_file(dense_map_to_csv(made.target), args.output)
    except DarcyanError as exc:  # a bad file or an unwritable output: one line
        print(f"pyfm_pair.py: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
