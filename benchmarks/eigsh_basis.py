"""How long the dense basis's eigensolve takes with ARPACK's Lanczos basis of different sizes
(``ncv``) and each shift-invert step solved by eigsh's own LU factorization or by the sparse
Cholesky factorization darcyan gives it: the measurement behind ``DenseConfig.basis_lanczos``
and the Cholesky solves in ``docs/decisions/speed.md``.

    python benchmarks/eigsh_basis.py                       # a few meshes of faust-5k and tosca-5k
    python benchmarks/eigsh_basis.py A.off B.off --k 130 --repeat 3

Each mesh is prepared as darcyan prepares it; the k smallest eigenpairs of its cotangent
Laplacian are solved by :func:`darcyan.geometry.spectral.laplace_beltrami_spectrum` itself
(shift-invert about the dense basis's shift, the dense basis's tolerance, the fixed start), once
per way (the operators' and the factorization's time included); the table prints the best of ``--repeat`` runs per
mesh and the sums.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from speed import DATA  # benchmarks/speed.py: the data folder


def main(argv: list | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("meshes", nargs="*", help="mesh files (default: six of faust-5k and tosca-5k)")
    parser.add_argument("--k", type=int, help="eigenpairs (default: the dense basis's, basis_size + basis_margin)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    from darcyan.config import DenseConfig
    from darcyan.dense.zoomout import EIGSH_SHIFT, fit_width
    from darcyan.errors import DarcyanError
    from darcyan.geometry.shape import prepare_shape
    from darcyan.geometry.spectral import laplace_beltrami_spectrum
    from darcyan.io.mesh_files import load_mesh

    paths = args.meshes or [str(DATA / f) for f in ("faust-5k/tr_reg_000.off", "faust-5k/tr_reg_001.off",
                                                    "tosca-5k/cat0.off", "tosca-5k/david1.off",
                                                    "tosca-5k/dog6.off", "tosca-5k/michael1.off")]
    try:  # every mesh read first: a missing or malformed file is one line, before any table
        meshes = [prepare_shape(load_mesh(path)).mesh for path in paths]
    except DarcyanError as exc:
        print(f"eigsh_basis.py: error: {exc}", file=sys.stderr)
        return 2
    k = args.k or fit_width(DenseConfig().basis_size, DenseConfig())
    per_pair = DenseConfig().basis_lanczos  # Lanczos vectors per eigenpair (0: eigsh's default, 2k+1)
    label = f"{per_pair:g}k"
    choices = {"LU, 2k+1 (eigsh's defaults)": (False, 0.0), f"LU, {label}": (False, per_pair),
               "Cholesky, 2k+1": (True, 0.0), f"Cholesky, {label} (darcyan's)": (True, per_pair)}
    sums = dict.fromkeys(choices, 0.0)
    print("| mesh | vertices | " + " | ".join(choices) + " |")
    print("| --- | ---: |" + " ---: |" * len(choices))
    for path, mesh in zip(paths, meshes):
        row = []
        for name, (cholesky, lanczos) in choices.items():
            best = np.inf
            for _ in range(args.repeat):  # the library's own solve, operators included (alike in every column)
                t = time.perf_counter()
                laplace_beltrami_spectrum(mesh, k, tol=DenseConfig().basis_tolerance, shift=EIGSH_SHIFT,
                                          lanczos=lanczos, cholesky=cholesky)
                best = min(best, time.perf_counter() - t)
            sums[name] += best
            row.append(f"{best:.3f} s")
        print(f"| {path.rsplit('/', 1)[-1]} | {mesh.n_vertices} | " + " | ".join(row) + " |")
    print("| **sum** | | " + " | ".join(f"**{v:.3f} s**" for v in sums.values()) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
