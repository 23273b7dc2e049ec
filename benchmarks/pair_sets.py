"""What the benchmarks that walk a dataset's pairs share: their command line (a dataset folder,
``--pairs``, ``--repair``) and a bad dataset, pair list or mesh as one error line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def pair_set_parser(doc: str) -> argparse.ArgumentParser:
    """A parser described by ``doc``'s first line, with the dataset folder, ``--pairs`` and
    ``--repair``; a script adds its own options."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a folder of meshes with corres/*.vts (or one numbering)")
    parser.add_argument("--pairs", type=Path, required=True, help="a file of 'source<TAB>target[<TAB>group]' lines")
    parser.add_argument("--repair", action="store_true")
    return parser


def pair_truth(dataset, source: str, target: str):
    """The :class:`~darcyan.eval.metrics.GroundTruth` of ``source -> target`` in ``dataset`` (a
    :func:`~darcyan.bench.datasets.discover_dataset`): one numbering, or the pair's vts files."""
    from darcyan.eval.metrics import GroundTruth, read_vts

    if dataset.truth == "identity":
        return GroundTruth.identity()
    return GroundTruth(read_vts(dataset.vts(source)), read_vts(dataset.vts(target)))


def run_reporting_errors(name: str, run, args) -> int:
    """``run(args)``, a :class:`~darcyan.errors.DarcyanError` (a bad dataset, pair list or mesh)
    said as one line ``NAME: error: ...`` with exit status 2, never a traceback."""
    from darcyan.errors import DarcyanError

    try:
        return run(args)
    except DarcyanError as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2
