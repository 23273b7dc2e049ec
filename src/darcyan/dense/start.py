"""A start without landmarks: landmarks found by a short spectral map when the matches give too few.

When the extremities are not all distinct (hands glued to the hips, an arm fused to the chest)
the sparse matches leave fewer than :data:`~darcyan.dense.landmarks.MIN_LANDMARKS` consistent
landmarks, and no seed of :mod:`darcyan.dense.seeds` can start a map. Then the map starts from
the shapes' spectra: the first ``start_dimensions`` Laplace-Beltrami eigenfunctions of the two
shapes agree up to the sign of each (near an isometry, and when their eigenvalues are apart), so
each choice of signs is a first map, which a short ZoomOut refines (with the distances to the
landmarks there are, and the curvature signature beside the spectral terms). Of those maps, a
reflection keeps every distance and the signature as well as the right one; it reverses the
turns between directions on the surface, which :func:`map_orientation` reads. The chosen map
(the best signature score among those that keep the orientation) then names the landmarks:
``start_landmarks`` farthest points of the source and their images, which seed the dense map
like sparse matches (:func:`spectral_matching`).
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np

from ..geometry.knn import nearest_rows
from ..geometry.sampling import farthest_point_vertices
from .config import DenseConfig
from .landmarks import distance_fields, orientation_coordinates
from .signatures import point_signature, signature_coordinates, signature_score
from .zoomout import map_embeddings, seed_subset, zoomout


@dataclass(frozen=True)
class SpectralMatching:
    """Matches found by a short spectral map (the shape of a sparse correspondence): ``source_vertex
    (k,)`` and ``target_vertex (k,)`` in input numbering, ``distance (k,)`` zeros; ``start``
    the first map the short map started from (``"spectral +-++"``: the eigenfunctions' signs;
    ``"axes +-"``: the axes of inertia's), ``orientation`` its
    :func:`map_orientation` and ``signature`` its signature score (lower is better)."""

    source_vertex: np.ndarray
    target_vertex: np.ndarray
    distance: np.ndarray
    start: str
    orientation: float
    signature: float
    alternatives: tuple = ()


def spectral_matching(shape_1, shape_2, config: DenseConfig, samples: tuple, bases: tuple,
                      fields: tuple | None = None, known: tuple | None = None) -> SpectralMatching | None:
    """Landmark matches read from the best of the short spectral maps (see the module's text).

    Args:
        shape_1: the prepared source shape.
        shape_2: the prepared target shape.
        config: ``start_dimensions``, ``start_landmarks``, ``start_checked``, ``seed_basis``,
            ``seed_samples`` and the ZoomOut terms.
        samples: both shapes' ZoomOut samples ``(s_i,)``; the short maps run on a spread subset.
        bases: ``(n_i, >= seed_basis)`` Laplace-Beltrami eigenfunctions of both shapes.
        fields: one ``{vertex: (n,) distance}`` per shape, read and filled in (geodesic distances
            already computed).
        known: ``(fields_1 (n1, j), fields_2 (n2, j))``: distances to j < 3 landmark pairs the
            matches gave, which the short maps keep beside the spectral terms (``None``: none).

    Returns:
        a :class:`SpectralMatching`, or ``None`` when the bases are too small for a start.
    """
    fields = ({}, {}) if fields is None else fields
    dims = config.start_dimensions
    size = min(config.seed_basis, config.basis_size, bases[0].shape[1], bases[1].shape[1])
    if size < dims + 2:
        return None
    short = dataclasses.replace(config, basis_size=size, basis_start=min(config.basis_start, size), basis_margin=0)
    p_1, p_2 = (seed_subset(shape, sample, config.seed_samples, config) for shape, sample in zip((shape_1, shape_2),
                                                                                             samples))
    b_1, b_2 = bases[0][p_1, :size], bases[1][p_2, :size]
    f_1 = f_2 = None
    if known is not None and known[0].shape[1] > 0:
        f_1, f_2 = known[0][p_1], known[1][p_2]
    coarse_1, coarse_2 = signature_coordinates(shape_1, shape_2, config, p_1, p_2)
    signature_1, signature_2 = point_signature(shape_1, config)[p_1], point_signature(shape_2, config)[p_2]
    tried = []
    for name, first_12, first_21 in _first_maps(shape_1, shape_2, p_1, p_2, b_1, b_2, f_1, f_2, config):
        c_12, c_21 = zoomout(b_1, b_2, first_12, first_21, short, f_1, f_2, coarse_1, coarse_2)
        map_12 = map_embeddings(b_1, b_2, c_12, c_21, short, f_1, f_2).nearest()
        score = signature_score(signature_1, signature_2[map_12], config)
        tried.append((score, name, map_12))
    tried.sort(key=lambda entry: entry[0])
    # Landmarks of the source: farthest points among the samples (extremities first), the same
    # for every candidate; their distance fields once.
    start = int(np.argmax((shape_1.mesh.vertices[p_1] ** 2).sum(axis=1)))
    picks = farthest_point_vertices(shape_1.mesh.vertices[p_1], config.start_landmarks, start)
    source = p_1[picks]
    distances_1 = distance_fields(shape_1, fields[0], source)
    turns_1 = orientation_coordinates(shape_1, distances_1)[p_1]
    best = None
    for score, name, map_12 in tried[:config.start_checked]:
        target = p_2[map_12[picks]]
        distances_2 = distance_fields(shape_2, fields[1], target)
        orientation = map_orientation(turns_1, orientation_coordinates(shape_2, distances_2)[p_2][map_12])
        candidate = (orientation > 0, -score, orientation, name, target)
        if best is None or candidate[:2] > best[:2]:
            best = candidate
    _, minus_score, orientation, name, target = best
    return SpectralMatching(shape_1.mesh.input_index[source], shape_2.mesh.input_index[target],
                            np.zeros(len(source)), name, float(orientation), -minus_score)


def _first_maps(shape_1, shape_2, p_1, p_2, b_1, b_2, f_1, f_2, config: DenseConfig):
    """``(name, first_12 (s_1,), first_21 (s_2,))`` for each candidate start, on the samples
    ``p_i``: each choice of signs of the first ``start_dimensions`` non-constant eigenfunctions
    (``"spectral +-+-"``), and each proper rotation taking one shape's principal axes of inertia
    onto the other's (``"axes ++"``). The spectra pair up only while the shapes' topology and
    proportions agree (parts glued where they touch reorder the eigenfunctions); the axes of
    inertia do not depend on topology, only on the pose being alike."""
    dims = config.start_dimensions
    spectral_1, spectral_2 = b_1[:, 1:dims + 1], b_2[:, 1:dims + 1]  # the first is constant
    for signs in itertools.product((1.0, -1.0), repeat=dims):
        queries, references = spectral_1 * np.array(signs), spectral_2
        name = "spectral " + "".join("+" if x > 0 else "-" for x in signs)
        yield (name, nearest_rows(_beside(references, f_2, config), _beside(queries, f_1, config)),
               nearest_rows(_beside(queries, f_1, config), _beside(references, f_2, config)))
    axes_1, axes_2 = _inertia_axes(shape_1), _inertia_axes(shape_2)
    x_1, x_2 = shape_1.mesh.vertices[p_1] - shape_1.mesh.vertices.T @ (shape_1.vertex_areas / shape_1.vertex_areas.sum()), \
        shape_2.mesh.vertices[p_2] - shape_2.mesh.vertices.T @ (shape_2.vertex_areas / shape_2.vertex_areas.sum())
    for signs in itertools.product((1.0, -1.0), repeat=2):
        flips = np.array([*signs, signs[0] * signs[1]])  # the third sign keeps the rotation proper
        rotation = axes_2 @ np.diag(flips) @ axes_1.T * np.linalg.det(axes_2 @ axes_1.T)
        moved = x_1 @ rotation.T
        name = "axes " + "".join("+" if x > 0 else "-" for x in signs)
        yield (name, nearest_rows(_beside(x_2, f_2, config), _beside(moved, f_1, config)),
               nearest_rows(_beside(moved, f_1, config), _beside(x_2, f_2, config)))


def _inertia_axes(shape) -> np.ndarray:
    """``(3, 3)`` the area-weighted principal axes of the shape's vertices (columns, largest
    spread first)."""
    weights = shape.vertex_areas / shape.vertex_areas.sum()
    centred = shape.mesh.vertices - weights @ shape.mesh.vertices
    _, axes = np.linalg.eigh((centred * weights[:, None]).T @ centred)
    return axes[:, ::-1]


def map_orientation(turns_1: np.ndarray, turns_at_images: np.ndarray) -> float:
    """The correlation, in [-1, 1], of the :func:`~darcyan.dense.landmarks.orientation_coordinates`
    at source points ``(s, c)`` and at their images ``(s, c)`` (the turns between the directions to
    landmarks and those to their images): 1 for a map that keeps the surface's orientation, -1
    for a reflection, near 0 for a map unrelated to its landmarks."""
    a = turns_1 - turns_1.mean(axis=0)
    b = turns_at_images - turns_at_images.mean(axis=0)
    scale = np.sqrt((a * a).sum() * (b * b).sum())
    return float((a * b).sum() / scale) if scale > 0 else 0.0


def _beside(spectral: np.ndarray, landmark: np.ndarray | None, config: DenseConfig) -> np.ndarray:
    """Spectral coordinates beside the weighed landmark distances (when there are any)."""
    return spectral if landmark is None else np.hstack([spectral, config.landmark_weight * landmark])
