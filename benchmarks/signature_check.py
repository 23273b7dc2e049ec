"""How well the curvature signature (the mean curvature diffused over a few lengths) of one point
agrees with that of its true image, across meshes of one surface at different resolutions:
for each pair, the median over the ground truth's points of the mean absolute difference of
their signatures (lower is better), beside the same for the truth's mirror image (``.sym.vts``,
when the dataset has it) and for a random pairing of the same points. Four ways of computing it:
on a large mesh's coarse copy (darcyan's way; a mesh with at most twice ``--proxy-vertices``
vertices has none) or on the mesh itself, each column scaled to mean magnitude 1 over the
vertices (darcyan before 2026-12-07) or over the area (darcyan now). Behind "The curvature
signature scaled over the area" in ``docs/decisions/every-pair.md``.

Usage (from the repository root; the data at ../shared/data or $DARCYAN_DATA; a dataset is a
folder of DATA or a path holding NAME.off and corres/NAME.vts)::

    python benchmarks/signature_check.py COPIES/faust-5k/mixed-resolution benchmarks/faust5k_test_pairs_groups.txt 24
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path

import numpy as np

DATA = Path(os.environ.get("DARCYAN_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data"))
VARIANTS = (("copy", "vertices"), ("copy", "area"), ("mesh", "vertices"), ("mesh", "area"))


def signature(shape, where: str, scale: str, lengths, steps: int, smoothing: int, proxy_vertices: int) -> np.ndarray:
    """``(n, len(lengths))`` the shape's curvature signature computed as ``where`` and ``scale`` say."""
    from darcyan.geometry.curvature import principal_curvatures
    from darcyan.geometry.heat import heat_diffuse
    from darcyan.geometry.operators import mixed_voronoi_area

    proxy = shape.proxy(proxy_vertices) if where == "copy" else None
    mesh = shape.mesh if proxy is None else proxy.mesh
    curvature = shape.curvatures(smoothing).mean if proxy is None else principal_curvatures(mesh, smoothing=smoothing).mean
    area = mixed_voronoi_area(mesh)
    columns = []
    for length in lengths:
        c = heat_diffuse(mesh, curvature, length, steps)
        magnitude = np.abs(c) @ area / area.sum() if scale == "area" else np.abs(c).mean()
        columns.append(c / max(float(magnitude), 1e-12))
    values = np.stack(columns, axis=1)
    return values if proxy is None else proxy.to_full(values)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", help="a folder of DATA, or a path, holding NAME.off and corres/NAME.vts")
    parser.add_argument("pairs", type=Path, help="source<TAB>target lines")
    parser.add_argument("count", type=int, help="the first this many pairs")
    parser.add_argument("--proxy-vertices", type=int, default=None, help="default: the dense map's")
    args = parser.parse_args(argv)

    from darcyan.config import DarcyanConfig
    from darcyan.dense.config import DenseConfig
    from darcyan.errors import DarcyanError
    from darcyan.eval.metrics import read_vts
    from darcyan.method.pipeline import load_shape

    folder = Path(args.dataset) if Path(args.dataset).is_dir() else DATA / args.dataset
    try:
        lines = [line.split()[:2] for line in args.pairs.read_text().splitlines()
                 if line.strip() and not line.startswith("#")][:args.count]
    except OSError as exc:
        print(f"signature_check: {args.pairs}: {exc.strerror}", file=sys.stderr)
        return 2
    for name in {n for pair in lines for n in pair}:
        for path in (folder / f"{name}.off", folder / "corres" / f"{name}.vts"):
            if not path.is_file():
                print(f"signature_check: {path}: no such file", file=sys.stderr)
                return 2
    warnings.simplefilter("ignore")
    config, dense = DarcyanConfig(), DenseConfig()
    proxy_vertices = dense.basis_proxy_vertices if args.proxy_vertices is None else args.proxy_vertices
    made: dict = {}

    def shape_of(name: str) -> tuple:
        if name not in made:
            shape = load_shape(folder / f"{name}.off", config, repair=True, warn=False)
            prepared = np.full(shape.n_input_vertices, -1)
            prepared[shape.mesh.input_index] = np.arange(shape.mesh.n_vertices)
            made[name] = (shape, prepared, {v: signature(shape, *v, dense.signature_lengths,
                                                         config.heat.diffusion_steps, config.curvature_smoothing,
                                                         proxy_vertices) for v in VARIANTS})
        return made[name]

    scores = {v: [] for v in VARIANTS}  # per pair: (truth, mirror image, random)
    try:
        for number, (a, b) in enumerate(lines, 1):
            print(f"signature_check: pair {number}/{len(lines)} {a} -> {b}", file=sys.stderr)
            (_, prepared_a, sig_a), (_, prepared_b, sig_b) = shape_of(a), shape_of(b)
            truth_a, truth_b = read_vts(folder / "corres" / f"{a}.vts"), read_vts(folder / "corres" / f"{b}.vts")
            mirror_path = folder / "corres" / f"{b}.sym.vts"
            mirror_b = read_vts(mirror_path) if mirror_path.is_file() else None
            kept = (prepared_a[truth_a] >= 0) & (prepared_b[truth_b] >= 0)
            if mirror_b is not None:
                kept &= prepared_b[mirror_b] >= 0
            points_a = prepared_a[truth_a[kept]]
            images = [prepared_b[truth_b[kept]], None if mirror_b is None else prepared_b[mirror_b[kept]]]
            images.append(images[0][np.random.default_rng(number).permutation(len(images[0]))])
            for v in VARIANTS:
                scores[v].append([np.nan if to is None else
                                  float(np.median(np.abs(sig_a[v][points_a] - sig_b[v][to]).mean(axis=1)))
                                  for to in images])
    except DarcyanError as exc:
        print(f"signature_check: {exc}", file=sys.stderr)
        return 2
    print(f"{len(lines)} pairs of {folder}; the median signature difference between a point and its image, "
          "means over the pairs (lower is better)\n")
    print("| computed on | scaled over | true image | mirror image | random point | true / mirror | true / random |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for (where, scale), rows in scores.items():
        r = np.array(rows)
        print(f"| {'the coarse copy' if where == 'copy' else 'the mesh itself'} | the {scale} | {r[:, 0].mean():.4f} "
              f"| {np.nanmean(r[:, 1]):.4f} | {r[:, 2].mean():.4f} | {np.nanmean(r[:, 0] / r[:, 1]):.3f} "
              f"| {(r[:, 0] / r[:, 2]).mean():.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
