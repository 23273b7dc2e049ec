"""Dense maps seeded by the sparse matches: :func:`dense_map` and its configuration,
:func:`verified_matches` (the seed a dense map would choose, as sparse matches) and
:func:`seed_scores` (the scores it chooses by).

Modules: ``maps`` (:func:`dense_map`, which puts the parts together), ``config``
(:class:`DenseConfig`), ``landmarks``, ``seeds``, ``signatures``, ``zoomout``, ``verify`` (a
verification kept per pair of files) and ``pyfm`` (pyFM's pipeline)."""

from importlib import import_module as _import_module

from .config import DenseConfig

# Where each name lives: the modules are imported when a name is first read (PEP 562), so that a
# sparse match, which reads DenseConfig only, does not load the dense layer.
_HOMES = {"consistent_landmarks": "landmarks", "UNMAPPED": "maps", "DenseMap": "maps", "MapCheck": "maps",
          "dense_map": "maps", "dense_map_to_csv": "maps", "pyfm_own_map": "maps", "shape_operators": "maps",
          "SeedVerdict": "seeds", "seed_scores": "seeds", "verified_matches": "seeds"}

__all__ = ["UNMAPPED", "DenseConfig", "DenseMap", "MapCheck", "SeedVerdict", "consistent_landmarks", "dense_map",
           "dense_map_to_csv", "pyfm_own_map", "seed_scores", "shape_operators", "verified_matches"]


def __getattr__(name: str):
    if name in _HOMES:
        value = getattr(_import_module(f".{_HOMES[name]}", __name__), name)
        globals()[name] = value  # read once
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list:
    return sorted(set(globals()) | set(__all__))
