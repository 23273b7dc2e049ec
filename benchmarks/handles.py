"""How many handles a set of meshes has, and how long the loops that would cut them are.

    python benchmarks/handles.py COPIES/faust-5k/glued COPIES/tosca-5k/marching-cubes --repair

For each folder, every ``*.off`` mesh is prepared as darcyan prepares it (``--repair``: as
``darcyan bench --repair``) without cutting handles, and its genus counted
(:func:`darcyan.geometry.handles.genus`; a body is a sphere, genus 0: a handle is where parts
that touch were joined). Each mesh with handles is prepared again cutting every handle
(``handle_length`` 10), and the cut loops' lengths (sqrt(area)) are binned; then once more with
``--length`` (0.05), timed, to say how many handles that length leaves. Prints a table per folder
(the census of ``docs/decisions/every-pair.md``, "Handles cut open"). ``--plot FILE``: a picture
of where the cuts below ``--length`` fall on the shape with the most handles of each folder.
"""

from __future__ import annotations

import argparse
import collections
import time
import warnings
from pathlib import Path

import numpy as np

from darcyan import load_mesh, prepare_mesh
from darcyan.config import Repairing
from darcyan.geometry.handles import genus

BINS = (0.03, 0.05, 0.1)


def cut_lengths(changes: list[str]) -> list[float]:
    """The loop lengths of a ``cut N handles ... each, a, b sqrt(area) long`` note."""
    note = next((c for c in changes if c.startswith("cut ")), None)
    return [] if note is None else [float(x) for x in note.split("each, ")[1].split(" sqrt")[0].split(", ")]


def census(folder: Path, repair: bool, length: float) -> tuple[str, Path | None]:
    """The folder's table row, and its mesh with the most handles."""
    shapes, counts, lengths, seconds, left = 0, collections.Counter(), [], [], collections.Counter()
    most = (0, None)
    for path in sorted(folder.glob("*.off")):
        mesh = load_mesh(path)
        shapes += 1
        handles = genus(prepare_mesh(mesh, repair, Repairing(handle_length=0))[0])
        counts[handles] += 1
        most = max(most, (handles, path), key=lambda m: m[0])
        if not handles:
            continue
        lengths += cut_lengths(prepare_mesh(mesh, repair, Repairing(handle_length=10.0))[1])
        start = time.perf_counter()
        cut, _ = prepare_mesh(mesh, repair, Repairing(handle_length=length))
        seconds.append(time.perf_counter() - start)
        left[genus(cut)] += 1
    loops = np.array(lengths)
    edges = (0.0, *BINS, np.inf)
    binned = " / ".join(str(int(((loops >= lo) & (loops < hi)).sum())) for lo, hi in zip(edges, edges[1:]))
    with_handles = shapes - counts[0]
    timing = f"{np.median(seconds):.2f} s (at most {max(seconds):.2f} s)" if seconds else "-"
    return (f"| {folder} | {with_handles} of {shapes} | {sum(k * v for k, v in counts.items())} | {binned} | "
            f"{with_handles - left[0]} | {timing} |"), most[1]


def plot_cuts(paths: list, repair: bool, length: float, out: Path) -> None:
    """Each mesh's prepared vertices (grey) and the vertices of its cut loops (red), front and side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(4 * len(paths), 8))
    for i, path in enumerate(paths):
        mesh, changes = prepare_mesh(load_mesh(path), repair, Repairing(handle_length=length))
        copies, counts = np.unique(mesh.input_index, return_counts=True)
        on_cut = np.isin(mesh.input_index, copies[counts > 1])
        # the shape's principal axes: its longest upright, its shortest towards the viewer
        centred = mesh.vertices - mesh.vertices.mean(axis=0)
        axes = np.linalg.svd(centred, full_matrices=False)[2]
        v = centred @ axes[[1, 2, 0]].T
        for row, azimuth in enumerate((-90, 0)):
            ax = fig.add_subplot(2, len(paths), row * len(paths) + i + 1, projection="3d")
            ax.scatter(*v[::2].T, s=0.3, c="0.75")
            ax.scatter(*v[on_cut].T, s=14, c="tab:red")
            ax.view_init(5, azimuth)
            ax.set_box_aspect(np.ptp(v, axis=0))
            ax.set_axis_off()
        cuts = cut_lengths(changes)
        shown = ", ".join(f"{c:.3f}" for c in cuts[:4]) + (", ..." if len(cuts) > 4 else "")
        fig.axes[-2].set_title(f"{path.parent.name}/{path.name}\n{len(cuts)} cut below {length:g}: {shown}", fontsize=9)
    fig.suptitle(f"handles cut open (red: the cut loops' vertices; handle_length {length:g} sqrt(area))")
    fig.savefig(out, dpi=80, bbox_inches="tight")
    print(f"wrote {out}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", type=Path, nargs="+")
    parser.add_argument("--repair", action="store_true", help="prepare as with --repair")
    parser.add_argument("--length", type=float, default=0.05, help="handle_length of the timed cut")
    parser.add_argument("--plot", type=Path, help="a picture of the cuts on each folder's mesh with the most handles")
    args = parser.parse_args()
    for folder in args.folders:
        if not folder.is_dir() or not any(folder.glob("*.off")):
            parser.error(f"{folder}: not a folder of .off meshes")
    print(f"| folder | shapes with handles | handles | shortest loops < {' / '.join(f'{b:g}' for b in BINS)} / more "
          f"(sqrt(area)) | shapes left with handles at {args.length:g} | preparing with the cut, median |")
    print("| --- | ---: | ---: | --- | ---: | --- |")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        most = []
        for folder in args.folders:
            row, path = census(folder, args.repair, args.length)
            print(row, flush=True)
            most += [path] if path is not None else []
        if args.plot and most:
            plot_cuts(most, args.repair, args.length, args.plot)


if __name__ == "__main__":
    main()
