"""Feature points at shape extremities: local maxima of the Average Geodesic Distance (AGD).

AGD(v) is the mean geodesic distance from v to every point of the surface (Hilaga et al. 2001,
Zhang et al. 2005); it is largest at the tips of limbs, head and tail. Computing it exactly needs
one distance field per vertex, so it is approximated from a few sources spread by farthest-point
sampling, each weighted by the area of its geodesic Voronoi cell: memory stays O(V x sources).

AGD is global: where a body stretches from pose to pose (the TOSCA cat's neck and back), its
values at the tips of one extremity (a cat's nose and ears) trade places, and the highest of them
jumps. :func:`sharpest_tips` then moves each feature point, within its extremity, to where the heat
kernel (Sun et al. 2009's HKS at one time) is clearly highest: a local, intrinsic measure of how
sharp a tip is, which a stretch elsewhere leaves alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import DarcyanConfig, HeatKernel
from ..geometry.geodesics import GeodesicSolver, LocalGeodesicSolver
from ..geometry.heat import heat_diffuse, heat_kernel_diagonal  # noqa: F401 (darcyan.method.features.*)
from ..geometry.mesh import Mesh
from ..geometry.operators import mixed_voronoi_area


@dataclass(frozen=True)
class AGD:
    """``values (n,)``: approximate AGD per vertex (mesh units); ``sources (s,)``: the sample
    (vertices of the mesh it was computed on, which may be a decimated proxy)."""

    values: np.ndarray
    sources: np.ndarray


@dataclass(frozen=True)
class FeaturePoints:
    """Extremities: ``vertices (k,) int64`` ordered by decreasing ``agd (k,)``; ``at_rims``: how
    many more there would be without the cut rims kept out (see :func:`extremities`)."""

    vertices: np.ndarray
    agd: np.ndarray
    at_rims: int = 0

    def __len__(self) -> int:
        return len(self.vertices)


def farthest_point_sources(mesh: Mesh, solver: GeodesicSolver, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Farthest-point sampling by geodesic distance.

    Starts at the vertex nearest the area-weighted centroid (so the sample does not depend on
    vertex numbering or rigid motion) and adds, ``count`` times, the vertex farthest from all
    sources so far. Returns the ``(count,)`` sources and their ``(count, n)`` distance fields.
    """
    areas = mesh.face_areas()
    centroid = (mesh.vertices[mesh.faces].mean(axis=1) * areas[:, None]).sum(0) / areas.sum()
    start = int(np.argmin(np.linalg.norm(mesh.vertices - centroid, axis=1)))
    first = solver.distance(start)
    sources, fields = [], []
    nearest = first
    current = int(np.argmax(first))  # the centroid itself is not a good source: start far from it
    for _ in range(min(count, mesh.n_vertices)):
        d = solver.distance(current)
        sources.append(current)
        fields.append(d)
        nearest = d if len(sources) == 1 else np.minimum(nearest, d)
        current = int(np.argmax(nearest))
    return np.array(sources, dtype=np.int64), np.array(fields)


def average_geodesic_distance(mesh: Mesh, solver: GeodesicSolver, sources: int, smoothing: float = 0.0,
                              diffusion_steps: int = HeatKernel().diffusion_steps) -> AGD:
    """Approximate AGD from ``sources`` farthest-point samples weighted by their Voronoi areas.

    Args:
        smoothing: length scale (mesh units) of a heat diffusion applied to the AGD field (0:
            none). AGD rises along a limb to every fingertip or toe alike; diffusing it over about
            a hand's size moves its maximum to the middle of the extremity, which stays put when
            fingers bend, instead of jumping between fingertips.
    """
    src, fields = farthest_point_sources(mesh, solver, sources)
    owner = np.argmin(fields, axis=0)
    area = mixed_voronoi_area(mesh)
    cell_area = np.bincount(owner, weights=area, minlength=len(src))
    values = (cell_area[:, None] * fields).sum(axis=0) / cell_area.sum()
    if smoothing > 0:
        values = heat_diffuse(mesh, values, smoothing, diffusion_steps)
    return AGD(values, src)


def one_ring_maxima(mesh: Mesh, values: np.ndarray) -> np.ndarray:
    """Vertices whose value is at least that of every neighbour."""
    e = mesh.edges()
    neighbour_max = np.full(mesh.n_vertices, -np.inf)
    np.maximum.at(neighbour_max, e[:, 0], values[e[:, 1]])
    np.maximum.at(neighbour_max, e[:, 1], values[e[:, 0]])
    return np.flatnonzero(values >= neighbour_max)


def extremities(mesh: Mesh, solver: GeodesicSolver | LocalGeodesicSolver, agd: AGD, config: DarcyanConfig,
                distance_cache: dict | None = None, near_rim: np.ndarray | None = None) -> FeaturePoints:
    """Local maxima of AGD over a geodesic ball of radius ``config.extremity_radius``.

    Candidates are one-ring maxima above the ``min_agd_quantile`` of AGD, visited by decreasing
    AGD; one is kept when no kept point lies within the radius and no vertex within the radius
    has a larger AGD (checked on its own fast-marching field, which ``distance_cache`` keeps for
    the grid built around it next). A :class:`LocalGeodesicSolver` needs a radius of at least
    ``config.extremity_radius``. Maxima where ``near_rim (n,) bool`` holds (near a cut's rim,
    :func:`cut_rim_zone`) are left out at the end: AGD peaks on a rim because the part beyond
    it is missing. Such a peak still suppresses the smaller maxima within the radius, which lie
    on the slope of the cut limb, not at an extremity.
    """
    values = agd.values
    floor = np.quantile(values, config.min_agd_quantile)
    candidates = one_ring_maxima(mesh, values)
    candidates = candidates[values[candidates] >= floor]
    candidates = candidates[np.argsort(-values[candidates], kind="stable")]
    radius = config.extremity_radius
    kept: list[int] = []
    near_kept = np.zeros(mesh.n_vertices, bool)
    cache = distance_cache if distance_cache is not None else {}
    for v in candidates:
        if near_kept[v]:
            continue
        d = cache.get(int(v))
        if d is None:
            d = solver.distance(int(v))
        ball = d <= radius
        if values[ball].max() > values[v] * (1 + 1e-9):
            continue  # a higher point within the radius: v sits on the slope of another extremity
        cache[int(v)] = d
        kept.append(int(v))
        near_kept |= ball
        if config.max_features and len(kept) >= config.max_features:
            break
    kept_arr = np.array(kept, dtype=np.int64)
    at_rim = np.zeros(len(kept_arr), bool) if near_rim is None else near_rim[kept_arr]
    kept_arr = kept_arr[~at_rim]
    return FeaturePoints(kept_arr, values[kept_arr], int(at_rim.sum()))


def cut_rim_zone(mesh: Mesh, solver: GeodesicSolver, config: DarcyanConfig) -> tuple[np.ndarray | None, int]:
    """``(n,) bool`` the vertices within ``config.rims.clearance`` of a cut's rim (a boundary loop
    at least ``config.rims.min_length`` long), or ``None`` where there is none; and how many such
    loops there are."""
    from ..geometry.mesh import boundary_loops

    if config.rims.min_length <= 0:
        return None, 0
    label, lengths = boundary_loops(mesh)
    long_loops = np.flatnonzero(lengths >= config.rims.min_length)
    if len(long_loops) == 0:
        return None, 0
    rim = np.flatnonzero(np.isin(label, long_loops))
    return solver.distance_multi(rim) <= config.rims.clearance, len(long_loops)


def sharpest_tips(features: FeaturePoints, values: np.ndarray, heat: np.ndarray, distances: dict,
                  config: DarcyanConfig, near_rim: np.ndarray | None = None) -> FeaturePoints:
    """Move each feature point to the sharpest tip of its extremity.

    The extremity's top is the part of the feature point's geodesic ball of radius
    ``config.tip_radius`` whose AGD ``values (n,)`` lie within ``config.tip_agd_drop`` of the
    point's; the point moves to the vertex of the top with the largest ``heat (n,)``
    (:func:`heat_kernel_diagonal`) if that beats the point's own by the factor
    ``config.tip_gain`` and lies farther than ``config.extremity_radius`` from every other
    feature point; it stays otherwise (a hand's fingertips are no sharper than its middle at this
    scale: it stays put). ``distances`` holds each feature point's distance field (from
    :func:`extremities`; beyond a :class:`LocalGeodesicSolver`'s radius its estimate does).
    No point moves where ``near_rim (n,) bool`` holds (a cut's rim, where the heat kernel of a
    surface with a boundary is highest). Returned in decreasing AGD.
    """
    found = [int(v) for v in features.vertices]
    kept = list(found)
    for i, v in enumerate(found):
        d = distances[v]
        top = (d <= config.tip_radius) & (values >= values[v] - config.tip_agd_drop)
        top = np.flatnonzero(top if near_rim is None else top & ~near_rim)
        if len(top) == 0:
            continue
        u = int(top[np.argmax(heat[top])])
        apart = all(distances[w][u] > config.extremity_radius for w in found if w != v)
        if heat[u] >= config.tip_gain * heat[v] and apart:
            kept[i] = u
    vertices = np.array(kept, dtype=np.int64)
    vertices = vertices[np.argsort(-values[vertices], kind="stable")]
    return FeaturePoints(vertices, values[vertices], features.at_rims)
