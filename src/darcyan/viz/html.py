"""Interactive views in one self-contained HTML file (plotly, its JavaScript inlined).

:func:`grid_html` shows a :class:`darcyan.viz.scenes.GridScene` (the surface around the centre, the
level curves, the radial lines and the intersection points coloured by curvature);
:func:`matches_html` a :class:`darcyan.viz.scenes.MatchScene` (both shapes side by side, each matched
pair linked by a line of its colour); :func:`dense_html` a :class:`darcyan.viz.scenes.DenseScene`
(the source coloured by position, the target through the map, and the scored vertices by error).
The page needs no network access: plotly.js is written
into the file (about 5 MB). Shapes rotate (drag), zoom (wheel) and pan (right drag); hovering
a point shows its vertex index (the input file's numbering), curvature and distance.

Large meshes are decimated *for display only* (vertex clustering, each cluster shown at one of
its own vertices, so the hover data are those of real vertices). ``pip install 'darcyan[html]'``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import DarcyanError, require
from ..geometry.geodesics import vertex_normals
from ..geometry.mesh import Mesh
from .scenes import (
    DENSE_ERROR_CMAP,
    DENSE_ERROR_MAX,
    GRID_CMAP,
    DenseScene,
    GridScene,
    MatchScene,
    cluster_faces,
    match_colours,
)

HTML_FACE_BUDGET = 40_000  # triangles per shape written to the page before clustering
SURFACE_COLOUR = "#CCCCCC"
LEVEL_COLOUR = "#111111"
RADIAL_COLOUR = "#4D4D4D"
PATCH_SHARE = 1.6  # the grid view shows the triangles reaching within this many R of the centre
LIFT_EDGES = 0.3  # lines and points float this many median edges above the surface (no z-fighting)
SIDE_GAP = 0.15  # gap between the two shapes, as a share of the source's width
EYE_DISTANCE = 1.8  # plotly camera eye distance (in its normalized scene units)
LINE_WIDTH = 5
POINT_SIZE = 5
MATCH_POINT_SIZE = 8
# plotly's own light position (its lighting mixes coordinate frames, so a light placed "at the
# eye" in world coordinates can end up behind the shape; the default lights every view tried).
LIGHTING = dict(ambient=0.6, diffuse=0.5, specular=0.05, roughness=0.9, fresnel=0.0)
PLOTLY_CONFIG = {"displaylogo": False, "responsive": True, "scrollZoom": True}


def _plotly():
    return require("plotly.graph_objects", "html")


def _median_edge(mesh: Mesh) -> float:
    v, f = mesh.vertices, mesh.faces
    return float(np.median(np.linalg.norm(v[f[:, 1]] - v[f[:, 0]], axis=1)))


def _display_faces(mesh: Mesh, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(vertex_ids (u,), faces (t, 3) into vertex_ids)``: ``faces`` decimated to about
    :data:`HTML_FACE_BUDGET` when larger (display only)."""
    if len(faces) > HTML_FACE_BUDGET:
        v = mesh.vertices
        area = 0.5 * float(np.linalg.norm(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]),
                                          axis=1).sum())
        faces = cluster_faces(mesh.vertices, faces, np.sqrt(2.0 * area / HTML_FACE_BUDGET))
    ids, local = np.unique(faces, return_inverse=True)
    return ids, local.reshape(-1, 3)


def _surface_trace(go, mesh: Mesh, faces: np.ndarray, shift: np.ndarray, name: str, kmax: np.ndarray,
                   kmin: np.ndarray, extra: np.ndarray | None = None, extra_label: str = ""):
    ids, local = _display_faces(mesh, faces)
    p = mesh.vertices[ids] + shift
    data = [mesh.input_index[ids], kmax[ids], kmin[ids]]
    template = "vertex %{customdata[0]}<br>kmax %{customdata[1]:.4g}<br>kmin %{customdata[2]:.4g}"
    if extra is not None:
        data.append(extra[ids])
        template += f"<br>{extra_label} %{{customdata[3]:.4g}}"
    return go.Mesh3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], i=local[:, 0], j=local[:, 1], k=local[:, 2],
                     color=SURFACE_COLOUR, flatshading=False, name=name, showscale=False,
                     customdata=np.column_stack(data), hovertemplate=template + f"<extra>{name}</extra>",
                     lighting=LIGHTING)


def _layout(go, fig, title: str, forward: np.ndarray, up: np.ndarray) -> None:
    hidden = dict(visible=False, showbackground=False)
    eye = -np.asarray(forward) * EYE_DISTANCE
    fig.update_layout(
        title=dict(text=title, x=0.5), margin=dict(l=0, r=0, t=50, b=0), paper_bgcolor="white",
        legend=dict(itemsizing="constant", bgcolor="rgba(255,255,255,0.8)"),
        scene=dict(aspectmode="data", xaxis=hidden, yaxis=hidden, zaxis=hidden,
                   camera=dict(eye=dict(x=eye[0], y=eye[1], z=eye[2]), up=dict(x=up[0], y=up[1], z=up[2]),
                               projection=dict(type="orthographic"))))


def _write(fig, path) -> Path:
    path = Path(path)
    try:
        fig.write_html(path, include_plotlyjs=True, full_html=True, config=PLOTLY_CONFIG)
    except OSError as exc:
        raise DarcyanError(f"{path}: cannot write ({exc.strerror or exc})") from None
    return path


def _broken_line(pieces) -> np.ndarray:
    """Polylines ``[(k_i, 3)]`` as one ``(sum k_i + count, 3)`` array with NaN rows between them."""
    out = []
    for p in pieces:
        if len(p) > 1:
            out += [p, np.full((1, 3), np.nan)]
    return np.vstack(out) if out else np.zeros((0, 3))


def _lifted(mesh: Mesh, normals: np.ndarray, points: np.ndarray, lift: float) -> np.ndarray:
    """``points (..., 3)`` moved ``lift`` along the normal of their nearest vertex."""
    from scipy.spatial import cKDTree

    flat = points.reshape(-1, 3)
    ok = np.isfinite(flat).all(axis=1)
    out = flat.copy()
    if ok.any():
        _, nearest = cKDTree(mesh.vertices).query(flat[ok])
        out[ok] += lift * normals[nearest]
    return out.reshape(points.shape)


def grid_html(scene: GridScene, path: str | os.PathLike, title: str | None = None) -> Path:
    """Write an interactive view of a :class:`GridScene` to ``path`` (self-contained HTML)."""
    go = _plotly()
    mesh, grid = scene.mesh, scene.grid
    normals = vertex_normals(mesh)
    lift = LIFT_EDGES * _median_edge(mesh)
    radius = float(grid.radii[-1])
    near = (scene.distance[mesh.faces] <= PATCH_SHARE * radius).any(axis=1)
    traces = [_surface_trace(go, mesh, mesh.faces[near], np.zeros(3), Path(scene.name).name, scene.kmax,
                             scene.kmin, scene.distance, "geodesic distance from the centre")]

    levels = _lifted(mesh, normals, _broken_line([s for segs in scene.level_curves for s in segs]), lift)
    traces.append(go.Scatter3d(x=levels[:, 0], y=levels[:, 1], z=levels[:, 2], mode="lines", hoverinfo="skip",
                               line=dict(color=LEVEL_COLOUR, width=LINE_WIDTH - 1), name="level curves U = \u03bb_k"))
    q = grid.interpolation
    for main in (True, False):
        lines = [p for c, p in enumerate(scene.radial_lines) if (c % q == 0) == main]
        if not lines:
            continue
        xyz = _lifted(mesh, normals, _broken_line(lines), lift)
        traces.append(go.Scatter3d(
            x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2], mode="lines", hoverinfo="skip",
            line=dict(color=RADIAL_COLOUR, width=LINE_WIDTH - 2 if main else 2, dash="solid" if main else "dot"),
            name="radial lines" if main else f"interpolated radial lines (x{q})"))

    ok = grid.valid
    level_idx, col_idx = np.nonzero(ok)
    pts = _lifted(mesh, normals, grid.points[ok], lift)
    values = scene.point_values[ok]
    finite = values[np.isfinite(values)]
    limit = float(np.abs(finite).max()) if len(finite) else 1.0
    kmax = grid.sample(mesh, scene.kmax)[ok]
    kmin = grid.sample(mesh, scene.kmin)[ok]
    nearest = mesh.faces[grid.faces[ok], np.argmax(grid.barycentric[ok], axis=1)]
    custom = np.column_stack([level_idx + 1, grid.radii[level_idx], col_idx, np.degrees(grid.angles[col_idx]),
                              kmax, kmin, mesh.input_index[nearest], scene.distance[nearest]])
    traces.append(go.Scatter3d(
        x=pts[:, 0], y=pts[:, 1], z=pts[:, 2], mode="markers", name=f"intersection points ({scene.curvature})",
        marker=dict(size=POINT_SIZE, color=values, colorscale=GRID_CMAP, cmin=-limit, cmax=limit,
                    line=dict(color="black", width=1),
                    colorbar=dict(title=dict(text=f"{scene.curvature} (1/\u221aarea)"), x=1.0, len=0.7)),
        customdata=custom,
        hovertemplate=("level %{customdata[0]} (\u03bb = %{customdata[1]:.3g})<br>radial line %{customdata[2]} "
                       "(%{customdata[3]:.1f}\u00b0)<br>kmax %{customdata[4]:.4g}<br>kmin %{customdata[5]:.4g}"
                       "<br>nearest vertex %{customdata[6]}<br>geodesic distance %{customdata[7]:.4g}"
                       "<extra></extra>")))
    c = _lifted(mesh, normals, mesh.vertices[[grid.centre]], lift)
    traces.append(go.Scatter3d(x=c[:, 0], y=c[:, 1], z=c[:, 2], mode="markers", name="centre",
                               marker=dict(size=MATCH_POINT_SIZE, color="black", symbol="diamond"),
                               hovertemplate=f"centre: vertex {scene.centre_input}<extra></extra>"))
    fig = go.Figure(traces)
    where = f"feature {scene.feature} (vertex {scene.centre_input})" if scene.feature is not None \
        else f"vertex {scene.centre_input}"
    _layout(go, fig, title or f"Darcyan grid at {where} of {Path(scene.name).name}: n = {len(grid.radii)}, "
                              f"m = {scene.config.radial_lines}, R = {radius:.3g} \u221aarea",
            scene.camera.forward, scene.camera.up)
    return _write(fig, path)


def matches_html(scene: MatchScene, path: str | os.PathLike, title: str | None = None) -> Path:
    """Write an interactive view of a :class:`MatchScene` to ``path`` (self-contained HTML)."""
    go = _plotly()
    cam = scene.camera
    src, tgt = scene.source, scene.target
    s_right = src.mesh.vertices @ cam.right
    t_right = tgt.mesh.vertices @ cam.right
    width = s_right.max() - s_right.min()
    shift = cam.right * (s_right.max() - t_right.min() + SIDE_GAP * width)
    traces = [_surface_trace(go, src.mesh, src.mesh.faces, np.zeros(3), "source: " + Path(src.name).name,
                             src.kmax, src.kmin),
              _surface_trace(go, tgt.mesh, tgt.mesh.faces, shift, "target: " + Path(tgt.name).name,
                             tgt.kmax, tgt.kmin)]
    lift_s = LIFT_EDGES * _median_edge(src.mesh)
    lift_t = LIFT_EDGES * _median_edge(tgt.mesh)
    a = src.mesh.vertices[src.points] + lift_s * vertex_normals(src.mesh)[src.points]
    b = tgt.mesh.vertices[tgt.points] + lift_t * vertex_normals(tgt.mesh)[tgt.points] + shift
    colours = match_colours(len(scene))
    wrong = scene.wrong
    errors = scene.errors if scene.errors is not None else np.full(len(scene), np.nan)
    for i in range(len(scene)):
        bad = wrong is not None and bool(wrong[i])
        xyz = np.vstack([a[i], b[i]])
        custom = np.array([[scene.source_vertex[i], src.kmax[src.points[i]], src.kmin[src.points[i]]],
                           [scene.target_vertex[i], tgt.kmax[tgt.points[i]], tgt.kmin[tgt.points[i]]]])
        verdict = "" if wrong is None else (
            f"<br>ground truth: {'WRONG' if bad else 'right'}, error {errors[i]:.3f} \u221aarea"
            if np.isfinite(errors[i]) else "<br>ground truth: unknown")
        label = f"{i + 1}: {scene.source_vertex[i]} \u2192 {scene.target_vertex[i]}, d = {scene.distance[i]:.3g}"
        if wrong is not None and bad:
            label += " \u2717 wrong"
        traces.append(go.Scatter3d(
            x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2], mode="lines+markers", name=label,
            line=dict(color=colours[i], width=LINE_WIDTH),
            marker=dict(size=MATCH_POINT_SIZE, color=colours[i], symbol=["circle", "square" if bad else "circle"],
                        line=dict(color="black", width=1)),
            customdata=custom,
            hovertemplate=(f"match {i + 1}<br>vertex %{{customdata[0]}}<br>kmax %{{customdata[1]:.4g}}<br>"
                           f"kmin %{{customdata[2]:.4g}}<br>descriptor distance {scene.distance[i]:.4g}{verdict}"
                           "<extra></extra>")))
        if bad and scene.truth_points[i] >= 0:
            t = tgt.mesh.vertices[scene.truth_points[i]] + lift_t * vertex_normals(tgt.mesh)[scene.truth_points[i]] + shift
            truth_xyz = np.vstack([b[i], t])
            traces.append(go.Scatter3d(
                x=truth_xyz[:, 0], y=truth_xyz[:, 1], z=truth_xyz[:, 2], mode="lines+markers",
                name=f"{i + 1}*: true correspondent", line=dict(color="black", width=2, dash="dot"),
                marker=dict(size=[0, MATCH_POINT_SIZE], color="black", symbol="circle-open"),
                hovertemplate=f"true correspondent of match {i + 1}: vertex "
                              f"{int(tgt.mesh.input_index[scene.truth_points[i]])}<extra></extra>"))
    fig = go.Figure(traces)
    n_wrong = "" if wrong is None else f", {len(scene) - int(wrong.sum())} right by the ground truth"
    _layout(go, fig, title or f"{len(scene)} matches, {Path(src.name).name} \u2192 {Path(tgt.name).name}{n_wrong}",
            cam.forward, cam.up)
    return _write(fig, path)


def dense_html(scene: DenseScene, path: str | os.PathLike, title: str | None = None) -> Path:
    """Write an interactive view of a :class:`DenseScene` to ``path`` (self-contained HTML): the
    source coloured by position beside the target coloured through the map; with ground truth,
    the scored source vertices coloured by geodesic error beside them."""
    go = _plotly()
    cam = scene.source_camera
    traces, offset = [], 0.0
    panels = [("source: " + Path(scene.source_name).name, scene.source, scene.source_colours),
              ("target (through the map): " + Path(scene.target_name).name, scene.target, scene.target_colours)]
    shifts = []
    for name, mesh, colours in panels:
        right = mesh.vertices @ cam.right
        shift = cam.right * (offset - right.min())
        offset += (right.max() - right.min()) * (1 + SIDE_GAP)
        ids, local = _display_faces(mesh, mesh.faces)
        p = mesh.vertices[ids] + shift
        rgb = [f"rgb({r},{g},{b})" for r, g, b in np.round(255 * np.clip(colours[ids], 0, 1)).astype(int)]
        traces.append(go.Mesh3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], i=local[:, 0], j=local[:, 1], k=local[:, 2],
                                vertexcolor=rgb, flatshading=False, name=name, showlegend=True,
                                customdata=mesh.input_index[ids],
                                hovertemplate="vertex %{customdata}<extra>" + name + "</extra>", lighting=LIGHTING))
        shifts.append(shift)
    if scene.sample_errors is not None:
        mesh = scene.source
        right = mesh.vertices @ cam.right
        shift = cam.right * (offset - right.min())
        traces.append(_surface_trace(go, mesh, mesh.faces, shift, "source, scored vertices by error",
                                     np.zeros(mesh.n_vertices), np.zeros(mesh.n_vertices)))
        lift = LIFT_EDGES * _median_edge(mesh)
        points = mesh.vertices[scene.sample_vertices] + lift * vertex_normals(mesh)[scene.sample_vertices] + shift
        errors = np.minimum(scene.sample_errors, DENSE_ERROR_MAX)
        traces.append(go.Scatter3d(
            x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="markers", name="geodesic error (\u221aarea)",
            marker=dict(size=3, color=errors, colorscale=DENSE_ERROR_CMAP.replace("_r", ""), reversescale=True,
                        cmin=0, cmax=DENSE_ERROR_MAX, colorbar=dict(title="error")),
            customdata=np.column_stack([mesh.input_index[scene.sample_vertices], scene.sample_errors]),
            hovertemplate="vertex %{customdata[0]}<br>error %{customdata[1]:.3f}<extra></extra>"))
    fig = go.Figure(traces)
    _layout(go, fig, title or f"dense map {Path(scene.source_name).name} \u2192 {Path(scene.target_name).name}",
            cam.forward, cam.up)
    return _write(fig, path)
