"""Verifying a matching (in doubt, or won by a small margin: ``Correspondence.to_verify``), once
per pair of files: :func:`verified_file_matches`.

The verification (:func:`darcyan.dense.seeds.verified_matches`) prepares both shapes and runs a
short ZoomOut per candidate matching: seconds on large meshes, against a tenth of a second for a
match from cached descriptions. Its outcome (which seed, the seeds' scores) depends only on the
two files' contents, how they are prepared, the matchings weighed, the dense settings and
darcyan's code, so it is kept in the shape cache under a key of those, and a second match of the
same pair reads it instead of preparing the shapes. A verification that fails (too few
consistent landmarks) is not kept.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from typing import Callable

import numpy as np

from ..config import DarcyanConfig
from ..io.cache import ShapeCache, code_digest, file_digest
from ..parallel import owns_threads
from .config import DenseConfig
from .seeds import matching_of_seed, seed_check, verified_matches


@owns_threads
def verified_file_matches(source: str | os.PathLike, target: str | os.PathLike, correspondence,
                          shapes: Callable[[], tuple], config: DarcyanConfig = DarcyanConfig(),
                          dense_config: DenseConfig = DenseConfig(), repair: bool = False,
                          cache: ShapeCache | None = None, full_basis: bool = False) -> tuple:
    """:func:`~darcyan.dense.seeds.verified_matches` of the files ``source`` and ``target``,
    whose ``correspondence`` was matched with ``config`` (and ``repair``); ``shapes()`` gives
    their two prepared shapes, called only when the outcome is not in ``cache``; ``full_basis``
    as ``verified_matches`` takes it.

    Returns ``(matches, about)`` as ``verified_matches`` does; ``about["cached"]`` says whether
    the outcome was read from the cache.
    """
    key = None
    if cache is not None:
        settings = json.dumps(dataclasses.asdict(dense_config), sort_keys=True, default=str)
        key = cache.key("verify", f"code={code_digest()}", file_digest(source), file_digest(target),
                        config.prepare_fingerprint(), f"repair={repair}", f"full_basis={full_basis}", settings,
                        _matchings_digest(correspondence, dense_config.candidates))
        about = _about_from_arrays(cache.load(key), correspondence, dense_config.seed_margin)
        if about is not None:
            return matching_of_seed(correspondence, about["seed"]), {**about, "cached": True}
    matches, about = verified_matches(*shapes(), correspondence, dense_config, full_basis)
    if key is not None:
        cache.save(key, _about_arrays(about))
    return matches, {**about, "cached": False}


def _about_arrays(about: dict) -> dict:
    """What a cache entry keeps: the chosen seed and every seed's score (the rest follows)."""
    ranks = sorted(about["signatures"])
    return {"seed": np.array(about["seed"]), "ranks": np.array(ranks, dtype=np.int64),
            "scores": np.array([about["signatures"][r] for r in ranks], dtype=np.float64)}


def _matchings_digest(correspondence, candidates: int) -> str:
    """What the verification weighs: the matching and the alternatives it looks at (their
    vertex pairs and descriptor distances, which break ties between landmark sets), so that
    another matching of the same files (other settings) is verified anew."""
    matchings = [correspondence] + list(getattr(correspondence, "alternatives", ()))[:max(candidates - 1, 0)]
    h = hashlib.sha1()
    for matching in matchings:
        for values, kind in ((matching.source_vertex, np.int64), (matching.target_vertex, np.int64),
                             (matching.distance, np.float64)):
            h.update(np.asarray(values, dtype=kind).tobytes() + b"|")
    return h.hexdigest()


def _about_from_arrays(stored: dict | None, correspondence, margin: float) -> dict | None:
    """The outcome kept in a cache entry (:func:`~darcyan.dense.seeds.seed_check` of it);
    ``None`` when there is none or it does not fit ``correspondence`` (then the pair is verified
    anew)."""
    if stored is None or not {"seed", "ranks", "scores"} <= stored.keys():
        return None
    seed, ranks = int(stored["seed"]), stored["ranks"].tolist()
    if seed not in ranks or seed > len(getattr(correspondence, "alternatives", ())):
        return None
    return seed_check(seed, dict(zip(ranks, stored["scores"].tolist())), margin).as_dict()
