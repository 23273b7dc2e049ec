"""The curvature signature of a dense map (:mod:`darcyan.dense.signatures`)."""

import numpy as np
import pytest
from conftest import moved_and_mirrored_tip_fields

from darcyan.dense.config import DenseConfig
from darcyan.errors import ConfigError


def test_signature_turns_flip_in_a_mirror_stay_under_rigid_motion_and_scale_with_the_weight(figure_poses):
    from darcyan.dense.signatures import point_signature, signature_turn_coordinates

    turns = {}
    for name, shape, fields in moved_and_mirrored_tip_fields(figure_poses[0], seed=4):
        turns[name] = signature_turn_coordinates(shape, shape, DenseConfig(), fields, fields, 2.0)[0]
        if name == "as is":
            once = signature_turn_coordinates(shape, shape, DenseConfig(), fields, fields, 1.0)[0]
            assert turns[name].shape == (shape.n_vertices, 3 * len(point_signature(shape, DenseConfig())[0]))
            assert np.allclose(turns[name], 2.0 * once)
            assert signature_turn_coordinates(shape, shape, DenseConfig(), fields, fields, 0.0) == (None, None)
    assert np.abs(turns["as is"]).max() > 0.5  # not vacuous: the turns are not all zero
    assert np.allclose(turns["moved"], turns["as is"], atol=1e-6)
    assert np.allclose(turns["mirrored"], -turns["as is"], atol=1e-6)
    with pytest.raises(ConfigError, match="signature_turns"):
        DenseConfig(signature_turns=-1)
    with pytest.raises(ConfigError, match="signature_turns_partial"):
        DenseConfig(signature_turns_partial=-1)


def test_signature_turns_are_strong_only_when_every_extremity_is_anchored():
    """The full weight when the landmarks are at least as many as the feature points of the shape
    with fewer (or when the counts are not known), the partial weight when one is missing."""
    from darcyan.dense.signatures import signature_turn_weight

    config = DenseConfig(signature_turns=4.0, signature_turns_partial=1.5)
    assert signature_turn_weight(5, (5, 6), config) == 4.0  # the shape with fewer: all five anchored
    assert signature_turn_weight(5, (6, 6), config) == 1.5  # a tail left unmatched
    assert signature_turn_weight(3, (), config) == 4.0  # a user's own landmarks: nothing else known
    assert signature_turn_weight(6, (5, 5), config) == 4.0  # a start without the matches may find more


@pytest.mark.slow
def test_a_map_with_an_unanchored_extremity_uses_the_partial_turns(figure_pair):
    """The same landmarks between shapes said to have one feature point more than matched give the
    map of the partial weight, and with every feature point matched the map of the full weight."""
    import dataclasses

    from conftest import FAST_DENSE

    from darcyan.dense.maps import dense_map

    shape_1, shape_2, matches = figure_pair
    assert matches.feature_counts == (len(shape_1.description.feature_vertices),
                                      len(shape_2.description.feature_vertices))
    k = len(matches)
    full, partial = (dataclasses.replace(FAST_DENSE, signature_turns=w, signature_turns_partial=w) for w in (4.0, 1.0))
    mixed = dataclasses.replace(FAST_DENSE, signature_turns=4.0, signature_turns_partial=1.0)
    anchored = dataclasses.replace(matches, feature_counts=(k, k + 1), alternatives=())
    unanchored = dataclasses.replace(matches, feature_counts=(k + 1, k + 2), alternatives=())
    made = {name: dense_map(shape_1, shape_2, c, config).target
            for name, c, config in (("mixed anchored", anchored, mixed), ("mixed unanchored", unanchored, mixed),
                                    ("full", anchored, full), ("partial", anchored, partial))}
    assert not np.array_equal(made["full"], made["partial"])  # not vacuous: the weight changes the map
    assert np.array_equal(made["mixed anchored"], made["full"])
    assert np.array_equal(made["mixed unanchored"], made["partial"])
    # The landmarks are counted, not the matches: a sixth match that the consistency test drops
    # (the source's first tip sent to the target's second tip as well) leaves five landmarks of
    # six feature points, and the partial weight.
    extra = dataclasses.replace(anchored, source_vertex=np.append(matches.source_vertex, matches.source_vertex[0]),
                                target_vertex=np.append(matches.target_vertex, matches.target_vertex[1]),
                                distance=np.append(matches.distance, matches.distance.max()),
                                feature_counts=(k + 1, k + 1))
    dropped = dense_map(shape_1, shape_2, extra, mixed)
    assert len(dropped.landmarks) == k
    assert np.array_equal(dropped.target, made["partial"])


def test_signature_coordinates_have_the_configured_spread(figure_poses):
    from darcyan.dense.signatures import point_signature, signature_coordinates
    from darcyan.geometry.shape import prepare_shape

    shape_1, shape_2 = (prepare_shape(mesh) for mesh in figure_poses[:2])
    everywhere = np.arange(shape_1.n_vertices), np.arange(shape_2.n_vertices)
    config = DenseConfig(signature_weight=2.0)
    coarse_1, coarse_2 = signature_coordinates(shape_1, shape_2, config, *everywhere)
    assert np.allclose(np.concatenate([coarse_1, coarse_2]).std(axis=0), 2.0)
    ratio = coarse_1 / point_signature(shape_1, config)  # each length scaled by one number
    assert np.allclose(ratio, ratio[0], rtol=1e-9)
    assert signature_coordinates(shape_1, shape_2, DenseConfig(signature_weight=0), *everywhere) == (None, None)
    with pytest.raises(ConfigError, match="signature_weight"):
        DenseConfig(signature_weight=-1)
    with pytest.raises(ConfigError, match="signature_until"):
        DenseConfig(signature_until=-1)


def test_signature_score_by_median_ignores_a_region_that_changed():
    """A fifth of the points far off (a glued region whose curvature changed): the median of the
    points' differences stays that of the others, the mean follows the region."""
    from darcyan.dense.signatures import signature_score

    rng = np.random.default_rng(0)
    signature = rng.normal(size=(1000, 3))
    images = signature + 0.01 * rng.choice([-1.0, 1.0], size=signature.shape)  # every point 0.01 off
    images[:200] += 5.0
    assert signature_score(signature, images, DenseConfig(seed_statistic="median")) == pytest.approx(0.01)
    assert signature_score(signature, images, DenseConfig(seed_statistic="mean")) == pytest.approx(0.01 + 0.2 * 5.0,
                                                                                                 abs=0.02)
    with pytest.raises(ConfigError, match="seed_statistic"):
        DenseConfig(seed_statistic="mode")


def test_point_signature_follows_the_callers_curvature_smoothing():
    """A dense map's point signature uses the caller's curvature smoothing (issue 41), filled into
    the dense section by DarcyanConfig.dense_for; a standalone DenseConfig keeps the describe defaults."""
    import dataclasses

    from darcyan.config import DarcyanConfig, DenseConfig
    from darcyan.dense.signatures import point_signature
    from darcyan.geometry.shape import prepare_shape
    from darcyan.geometry.synthetic import figure

    assert DenseConfig().signature_smoothing is None
    assert DarcyanConfig().dense_for().signature_smoothing == DarcyanConfig().curvature_smoothing
    assert DarcyanConfig(curvature_smoothing=0).dense_for().signature_smoothing == 0
    # however the config was made: replace, updated (a --config file), the command's options
    assert DarcyanConfig().replace(curvature_smoothing=1).dense_for().signature_smoothing == 1
    assert DarcyanConfig().updated({"heat": {"diffusion_steps": 7}}).dense_for().signature_diffusion_steps == 7
    kept = DarcyanConfig(curvature_smoothing=0, dense=DenseConfig(signature_smoothing=2))
    assert kept.dense_for().signature_smoothing == 2  # a section's own value is not overwritten
    assert DarcyanConfig(curvature_smoothing=0).dense_for(DenseConfig()).signature_smoothing == 0
    shape = prepare_shape(figure(subdivisions=3))
    default = point_signature(shape, DarcyanConfig().dense_for())
    assert np.array_equal(default, point_signature(shape, DenseConfig()))
    raw = point_signature(shape, DarcyanConfig(curvature_smoothing=0).dense_for())
    assert raw.shape == default.shape and not np.allclose(raw, default)
    assert dataclasses.replace(DenseConfig(), signature_smoothing=0) != DenseConfig()
