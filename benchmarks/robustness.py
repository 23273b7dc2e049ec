"""Accuracy under vertex noise and other meshings of the same surfaces (issue: trustworthy input).

Makes perturbed copies of a dataset laid out like ``tosca-5k`` (meshes + ``corres/*.vts``) in
``--out/meshes`` and runs ``darcyan bench`` on each (the decimated copies with ``--repair``); a
second run into the same ``--out`` reuses the copies and the finished pairs:

- ``noise=L``: Gaussian noise on every vertex, of standard deviation L = 0.1%, 0.5% and 1% of the
  bounding-box diagonal (vertex numbering kept, so the ground truth files stay valid);
- ``decimated``: decimation to half the faces (fast-simplification; the few faces it leaves on
  non-manifold edges are dropped); each ground-truth sample moves to the nearest remaining vertex;
- ``subdivided``: every triangle split in four at its edge midpoints (the same surface, four
  times the faces; vertex numbering kept for the original vertices);
- ``holes``: three faces taken out of every shape, far apart (small holes: no surface is
  closed); vertex numbering kept;
- ``inside-out``: every other shape (in name order) with every face flipped (the normals point
  in, as some exporters write them), and three faces taken out of every shape, far apart (small
  holes: no surface is closed); vertex numbering kept.
- ``isotropic``: the surface remeshed with edges of one length (Botsch and Kobbelt's isotropic
  remeshing, gpytoolbox's ``remesh_botsch``, projected back onto the input), about as many
  vertices as the input: another meshing of the same surface, as a scanner's software writes it.
  Each ground-truth sample moves to the nearest vertex of the copy.
- ``mixed-resolution``: the same isotropic remeshing, each shape to its own vertex count, drawn
  (seeded) between 0.75 and 4 times the input's on a log scale: source and target differ in
  resolution and meshing, as in SHREC'19's humans (4.7k to 60k vertices).
- ``marching-cubes`` and ``glued``: the surface rebuilt as a scan reconstruction would, by
  marching cubes (scikit-image) on the signed distance to the surface (libigl, the sign by the
  winding number), at the level of an offset, then decimated to the input's vertex count
  (libigl's QSlim, which keeps the topology); the outer sheet is kept. At
  ``marching-cubes`` the grid is fine and the offset small (0.004 sqrt(area)): a new meshing of
  the same surface. At ``glued`` the offset (0.012 sqrt(area), about 2 cm on a person) fuses the
  parts that nearly touch, hands on hips, thighs, a tail on a leg: topological noise, as in
  TOPKIDS. Each ground-truth sample moves to the nearest vertex of the copy.

Every shape of the dataset is perturbed independently (a decimated source is matched to a
decimated target with its own triangles). Moving a ground-truth sample to the nearest remaining
vertex costs about a third of an edge of the coarser mesh on average, more at worst: dense mean
errors on decimated meshes carry that rounding.

    python benchmarks/robustness.py ../shared/data/tosca-5k --pairs benchmarks/sweep_pairs_tosca5k.txt --out robustness
    python benchmarks/robustness.py ../shared/data/faust-5k --pairs benchmarks/faust5k_test_pairs_groups.txt \
        --conditions decimated subdivided --dense --jobs 2 --out robustness-faust

Prints the per-class-mean strict rate (per source feature), rate with flips and repeatability
for each condition (with ``--dense``, also each group's share of dense samples within 0.05 and
mean geodesic error) and writes ``robustness.json`` in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from darcyan import DarcyanConfig, load_mesh, save_mesh
from darcyan.bench.runner import run_bench
from darcyan.geometry.mesh import Mesh

NOISE_LEVELS = (0.001, 0.005, 0.01)  # fractions of the bounding-box diagonal
DECIMATION = 0.5  # fraction of the faces kept
DEFAULT_CONDITIONS = ("clean",) + tuple(f"noise={level}" for level in NOISE_LEVELS) + ("decimated",)
CONDITIONS = DEFAULT_CONDITIONS + ("subdivided", "holes", "inside-out", "isotropic", "mixed-resolution",
                                   "marching-cubes", "glued")
REMESH_ITERATIONS = 10  # of remesh_botsch (its default)
MIXED_RESOLUTION = (0.75, 4.0)  # the mixed-resolution copies' vertex counts, times the input's
# Marching cubes: (grid step, offset of the level set), both in sqrt(area) units of the input.
LEVEL_SETS = {"marching-cubes": (0.006, 0.004), "glued": (0.01, 0.012)}
# Copies benched with --repair (remeshing and decimation can leave duplicate faces).
REPAIRED = ("decimated", "isotropic", "mixed-resolution") + tuple(LEVEL_SETS)
HOLES = 3  # faces taken out of each shape of the holes and inside-out copies
# Written in each copy's "done" file; a copy of another version is made again. 2: the level-set
# copies by libigl's signed distance and QSlim (2026-12-06).
COPIES_VERSION = "2"


def perturbed_dataset(source: Path, target: Path, condition: str, seed: int = 0) -> None:
    """Write ``source``'s meshes and ground truth, perturbed by ``condition``, into ``target``."""
    rng = np.random.default_rng(seed)
    (target / "corres").mkdir(parents=True, exist_ok=True)
    for number, path in enumerate(sorted(source.glob("*.off"))):
        mesh = load_mesh(path)
        remap = None
        if condition.startswith("noise"):
            level = float(condition.split("=")[1])
            diagonal = np.linalg.norm(mesh.vertices.max(0) - mesh.vertices.min(0))
            mesh = Mesh(mesh.vertices + rng.normal(scale=level * diagonal, size=mesh.vertices.shape), mesh.faces)
        elif condition == "decimated":
            import fast_simplification

            v, f = fast_simplification.simplify(mesh.vertices, mesh.faces, target_reduction=1 - DECIMATION)
            f = without_nonmanifold_edges(f)
            remap = cKDTree(v).query(mesh.vertices)[1]  # each old vertex -> nearest kept vertex
            mesh = Mesh(v, f)
        elif condition == "subdivided":
            import trimesh

            v, f = trimesh.remesh.subdivide(mesh.vertices, mesh.faces)  # keeps the old vertices first
            mesh = Mesh(v, f)
        elif condition in ("isotropic", "mixed-resolution"):
            import gpytoolbox

            # equilateral triangles, two per vertex, of the input's area: about as many vertices
            # (times a factor drawn per shape for mixed resolutions)
            factor = 1.0 if condition == "isotropic" else float(np.exp(rng.uniform(*np.log(MIXED_RESOLUTION))))
            length = np.sqrt(2 * mesh.area() / (np.sqrt(3) * mesh.n_vertices * factor))
            v, f = gpytoolbox.remesh_botsch(mesh.vertices.astype(np.float64), mesh.faces.astype(np.int32),
                                            i=REMESH_ITERATIONS, h=length, project=True)
            mesh = Mesh(v, without_nonmanifold_edges(f))
            remap = cKDTree(mesh.vertices).query(load_mesh(path).vertices)[1]
        elif condition in LEVEL_SETS:
            mesh = level_set_copy(mesh, *LEVEL_SETS[condition])
            remap = cKDTree(mesh.vertices).query(load_mesh(path).vertices)[1]
        elif condition in ("holes", "inside-out"):
            faces = mesh.faces[:, ::-1] if number % 2 and condition == "inside-out" else mesh.faces
            mesh = Mesh(mesh.vertices, np.delete(faces, spread_faces(mesh, HOLES, rng), axis=0))
        save_mesh(mesh, target / path.name)
        for suffix in (".vts", ".sym.vts"):
            gt = source / "corres" / f"{path.stem}{suffix}"
            if not gt.exists():
                continue
            if remap is None:
                shutil.copy(gt, target / "corres" / gt.name)
            else:
                idx = np.loadtxt(gt, dtype=np.int64) - 1
                np.savetxt(target / "corres" / gt.name, remap[idx] + 1, fmt="%d")


def level_set_copy(mesh: Mesh, step: float, offset: float) -> Mesh:
    """The surface at distance ``offset`` outside ``mesh`` (marching cubes on a grid of ``step``
    over its signed distance; both in sqrt(area) units), decimated to ``mesh``'s vertex count.
    Parts of ``mesh`` closer than twice the offset are one part of the copy; elsewhere the copy
    keeps the input's topology. The distance is libigl's exact distance to the triangles, its
    sign the generalized winding number (the input is closed): the side of the nearest sample's
    normal, which the first copies used, is wrong near thin or folded parts, and those copies
    had up to 40 handles the input has not (``docs/decisions/every-pair.md``). The decimation is
    libigl's QSlim, whose edge collapses keep the topology (fast-simplification's added up to 11
    handles more)."""
    import igl
    import trimesh
    from skimage.measure import marching_cubes

    vertices, faces = mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64)
    scale = np.sqrt(mesh.area())
    step, offset = step * scale, offset * scale
    margin = offset + 3 * step
    low = vertices.min(axis=0) - margin
    axes = [np.arange(a, b + step, step) for a, b in zip(low, vertices.max(axis=0) + margin)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    # No distance bounds: beyond them libigl returns NaN, sign and all.
    signed, _, _, _ = igl.signed_distance(grid, vertices, faces,
                                          sign_type=igl.SignedDistanceType.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)
    if not np.isfinite(signed).all():
        raise ValueError(f"{mesh.name}: the signed distance is not finite at {int((~np.isfinite(signed)).sum())} grid points")
    level_vertices, level_faces, _, _ = marching_cubes(signed.reshape([len(a) for a in axes]), level=offset,
                                                       spacing=(step,) * 3)
    level = trimesh.Trimesh(level_vertices + low, level_faces, process=True)
    outer = max(level.split(only_watertight=False), key=lambda part: part.area)  # bubbles, if any, left out
    manifold = without_nonmanifold_edges(np.asarray(outer.faces))  # QSlim needs a manifold mesh
    count = 2 * mesh.n_vertices - 4  # faces of a closed genus-0 surface of the input's vertex count
    v, f, _, _ = igl.qslim(np.asfortranarray(outer.vertices, dtype=np.float64),
                           np.asfortranarray(manifold, dtype=np.int32), count)
    if len(f) > count:
        raise ValueError(f"{mesh.name}: QSlim stopped at {len(f)} faces, above {count}")
    return Mesh(v, f)  # QSlim returns only the vertices its faces use


def spread_faces(mesh: Mesh, count: int, rng) -> np.ndarray:
    """``count`` face indices far apart: a random first face, then each the face whose centre is
    farthest in space from those taken."""
    centres = mesh.vertices[mesh.faces].mean(axis=1)
    chosen = [int(rng.integers(mesh.n_faces))]
    for _ in range(count - 1):
        chosen.append(int(np.argmax(cKDTree(centres[chosen]).query(centres)[0])))
    return np.array(chosen)


def without_nonmanifold_edges(faces: np.ndarray) -> np.ndarray:
    """Drop the faces on edges shared by more than two faces (decimation leaves a few): a small
    hole is valid input, a non-manifold edge is refused."""
    while True:
        edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
        bad = (counts[inverse.reshape(-1)] > 2).reshape(-1, 3).any(axis=1)
        if not bad.any():
            return faces
        faces = faces[~bad]


def summary(results: dict) -> dict:
    classes = results["methods"]["darcyan"]["classes"].values()
    mean = lambda values: float(np.mean([v for v in values if v is not None]))  # noqa: E731
    row = {"rate_per_feature": mean(c["correct"] / c["features"] for c in classes if c["features"]),
           "rate_sym": mean(c["rate_sym"] for c in classes), "repeatability": mean(c["repeatability"] for c in classes)}
    dense = results.get("dense", {}).get("darcyan")
    if dense:
        groups = dense.get("groups") or {}
        row["dense"] = {name: {key: part.get(key) for key in ("pairs", "samples", "within", "rate", "mean_error",
                                                               "untrusted", "seconds_per_pair")}
                        for name, part in [("overall", dense["overall"]), *groups.items()]}
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dataset")
    parser.add_argument("--pairs")
    parser.add_argument("--out", default="robustness-out")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--conditions", nargs="+", choices=CONDITIONS, default=DEFAULT_CONDITIONS,
                        help="which copies to make and bench (default: clean, the noise levels, decimated)")
    parser.add_argument("--dense", action="store_true", help="also dense maps (darcyan bench --dense)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kept = out / "robustness.json"  # rows of earlier runs into --out stay, this run's replace theirs
    rows = json.loads(kept.read_text()) if kept.exists() else {}
    for condition in args.conditions:
        # The perturbed meshes are kept in --out, so that an interrupted run resumes.
        folder = Path(args.dataset) if condition == "clean" else out / "meshes" / condition
        # A copy made by another version of the generator is made again (see COPIES_VERSION).
        done = folder / "done"
        if condition != "clean" and (not done.exists() or done.read_text().strip() != COPIES_VERSION):
            perturbed_dataset(Path(args.dataset), folder, condition)
            done.write_text(COPIES_VERSION + "\n")
        # Decimation can leave duplicate faces: drop them as `--repair` would.
        result = run_bench(folder, out / condition, ("darcyan",), args.pairs, config=DarcyanConfig(),
                           jobs=args.jobs, resume=True, repair=condition in REPAIRED,
                           plots=False, progress=False, dense=args.dense)
        rows[condition] = row = summary(result.results)
        print(f"{condition:<16} strict {row['rate_per_feature']:.3f}  with flips "
              f"{row['rate_sym']:.3f}  repeatability {row['repeatability']:.3f}", flush=True)
        for name, part in row.get("dense", {}).items():
            figures = "no sample mapped" if part["rate"] is None or part["mean_error"] is None else \
                f"{part['within']} of {part['samples']} within 0.05 ({part['rate']:.4f}), mean error {part['mean_error']:.4f}"
            print(f"{'':<16} dense {name}: {figures}, {part['untrusted']} not trusted", flush=True)
        kept.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
