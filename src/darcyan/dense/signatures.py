"""The curvature signature that a dense map keeps: which way a body is turned.

Distances to a few extremities cannot tell a body's front from its back; the mean curvature
diffused over a few lengths (:func:`point_signature`) can, and survives a change of pose. It
scores the seeds (:mod:`darcyan.dense.seeds`), joins ZoomOut's coarse steps
(:func:`signature_coordinates`), and, turned against the directions to the landmarks, every
step (:func:`signature_turn_coordinates`).
"""

from __future__ import annotations

import numpy as np

from .config import DenseConfig
from .landmarks import orientation_coordinates


def point_signature(shape, config: DenseConfig) -> np.ndarray:
    """``(n, len(config.signature_lengths))`` the shape's mean curvature diffused over each of
    ``config.signature_lengths`` (:func:`darcyan.geometry.heat.curvature_signature`: intrinsic
    enough to survive a change of pose, different on the front and the back of a body), on the
    coarse proxy of a large mesh; the curvatures smoothed ``config.signature_smoothing`` times
    and diffused in ``config.signature_diffusion_steps`` steps (``None``: the defaults of the
    describe stage; a :class:`~darcyan.config.DarcyanConfig`'s ``dense`` section carries its own)."""
    from ..config import DarcyanConfig
    from ..geometry.heat import shape_signature

    describe = DarcyanConfig()
    smoothing = describe.curvature_smoothing if config.signature_smoothing is None else config.signature_smoothing
    steps = describe.heat.diffusion_steps if config.signature_diffusion_steps is None else config.signature_diffusion_steps

    def compute():
        return shape_signature(shape, config.basis_proxy_vertices, config.signature_lengths, steps, smoothing)

    # once per shape: --verify and the dense map, or several dense variants, score seeds alike
    return shape.derived(("point signature", config.signature_lengths, config.basis_proxy_vertices, smoothing, steps),
                         compute)


def signature_coordinates(shape_1, shape_2, config: DenseConfig, sample_1: np.ndarray,
                          sample_2: np.ndarray) -> tuple:
    """``(coarse_1 (s_1, c), coarse_2 (s_2, c))``: the :func:`point_signature` at the samples,
    each length divided by its standard deviation over both shapes' vertices and weighed by
    ``config.signature_weight`` (``(None, None)`` at weight 0): the coordinates that join the
    coarse ZoomOut steps (:func:`~darcyan.dense.zoomout.zoomout`)."""
    if config.signature_weight <= 0:
        return None, None
    s_1, s_2 = point_signature(shape_1, config), point_signature(shape_2, config)
    scale = np.concatenate([s_1, s_2]).std(axis=0)
    scale[scale == 0] = 1.0  # a constant signature (a sphere) tells nothing: left as it is
    weight = config.signature_weight / scale
    return weight * s_1[sample_1], weight * s_2[sample_2]


def signature_turn_coordinates(shape_1, shape_2, config: DenseConfig, fields_1: np.ndarray,
                               fields_2: np.ndarray, weight: float) -> tuple:
    """``(turns_1 (n1, k l), turns_2 (n2, k l))``: at every vertex, the sine of the turn from the
    gradient of the distance to each of the k landmarks (``fields_i (n_i, k)``) to the gradient
    of each of the l lengths of the :func:`point_signature`, about the outward normal
    (:func:`~darcyan.dense.landmarks.orientation_coordinates`), times ``weight``
    (:func:`signature_turn_weight` gives a map's; ``(None, None)`` at weight 0). An isometry
    keeps them and a reflection flips them, like the turns between landmarks; unlike those,
    they do not vanish along a limb, where the directions to all the landmarks run along it and
    only the curvature tells one side of it from another."""
    if weight <= 0:
        return None, None
    return tuple(weight * orientation_coordinates(shape, fields, point_signature(shape, config))
                 for shape, fields in ((shape_1, fields_1), (shape_2, fields_2)))


def signature_turn_weight(landmarks: int, feature_counts: tuple, config: DenseConfig) -> float:
    """The weight of the :func:`signature_turn_coordinates` of a map with ``landmarks`` landmark
    pairs between shapes with ``feature_counts`` ``(k1, k2)`` feature points:
    ``config.signature_turns`` when there are at least as many landmarks as the shape with fewer
    feature points has (every extremity of it anchored; so too when the counts are not known,
    and for the landmarks of a start without the matches, farthest points spread over the whole
    source), ``config.signature_turns_partial`` otherwise: a map made without a landmark pair
    the others contradict has one pair fewer, and is weighed by its own count. The turns pull each vertex towards the side of
    its limb the curvature says; along a limb without a landmark nothing holds its place along
    the limb, and strong turns let the map slide there (``docs/decisions/every-pair.md``)."""
    if len(feature_counts) == 2 and landmarks < min(feature_counts):
        return config.signature_turns_partial
    return config.signature_turns


def signature_score(signature_1: np.ndarray, signature_at_images: np.ndarray, config: DenseConfig) -> float:
    """How far a map keeps the :func:`point_signature`: the ``config.seed_statistic`` (median or
    mean) over source points of the mean absolute difference between a point's signature
    ``(s, l)`` and its image's ``(s, l)`` (lower is better)."""
    difference = np.abs(signature_1 - signature_at_images).mean(axis=1)
    return float(np.median(difference) if config.seed_statistic == "median" else difference.mean())
