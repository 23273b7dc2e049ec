"""PNG pictures: what is drawn is checked in the pixels (markers counted by colour, grid points
counted), and the drawn geometry against what is known of it (level curves on a sphere)."""

from __future__ import annotations

import re

import numpy as np
import pytest

pytest.importorskip("matplotlib")
from matplotlib.image import imread  # noqa: E402
from scipy import ndimage  # noqa: E402

from darcyan import DarcyanConfig, save_mesh
from darcyan.cli import main  # noqa: E402
from darcyan.eval.metrics import GroundTruth  # noqa: E402
from darcyan.geometry import synthetic
from darcyan.viz import scenes as viz  # noqa: E402

SUBDIVISIONS = 4  # 2,562-vertex figure: fast, still smooth enough to carry a grid
COLOUR_TOLERANCE = 0.02  # PNG channels are 8-bit: an exact colour is within 1/255
MIN_BLOB_PIXELS = 12  # smaller same-coloured specks would be antialiasing, not a marker


class Pairs:
    """A correspondence given by hand (only what the pictures read)."""

    def __init__(self, source, target):
        self.source_vertex = np.asarray(source)
        self.target_vertex = np.asarray(target)
        self.distance = np.linspace(0.1, 0.5, len(self.source_vertex))


@pytest.fixture(scope="module")
def poses():
    return synthetic.figure(0, SUBDIVISIONS), synthetic.figure(1, SUBDIVISIONS)


@pytest.fixture(scope="module")
def tips():
    return synthetic.figure_tips(SUBDIVISIONS)


def rgb(hex_colour: str) -> np.ndarray:
    return np.array([int(hex_colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])


def read(path) -> np.ndarray:
    image = imread(str(path))
    return image[..., :3]


def crop(image, box):
    left, top, right, bottom = box
    return image[top:bottom, left:right]


def blobs(image: np.ndarray, colour: np.ndarray) -> list:
    """Connected regions (8-connected) of pixels of ``colour``: list of (pixel count, share of
    their bounding box covered once holes are filled: a disc or ring ~pi/4, a square ~1)."""
    mask = np.abs(image - colour).max(axis=-1) <= COLOUR_TOLERANCE
    labels, count = ndimage.label(mask, structure=np.ones((3, 3)))
    out = []
    for i, sl in enumerate(ndimage.find_objects(labels), start=1):
        own = labels[sl] == i
        if own.sum() >= MIN_BLOB_PIXELS:
            out.append((int(own.sum()), float(ndimage.binary_fill_holes(own).mean())))
    return out


DISC_MAX_FILL = 0.88  # pi/4 plus antialiased edges
SQUARE_MIN_FILL = 0.95


def test_match_colours_are_distinct_and_not_grey():
    colours = viz.match_colours(12)
    assert len(set(colours)) == 12
    for c in colours:
        r, g, b = rgb(c)
        assert max(r, g, b) - min(r, g, b) > 0.15, c  # far from the grey surface


def test_match_picture_one_marker_per_pair_on_each_shape(poses, tips, tmp_path):
    scene = viz.match_scene(poses[0], poses[1], Pairs(tips, tips))
    picture = viz.render_matches(scene, tmp_path / "m.png")
    image = read(picture.path)
    assert image.shape[0] > 500 and image.shape[1] > 1000
    for side in ("source", "target"):
        panel = crop(image, picture.panels[side])
        assert (panel.mean(axis=-1) < 0.95).mean() > 0.1  # a shape is drawn, not a blank panel
        for colour in viz.match_colours(len(tips)):
            found = blobs(panel, rgb(colour))
            assert len(found) == 1, (side, colour, found)


def test_match_picture_marks_wrong_matches(poses, tips, tmp_path):
    """The same matches (tip i -> tip i) scored by two truths: the identity (all right) and a
    truth sending tip i to tip i+1 (all wrong): the target markers turn from discs to squares."""
    pairs = Pairs(tips, tips)
    right = viz.match_scene(poses[0], poses[1], pairs, GroundTruth.identity())
    assert not right.wrong.any() and np.allclose(right.errors, 0.0)
    shifted = GroundTruth(tips, np.roll(tips, -1))
    wrong = viz.match_scene(poses[0], poses[1], pairs, shifted)
    assert wrong.wrong.all() and (wrong.errors > 0.2).all()  # tips are far apart
    assert np.array_equal(wrong.truth_points, np.roll(tips, -1))
    pictures = [viz.render_matches(s, tmp_path / f"{name}.png") for name, s in (("right", right), ("wrong", wrong))]
    images = [read(p.path) for p in pictures]
    for colour in viz.match_colours(len(tips)):
        before = blobs(crop(images[0], pictures[0].panels["target"]), rgb(colour))
        after = blobs(crop(images[1], pictures[1].panels["target"]), rgb(colour))
        assert len(before) == len(after) == 1, (colour, before, after)
        # Discs (filled, or rings when on the far side) become squares.
        assert before[0][1] < DISC_MAX_FILL < SQUARE_MIN_FILL < after[0][1], (colour, before, after)
        # The source markers stay discs.
        for image, picture in zip(images, pictures):
            (source,) = blobs(crop(image, picture.panels["source"]), rgb(colour))
            assert source[1] < DISC_MAX_FILL


def test_display_decimation_keeps_the_markers(poses, tips, tmp_path, monkeypatch):
    monkeypatch.setattr(viz, "FACE_BUDGET", 1000)
    scene = viz.match_scene(poses[0], poses[1], Pairs(tips, tips))
    picture = viz.render_matches(scene, tmp_path / "small.png")
    image = read(picture.path)
    for colour in viz.match_colours(len(tips)):
        for side in ("source", "target"):
            assert len(blobs(crop(image, picture.panels[side]), rgb(colour))) == 1


def test_cluster_faces_uses_own_vertices(poses):
    mesh = poses[0]  # about 4 units across, edges about 0.1
    cell = 0.4
    faces = viz.cluster_faces(mesh.vertices, mesh.faces, cell)
    assert 0 < len(faces) < mesh.n_faces / 4
    assert faces.max() < mesh.n_vertices
    assert (faces[:, 0] != faces[:, 1]).all() and (faces[:, 1] != faces[:, 2]).all()
    # Every kept vertex stands for a cell: no two share one.
    kept = np.unique(faces)
    keys = np.floor(mesh.vertices[kept] / cell).astype(int)
    assert len(np.unique(keys, axis=0)) == len(kept)


def test_far_side_is_hidden():
    sphere = synthetic.icosphere(4)
    camera = viz.Camera.looking_along([0.0, 0.0, -1.0])  # eye on +z
    xy = camera.project(sphere.vertices)[:, :2]
    surface = viz._Surface(sphere, camera, viz._window(xy, 1.1), 400)
    near, far, side = [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]
    assert surface.visible(np.array([near, far, side])).tolist() == [True, False, True]


@pytest.fixture(scope="module")
def sphere_scene():
    # Area 1 after normalization: radius r = 1/sqrt(4 pi), kmax = kmin = 1/r; the grid (R = 0.08)
    # covers a cap of half-angle R/r ~ 0.28 rad, all of it facing the camera.
    config = DarcyanConfig(levels=3, radial_lines=8, interpolation=1, radius=0.08)
    return viz.grid_scene(synthetic.icosphere(4), vertex=0, config=config)


def test_grid_scene_geometry_on_a_sphere(sphere_scene):
    scene = sphere_scene
    r = 1 / np.sqrt(4 * np.pi)
    centre = scene.mesh.vertices[scene.grid.centre]
    centre_dir = centre / np.linalg.norm(centre)
    edge = np.median(np.linalg.norm(np.diff(scene.mesh.vertices[scene.mesh.faces[:, :2]], axis=1)[:, 0], axis=1))

    def geodesic(points):
        p = points / np.linalg.norm(points, axis=-1, keepdims=True)
        return r * np.arccos(np.clip(p @ centre_dir, -1, 1))

    for radius, segments in zip(scene.grid.radii, scene.level_curves):
        assert len(segments) > 8
        # Each level curve is the geodesic circle of its radius (up to the fast-marching error).
        assert np.abs(geodesic(segments.reshape(-1, 3)) - radius).max() < 0.5 * edge
    assert len(scene.radial_lines) == 8
    for line in scene.radial_lines:
        assert geodesic(line[-1:])[0] == pytest.approx(scene.grid.radii[-1], abs=0.5 * edge)
    assert np.allclose(scene.point_values, 1 / r, rtol=0.05)  # kmax of a sphere


def test_grid_picture_shows_every_intersection_point(sphere_scene, tmp_path):
    picture = viz.render_grid(sphere_scene, tmp_path / "grid.png")
    image = read(picture.path)
    panel = crop(image, picture.panels["grid"])
    left, top, right, bottom = picture.panels["overview"]
    gl, gt = picture.panels["grid"][:2]
    panel = panel.copy()
    panel[max(0, top - gt - 2):bottom - gt + 2, max(0, left - gl - 2):right - gl + 2] = 1.0  # the inset is not the grid
    # All points have kmax = 1/r > 0: red end of the diverging scale.
    red = (panel[..., 0] - panel[..., 2] > 0.25)
    labels, count = ndimage.label(red, structure=np.ones((3, 3)))
    sizes = ndimage.sum(red, labels, range(1, count + 1))
    assert int((sizes >= MIN_BLOB_PIXELS).sum()) == 3 * 8  # n x m x q intersection points
    # Level curves and radial lines: many dark pixels.
    assert (panel.max(axis=-1) < 0.15).sum() > 2000
    # The colour bar is drawn (both ends of the scale present outside the panel).
    assert (np.abs(image - rgb("#053061")).max(axis=-1) < 0.05).any()


def test_grid_picture_on_a_feature_point(poses, tmp_path):
    scene = viz.grid_scene(poses[0], feature=0)
    assert scene.feature == 0 and scene.centre_input == int(scene.mesh.input_index[scene.grid.centre])
    picture = viz.render_grid(scene, tmp_path / "f.png", title="test")
    panel = crop(read(picture.path), picture.panels["grid"])
    coloured = (panel.max(axis=-1) - panel.min(axis=-1)) > 0.2  # curvature-coloured points
    assert coloured.sum() > 1000
    assert (panel.mean(axis=-1) < 0.9).mean() > 0.2  # the surface is drawn around the grid


def test_cli_show_grid_and_match_plot(poses, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))
    files = []
    for i, mesh in enumerate(poses):
        files.append(tmp_path / f"figure{i}.off")
        save_mesh(mesh, files[-1])
    assert main(["show-grid", str(files[0]), "--vertex", "5", "--curvature", "kmin", "-o", str(tmp_path / "g.png")]) == 0
    assert read(tmp_path / "g.png").mean() < 0.97
    assert main(["match", str(files[0]), str(files[1]), "-o", str(tmp_path / "plain.csv")]) == 0
    assert main(["match", str(files[0]), str(files[1]), "-o", str(tmp_path / "pictured.csv"),
                 "--plot", str(tmp_path / "m.png"), "--truth", "identity"]) == 0
    # The CSV contract does not change with pictures.
    assert (tmp_path / "plain.csv").read_text() == (tmp_path / "pictured.csv").read_text()
    assert (tmp_path / "m.png").stat().st_size > 10_000
    capsys.readouterr()
    # --truth alone scores the matches on stderr (the figure's poses share one numbering)
    assert main(["match", str(files[0]), str(files[1]), "-o", str(tmp_path / "scored.csv"), "--truth", "identity"]) == 0
    said = capsys.readouterr().err
    assert re.search(r"darcyan: (\d+) of \1 matches correct", said), said
    # identity between files of different vertex counts is refused, not drawn as all wrong
    coarse = tmp_path / "coarse.off"
    save_mesh(synthetic.figure(1, subdivisions=SUBDIVISIONS - 1), coarse)
    assert main(["match", str(files[0]), str(coarse), "--truth", "identity"]) == 2
    assert "identity needs one vertex numbering" in capsys.readouterr().err
    assert main(["show-grid", str(files[0]), "--feature", "99", "-o", str(tmp_path / "x.png")]) == 2
    assert "out of range" in capsys.readouterr().err
    assert main(["show-grid", str(files[0]), "-o", str(tmp_path / "no" / "x.png")]) == 2
    assert "cannot write" in capsys.readouterr().err
    assert main(["match", str(files[0]), str(files[1]), "--plot", str(tmp_path / "y.png"),
                 "--truth", str(tmp_path / "missing.vts")]) == 2
    assert "identity" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["show-grid", str(files[0]), "--vertex", "1", "--feature", "0", "-o", "x.png"])
    assert exc.value.code == 2


# ---------------------------------------------------------------------------------------------
# Dense maps: texture transfer and errors


def _dense(target):
    from darcyan.dense.maps import DenseMap

    return DenseMap(np.asarray(target, dtype=np.int64), np.zeros((0, 2), np.int64))


@pytest.mark.slow
def test_dense_scene_carries_the_colours_through_the_map(poses):
    from darcyan.geometry.shape import prepare_shape

    source, target = (prepare_shape(m) for m in poses)
    n = source.mesh.n_vertices
    identity = viz.dense_scene(source, target, _dense(np.arange(n)), GroundTruth.identity())
    # the figure's poses share one numbering: through the identity every vertex keeps its colour
    assert np.array_equal(identity.target_colours, identity.source_colours)
    assert identity.sample_errors.max() == 0
    # colours are a smooth function of position (0.85 of the range per span of the shape along
    # an axis: Lipschitz), and the shape spans most of each channel
    v, edges = source.mesh.vertices, source.mesh.edges()
    span = np.ptp(v - v.mean(axis=0), axis=0).min()
    step = np.abs(np.diff(identity.source_colours[edges], axis=1)).max(axis=(1, 2))
    assert (step <= 0.85 * np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1) / span * 2 + 1e-9).all()
    assert np.ptp(identity.source_colours, axis=0).min() > 0.8
    # a map that sends every vertex to one point paints the whole target in one colour, and errs
    constant = viz.dense_scene(source, target, _dense(np.full(n, 7)), GroundTruth.identity())
    assert np.ptp(constant.target_colours, axis=0).max() == 0
    assert np.median(constant.sample_errors) > 0.1


@pytest.mark.slow
def test_dense_picture_has_three_panels_with_truth_and_colours_through_the_map(poses, tmp_path):
    from darcyan.geometry.shape import prepare_shape

    source, target = (prepare_shape(m) for m in poses)
    n = source.mesh.n_vertices
    scene = viz.dense_scene(source, target, _dense(np.arange(n)), GroundTruth.identity())
    picture = viz.render_dense(scene, tmp_path / "dense.png")
    assert set(picture.panels) == {"source", "target", "errors"}
    image = read(picture.path)
    for name in ("source", "target"):
        panel = crop(image, picture.panels[name])
        saturation = panel.max(axis=-1) - panel.min(axis=-1)
        assert (saturation > 0.15).mean() > 0.05, name  # coloured, not grey
    untrue = viz.dense_scene(source, target, _dense(np.arange(n)), None)
    assert set(viz.render_dense(untrue, tmp_path / "two.png").panels) == {"source", "target"}


@pytest.mark.slow
def test_cli_dense_plot_and_html(poses, tmp_path, capsys, monkeypatch):
    pytest.importorskip("plotly")
    monkeypatch.setenv("DARCYAN_CACHE", str(tmp_path / "cache"))
    files = []
    for i, mesh in enumerate(poses):
        files.append(tmp_path / f"figure{i}.off")
        save_mesh(mesh, files[-1])
    assert main(["match", str(files[0]), str(files[1]), "--dense", "-o", str(tmp_path / "map.csv"), "--truth",
                 "identity", "--plot", str(tmp_path / "map.png"), "--html", str(tmp_path / "map.html")]) == 0
    said = capsys.readouterr().err
    assert "orientation agreement" in said and "map.png" in said and "map.html" in said
    assert (tmp_path / "map.png").stat().st_size > 10_000
    assert "vertexcolor" in (tmp_path / "map.html").read_text()


def test_match_scene_counts_the_files_vertices_not_the_split_copies():
    """A picture's title quotes the file's vertex count, not the prepared mesh's (two spheres
    touching at one vertex: the vertex is split, and one sphere is analysed; issue 41)."""
    from darcyan.geometry.mesh import Mesh

    ball = synthetic.icosphere(3)
    top = int(np.argmax(ball.vertices[:, 2]))
    other = ball.vertices.copy()
    other[:, 2] = 2 * ball.vertices[top, 2] - other[:, 2]  # mirrored above, touching at the top vertex
    bottom = int(np.argmin(other[:, 2]))
    keep = np.arange(len(other)) != bottom
    renumber = np.cumsum(keep) - 1 + len(ball.vertices)
    renumber[bottom] = top
    faces = np.vstack([ball.faces, renumber[ball.faces[:, ::-1]]])
    touching = Mesh(np.vstack([ball.vertices, other[keep]]), faces, "touching")
    with pytest.warns(UserWarning, match="split 1 non-manifold"):
        scene = viz.match_scene(touching, touching, Pairs(np.array([0, 5, 9]), np.array([0, 5, 9])))
    assert scene.source.mesh.n_vertices == len(ball.vertices)  # one sphere, its copy of the vertex
    assert scene.source.input_vertices == touching.n_vertices
