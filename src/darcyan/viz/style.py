"""One small shared look for darcyan's figures (benchmark plots, visualizations).

Matplotlib is optional (``pip install 'darcyan[plot]'``) and imported only by :func:`figure`.
Colours are fixed per method so a method keeps its colour in every plot.
"""

from __future__ import annotations

import zlib

# A colour-blind-safe palette (Okabe and Ito, 2008), in the order new names receive it.
PALETTE = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000")

# Fixed colours of the methods darcyan knows; any other name gets a stable palette colour.
METHOD_COLOURS = {"darcyan": PALETTE[0], "hks": PALETTE[1], "wks": PALETTE[2], "pyfm": PALETTE[3]}

# Neutral colours for surfaces, grids and text.
NEUTRAL = {"surface": "#D9D9D9", "edge": "#7F7F7F", "text": "#222222", "grid": "#E5E5E5"}

FIGURE_SIZE = (7.0, 4.0)  # inches
FIGURE_DPI = 150
FONT_SIZE = 9

RC_PARAMS = {
    "figure.dpi": FIGURE_DPI,
    "savefig.dpi": FIGURE_DPI,
    "savefig.bbox": "tight",
    "font.size": FONT_SIZE,
    "axes.titlesize": FONT_SIZE + 1,
    "axes.labelsize": FONT_SIZE,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": True,
    "grid.color": NEUTRAL["grid"],
    "grid.linewidth": 0.6,
    "axes.axisbelow": True,
    "legend.frameon": False,
    "text.color": NEUTRAL["text"],
}


def method_colour(name: str) -> str:
    """The colour of a method: fixed for darcyan's methods, else stable for the same name."""
    key = str(name).lower()
    if key in METHOD_COLOURS:
        return METHOD_COLOURS[key]
    return PALETTE[zlib.crc32(key.encode()) % len(PALETTE)]


def context():
    """A context manager applying darcyan's matplotlib defaults; draw whole figures inside it::

        with style.context():
            fig, ax = style.figure()
            ...
            style.save(fig, "plot.png")
    """
    from ..errors import require

    matplotlib = require("matplotlib", "plot")
    matplotlib.use("Agg", force=False)  # files only, no display needed
    return matplotlib.rc_context(RC_PARAMS)


def figure(size: tuple = FIGURE_SIZE):
    """``(fig, ax)``: a new figure (call inside :func:`context`)."""
    from ..errors import require

    plt = require("matplotlib.pyplot", "plot")
    return plt.subplots(figsize=size)


def save(fig, path) -> None:
    """Write ``fig`` to ``path`` and release it."""
    import matplotlib.pyplot as plt

    fig.savefig(path)
    plt.close(fig)
