"""Pictures of the method: a Darcyan grid on a surface, and matched feature points of two shapes.

Two steps, so the PNG pictures here and the interactive viewer (:mod:`darcyan.viz.html`) show the
same thing:

* a *scene* holds what is drawn, computed on the full mesh with the method's own code:
  :func:`grid_scene` (the prepared, area-1 mesh, one grid, its level curves, radial lines and
  the curvature at its intersection points) and :func:`match_scene` (two meshes, the matched
  points, their descriptor distances and, given ground truth, which matches are wrong);
* :func:`render_grid` and :func:`render_matches` draw a scene to a PNG with matplotlib's Agg
  canvas (no display needed; ``pip install 'darcyan[plot]'``).

Surfaces are drawn by an orthographic camera with the painter's algorithm: front-facing
triangles sorted far to near, Gouraud-shaded under a head light. Lines and points drawn over
the surface are depth-tested against a coarse depth map of it, so what lies behind the shape is
not drawn over it (hidden matched points are drawn hollow). Large meshes are decimated *for
display only* by vertex clustering, each cluster drawn at one of its own vertices: every
computation uses the full mesh.

Level curves are the iso-lines ``U = lambda_k`` of the fast-marching distance U from the centre
(marching triangles on the piecewise-linear U, the same U the grid's intersection points are
cut from); radial lines are the grid's traced geodesics, cut where U reaches R.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import DarcyanConfig
from ..errors import DarcyanError, MeshError, require
from ..eval.metrics import DEFAULT_THRESHOLD, GroundTruth, MatchScore, score_matches
from ..geometry.geodesics import GeodesicSolver, interpolate, vertex_normals
from ..geometry.mesh import Mesh
from ..geometry.shape import Shape, prepare_shape
from ..io.mesh_files import load_mesh
from ..method.grid import DarcyanGrid

CURVATURES = ("kmax", "kmin")

# --- camera and shading
UP_HINT = np.array([0.0, 0.0, 1.0])  # world axis drawn upwards when the view allows it
UP_FALLBACK = np.array([0.0, 1.0, 0.0])
UP_MIN_SINE = 0.3  # below this |sin(angle)| between the view and UP_HINT, use UP_FALLBACK
AMBIENT = 0.32  # share of light every visible triangle gets
DIFFUSE = 0.68  # share from the head light (Lambert)
SURFACE_GREY = (0.25, 0.93)  # darkest and lightest grey of the shaded surface

# --- display decimation (never used for computation)
FACE_BUDGET = 60_000  # front-facing triangles drawn per panel before clustering vertices
CLUSTER_PIXELS = 1.5  # side of a clustering cell, in output pixels
DEPTH_CELLS = 200  # picture-plane buckets (per side) of the triangles tested for hiding overlays
DEPTH_TOLERANCE = 0.25  # an overlay is hidden when a triangle lies nearer by more than this many median edges

# --- the grid picture
FACING_SHARE = 0.35  # the grid picture looks along the mean normal within this share of R
GRID_WINDOW_MARGIN = 1.3  # half-width of the zoomed view over the grid's projected half-extent
GRID_SIZE = (7.6, 6.4)  # inches
GRID_DPI = 150
GRID_CMAP = "RdBu_r"  # diverging, centred on zero curvature
MAIN_POINT_AREA = 34.0  # marker areas (points^2) of the m main and the interpolated intersections
FINE_POINT_AREA = 15.0
LEVEL_COLOUR = "#111111"
RADIAL_COLOUR = "#4D4D4D"

# --- the match picture
MATCH_SIZE = (10.0, 6.2)  # inches
MATCH_DPI = 150
MATCH_MARKER_AREA = 110.0
WRONG_MARKER = "s"  # wrong matches: squares (the right ones are discs)
RIGHT_MARKER = "o"
TRUTH_MARKER_AREA = 260.0  # a ring around the true point, wider than a marker
# Extra colours beyond darcyan.viz.style.PALETTE (black excluded: it draws edges and text).
EXTRA_MATCH_COLOURS = ("#7B3294", "#1B7837", "#B2182B", "#2166AC", "#8C510A", "#01665E",
                       "#C51B7D", "#4D9221", "#E08214", "#542788")


def match_colours(k: int) -> list[str]:
    """``k`` hex colours for k matched pairs: darcyan's palette (without black), then
    :data:`EXTRA_MATCH_COLOURS`; they repeat beyond that (the numbers still tell pairs apart)."""
    from .style import PALETTE

    base = [c for c in PALETTE if c.lower() != "#000000"] + list(EXTRA_MATCH_COLOURS)
    return [base[i % len(base)] for i in range(k)]


# ---------------------------------------------------------------------------------------------
# Geometry for display


@dataclass(frozen=True)
class Camera:
    """An orthographic camera: ``forward`` (3,) unit vector from the eye into the scene; ``up`` and
    ``right`` (3,) span the picture plane. Picture x = p . right, y = p . up; depth = -p . forward
    (larger is nearer the viewer)."""

    forward: np.ndarray
    up: np.ndarray
    right: np.ndarray

    @classmethod
    def looking_along(cls, forward, up_hint=UP_HINT) -> "Camera":
        f = np.asarray(forward, dtype=np.float64)
        f = f / np.linalg.norm(f)
        hint = np.asarray(up_hint, dtype=np.float64)
        if np.linalg.norm(np.cross(f, hint)) < UP_MIN_SINE * np.linalg.norm(hint):
            hint = UP_FALLBACK if np.linalg.norm(np.cross(f, UP_FALLBACK)) >= UP_MIN_SINE else np.array([1.0, 0, 0])
        up = hint - f * np.dot(hint, f)
        up /= np.linalg.norm(up)
        return cls(f, up, np.cross(f, up))

    def project(self, points: np.ndarray) -> np.ndarray:
        """``(..., 3)`` points -> ``(..., 3)`` picture x, y and depth."""
        p = np.asarray(points, dtype=np.float64)
        return np.stack([p @ self.right, p @ self.up, -(p @ self.forward)], axis=-1)


def facing_camera(mesh: Mesh, vertex: int, distance: np.ndarray, radius: float) -> Camera:
    """A camera looking straight at ``vertex``: along minus the area-weighted mean normal of the
    faces within geodesic ``radius`` (``distance (V,)`` from the vertex)."""
    v, f = mesh.vertices, mesh.faces
    near = f[(distance[f] <= radius).all(axis=1)]
    if len(near):
        n = np.cross(v[near[:, 1]] - v[near[:, 0]], v[near[:, 2]] - v[near[:, 0]]).sum(axis=0)
    else:
        n = vertex_normals(mesh)[vertex]
    if np.linalg.norm(n) < 1e-12:
        n = np.array([0.0, -1.0, 0.0])
    return Camera.looking_along(-n)


def principal_axes(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(centred (n, 3), axes (3, 3))``: the vertices about their mean, and the mesh's principal
    axes as rows, widest first (from at most about 20,000 vertices)."""
    centred = mesh.vertices - mesh.vertices.mean(axis=0)
    _, _, axes = np.linalg.svd(centred[:: max(1, len(centred) // 20000)], full_matrices=False)
    return centred, axes


def overview_camera(mesh: Mesh, points: np.ndarray | None = None) -> Camera:
    """A camera along the shape's thinnest principal axis (its widest silhouette), from the side
    where most of ``points`` (vertex indices, e.g. matched points) face the viewer."""
    forward = principal_axes(mesh)[1][2]
    if points is not None and len(points):
        facing = (vertex_normals(mesh)[np.asarray(points)] @ forward < 0).sum()
        if facing < len(points) - facing:
            forward = -forward
    return Camera.looking_along(forward)


def level_segments(mesh: Mesh, field: np.ndarray, level: float) -> np.ndarray:
    """``(s, 2, 3)`` segments of the iso-line ``field = level`` of a piecewise-linear ``field (V,)``
    (marching triangles: one segment per triangle the level crosses)."""
    f = mesh.faces
    u = field[f]  # (m, 3)
    above = u > level
    count = above.sum(axis=1)
    crossed = (count == 1) | (count == 2)
    f, u, above = f[crossed], u[crossed], above[crossed]
    # The corner alone on its side of the level: the two crossed edges are the ones leaving it.
    lonely = np.where(above.sum(axis=1) == 1, np.argmax(above, axis=1), np.argmin(above, axis=1))
    rows = np.arange(len(f))
    ends = []
    for step in (1, 2):
        other = (lonely + step) % 3
        ua, ub = u[rows, lonely], u[rows, other]
        t = (level - ua) / np.where(ub != ua, ub - ua, 1.0)
        pa, pb = mesh.vertices[f[rows, lonely]], mesh.vertices[f[rows, other]]
        ends.append(pa + t[:, None] * (pb - pa))
    return np.stack(ends, axis=1)


def cut_radial_line(mesh: Mesh, solver: GeodesicSolver, distance: np.ndarray, path: np.ndarray,
                    radius: float) -> np.ndarray:
    """The part of a traced radial geodesic ``path (k, 3)`` where the distance field U (V,) from
    its centre has not yet reached ``radius``: ``(j, 3)``, ending on the level curve U = radius
    (as :mod:`darcyan.method.grid` cuts it)."""
    if len(path) < 2:
        return path
    faces, bary = solver.locate(path)
    u = interpolate(mesh, distance, faces, bary)
    u[0] = 0.0
    running = np.maximum.accumulate(u)
    j = int(np.searchsorted(running, radius, side="left"))
    if j >= len(path):
        return path
    u0, u1 = running[j - 1], running[j]
    t = (radius - u0) / (u1 - u0) if u1 > u0 else 0.0
    return np.vstack([path[:j], path[j - 1] + t * (path[j] - path[j - 1])])


def cluster_faces(vertices: np.ndarray, faces: np.ndarray, cell: float) -> np.ndarray:
    """Display decimation: ``faces (m, 3)`` re-indexed onto one representative vertex (one of its
    own) per cubic cell of side ``cell``; triangles that collapse are dropped. Returns the new
    ``(m', 3)`` faces, indices of ``vertices``."""
    used = np.unique(faces)
    keys = np.floor(vertices[used] / cell).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    representative = np.full(len(vertices), -1, dtype=np.int64)
    representative[used] = used[first][inverse.reshape(-1)]
    out = representative[faces]
    keep = (out[:, 0] != out[:, 1]) & (out[:, 1] != out[:, 2]) & (out[:, 0] != out[:, 2])
    out = out[keep]
    _, unique_rows = np.unique(np.sort(out, axis=1), axis=0, return_index=True)
    return out[np.sort(unique_rows)]


# ---------------------------------------------------------------------------------------------
# Scenes


@dataclass
class GridScene:
    """One Darcyan grid ready to draw (all lengths in sqrt(area) units of the prepared mesh).

    Attributes:
        mesh: the prepared, normalized (area 1) mesh; ``mesh.input_index`` maps to the file.
        name: the shape's name (file).
        grid: the grid (see :class:`darcyan.method.grid.DarcyanGrid`).
        centre_input: the centre as a vertex index of the input file.
        feature: which feature point (row of ``darcyan features``) the centre is, or ``None``.
        curvature: ``"kmax"`` or ``"kmin"``, the curvature the points are coloured by.
        kmax, kmin: ``(V,)`` principal curvatures (1/sqrt(area)).
        point_values: ``(n, m*q)`` the chosen curvature at the intersection points (NaN: missing).
        distance: ``(V,)`` fast-marching distance from the centre.
        level_curves: n arrays ``(s, 2, 3)`` of segments, level curve k at ``grid.radii[k]``.
        radial_lines: m*q polylines ``(j, 3)`` from the centre to the outer level curve.
        config: the parameters used.
        camera: a camera facing the centre.
    """

    mesh: Mesh
    name: str
    grid: DarcyanGrid
    centre_input: int
    feature: int | None
    curvature: str
    kmax: np.ndarray
    kmin: np.ndarray
    point_values: np.ndarray
    distance: np.ndarray
    level_curves: list
    radial_lines: list
    config: DarcyanConfig
    camera: Camera

    @property
    def vertex_values(self) -> np.ndarray:
        return self.kmax if self.curvature == "kmax" else self.kmin


def _load(source) -> tuple[Mesh, str]:
    if isinstance(source, Mesh):
        return source, source.name
    return load_mesh(source), str(source)


def _mesh_index(shape: Shape, input_vertex: int) -> int:
    """The prepared mesh's index of input vertex ``input_vertex`` (refused if it was left out)."""
    index = int(shape.mesh_index([input_vertex])[0])
    if index < 0:
        raise MeshError(shape.name, f"vertex {input_vertex} is not on the prepared mesh (it belongs to a part "
                                    f"that was left out)")
    return index


def grid_scene(source: str | os.PathLike | Mesh, vertex: int | None = None, feature: int | None = None,
               config: DarcyanConfig = DarcyanConfig(), curvature: str = "kmax", repair: bool = False,
               progress=None) -> GridScene:
    """The Darcyan grid around a vertex or a feature point of a mesh, ready to draw.

    Args:
        source: a mesh file or :class:`Mesh`.
        vertex: centre as a vertex index of the input (0-based). Angle 0 then points toward the
            vertex farthest from it (the descriptor does not depend on it).
        feature: centre = feature point number ``feature`` (0-based, in the order of ``darcyan
            features``), with the grid exactly as the descriptor uses it. Default: feature 0
            when ``vertex`` is not given.
        config: the method's parameters (levels, radial lines, radius, interpolation...).
        curvature: ``"kmax"`` or ``"kmin"``.
        repair: as for :func:`darcyan.prepare_mesh`.
    """
    from ..method.grid import darcyan_grid
    from ..method.pipeline import analyze_mesh

    if curvature not in CURVATURES:
        raise DarcyanError(f"curvature must be one of {CURVATURES}, got {curvature!r}")
    if vertex is not None and feature is not None:
        raise DarcyanError("give a vertex or a feature point, not both")
    mesh, name = _load(source)
    if vertex is None:
        feature = 0 if feature is None else int(feature)
        analysis = analyze_mesh(mesh, config, repair, progress)
        if not 0 <= feature < len(analysis):
            raise MeshError(name, f"feature point {feature} out of range: the shape has {len(analysis)} "
                                  f"(0..{len(analysis) - 1})")
        normalized, solver, curv = analysis.mesh, analysis.solver, analysis.curvatures
        grid = analysis.grids[feature]
        centre_input = int(analysis.feature_vertices[feature])
    else:
        shape = prepare_shape(mesh, config, repair)
        normalized, solver = shape.mesh, shape.solver
        centre = _mesh_index(shape, int(vertex))
        curv = shape.curvatures(config.curvature_smoothing)
        grid = darcyan_grid(normalized, solver, centre, config)
        centre_input = int(vertex)
    distance = solver.distance(grid.centre)
    values = curv.kmax if curvature == "kmax" else curv.kmin
    levels = [level_segments(normalized, distance, r) for r in grid.radii]
    radial = [cut_radial_line(normalized, solver, distance, p, grid.radii[-1]) for p in grid.radial_paths]
    return GridScene(
        mesh=normalized, name=name, grid=grid, centre_input=centre_input, feature=feature,
        curvature=curvature, kmax=curv.kmax, kmin=curv.kmin, point_values=grid.sample(normalized, values),
        distance=distance, level_curves=levels, radial_lines=radial, config=config,
        camera=facing_camera(normalized, grid.centre, distance, FACING_SHARE * grid.radii[-1]))


@dataclass
class ShapeView:
    """One shape of a match scene: the prepared, normalized (area 1) ``mesh``, its ``name``,
    ``points (k,)`` the matched points as indices of ``mesh``, and ``kmax``/``kmin`` ``(V,)``;
    ``input_vertices``: the file's vertex count (the prepared mesh may have more, where a
    non-manifold vertex was split, or fewer), which titles quote."""

    mesh: Mesh
    name: str
    points: np.ndarray
    kmax: np.ndarray
    kmin: np.ndarray
    input_vertices: int | None = None


@dataclass
class MatchScene:
    """Matched feature points of two shapes, ready to draw.

    Attributes:
        source, target: the two shapes; ``source.points[i]`` is matched to ``target.points[i]``.
        source_vertex, target_vertex: ``(k,)`` the same in the input files' numbering.
        distance: ``(k,)`` descriptor distances.
        errors: ``(k,)`` geodesic error / sqrt(area) of each match on the target, or ``None``
            without ground truth (NaN where the truth is unknown).
        truth_points: ``(k,)`` true correspondents (indices of ``target.mesh``), or ``None``.
        threshold: a match is wrong when its error exceeds this.
        camera: a camera showing both shapes from the same direction.
    """

    source: ShapeView
    target: ShapeView
    source_vertex: np.ndarray
    target_vertex: np.ndarray
    distance: np.ndarray
    errors: np.ndarray | None
    truth_points: np.ndarray | None
    threshold: float
    camera: Camera

    def __len__(self) -> int:
        return len(self.distance)

    @property
    def wrong(self) -> np.ndarray | None:
        """``(k,)`` bool: error above the threshold (``None`` without ground truth)."""
        if self.errors is None:
            return None
        return np.nan_to_num(self.errors, nan=0.0) > self.threshold


def match_scene(source, target, correspondence, truth: GroundTruth | None = None,
                config: DarcyanConfig = DarcyanConfig(), repair: bool = False,
                threshold: float = DEFAULT_THRESHOLD, score: MatchScore | None = None) -> MatchScene:
    """Matched points of ``correspondence`` (a :class:`darcyan.Correspondence`, vertices in the
    files' numbering) on ``source`` and ``target`` (prepared :class:`~darcyan.geometry.shape.Shape`
    s, files or :class:`Mesh`), with the errors of ``score`` (from
    :func:`darcyan.eval.metrics.score_matches`), or scored against ``truth`` by it."""
    views, shapes = [], []
    for given, vertices in ((source, correspondence.source_vertex), (target, correspondence.target_vertex)):
        shape = given if isinstance(given, Shape) else prepare_shape(_load(given)[0], config, repair)
        points = np.array([_mesh_index(shape, int(v)) for v in vertices], dtype=np.int64)
        curv = shape.curvatures(config.curvature_smoothing)
        views.append(ShapeView(shape.mesh, shape.name, points, curv.kmax, curv.kmin, shape.n_input_vertices))
        shapes.append(shape)
    if score is None and truth is not None:
        score = score_matches(shapes[0], shapes[1], correspondence, truth, threshold)
    errors = None if score is None else score.errors
    truth_points = None if score is None else score.true_points
    return MatchScene(views[0], views[1], np.asarray(correspondence.source_vertex),
                      np.asarray(correspondence.target_vertex), np.asarray(correspondence.distance, dtype=float),
                      errors, truth_points, threshold, overview_camera(views[0].mesh, views[0].points))


@dataclass
class DenseScene:
    """A dense map ready to draw: texture transfer, and its errors given ground truth.

    Attributes:
        source, target: the prepared, area-1 meshes; ``source_name``, ``target_name``.
        source_colours: ``(n1, 3)`` RGB in [0, 1], a smooth function of position on the source
            (its coordinates along its principal axes, each scaled to [0, 1]).
        target_colours: ``(n2, 3)`` the source's colours carried through the map: each target
            vertex takes the colour of the source vertex whose image lies nearest to it (a seam
            or a flip shows as a jump of colour).
        sample_vertices: ``(s,)`` source vertices (indices of ``source``) scored against ground
            truth, ``sample_errors (s,)`` their geodesic errors (sqrt(area)); ``None`` without.
        threshold: a vertex is mapped right within this error.
        check: the map's own check (:class:`darcyan.dense.maps.MapCheck`), or ``None``.
        source_camera, target_camera: one camera per shape (their poses differ).
    """

    source: Mesh
    target: Mesh
    source_name: str
    target_name: str
    source_colours: np.ndarray
    target_colours: np.ndarray
    sample_vertices: np.ndarray | None
    sample_errors: np.ndarray | None
    threshold: float
    check: object
    source_camera: Camera
    target_camera: Camera


def position_colours(mesh: Mesh) -> np.ndarray:
    """``(n, 3)`` RGB in [0, 1]: the vertices' coordinates along the mesh's principal axes (widest
    first), each scaled to [0, 1]; a smooth colouring whose every colour sits in one place."""
    centred, axes = principal_axes(mesh)
    coordinates = centred @ axes.T
    low, high = coordinates.min(axis=0), coordinates.max(axis=0)
    return 0.1 + 0.85 * (coordinates - low) / np.maximum(high - low, 1e-12)


def dense_scene(source: Shape, target: Shape, dense, truth: GroundTruth | None = None,
                threshold: float = DEFAULT_THRESHOLD, scored=None) -> DenseScene:
    """The :class:`DenseScene` of ``dense`` (a :class:`darcyan.dense.maps.DenseMap`, input
    numbering) between prepared shapes ``source`` and ``target``; with ``truth``, scored on the
    sample of :func:`darcyan.eval.dense_scores.evaluate_dense`."""
    from ..dense.maps import UNMAPPED
    from ..eval.dense_scores import evaluate_dense
    from ..geometry.knn import nearest_rows

    mesh_1, mesh_2 = source.mesh, target.mesh
    images = target.mesh_index(np.maximum(dense.target[mesh_1.input_index], 0))
    mapped = (dense.target[mesh_1.input_index] != UNMAPPED) & (images >= 0)
    colours_1 = position_colours(mesh_1)
    colours_2 = np.full((mesh_2.n_vertices, 3), 0.6)
    if mapped.any():
        pulled = nearest_rows(mesh_2.vertices[images[mapped]], mesh_2.vertices)  # target -> nearest image
        colours_2 = colours_1[np.flatnonzero(mapped)[pulled]]
    samples = errors = None
    if truth is not None:
        if scored is None:  # the scores already made of this map (``scored``) are not made again
            scored = evaluate_dense(mesh_1, mesh_2, dense.target, truth, target_solver=target.solver,
                                    threshold=threshold)
        samples, errors = source.mesh_index(scored.source_vertices), scored.errors
    return DenseScene(mesh_1, mesh_2, source.name, target.name, colours_1, colours_2, samples, errors, threshold,
                      getattr(dense, "check", None), overview_camera(mesh_1), overview_camera(mesh_2))


# ---------------------------------------------------------------------------------------------
# Drawing


@dataclass(frozen=True)
class Picture:
    """A written picture: ``path``, ``seconds`` spent drawing and writing it, and ``panels``:
    name -> ``(left, top, right, bottom)`` pixel box of each shape panel in the PNG (rows from the
    top), e.g. to look at the pixels of one panel."""

    path: Path
    seconds: float
    panels: dict


class _Surface:
    """The front-facing part of a mesh drawn in one panel, and its depth map."""

    def __init__(self, mesh: Mesh, camera: Camera, window: tuple, pixels: float, normals: np.ndarray | None = None):
        self.camera = camera
        self.window = window  # (x0, x1, y0, y1) in picture units
        self.xyz = camera.project(mesh.vertices)
        normals = vertex_normals(mesh) if normals is None else normals
        v, f = mesh.vertices, mesh.faces
        face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        front = face_n @ camera.forward < 0
        x0, x1, y0, y1 = window
        x, y = self.xyz[:, 0], self.xyz[:, 1]
        inside = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        faces = f[front & inside[f].any(axis=1)]
        self.edge = float(np.median(np.linalg.norm(v[f[:, 1]] - v[f[:, 0]], axis=1))) if len(f) else 1.0
        self._depth_map(faces)
        self.faces_total = len(faces)
        if len(faces) > FACE_BUDGET:
            faces = cluster_faces(v, faces, CLUSTER_PIXELS * (x1 - x0) / pixels)
        depth = self.xyz[faces, 2].mean(axis=1)
        self.faces = faces[np.argsort(depth)]  # far to near: the painter's order
        light = np.clip(-(normals @ camera.forward), 0.0, 1.0)
        self.intensity = AMBIENT + DIFFUSE * light

    def _depth_map(self, faces: np.ndarray) -> None:
        """Bucket the front-facing triangles (full resolution) by the cells their picture-plane
        bounding boxes overlap, for :meth:`visible`."""
        x0, x1, y0, y1 = self.window
        self.cell = max((x1 - x0), (y1 - y0)) / DEPTH_CELLS
        self.shape = (int(np.ceil((x1 - x0) / self.cell)) + 1, int(np.ceil((y1 - y0) / self.cell)) + 1)
        self.occluders = faces
        corners = self.xyz[faces]  # (m, 3 corners, xyz)
        lo = self._cell_index(corners[:, :, :2].min(axis=1))
        hi = self._cell_index(corners[:, :, :2].max(axis=1))
        span = hi - lo + 1
        counts = span[:, 0] * span[:, 1]
        owner = np.repeat(np.arange(len(faces)), counts)
        offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        ci = lo[owner, 0] + offset % span[owner, 0]
        cj = lo[owner, 1] + offset // span[owner, 0]
        key = ci * self.shape[1] + cj
        order = np.argsort(key, kind="stable")
        self._bucket_faces = owner[order]
        self._bucket_start = np.searchsorted(key[order], np.arange(self.shape[0] * self.shape[1] + 1))

    def _cell_index(self, xy: np.ndarray) -> np.ndarray:
        x0, _, y0, _ = self.window
        ij = np.floor((xy - np.array([x0, y0])) / self.cell).astype(np.int64)
        return np.clip(ij, 0, np.array(self.shape) - 1)

    def visible(self, points: np.ndarray) -> np.ndarray:
        """``(k,)`` bool: no front-facing triangle lies in front of ``points (k, 3)`` (world)
        along the viewing direction (an orthographic ray test, exact up to a small fraction of
        an edge)."""
        xyz = self.camera.project(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        out = np.ones(len(xyz), dtype=bool)
        if len(xyz) == 0 or len(self.occluders) == 0:
            return out
        ij = self._cell_index(xyz[:, :2])
        key = ij[:, 0] * self.shape[1] + ij[:, 1]
        start, stop = self._bucket_start[key], self._bucket_start[key + 1]
        counts = stop - start
        query = np.repeat(np.arange(len(xyz)), counts)
        if len(query) == 0:
            return out
        pos = np.repeat(start - np.cumsum(counts) + counts, counts) + np.arange(len(query))
        tri = self.xyz[self.occluders[self._bucket_faces[pos]]]  # (pairs, 3, 3)
        p = xyz[query]
        a, b, c = tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2]
        v0, v1, v2 = b - a, c - a, p[:, :2] - a
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        ok = np.abs(den) > 1e-300
        den = np.where(ok, den, 1.0)
        w1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        w2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        w0 = 1 - w1 - w2
        inside = ok & (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        depth = w0 * tri[:, 0, 2] + w1 * tri[:, 1, 2] + w2 * tri[:, 2, 2]
        covered = inside & (depth > p[:, 2] + DEPTH_TOLERANCE * self.edge)
        out[np.unique(query[covered])] = False
        return out

    def draw_coloured(self, ax, colours: np.ndarray) -> None:
        """Draw the surface with ``colours (n, 3)`` RGB per vertex, shaded by the head light
        (flat per triangle, painter's order)."""
        from matplotlib.collections import PolyCollection

        faces = self.faces
        if len(faces):
            shade = self.intensity[faces].mean(axis=1)
            rgb = np.clip(np.asarray(colours)[faces].mean(axis=1) * shade[:, None], 0.0, 1.0)
            ax.add_collection(PolyCollection(self.xyz[faces][:, :, :2], facecolors=rgb, edgecolors=rgb,
                                             linewidths=0.2, rasterized=True, zorder=1))
        self._frame(ax)

    def _frame(self, ax) -> None:
        x0, x1, y0, y1 = self.window
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xticks([])
        ax.set_yticks([])

    def draw(self, ax) -> None:
        from matplotlib.colors import LinearSegmentedColormap
        from matplotlib.tri import Triangulation

        grey = LinearSegmentedColormap.from_list("darcyan-surface", [(SURFACE_GREY[0],) * 3, (SURFACE_GREY[1],) * 3])
        if len(self.faces):
            tri = Triangulation(self.xyz[:, 0], self.xyz[:, 1], self.faces)
            ax.tripcolor(tri, self.intensity, shading="gouraud", cmap=grey, vmin=0.0, vmax=1.0,
                         rasterized=True, zorder=1)
        self._frame(ax)


def _window(xy: np.ndarray, margin: float, aspect: float = 1.0) -> tuple:
    """``(x0, x1, y0, y1)`` around ``xy (k, 2)`` with relative ``margin``, of width/height ``aspect``."""
    lo, hi = np.nanmin(xy, axis=0), np.nanmax(xy, axis=0)
    centre = (lo + hi) / 2
    half = (hi - lo) / 2 * margin
    half = np.maximum(half, 1e-9)
    if half[0] / half[1] < aspect:
        half[0] = half[1] * aspect
    else:
        half[1] = half[0] / aspect
    return (centre[0] - half[0], centre[0] + half[0], centre[1] - half[1], centre[1] + half[1])


def _figure(size, dpi):
    require("matplotlib", "plot")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=dpi)
    FigureCanvasAgg(fig)  # Agg: files only, no display
    return fig


def _panel_boxes(fig, axes: dict) -> dict:
    fig.canvas.draw()
    height = fig.bbox.height
    boxes = {}
    for name, ax in axes.items():
        b = ax.get_window_extent()
        boxes[name] = (int(np.floor(b.x0)), int(np.floor(height - b.y1)), int(np.ceil(b.x1)), int(np.ceil(height - b.y0)))
    return boxes


def _save(fig, path) -> Path:
    path = Path(path)
    try:
        fig.savefig(path, dpi=fig.dpi, facecolor="white")
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot write ({exc.strerror or exc})") from None
    except ValueError as exc:  # unknown image format
        raise DarcyanError(f"{path}: cannot write ({exc})") from None
    return path


def _segments_2d(surface: _Surface, segments: np.ndarray) -> np.ndarray:
    """Visible ``(s, 2, 3)`` world segments as ``(s', 2, 2)`` picture segments."""
    if len(segments) == 0:
        return np.zeros((0, 2, 2))
    keep = surface.visible(segments.mean(axis=1))
    return surface.camera.project(segments[keep])[..., :2]


def _polyline_segments(path: np.ndarray) -> np.ndarray:
    return np.stack([path[:-1], path[1:]], axis=1) if len(path) > 1 else np.zeros((0, 2, 3))


def render_grid(scene: GridScene, path: str | os.PathLike, title: str | None = None) -> Picture:
    """Draw a :class:`GridScene` to a PNG: the surface around the centre seen from in front, the
    n level curves (black), the m radial lines (grey; the interpolated ones dotted, angle 0
    thick), the intersection points coloured by curvature with a colour bar, and a small
    overview of the whole shape."""
    start = time.perf_counter()
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize

    fig = _figure(GRID_SIZE, GRID_DPI)
    grid, camera, mesh = scene.grid, scene.camera, scene.mesh
    ax = fig.add_axes((0.02, 0.03, 0.78, 0.86))
    cax = fig.add_axes((0.86, 0.12, 0.03, 0.68))
    centre_xyz = mesh.vertices[grid.centre]
    points = grid.points[grid.valid]
    xy = camera.project(np.vstack([points, centre_xyz[None]]))[:, :2] if len(points) else \
        camera.project(centre_xyz[None])[:, :2] + np.array([[-1, -1], [1, 1]]) * grid.radii[-1]
    c = camera.project(centre_xyz)[:2]
    ratio = 0.78 * GRID_SIZE[0] / (0.86 * GRID_SIZE[1])
    window = _window(xy, GRID_WINDOW_MARGIN, ratio)
    pixels = 0.78 * GRID_SIZE[0] * GRID_DPI
    surface = _Surface(mesh, camera, window, pixels)
    surface.draw(ax)

    level_segs = [_segments_2d(surface, s) for s in scene.level_curves]
    ax.add_collection(LineCollection([s for segs in level_segs for s in segs], colors=LEVEL_COLOUR,
                                     linewidths=1.1, zorder=3))
    q = grid.interpolation
    for col, line in enumerate(scene.radial_lines):
        segs = _segments_2d(surface, _polyline_segments(line))
        main = col % q == 0
        style = dict(colors=RADIAL_COLOUR, linewidths=0.6, linestyles=":") if not main else \
            dict(colors=LEVEL_COLOUR if col == 0 else RADIAL_COLOUR, linewidths=2.2 if col == 0 else 1.0)
        ax.add_collection(LineCollection(list(segs), zorder=3, **style))

    values = scene.point_values
    finite = values[np.isfinite(values)]
    limit = float(np.abs(finite).max()) if len(finite) else 1.0
    norm = Normalize(-limit, limit)
    hidden = 0
    for main in (False, True):
        cols = (np.arange(values.shape[1]) % q == 0) == main
        sel = grid.valid & cols[None, :]
        pts, vals = grid.points[sel], values[sel]
        seen = surface.visible(pts) if len(pts) else np.zeros(0, bool)
        hidden += int((~seen).sum())
        p2 = camera.project(pts[seen])
        ax.scatter(p2[:, 0], p2[:, 1], c=vals[seen], cmap=GRID_CMAP, norm=norm,
                   s=MAIN_POINT_AREA if main else FINE_POINT_AREA, edgecolors="black", linewidths=0.4, zorder=5)
    ax.scatter([c[0]], [c[1]], marker="+", s=120, c="black", linewidths=1.6, zorder=6)
    unit = "1/\u221aarea"
    fig.colorbar(ScalarMappable(norm=norm, cmap=GRID_CMAP), cax=cax,
                 label=f"{scene.curvature} at the intersection points ({unit})")

    # Overview of the whole shape, same direction, the grid's place ringed.
    inset = fig.add_axes((0.03, 0.66, 0.2, 0.22))
    all_xy = camera.project(mesh.vertices)[:, :2]
    over = _Surface(mesh, camera, _window(all_xy, 1.05), 0.2 * GRID_SIZE[0] * GRID_DPI)
    over.draw(inset)
    inset.scatter([c[0]], [c[1]], s=160, facecolors="none", edgecolors="#D55E00", linewidths=2.0, zorder=5)
    for spine in inset.spines.values():
        spine.set_edgecolor("#7F7F7F")

    cfg = scene.config
    where = f"feature {scene.feature} (vertex {scene.centre_input})" if scene.feature is not None \
        else f"vertex {scene.centre_input}"
    fig.suptitle(title or f"Darcyan grid at {where} of {Path(scene.name).name}", fontsize=11, y=0.975)
    fig.text(0.5, 0.905, f"n = {len(grid.radii)} level curves (black) up to R = {grid.radii[-1]:.3g} \u221aarea, "
                         f"m = {cfg.radial_lines} radial lines (grey; thick: angle 0; dotted: interpolated, "
                         f"x{q})\n{int(grid.valid.sum())} intersection points"
                         + (f", {hidden} of them hidden behind the surface" if hidden else ""),
             ha="center", fontsize=8, color="#333333", linespacing=1.4)
    boxes = _panel_boxes(fig, {"grid": ax, "overview": inset})
    out = _save(fig, path)
    return Picture(out, time.perf_counter() - start, boxes)


def render_matches(scene: MatchScene, path: str | os.PathLike, title: str | None = None) -> Picture:
    """Draw a :class:`MatchScene` to a PNG: both shapes side by side from one direction, matched
    pair i as a numbered marker of colour i on both (hollow when on the far side), the descriptor
    distances in the legend; with ground truth, wrong matches are squares marked with a cross,
    their true correspondent a black ring."""
    start = time.perf_counter()
    import matplotlib.patheffects as effects
    from matplotlib.lines import Line2D

    fig = _figure(MATCH_SIZE, MATCH_DPI)
    k = len(scene)
    colours = match_colours(k)
    wrong = scene.wrong
    panel_w, panel_h = 0.48, 0.62
    axes = {"source": fig.add_axes((0.01, 0.29, panel_w, panel_h)),
            "target": fig.add_axes((0.51, 0.29, panel_w, panel_h))}
    pixels = panel_w * MATCH_SIZE[0] * MATCH_DPI
    aspect = panel_w * MATCH_SIZE[0] / (panel_h * MATCH_SIZE[1])
    outline = [effects.withStroke(linewidth=2.5, foreground="white")]
    for side, view in (("source", scene.source), ("target", scene.target)):
        ax = axes[side]
        xy = scene.camera.project(view.mesh.vertices)[:, :2]
        surface = _Surface(view.mesh, scene.camera, _window(xy, 1.06, aspect), pixels)
        surface.draw(ax)
        pts = view.mesh.vertices[view.points]
        seen = surface.visible(pts) if k else np.zeros(0, bool)
        p2 = scene.camera.project(pts)
        for i in range(k):
            is_wrong = wrong is not None and wrong[i]
            marker = WRONG_MARKER if is_wrong and side == "target" else RIGHT_MARKER
            face = colours[i] if seen[i] else "none"
            edge = "black" if seen[i] else colours[i]
            ax.scatter([p2[i, 0]], [p2[i, 1]], s=MATCH_MARKER_AREA, marker=marker, facecolors=face,
                       edgecolors=edge, linewidths=0.8 if seen[i] else 2.2, zorder=6)
            label = f"{i + 1}" + ("\u2717" if is_wrong and side == "target" else "")
            ax.annotate(label, (p2[i, 0], p2[i, 1]), xytext=(9, 6), textcoords="offset points", fontsize=8,
                        fontweight="bold", color="black", zorder=7, path_effects=outline)
            if is_wrong and side == "target" and scene.truth_points[i] >= 0:
                t2 = scene.camera.project(view.mesh.vertices[scene.truth_points[i]])
                # Below the markers (zorder 5): the truth is often another matched point (Fig. 9).
                ax.plot([p2[i, 0], t2[0]], [p2[i, 1], t2[1]], ls=":", lw=1.2, color="black", zorder=5)
                ax.scatter([t2[0]], [t2[1]], s=TRUTH_MARKER_AREA, facecolors="none", edgecolors="black",
                           linewidths=1.6, zorder=5)
                ax.annotate(f"{i + 1}*", (t2[0], t2[1]), xytext=(8, -12), textcoords="offset points", fontsize=7.5,
                            color="black", zorder=5, path_effects=outline)
        vertices = view.mesh.n_vertices if view.input_vertices is None else view.input_vertices
        ax.set_title(f"{side}: {Path(view.name).name} ({vertices} vertices)", fontsize=9)

    handles, labels = [], []
    for i in range(k):
        is_wrong = wrong is not None and wrong[i]
        handles.append(Line2D([], [], ls="", marker=WRONG_MARKER if is_wrong else RIGHT_MARKER, markersize=8,
                              markerfacecolor=colours[i], markeredgecolor="black"))
        text = f"{i + 1}: {scene.source_vertex[i]} \u2192 {scene.target_vertex[i]}   d = {scene.distance[i]:.3g}"
        if scene.errors is not None:
            e = scene.errors[i]
            text += "   truth unknown" if not np.isfinite(e) else \
                (f"   \u2717 wrong, error {e:.3f}" if is_wrong else f"   \u2713 error {e:.3f}")
        labels.append(text)
    lax = fig.add_axes((0.02, 0.0, 0.96, 0.27))
    lax.axis("off")
    if k:
        columns = 1 if k <= 5 else 2 if k <= 12 else 3
        lax.legend(handles, labels, loc="upper center", ncol=columns, fontsize=7.5, frameon=False,
                   title="match: source vertex \u2192 target vertex, descriptor distance d", title_fontsize=8)
    note = "hollow marker: point on the far side of the shape"
    if scene.errors is not None:
        n_wrong = int(wrong.sum())
        note += (f"; square \u2717: wrong (geodesic error > {scene.threshold:g} \u221aarea), "
                 f"ring n*: its true correspondent; {k - n_wrong} of {k} right")
    lax.text(0.5, 0.0, note, ha="center", va="bottom", fontsize=7, color="#333333", transform=lax.transAxes)
    fig.suptitle(title or f"{k} matched feature points, {Path(scene.source.name).name} \u2192 "
                          f"{Path(scene.target.name).name}", fontsize=11, y=0.985)
    boxes = _panel_boxes(fig, axes)
    out = _save(fig, path)
    return Picture(out, time.perf_counter() - start, boxes)


DENSE_SIZE = (12.0, 5.4)  # inches, three panels
DENSE_ERROR_CMAP = "magma_r"
DENSE_ERROR_MAX = 0.25  # errors at or above this take the darkest colour (sqrt(area))


def render_dense(scene: DenseScene, path: str | os.PathLike, title: str | None = None) -> Picture:
    """Draw a :class:`DenseScene` to a PNG: the source coloured by position, the target coloured
    through the map, and with ground truth a third panel: the source with each scored vertex
    coloured by its geodesic error."""
    start = time.perf_counter()
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    fig = _figure(DENSE_SIZE, MATCH_DPI)
    panels = 3 if scene.sample_errors is not None else 2
    width = 0.96 / panels
    axes = {}
    for i, name in enumerate(["source", "target", "errors"][:panels]):
        axes[name] = fig.add_axes((0.02 + i * width, 0.17, width - 0.01, 0.68))
    pixels = (width - 0.01) * DENSE_SIZE[0] * MATCH_DPI
    aspect = (width - 0.01) * DENSE_SIZE[0] / (0.68 * DENSE_SIZE[1])
    for name, mesh, camera, colours in (("source", scene.source, scene.source_camera, scene.source_colours),
                                        ("target", scene.target, scene.target_camera, scene.target_colours)):
        surface = _Surface(mesh, camera, _window(camera.project(mesh.vertices)[:, :2], 1.05, aspect), pixels)
        surface.draw_coloured(axes[name], colours)
    axes["source"].set_title(f"source: {Path(scene.source_name).name}\ncoloured by position", fontsize=9)
    axes["target"].set_title(f"target: {Path(scene.target_name).name}\ncoloured through the map", fontsize=9)
    if scene.sample_errors is not None:
        ax = axes["errors"]
        mesh, camera = scene.source, scene.source_camera
        surface = _Surface(mesh, camera, _window(camera.project(mesh.vertices)[:, :2], 1.05, aspect), pixels)
        surface.draw(ax)
        points = mesh.vertices[scene.sample_vertices]
        seen = surface.visible(points)
        xy = camera.project(points[seen])
        errors = np.minimum(scene.sample_errors[seen], DENSE_ERROR_MAX)
        norm = Normalize(0.0, DENSE_ERROR_MAX)
        order = np.argsort(errors)  # the largest errors drawn last, on top
        ax.scatter(xy[order, 0], xy[order, 1], c=errors[order], cmap=DENSE_ERROR_CMAP, norm=norm, s=9,
                   linewidths=0, zorder=5)
        finite = scene.sample_errors[np.isfinite(scene.sample_errors)]
        rate = float((scene.sample_errors <= scene.threshold).mean())
        ax.set_title(f"geodesic error of {len(scene.sample_errors)} scored source vertices\n{rate:.1%} within "
                     f"{scene.threshold:g}, mean {finite.mean():.3f}", fontsize=9)
        cax = fig.add_axes((0.02 + 2 * width + 0.03, 0.1, width - 0.07, 0.022))
        bar = fig.colorbar(ScalarMappable(norm=norm, cmap=DENSE_ERROR_CMAP), cax=cax, orientation="horizontal")
        bar.ax.tick_params(labelsize=7)
        bar.set_label("error (\u221aarea); darkest: 0.25 or more", fontsize=7)
    check = scene.check
    note = "a seam or a flip shows as a jump of colour between the first two panels"
    if check is not None:
        note += (f"\nthe map's own check: orientation agreement {check.orientation:.2f} "
                 f"(1: kept, -1: mirrored), landmark distortion {check.distortion:.3f} \u221aarea")
    fig.text(0.02, 0.015, note, ha="left", fontsize=7.5, color="#333333")
    fig.suptitle(title or f"dense map {Path(scene.source_name).name} \u2192 {Path(scene.target_name).name}",
                 fontsize=11, y=0.97)
    boxes = _panel_boxes(fig, axes)
    out = _save(fig, path)
    return Picture(out, time.perf_counter() - start, boxes)
