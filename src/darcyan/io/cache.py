"""On-disk cache of per-shape work, keyed by the file's content and the parameters.

Entries are ``.npz`` files named by a hash of (format version, content digest, parameter
fingerprint, ...): renaming or moving a file keeps its entry, editing it does not. Writes go to a
temporary file first and are renamed into place, so an interrupted run never leaves a broken
entry.
"""

from __future__ import annotations

import functools
import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

CACHE_FORMAT = "2"
# The parts of darcyan whose code decides what is cached (pictures and the command line do not).
RESULT_CODE = ("config.py", "geometry", "io", "method", "dense", "eval", "bench")


def default_cache_dir() -> Path:
    """``$DARCYAN_CACHE``, else ``$XDG_CACHE_HOME/darcyan``, else ``~/.cache/darcyan``."""
    if os.environ.get("DARCYAN_CACHE"):
        return Path(os.environ["DARCYAN_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "darcyan"


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """sha1 of darcyan's own source files that cached results depend on (:data:`RESULT_CODE`):
    an entry made by other code is never reused, and no format version is bumped by hand."""
    package = Path(__file__).resolve().parents[1]
    h = hashlib.sha1()
    for part in RESULT_CODE:
        files = [package / part] if part.endswith(".py") else sorted((package / part).rglob("*.py"))
        for path in files:
            h.update(path.relative_to(package).as_posix().encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


def file_digest(path: str | os.PathLike) -> str:
    """sha1 of the bytes a mesh is read from: the file's, and those of the files it needs beside
    it (:func:`~darcyan.io.mesh_files.mesh_file_parts`: TOSCA's ``.vert``/``.tri`` sibling, a
    ``.gltf`` file's buffers; one that is missing counts as such, and loading then says so)."""
    from .mesh_files import _read_bytes, mesh_file_parts  # the same clear errors as loading

    path = Path(path)
    parts = mesh_file_parts(path)
    if len(parts) == 1:
        return hashlib.sha1(_read_bytes(path)).hexdigest()
    # TOSCA's two halves must both be there; a missing buffer of a .gltf is named when loading.
    required = len(parts) if path.suffix.lower() in (".vert", ".tri") else 1
    h = hashlib.sha1()
    for i, part in enumerate(parts):  # each part's own digest: no two layouts of bytes hash alike
        h.update(hashlib.sha1(_read_bytes(part)).digest() if i < required or part.is_file() else b"missing")
    return h.hexdigest()


class ShapeCache:
    """A folder of cached per-shape results."""

    def __init__(self, folder: str | os.PathLike | None = None):
        self.folder = Path(folder) if folder is not None else default_cache_dir()

    def key(self, *parts: str) -> str:
        return hashlib.sha1("|".join((CACHE_FORMAT,) + parts).encode()).hexdigest()

    def _path(self, key: str) -> Path:
        return self.folder / f"{key}.npz"

    def load(self, key: str) -> dict | None:
        path = self._path(key)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                return {k: data[k] for k in data.files}
        except Exception:  # a damaged entry is recomputed, never trusted
            return None

    def save(self, key: str, arrays: dict) -> None:
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=self.folder, suffix=".tmp.npz")
            with os.fdopen(fd, "wb") as fh:
                np.savez(fh, **arrays)
            os.replace(tmp, self._path(key))
        except OSError:
            pass  # a cache that cannot be written only costs time
