"""The interactive HTML viewer, opened in a real headless Chromium (Debian's ``chromium``, driven
by Playwright with its executable path; never a downloaded browser build).

Each page is loaded with every non-file request refused and recorded, so it is checked to work
offline; its console must show no error; the screenshot must show the shapes (non-background
pixels) and each matched pair's colour; hovering a matched point must show its vertex index.
Skipped, with the reason, where Chromium or Playwright is not installed.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("plotly", reason="plotly not installed (pip install 'darcyan[html]')")
from darcyan import DarcyanConfig
from darcyan.eval.metrics import GroundTruth  # noqa: E402
from darcyan.geometry import synthetic
from darcyan.viz import html as viewer  # noqa: E402
from darcyan.viz import scenes as viz

CHROMIUM = os.environ.get("DARCYAN_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1100, "height": 750}
RENDER_TIMEOUT_MS = 20_000
SUBDIVISIONS = 4
COLOUR_TOLERANCE = 0.06  # WebGL antialiasing and blending in the screenshot
MIN_COLOUR_PIXELS = 20
LEGEND_SHARE = 0.8  # the legend and colour bar sit right of this share of the page width
HOVER_TIMEOUT_MS = 8_000


class Pairs:
    def __init__(self, source, target):
        self.source_vertex = np.asarray(source)
        self.target_vertex = np.asarray(target)
        self.distance = np.linspace(0.1, 0.5, len(self.source_vertex))


def test_pages_are_self_contained(tmp_path):
    mesh = synthetic.figure(0, SUBDIVISIONS)
    tips = synthetic.figure_tips(SUBDIVISIONS)
    path = viewer.matches_html(viz.match_scene(mesh, mesh, Pairs(tips, tips)), tmp_path / "m.html")
    text = path.read_text()
    assert "<script src=" not in text  # plotly.js is inlined, nothing is fetched
    assert "plotly" in text.lower() and len(text) > 1_000_000


@pytest.fixture(scope="module")
def browser():
    if CHROMIUM is None:
        pytest.skip("chromium not installed (Debian: apt-get install chromium; or set DARCYAN_CHROMIUM)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright not installed (pip install playwright)")
    profile = tempfile.mkdtemp(prefix="darcyan-chromium-")
    with sync_api.sync_playwright() as p:
        context = p.chromium.launch_persistent_context(profile, executable_path=CHROMIUM, headless=True,
                                                       args=CHROMIUM_ARGS, viewport=VIEWPORT)
        yield context
        context.close()
    shutil.rmtree(profile, ignore_errors=True)


def open_page(context, path: Path):
    """Load ``path``; returns (page, console errors, refused requests)."""
    page = context.new_page()
    errors, outside = [], []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))

    def guard(route):
        if route.request.url.startswith("file://"):
            route.continue_()
        else:
            outside.append(route.request.url)
            route.abort()

    page.route("**/*", guard)
    page.goto(path.resolve().as_uri())
    page.wait_for_function("() => { const gd = document.querySelector('.js-plotly-plot');"
                           " return gd && gd._fullLayout && document.querySelectorAll('canvas').length > 0; }",
                           timeout=RENDER_TIMEOUT_MS)
    page.wait_for_timeout(500)  # let WebGL finish the first frame
    return page, errors, outside


def screenshot(page, path: Path) -> np.ndarray:
    from matplotlib.image import imread

    page.screenshot(path=str(path))
    return imread(str(path))[..., :3]


def colour_mask(image, hex_colour):
    rgb = np.array([int(hex_colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    return np.abs(image - rgb).max(axis=-1) <= COLOUR_TOLERANCE


@pytest.mark.slow
def test_matches_viewer_in_chromium(browser, tmp_path):
    poses = synthetic.figure(0, SUBDIVISIONS), synthetic.figure(1, SUBDIVISIONS)
    tips = synthetic.figure_tips(SUBDIVISIONS)
    scene = viz.match_scene(poses[0], poses[1], Pairs(tips, tips), GroundTruth.identity())
    path = viewer.matches_html(scene, tmp_path / "matches.html")
    page, errors, outside = open_page(browser, path)
    image = screenshot(page, tmp_path / "matches.png")
    assert errors == [] and outside == []
    drawn = image.mean(axis=-1) < 0.97
    assert drawn.mean() > 0.04  # the two shapes (and the legend) are on the canvas
    shaded = (np.abs(image - image.mean(axis=-1, keepdims=True)).max(axis=-1) < 0.03) & (image.mean(axis=-1) < 0.9)
    assert shaded.sum() > 20_000  # grey shaded surfaces
    colours = viz.match_colours(len(tips))
    for colour in colours:
        assert colour_mask(image, colour).sum() >= MIN_COLOUR_PIXELS, colour
    # Hover over matched point 1 (the pixel most surrounded by its colour: a marker, not the
    # link line, nor the legend on the right): plotly reports that point with its vertex index.
    from scipy import ndimage

    page.evaluate("() => { window.hovered = []; document.querySelector('.js-plotly-plot').on('plotly_hover', "
                  "d => window.hovered.push(d.points.map(p => [p.curveNumber, p.pointNumber, p.customdata]))); }")
    scene_part = colour_mask(image, colours[0])
    scene_part[:, int(image.shape[1] * LEGEND_SHARE):] = False
    y, x = np.unravel_index(np.argmax(ndimage.uniform_filter(scene_part.astype(float), size=7)), scene_part.shape)
    page.mouse.move(float(x) - 4, float(y) - 4)
    page.mouse.move(float(x), float(y))
    page.wait_for_function("() => window.hovered.length > 0", timeout=HOVER_TIMEOUT_MS)
    points = page.evaluate("() => window.hovered[window.hovered.length - 1]")
    curve, index, custom = points[0]
    first_match = 2  # traces 0 and 1 are the two surfaces
    assert curve == first_match and index in (0, 1)
    assert int(custom[0]) == int(tips[0])  # the same vertex on both shapes here
    template = page.evaluate(f"() => document.querySelector('.js-plotly-plot').data[{first_match}].hovertemplate")
    assert "vertex %{customdata[0]}" in template and "kmax" in template and "descriptor distance" in template
    page.close()


@pytest.mark.slow  # over 5 s on the CI machine
def test_grid_viewer_in_chromium(browser, tmp_path):
    config = DarcyanConfig(levels=3, radial_lines=8, interpolation=1)
    scene = viz.grid_scene(synthetic.icosphere(4), vertex=0, config=config)
    path = viewer.grid_html(scene, tmp_path / "grid.html")
    page, errors, outside = open_page(browser, path)
    image = screenshot(page, tmp_path / "grid.png")
    assert errors == [] and outside == []
    left = image[:, : int(image.shape[1] * LEGEND_SHARE)]  # the scene, without the colour bar and legend
    assert (left.mean(axis=-1) < 0.97).mean() > 0.05
    # Intersection points: all kmax > 0 on a sphere, the red end of the scale.
    red = (left[..., 0] - left[..., 2]) > 0.25
    assert red.sum() > 100
    # Traces: surface, level curves, radial lines, points, centre.
    count = page.evaluate("() => document.querySelector('.js-plotly-plot').data.length")
    assert count == 5
    page.close()
