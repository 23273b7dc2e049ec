"""The settings of a dense map: :class:`~darcyan.config.DenseConfig`, the ``dense`` section of the
one settings object (:mod:`darcyan.config`), named here for the dense modules that read it."""

from ..config import LANDMARK_MODES, METHODS, SAMPLINGS, SEED_STATISTICS, DenseConfig

__all__ = ["LANDMARK_MODES", "METHODS", "SAMPLINGS", "SEED_STATISTICS", "DenseConfig"]
