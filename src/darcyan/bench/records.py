"""The records of a run's journal (``pairs.jsonl``): one JSON object per method and pair, sparse
or dense (``kind``), and the conversions to and from it."""

from __future__ import annotations

import numpy as np

DENSE = "dense"  # the "kind" of a dense record in the journal (sparse records have no kind)


def record_kind(record: dict) -> str:
    """``"dense"`` for a dense record of the journal, ``"sparse"`` for the others."""
    return record.get("kind", "sparse")


def json_floats(values) -> list:
    """Floats for JSON: NaN and infinities become ``None``."""
    return [float(v) if np.isfinite(v) else None for v in np.asarray(values, dtype=np.float64)]


def record_array(values) -> np.ndarray:
    """The inverse of :func:`json_floats`: ``None`` back to NaN, as a float array."""
    return np.array([np.nan if v is None else v for v in values], dtype=np.float64)
