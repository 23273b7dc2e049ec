"""Dense maps seeded by the sparse matches: :func:`dense_map` and its configuration,
:func:`verified_matches` (the seed a dense map would choose, as sparse matches) and
:func:`seed_scores` (the scores it chooses by).

Modules: ``maps`` (:func:`dense_map`, which puts the parts together), ``config``
(:class:`DenseConfig`), ``landmarks``, ``seeds``, ``signatures``, ``zoomout``, ``verify`` (a
verification kept per pair of files) and ``pyfm`` (pyFM's pipeline)."""

from .config import DenseConfig
from .landmarks import consistent_landmarks
from .maps import UNMAPPED, DenseMap, MapCheck, dense_map, dense_map_to_csv, pyfm_own_map, shape_operators
from .seeds import SeedVerdict, seed_scores, verified_matches

__all__ = ["UNMAPPED", "DenseConfig", "DenseMap", "MapCheck", "SeedVerdict", "consistent_landmarks", "dense_map",
           "dense_map_to_csv", "pyfm_own_map", "seed_scores", "shape_operators", "verified_matches"]
