"""Dense maps seeded by the sparse matches: :func:`dense_map` and its configuration,
:func:`verified_matches` (the seed a dense map would choose, as sparse matches) and
:func:`seed_scores` (the scores it chooses by)."""

from .maps import (
    UNMAPPED,
    DenseConfig,
    DenseMap,
    consistent_landmarks,
    dense_map,
    dense_map_to_csv,
    pyfm_own_map,
    seed_scores,
    verified_matches,
)

__all__ = ["UNMAPPED", "DenseConfig", "DenseMap", "consistent_landmarks", "dense_map", "dense_map_to_csv",
           "pyfm_own_map", "seed_scores", "verified_matches"]
