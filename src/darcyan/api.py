"""The front door: :func:`correspond` does from Python what ``darcyan match`` does.

It describes the shapes (with the on-disk cache, several at once), matches the source with each
target, verifies a matching the sparse stage is in doubt of or won by a small margin
(:mod:`darcyan.dense.verify`; ``Correspondence.to_verify``) and, when asked, makes the dense
map; :class:`Correspondences` holds what came out and writes it exactly as ``darcyan match ...
-o`` does (the command is a shell over this module).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from .config import DarcyanConfig
from .dense.config import DenseConfig
from .errors import DarcyanError
from .geometry.mesh import Mesh
from .geometry.shape import Shape, prepare_shape
from .io.cache import ShapeCache
from .method.pipeline import (
    Correspondence,
    analyze_shape,
    describe_and_prepare,
    describe_keeping_first,
    load_shape,
    match_shapes,
)
from .parallel import owns_threads

if TYPE_CHECKING:  # the dense layer is imported where a map or a verification is made: a sparse match needs none
    from .dense.maps import DenseMap

VERIFY_CHOICES = ("auto", True, False)


@dataclass(frozen=True)
class PairResult:
    """What :func:`correspond` found for one target.

    Attributes:
        target: the target's name (its path, or the name of a mesh given in memory).
        matches: the feature matches (:class:`~darcyan.method.pipeline.Correspondence`, input
            numbering), verified when that was asked or the matching was to be verified
            (``to_verify``: in doubt, or won by a margin below ``mirror.verify_sparse_below``); with a dense
            map, the matching that seeded it (:func:`matches_of_map`).
        dense: the dense map (:class:`~darcyan.dense.maps.DenseMap`) with ``dense=True``, else ``None``.
        verification: what the verification said (``seed``, ``signatures``, ``clear``,
            ``cached``; ``why``: why it was made; ``failed``: why it could not be made), or
            ``None`` when none was made.
        shapes: the prepared source and target (:class:`~darcyan.geometry.shape.Shape`) when
            verifying or the dense map needed them, else ``None``.
    """

    target: str
    matches: Correspondence
    dense: DenseMap | None = None
    verification: dict | None = None
    shapes: tuple | None = None


@dataclass(frozen=True)
class Correspondences:
    """The result of :func:`correspond`: the source's name, its description and the targets'
    (``descriptions``: their notes of repairs are in ``.changes``), and one :class:`PairResult`
    per target, in order (``result[0]``, ``len(result)``, ``for pair in result``)."""

    source: str
    pairs: tuple
    descriptions: tuple
    dense: bool = False

    def __len__(self) -> int:
        return len(self.pairs)

    def __getitem__(self, index: int) -> PairResult:
        return self.pairs[index]

    def __iter__(self):
        return iter(self.pairs)

    def text(self, form: str = "csv") -> str:
        """What ``darcyan match`` writes for one target (``form``: ``"csv"`` or ``"json"``): the
        feature matches, or the dense map with ``dense=True``; for several targets the matches
        with a leading ``target`` column (CSV) or one object per target (JSON). Several dense
        maps are one text per target: :meth:`dense_text`."""
        if form not in ("csv", "json"):
            raise DarcyanError(f"output format must be 'csv' or 'json', got {form!r}")
        if self.dense:
            if len(self.pairs) > 1:
                raise DarcyanError("several dense maps are written one file per target (to_csv(folder))")
            return self.dense_text(0, form)
        return matches_text(self.source, [(p.target, p.matches) for p in self.pairs], form, len(self.pairs) > 1)

    def dense_text(self, index: int, form: str = "csv") -> str:
        """The dense map of target ``index`` as ``darcyan match --dense`` writes it."""
        pair = self.pairs[index]
        if pair.dense is None:
            raise DarcyanError(f"{self.source} -> {pair.target}: no dense map was asked for (dense=True)")
        return dense_text(self.source, pair.target, pair.dense.target, form)

    def to_csv(self, path: str | os.PathLike | None = None) -> str:
        """Write CSV to ``path`` (a file; with several dense maps, a folder: ``<target name>.csv``
        in it), the same bytes as ``darcyan match ... -o path``; returns the text (of the first
        map with several)."""
        return self._write(path, "csv")

    def to_json(self, path: str | os.PathLike | None = None) -> str:
        """:meth:`to_csv` in JSON (``darcyan match ... -o path.json``)."""
        return self._write(path, "json")

    def _write(self, path, form: str) -> str:
        if self.dense and len(self.pairs) > 1:
            stems = [Path(pair.target).stem for pair in self.pairs]
            twice = sorted({stem for stem in stems if stems.count(stem) > 1})
            if path is not None and twice:
                raise DarcyanError(f"several targets are named {twice[0]!r}: their maps would overwrite each other "
                                   f"in {path}")
            texts = [self.dense_text(i, form) for i in range(len(self.pairs))]
            if path is not None:
                folder = Path(path)
                write_file(None, folder, mkdir=True)
                for pair, text in zip(self.pairs, texts):
                    write_file(text, folder / f"{Path(pair.target).stem}.{form}")
            return texts[0]
        text = self.text(form)
        if path is not None:
            write_file(text, Path(path))
        return text


def matches_text(source: str, pairs: list, form: str, several: bool) -> str:
    """The matches of ``source`` with each ``(target, Correspondence)``: CSV (a leading
    ``target`` column with several targets) or JSON (one object per target)."""
    if form == "json":
        records = [{"source": str(source), "target": str(target),
                    "matches": [{"source_vertex": int(s), "target_vertex": int(t), "distance": float(d)}
                                for s, t, d in zip(c.source_vertex, c.target_vertex, c.distance)]}
                   for target, c in pairs]
        return json.dumps(records if several else records[0], indent=1) + "\n"
    if not several:
        return pairs[0][1].to_csv()
    lines = ["target,source_vertex,target_vertex,distance"]
    for target, c in pairs:
        lines += [f"{target},{s},{t},{d:.6g}" for s, t, d in zip(c.source_vertex, c.target_vertex, c.distance)]
    return "\n".join(lines) + "\n"


def dense_text(source: str, target: str, map_12, form: str) -> str:
    """A dense map as CSV (``source_vertex,target_vertex``) or JSON (``{"source", "target", "target_vertex"}``)."""
    if form == "json":
        return json.dumps({"source": str(source), "target": str(target),
                           "target_vertex": [int(v) for v in map_12]}) + "\n"
    from .dense.maps import dense_map_to_csv

    return dense_map_to_csv(map_12)


def verification_wanted(correspondence, verify, dense: bool) -> bool:
    """Whether a matching is verified: always with ``verify=True``, never with ``False``; with
    ``"auto"``, when no dense map follows (a dense map weighs the same alternatives on its full
    basis) and the orientation test's margin is below ``mirror.verify_sparse_below`` or the
    matching is in doubt (``Correspondence.to_verify``; a correspondence made elsewhere without
    it: ``in_doubt``)."""
    if verify not in VERIFY_CHOICES:
        raise DarcyanError(f"verify must be 'auto', True or False, got {verify!r}")
    wanted = getattr(correspondence, "to_verify", False) or bool(correspondence.in_doubt)
    return verify is True or (verify == "auto" and wanted and not dense)


@owns_threads
def correspond(source, targets, *, dense: bool = False, config: DarcyanConfig | None = None,
               dense_config: DenseConfig | None = None, cache: bool | ShapeCache = True, verify="auto",
               repair: bool = False, jobs: int = 2, progress=None) -> Correspondences:
    """Match ``source`` with each of ``targets`` as ``darcyan match`` does.

    Args:
        source: a mesh file's path, a :class:`~darcyan.geometry.mesh.Mesh`, a prepared
            :class:`~darcyan.geometry.shape.Shape` or a ``trimesh.Trimesh``.
        targets: one target of those kinds, or a list of them.
        dense: also make each pair's dense map (``darcyan match --dense``).
        config: the method's settings (default :class:`~darcyan.config.DarcyanConfig`).
        dense_config: the dense map's settings (default ``config.dense``; either way with the
            point signature's unset settings from ``config``, :meth:`DarcyanConfig.dense_for`).
        cache: keep and reuse shape descriptions and verifications on disk (``True``: the
            default cache, ``$DARCYAN_CACHE``; a :class:`~darcyan.io.cache.ShapeCache`; ``False``:
            none). Files only: shapes given in memory are described anew.
        verify: ``"auto"`` verifies a matching the sparse stage is in doubt of or won by a margin
            below ``config.mirror.verify_sparse_below`` (without ``dense``); ``True`` every
            matching (``--verify``); ``False`` none (``--no-verify``).
        repair: weld coincident boundary vertices (``--repair``); the ordinary repairs are made
            anyway, unless ``config.repairing.strict``.
        jobs: shapes described at once, in worker processes (files not yet cached).
        progress: called with a line of text at each stage (``darcyan match`` prints them).

    Returns:
        a :class:`Correspondences`; ``.to_csv(path)`` writes what ``darcyan match ... -o path``
        writes.

    Raises:
        DarcyanError: for bad input (a :class:`~darcyan.errors.MeshError` names the file), and
            for a pair that gets no dense map.
    """
    config = DarcyanConfig() if config is None else config
    dense_config = config.dense_for(dense_config)
    if isinstance(targets, (list, tuple)):
        targets = list(targets)
    else:
        targets = [targets]
    if not targets:
        raise DarcyanError("correspond: no target given")
    if not isinstance(jobs, int) or jobs < 1:
        raise DarcyanError(f"jobs must be at least 1, got {jobs!r}")
    if verify not in VERIFY_CHOICES:
        raise DarcyanError(f"verify must be 'auto', True or False, got {verify!r}")
    say = progress or (lambda text: None)
    store = ShapeCache() if cache is True else (cache or None)
    inputs = [_input(item) for item in [source, *targets]]
    # A mesh given in memory is prepared once, for its description and everything after.
    prepared: dict = {i: (item if isinstance(item, Shape) else prepare_shape(item, config, repair))
                      for i, item in enumerate(inputs) if isinstance(item, (Mesh, Shape))}
    descriptions = _describe(inputs, prepared, config, repair, store, jobs, dense_config if dense else None,
                             keep_source=verify is not False)
    say(f"described {len(descriptions)} shapes")
    names = [_name(item) for item in inputs]

    def shape_of(index: int) -> Shape:
        if index not in prepared:  # a file, prepared as its description was (its notes said once)
            prepared[index] = load_shape(inputs[index], config, repair, warn=False)
        return prepared[index]

    pairs = []
    for index, (target, description) in enumerate(zip(names[1:], descriptions[1:]), start=1):
        matches = match_shapes(descriptions[0], description, config)
        verification = None
        if verification_wanted(matches, verify, dense):
            from .dense.maps import DENSE_FAILURES

            below = config.mirror.verify_below if matches.in_doubt else config.mirror.verify_sparse_below
            why = "" if verify is True else (f" ({'in doubt: ' if matches.in_doubt else ''}the orientation test's "
                                             f"margin {matches.margin:.2f} < {below:g})")
            say(f"verifying the matches{why}")
            try:
                matches, verification = _verified(inputs[0], inputs[index], matches, lambda i=index: (shape_of(0),
                                                  shape_of(i)), config, dense_config, repair, store, dense)
            except DENSE_FAILURES as exc:
                verification = {"failed": str(exc)}
            verification["why"] = why
        made = None
        if dense:
            from .dense.maps import DENSE_FAILURES, dense_map

            try:
                made = dense_map(shape_of(0), shape_of(index), matches, dense_config,
                                 progress=lambda stage: say(f"dense map: {stage}"))
            except DENSE_FAILURES as exc:  # one line, never a traceback
                raise DarcyanError(f"{names[0]} -> {target}: no dense map: {exc}") from None
            matches = matches_of_map(matches, made, descriptions[0], description, shape_of(index))
        shapes = (shape_of(0), shape_of(index)) if index in prepared else None
        pairs.append(PairResult(target, matches, made, verification, shapes))
    return Correspondences(names[0], tuple(pairs), tuple(descriptions), dense)


def matches_of_map(matches: Correspondence, made: DenseMap, description_1=None, description_2=None,
                   shape_2: Shape | None = None) -> Correspondence:
    """The feature matches a dense map agrees with: ``matches`` itself, or the alternative
    matching that seeded the map instead (its own dense map contradicted the sparse one), the
    others kept as its alternatives. A map started without the matches (too few consistent
    ones, or a rival start that won), or made without a landmark pair the others contradicted
    (``check.verdict.left_out``), gives the matches it reads itself
    (:func:`~darcyan.dense.maps.matching_of_map`: the shapes' descriptions and the prepared
    target needed; without them ``matches`` stay as they are)."""
    from .dense.maps import matching_of_map
    from .dense.seeds import matching_of_seed

    if made.check is None:
        return matches
    if made.check.start != "matches" or made.check.verdict.left_out is not None:
        if description_1 is None or description_2 is None or shape_2 is None:
            return matches
        return matching_of_map(matches, made, description_1, description_2, shape_2)
    if made.check.seed == 0:
        return matches
    return matching_of_seed(matches, made.check.seed)


def _input(item):
    """A path, a :class:`Mesh` or a :class:`Shape` as they are; a ``trimesh.Trimesh`` as a Mesh."""
    if isinstance(item, (str, os.PathLike, Mesh, Shape)):
        return item
    if type(item).__name__ == "Trimesh" and hasattr(item, "vertices") and hasattr(item, "faces"):
        name = str(getattr(item, "metadata", {}).get("file_name") or "trimesh")
        return Mesh(item.vertices, item.faces, name)
    raise DarcyanError(f"correspond: cannot read {type(item).__name__!r}: give a path, a darcyan Mesh or Shape, "
                       f"or a trimesh.Trimesh")


def _name(item) -> str:
    return str(item) if isinstance(item, (str, os.PathLike)) else item.name


def _describe(inputs: list, prepared: dict, config: DarcyanConfig, repair: bool, store, jobs: int,
              dense_config: DenseConfig | None = None, keep_source: bool = True) -> list:
    """The descriptions of ``inputs``: the files together (cache, workers), the shapes given in
    memory from their ``prepared`` shapes. With ``dense_config`` (a dense map to follow), the
    files' shapes are prepared beside their descriptions, with what the map needs of each alone
    (:func:`~darcyan.dense.maps.shape_operators`), and join ``prepared``. Without it, with
    ``keep_source`` (a verification may follow), the source's shape joins ``prepared`` when this
    process prepared it beside the workers (:func:`~darcyan.method.pipeline.describe_keeping_first`)."""
    files = [i for i, item in enumerate(inputs) if isinstance(item, (str, os.PathLike))]
    sources = [inputs[i] for i in files]
    described = {}
    for i, shape in prepared.items():  # given in memory
        described[i] = analyze_shape(shape, config).description
    if dense_config is not None and files:
        from .dense.maps import shape_operators

        both = describe_and_prepare(sources, config, repair, store, jobs, partial(shape_operators, config=dense_config))
        described.update({i: description for i, (description, _) in zip(files, both)})
        prepared.update({i: shape for i, (_, shape) in zip(files, both)})
    else:
        descriptions, first = describe_keeping_first(sources, config, repair, store, jobs)
        described.update(zip(files, descriptions))
        if keep_source and first is not None and files[0] == 0:  # the source, prepared here: a verification reuses it
            prepared[0] = first
    return [described[i] for i in range(len(inputs))]


def _verified(source, target, matches, shapes, config, dense_config, repair, store, dense: bool) -> tuple:
    """``verified_file_matches`` (kept in the cache) for two files, ``verified_matches`` otherwise."""
    from .dense.seeds import verified_matches
    from .dense.verify import verified_file_matches

    if isinstance(source, (str, os.PathLike)) and isinstance(target, (str, os.PathLike)):
        # With a dense map to follow, scored on its basis, which the map then reuses.
        return verified_file_matches(source, target, matches, shapes, config, dense_config, repair, store,
                                     full_basis=dense)
    checked, about = verified_matches(*shapes(), matches, dense_config, full_basis=dense)
    return checked, {**about, "cached": False}


def write_file(text: str | None, path: Path, mkdir: bool = False) -> None:
    """Write ``text`` to ``path`` (or, with ``mkdir``, make the folder ``path``); a failure is one
    :class:`DarcyanError` naming the path (what ``darcyan`` writes, it writes through here)."""
    try:
        if mkdir:
            path.mkdir(parents=True, exist_ok=True)
        else:
            path.write_text(text)
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot write ({exc.strerror or exc})") from None
