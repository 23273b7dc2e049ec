"""Dense maps seeded by the sparse matches: :func:`dense_map` and its configuration, and
:func:`verified_matches` (the seed a dense map would choose, as sparse matches)."""

from .maps import (
    UNMAPPED,
    DenseConfig,
    DenseMap,
    consistent_landmarks,
    dense_map,
    dense_map_to_csv,
    pyfm_own_map,
    verified_matches,
)

__all__ = ["UNMAPPED", "DenseConfig", "DenseMap", "consistent_landmarks", "dense_map", "dense_map_to_csv",
           "pyfm_own_map", "verified_matches"]
