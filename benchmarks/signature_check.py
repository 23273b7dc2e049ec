"""How well the curvature signature (the mean curvature diffused over a few lengths) of a point
agrees with that of its true image, across meshes of one surface at different resolutions.

For each pair, the median over the ground truth's points of the mean absolute difference of
their signatures, beside the same for the truth's mirror image (``corres/NAME.sym.vts``, when the
dataset has it) and for a random pairing of the same points; printed as ratios (the scales of
the variants differ), means over the pairs, lower is better. Four ways of computing it: on a
large mesh's coarse copy (darcyan's way; a mesh with at most twice ``--proxy-vertices`` vertices
has none) or on the mesh itself, each column scaled to mean magnitude 1 over the vertices
(darcyan before 2026-12-07) or over the area (darcyan now: read from
:func:`darcyan.geometry.heat.shape_signature` itself). Behind "The curvature signature scaled
over the area" in ``docs/decisions/every-pair.md``.

    python benchmarks/signature_check.py COPIES/faust-5k/mixed-resolution \
        --pairs benchmarks/faust5k_test_pairs_groups.txt --count 24 --repair
"""

from __future__ import annotations

import sys

import numpy as np
from pair_sets import pair_set_parser, run_reporting_errors  # benchmarks/pair_sets.py

VARIANTS = (("copy", "vertices"), ("copy", "area"), ("mesh", "vertices"), ("mesh", "area"))


def main(argv=None) -> int:
    parser = pair_set_parser(__doc__)
    parser.add_argument("--count", type=int, default=0, help="the first this many pairs (default: all)")
    parser.add_argument("--proxy-vertices", type=int, default=None, help="default: the dense map's")
    return run_reporting_errors("signature_check", _check, parser.parse_args(argv))


def signature(shape, where: str, scale: str, lengths, steps: int, smoothing: int, proxy_vertices: int) -> np.ndarray:
    """``(n, len(lengths))`` the shape's curvature signature computed as ``where`` (``"copy"``: on
    its coarse copy when it has one) and ``scale`` (``"area"``: darcyan's own; ``"vertices"``: each
    column divided by its mean magnitude over the vertices it was computed on) say."""
    from darcyan.geometry.curvature import principal_curvatures
    from darcyan.geometry.heat import curvature_signature, shape_signature

    proxy_vertices = proxy_vertices if where == "copy" else 0
    if scale == "area":
        return shape_signature(shape, proxy_vertices, lengths, steps, smoothing)
    proxy = shape.proxy(proxy_vertices) if proxy_vertices > 0 else None
    mesh = shape.mesh if proxy is None else proxy.mesh
    curvature = shape.curvatures(smoothing).mean if proxy is None else principal_curvatures(mesh, smoothing=smoothing).mean
    # darcyan's columns rescaled: each divided by its mean magnitude over the vertices instead
    values = curvature_signature(mesh, curvature, lengths, steps)
    values = values / np.maximum(np.abs(values).mean(axis=0), 1e-12)
    return values if proxy is None else proxy.to_full(values)


def _difference(signature_a: np.ndarray, signature_b: np.ndarray, points: np.ndarray, images) -> float:
    """The median over ``points`` of the mean absolute difference between each one's signature
    and its image's (``images``, rows of ``signature_b``; NaN when ``None``)."""
    if images is None:
        return np.nan
    return float(np.median(np.abs(signature_a[points] - signature_b[images]).mean(axis=1)))


def _check(args) -> int:
    import warnings

    from darcyan.bench.datasets import discover_dataset, read_pairs
    from darcyan.config import DarcyanConfig
    from darcyan.dense.config import DenseConfig
    from darcyan.errors import DarcyanError
    from darcyan.eval.metrics import read_vts
    from darcyan.method.pipeline import load_shape

    if args.count < 0:
        raise DarcyanError(f"--count must be at least 0 (0: all pairs), got {args.count}")
    dataset = discover_dataset(args.dataset)
    if dataset.truth != "vts":
        raise DarcyanError(f"{args.dataset}: no corres/*.vts ground truth")
    pairs = read_pairs(args.pairs, dataset)
    pairs = pairs[:args.count] if args.count else pairs
    if not pairs:
        raise DarcyanError(f"{args.pairs}: no pairs")
    warnings.simplefilter("ignore")
    config, dense = DarcyanConfig(), DenseConfig()
    proxy_vertices = dense.basis_proxy_vertices if args.proxy_vertices is None else args.proxy_vertices
    made: dict = {}

    def shape_of(name: str) -> tuple:
        if name not in made:
            shape = load_shape(dataset.shapes[name], config, repair=args.repair, warn=False)
            prepared = np.full(shape.n_input_vertices, -1)
            prepared[shape.mesh.input_index] = np.arange(shape.mesh.n_vertices)
            made[name] = (shape, prepared, {v: signature(shape, *v, dense.signature_lengths,
                                                         config.heat.diffusion_steps, config.curvature_smoothing,
                                                         proxy_vertices) for v in VARIANTS})
        return made[name]

    def truth(name: str, mirror: bool = False):
        n = made[name][0].n_input_vertices
        path = dataset.vts(name, mirror)
        return read_vts(path, n) if path.is_file() else None

    ratios = {v: [] for v in VARIANTS}  # per pair: (true / mirror, true / random)
    for number, (a, b) in enumerate(pairs, 1):
        print(f"signature_check: pair {number}/{len(pairs)} {a} -> {b}", file=sys.stderr, flush=True)
        (_, prepared_a, sig_a), (_, prepared_b, sig_b) = shape_of(a), shape_of(b)
        truth_a, truth_b, mirror_b = truth(a), truth(b), truth(b, mirror=True)
        if len(truth_a) != len(truth_b) or (mirror_b is not None and len(mirror_b) != len(truth_b)):
            raise DarcyanError(f"{dataset.vts(a)}, {dataset.vts(b)}: ground truths of different lengths")
        kept = (prepared_a[truth_a] >= 0) & (prepared_b[truth_b] >= 0)
        if mirror_b is not None:
            kept &= prepared_b[mirror_b] >= 0
        points = prepared_a[truth_a[kept]]
        images = prepared_b[truth_b[kept]]
        shuffled = images[np.random.default_rng(number).permutation(len(images))]
        mirrored = None if mirror_b is None else prepared_b[mirror_b[kept]]
        for v in VARIANTS:
            true, mirror, random = (_difference(sig_a[v], sig_b[v], points, to) for to in (images, mirrored, shuffled))
            ratios[v].append((true / mirror, true / random))
    print(f"{len(pairs)} pairs of {args.dataset}: a point's signature difference to its true image over that to "
          "its mirror image and to a random point (medians over the points, means over the pairs; lower is better)\n")
    print("| computed on | scaled over | true / mirror | true / random |")
    print("| --- | --- | ---: | ---: |")
    for (where, scale), rows in ratios.items():
        r = np.array(rows)
        mirror = "–" if np.isnan(r[:, 0]).all() else f"{np.nanmean(r[:, 0]):.3f}"
        print(f"| {'the coarse copy' if where == 'copy' else 'the mesh itself'} | the {scale} | {mirror} "
              f"| {r[:, 1].mean():.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
