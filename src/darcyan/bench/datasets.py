"""A dataset folder for ``darcyan bench``: its shapes, classes, ground truth and pairs.

A dataset is a folder of meshes named ``{class}{pose}`` with a suffix of :data:`MESH_SUFFIXES`
(the class is the name without its trailing digits). Ground truth comes from
``corres/{shape}.vts`` when that folder exists, else it is the identity on vertex indices within
a class. Pairs are every ordered pair within a class, or the ``source<TAB>target[<TAB>group]``
lines of a pairs file.
"""

from __future__ import annotations

import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

from ..errors import DarcyanError
from ..geometry.mesh import MeshWarning

MESH_SUFFIXES = (".off", ".ply", ".obj", ".stl", ".glb", ".gltf")  # the formats load_mesh reads alone
# A file of these formats named like another mesh of the folder is taken for a copy of it (an
# export, a preview): left out with a warning, where two of the first three with one name are an error.
SECONDARY_SUFFIXES = (".stl", ".glb", ".gltf")
TRUTH_FOLDER = "corres"


def shape_class(name: str) -> str:
    """The class of a shape: its name without trailing digits (``cat10`` -> ``cat``)."""
    return re.sub(r"\d+$", "", name) or name


def pose_key(name: str):
    match = re.search(r"(\d+)$", name)
    return (shape_class(name), int(match.group(1)) if match else -1, name)


@dataclass(frozen=True)
class Dataset:
    """A folder of meshes: ``shapes`` name -> file, ``classes`` class -> names (by pose number),
    ``truth`` ``"vts"`` (``corres/*.vts``) or ``"identity"``."""

    root: Path
    shapes: dict
    classes: dict
    truth: str

    def vts(self, name: str, mirror: bool = False) -> Path:
        return self.root / TRUTH_FOLDER / (f"{name}.sym.vts" if mirror else f"{name}.vts")


def discover_dataset(root: str | os.PathLike) -> Dataset:
    """Read a dataset folder (see the module docstring); clear errors for an unusable one."""
    root = Path(root)
    if not root.is_dir():
        raise DarcyanError(f"{root}: not a folder")
    shapes: dict = {}
    for path in sorted(root.iterdir()):
        if path.suffix.lower() not in MESH_SUFFIXES or not path.is_file():
            continue
        if path.stem in shapes:
            kept, other = sorted([shapes[path.stem], path], key=lambda p: MESH_SUFFIXES.index(p.suffix.lower()))
            if other.suffix.lower() not in SECONDARY_SUFFIXES:
                raise DarcyanError(f"{root}: two meshes named {path.stem} ({shapes[path.stem].name}, {path.name})")
            warnings.warn(f"{root}: {other.name} left out: {kept.name} is the mesh named {path.stem}", MeshWarning,
                          stacklevel=2)
            path = kept
        shapes[path.stem] = path
    if not shapes:
        raise DarcyanError(f"{root}: no meshes ({', '.join(MESH_SUFFIXES)}) in this folder")
    names = sorted(shapes, key=pose_key)
    shapes = {n: shapes[n] for n in names}
    classes: dict = {}
    for n in names:
        classes.setdefault(shape_class(n), []).append(n)
    truth_dir = root / TRUTH_FOLDER
    truth = "vts" if truth_dir.is_dir() and any(truth_dir.glob("*.vts")) else "identity"
    if truth == "vts":
        missing = [n for n in names if not (truth_dir / f"{n}.vts").is_file()]
        if missing:
            raise DarcyanError(f"{truth_dir / (missing[0] + '.vts')}: ground truth missing "
                               f"({len(missing)} shape(s) without .vts)")
    return Dataset(root, shapes, classes, truth)


def default_pairs(dataset: Dataset) -> list:
    """Every ordered pair of distinct shapes within each class."""
    return [(a, b) for names in dataset.classes.values() for a in names for b in names if a != b]


def read_pairs(path: str | os.PathLike, dataset: Dataset, groups: dict | None = None) -> list:
    """``source<TAB>target[<TAB>group]`` lines (blank lines and ``#`` comments skipped; names with
    or without the mesh suffix). A third column names the pair's group (e.g. ``same`` and
    ``two people`` for FAUST), recorded in ``groups`` ``{(source, target): group}``; results are
    then also given per group (a pair without one is in its class's group)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise DarcyanError(f"{path}: not a text file of pair lines") from None
    pairs = []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split("\t") if "\t" in line else line.split(maxsplit=2)
        if len(parts) not in (2, 3) or not all(p.strip() for p in parts):
            raise DarcyanError(f"{path}: line {number}: expected 'source<TAB>target[<TAB>group]', got {line!r}")
        names = []
        for part in parts[:2]:
            name = part.strip()
            stem = Path(name).stem if Path(name).suffix.lower() in MESH_SUFFIXES else name
            if stem not in dataset.shapes:
                raise DarcyanError(f"{path}: line {number}: no mesh named {name!r} in {dataset.root}")
            names.append(stem)
        pairs.append(tuple(names))
        if len(parts) == 3 and groups is not None:
            groups[tuple(names)] = parts[2].strip()
    if not pairs:
        raise DarcyanError(f"{path}: no pairs in this file")
    return pairs
