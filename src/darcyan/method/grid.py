"""The Darcyan coordinate system around a surface point (the paper's section 2.1).

n geodesic level curves ``U = lambda_k`` of the fast-marching distance U from the centre are
superposed with m radial geodesic lines leaving the centre at equal angles. Their intersections
are ordered points: row k is level curve k, column l is radial line l, counter-clockwise about
the outward normal starting from a reference direction.

Radial lines are traced as straightest geodesics (geometry-central's tracer), which in the
smooth setting are the integral curves of the paper's eq. 2; a radial line meets level curve k
where the fast-marching U interpolated along it first reaches lambda_k. The paper's interpolation
step, raising the grid's resolution, traces ``interpolation - 1`` extra radial lines between
consecutive ones: ``DarcyanGrid.fine`` holds all of them, ``DarcyanGrid`` indexing the m main ones.

A radial line that reaches the mesh boundary before a level leaves that intersection missing
(``valid`` False, coordinates NaN): nothing is invented beyond the surface.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import DarcyanConfig
from ..geometry.geodesics import (
    GeodesicBall,
    GeodesicSolver,
    LocalGeodesicSolver,
    interpolate,
    vertex_gradient,
    vertex_normals,
)
from ..geometry.mesh import Mesh


@dataclass(frozen=True)
class DarcyanGrid:
    """The intersection points of one Darcyan coordinate system, at full (interpolated) resolution.

    Attributes:
        centre: the vertex the system is built around.
        radii: ``(n,)`` lambda_1..lambda_n (mesh units).
        angles: ``(m * q,)`` angles of the radial lines (radians, counter-clockwise about the
            outward normal from ``reference``); q = the interpolation factor.
        points: ``(n, m * q, 3)`` positions (NaN where missing).
        faces: ``(n, m * q)`` face of each point (-1 where missing).
        barycentric: ``(n, m * q, 3)`` barycentric coordinates in that face.
        valid: ``(n, m * q)`` bool, False where the radial line left the surface first.
        reference: ``(3,)`` unit tangent direction of angle 0.
        interpolation: q.
        radial_paths: the ``m * q`` traced radial lines, each a ``(k, 3)`` polyline.
    """

    centre: int
    radii: np.ndarray
    angles: np.ndarray
    points: np.ndarray
    faces: np.ndarray
    barycentric: np.ndarray
    valid: np.ndarray
    reference: np.ndarray
    interpolation: int
    radial_paths: tuple

    @property
    def main(self) -> slice:
        """Column slice of the m radial lines before interpolation."""
        return slice(None, None, self.interpolation)

    def sample(self, mesh: Mesh, values: np.ndarray) -> np.ndarray:
        """Per-vertex ``values (n_vertices,)`` at every grid point: ``(n, m * q)``, NaN where missing."""
        out = np.full(self.valid.shape, np.nan)
        ok = self.valid
        out[ok] = interpolate(mesh, values, self.faces[ok], self.barycentric[ok])
        return out


def reference_direction(mesh: Mesh, vertex: int, toward_field: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Unit tangent direction at ``vertex`` along which ``toward_field`` (a distance field)
    decreases fastest: the start of the geodesic toward that field's source."""
    g = -vertex_gradient(mesh, toward_field, vertex)
    g = g - normal * np.dot(g, normal)
    if np.linalg.norm(g) < 1e-12:  # at the source itself: any tangent direction will do
        g = np.cross(normal, [1.0, 0.0, 0.0])
        if np.linalg.norm(g) < 1e-6:
            g = np.cross(normal, [0.0, 1.0, 0.0])
    return g / np.linalg.norm(g)


def darcyan_grids(mesh: Mesh, solver: GeodesicSolver | LocalGeodesicSolver, vertices, config: DarcyanConfig,
                  distances: dict | None = None, toward: np.ndarray | None = None,
                  normals: np.ndarray | None = None) -> list[DarcyanGrid]:
    """Darcyan coordinate systems around several vertices.

    Args:
        mesh: the (normalized) mesh; radii in ``config`` are in its length unit.
        solver: the mesh's geodesic solver; a :class:`LocalGeodesicSolver` (radius at least
            :func:`grid_reach`) builds each grid on the ball around its centre alone.
        vertices: centre vertices.
        config: levels n, radial_lines m, radius R, interpolation q.
        distances: optional cache ``{vertex: (n_vertices,) fast-marching distance}``, filled in.
        toward: ``(n_vertices,)`` distance field whose source fixes angle 0 at every centre (the
            pipeline uses the shape's centre, the vertex of least AGD); by default each grid looks
            toward the vertex farthest from its centre.
        normals: ``(n_vertices, 3)`` the mesh's vertex normals, if already computed.

    Returns:
        One :class:`DarcyanGrid` per vertex.
    """
    distances = {} if distances is None else distances
    local = solver if isinstance(solver, LocalGeodesicSolver) else LocalGeodesicSolver(solver, np.inf)
    normals = vertex_normals(mesh) if normals is None else normals
    radii = np.asarray(config.level_radii)
    q = config.interpolation
    angles = 2 * np.pi * np.arange(config.radial_lines * q) / (config.radial_lines * q)
    grids = []
    for v in vertices:
        v = int(v)
        if v not in distances:
            distances[v] = local.distance(v)
        field = toward if toward is not None else local.solver.distance(int(np.argmax(distances[v])))
        ball = local.ball(v)
        grids.append(_grid(ball, distances[v][ball.vertices], field[ball.vertices], normals[v], radii, angles, q,
                           config.margins.trace))
    return grids


def _grid(ball: GeodesicBall, distance: np.ndarray, toward: np.ndarray, normal: np.ndarray,
          radii: np.ndarray, angles: np.ndarray, q: int, trace: float) -> DarcyanGrid:
    """One grid, built on ``ball`` (its fields ``distance`` and ``toward`` given on the ball's
    vertices); faces are reported in the whole mesh's numbering."""
    c, solver = ball.centre, ball.solver
    ref = reference_direction(ball.mesh, c, toward, normal)
    side = np.cross(normal, ref)
    paths = [solver.trace(c, np.cos(a) * ref + np.sin(a) * side, trace * radii[-1]) for a in angles]
    # Locate every traced point at once, read U there, and cut each line at the level radii.
    offsets = np.concatenate([[0], np.cumsum([len(p) for p in paths])])
    faces, bary = solver.locate(np.concatenate(paths))
    crossing = np.empty((len(angles), len(radii), 3))
    for p, path in enumerate(paths):
        sl = slice(offsets[p], offsets[p + 1])
        u = interpolate(ball.mesh, distance, faces[sl], bary[sl])
        u[0] = 0.0
        crossing[p] = _level_crossings(path, u, radii)
    valid = np.isfinite(crossing[..., 0])
    f_all = np.full(valid.shape, -1, dtype=np.int64)
    b_all = np.full(valid.shape + (3,), np.nan)
    if valid.any():
        f_ok, b_ok = solver.locate(crossing[valid])
        f_all[valid], b_all[valid] = ball.faces[f_ok], b_ok
    return DarcyanGrid(
        centre=int(ball.vertices[c]), radii=radii, angles=angles,
        points=crossing.transpose(1, 0, 2), faces=f_all.T, barycentric=b_all.transpose(1, 0, 2),
        valid=valid.T, reference=ref, interpolation=q, radial_paths=tuple(paths))


def grid_reach(config: DarcyanConfig) -> float:
    """Geodesic radius (mesh units) around its centre that a grid's construction looks at."""
    return config.margins.trace * config.level_radii[-1]


def darcyan_grid(mesh: Mesh, solver: GeodesicSolver, vertex: int, config: DarcyanConfig,
                 distance: np.ndarray | None = None, toward: np.ndarray | None = None) -> DarcyanGrid:
    """The Darcyan coordinate system around one vertex (see :func:`darcyan_grids`)."""
    cache = {int(vertex): distance} if distance is not None else None
    return darcyan_grids(mesh, solver, [vertex], config, cache, toward)[0]


def _level_crossings(path: np.ndarray, u: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """``(n, 3)``: where ``u`` along the polyline first reaches each radius (NaN if never)."""
    out = np.full((len(radii), 3), np.nan)
    if len(path) < 2:
        return out
    running = np.maximum.accumulate(u)  # first crossing of each level even if U wobbles
    idx = np.searchsorted(running, radii, side="left")
    ok = (idx > 0) & (idx < len(u))
    j = idx[ok]
    u0, u1 = running[j - 1], running[j]
    t = np.where(u1 > u0, (radii[ok] - u0) / np.where(u1 > u0, u1 - u0, 1.0), 0.0)
    out[ok] = path[j - 1] + t[:, None] * (path[j] - path[j - 1])
    return out

