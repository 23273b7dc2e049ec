"""Dense maps seeded by the sparse matches: :func:`dense_map` and its configuration."""

from .maps import UNMAPPED, DenseConfig, DenseMap, consistent_landmarks, dense_map, dense_map_to_csv, pyfm_own_map

__all__ = ["UNMAPPED", "DenseConfig", "DenseMap", "consistent_landmarks", "dense_map", "dense_map_to_csv",
           "pyfm_own_map"]
