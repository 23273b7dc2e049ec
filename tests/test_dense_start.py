"""The landmark-free start (:mod:`darcyan.dense.start`): every pair gets a map, even when the
sparse matches give fewer than three consistent landmarks."""

import dataclasses

import numpy as np
import pytest
from conftest import DENSE_MAX_MEAN, DENSE_MIN_RATE, DENSE_SCORED, FAST_DENSE, moved_and_mirrored_tip_fields, tip_correspondence

from darcyan.api import matches_of_map
from darcyan.cli import main
from darcyan.dense.landmarks import orientation_coordinates
from darcyan.dense.maps import dense_map, matching_of_map
from darcyan.dense.start import map_orientation, spectral_matching
from darcyan.dense.zoomout import dense_basis, zoomout_samples
from darcyan.eval.dense_scores import evaluate_dense
from darcyan.geometry import synthetic


def test_map_orientation_is_one_for_a_motion_and_minus_one_for_a_reflection():
    # The same vertices, moved rigidly or mirrored (faces flipped to keep the normals outward):
    # the identity map keeps the turns between the directions to the tips, or reverses them all.
    copies = moved_and_mirrored_tip_fields(synthetic.figure(0), seed=3)
    (_, shape, fields), *others = copies
    turns = orientation_coordinates(shape, fields)
    for name, other, other_fields in others:
        value = map_orientation(turns, orientation_coordinates(other, other_fields))
        assert value == pytest.approx(1.0 if name == "moved" else -1.0, abs=0.02), name
    # A map unrelated to its landmarks is near 0.
    rng = np.random.default_rng(0)
    assert abs(map_orientation(turns, turns[rng.permutation(len(turns))])) < 0.1


@pytest.mark.slow
@pytest.mark.parametrize("given", [0, 2])
def test_too_few_landmarks_still_give_a_right_map(figure_pair, given):
    """With no or 2 matched tips (fewer than three consistent landmarks) the map starts from the
    spectra and still lands where the shared numbering says (identity truth)."""
    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()[:given]
    result = dense_map(shape_1, shape_2, tip_correspondence(tips, tips), FAST_DENSE)
    assert result.check.start == "spectral" and len(result.landmarks) >= 3
    score = evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, sample=DENSE_SCORED, target_solver=shape_2.solver)
    assert score.rate >= DENSE_MIN_RATE and score.mean <= DENSE_MAX_MEAN
    assert result.check.orientation > 0.5
    assert not result.check.trusted  # landmarks from a short map nothing else checked
    assert "landmark check" in result.timings  # its landmark pairs checked against each other


@pytest.mark.slow
def test_the_spectral_start_rejects_the_mirrored_short_maps(figure_pair):
    """Of the 2^d sign choices, the chosen one keeps the orientation, and its landmarks are the
    source points' true images (shared numbering) to within a short map's accuracy."""
    shape_1, shape_2 = figure_pair[0].shape, figure_pair[1].shape
    samples = zoomout_samples(shape_1, shape_2, FAST_DENSE)
    bases = dense_basis(shape_1, FAST_DENSE), dense_basis(shape_2, FAST_DENSE)
    matching = spectral_matching(shape_1, shape_2, FAST_DENSE, samples, bases)
    assert matching.orientation > 0.5 and len(matching.source_vertex) == FAST_DENSE.start_landmarks
    truth = shape_2.solver
    errors = [truth.distance(int(s))[int(t)] / np.sqrt(shape_2.mesh.area())
              for s, t in zip(matching.source_vertex, matching.target_vertex)]
    assert np.median(errors) < 0.05


@pytest.mark.slow
def test_cli_dense_truth_prints_the_dense_score(small_pose_files, capsys, tmp_path):
    code = main(["match", *map(str, small_pose_files), "--dense", "--truth", "identity", "-o", str(tmp_path / "m.csv")])
    assert code == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if "vertices within" in x)
    within, total = (int(x) for x in line.split("dense map: ")[1].split(" vertices")[0].split(" of "))
    assert total > 0 and within / total >= DENSE_MIN_RATE and "mean error" in line
    assert "dense map trusted" in err  # said of every map, trusted or not


@pytest.mark.slow
def test_a_wrong_matching_gives_way_to_the_start_without_landmarks(figure_pair):
    """Every tip matched to the next one round (all kept: ``landmarks="all"``): the map from
    them is not trusted, the start without landmarks competes, scores lower, and its map is
    right (identity truth); without the rival the map is wholly wrong, so the test can fail."""
    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()
    wrong = tip_correspondence(tips, np.roll(tips, -1))
    config = dataclasses.replace(FAST_DENSE, landmarks="all")

    def rate(result):
        return evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, sample=DENSE_SCORED,
                              target_solver=shape_2.solver).rate

    result = dense_map(shape_1, shape_2, wrong, config)
    assert result.check.start == "spectral" and "rival start" in result.timings
    verdict = result.check.verdict
    assert verdict.seed == verdict.rival == 1 and set(verdict.signatures) == {0, 1}
    assert not verdict.by_checks  # taken by its signature
    assert rate(result) >= DENSE_MIN_RATE
    alone = dense_map(shape_1, shape_2, wrong, dataclasses.replace(config, start_in_doubt=False, landmark_contradiction=0.0))
    assert alone.check.start == "matches" and not alone.check.trusted and rate(alone) < 0.2
    # The feature matches are read back from the map that won: right (the shared numbering) where
    # the wrong matching had none right, that matching kept as the first alternative.
    read = matching_of_map(wrong, result, shape_1.description, shape_2.description, shape_2.shape)
    assert len(read) >= 3 and read.alternatives[0] is wrong
    assert max(_errors(shape_2, read)) < 0.05 and min(_errors(shape_2, wrong)) > 0.05
    assert matches_of_map(wrong, result, shape_1.description, shape_2.description, shape_2.shape).source_vertex.tolist() \
        == read.source_vertex.tolist()
    assert matches_of_map(wrong, result) is wrong  # without the descriptions: as they were


def _errors(shape_2, matches) -> list:
    """Geodesic error (sqrt(area) units) of each match on the figure's poses, whose vertex
    numbering is shared (a source vertex's truth is the same vertex of the target)."""
    solver, scale = shape_2.shape.solver, np.sqrt(shape_2.shape.mesh.area())
    return [solver.distance(int(s))[int(t)] / scale for s, t in zip(matches.source_vertex, matches.target_vertex)]


@pytest.mark.slow
def test_a_trusted_map_is_not_put_in_competition(figure_pair):
    """The figure's own matches give a trusted map: the start without landmarks is not tried."""
    shape_1, shape_2, matches = figure_pair
    result = dense_map(shape_1, shape_2, matches, FAST_DENSE)
    assert result.check.trusted and result.check.start == "matches"
    assert "rival start" not in result.timings and "landmark check" not in result.timings
    assert max(result.check.verdict.signatures) <= len(matches.alternatives)  # no rank past the matchings


def test_the_rival_passes_the_checks_only_by_beating_the_map_on_both():
    """``rival_by_checks``: orientation at least ``trust_orientation`` and residual at most
    ``trust_residual`` (a trusted map's), and both better than the map from the matches."""
    from darcyan.dense.maps import MapCheck, _passes_checks
    from darcyan.dense.seeds import SeedVerdict

    config = FAST_DENSE
    verdict = SeedVerdict(0, 1, 0.0, None, {0: 0.0}, True)
    chosen = MapCheck(0.5, 0.05, verdict, residual=0.010)
    right = MapCheck(0.8, 0.04, verdict, residual=0.007)
    assert _passes_checks(right, chosen, config)
    assert not _passes_checks(dataclasses.replace(right, orientation=config.trust_orientation - 0.01), chosen, config)
    # above the trust's ceiling, though below the chosen map's: refused by the ceiling alone
    assert not _passes_checks(dataclasses.replace(right, residual=config.trust_residual + 0.001),
                              dataclasses.replace(chosen, residual=config.trust_residual + 0.01), config)
    assert not _passes_checks(right, dataclasses.replace(chosen, orientation=0.9), config)
    assert not _passes_checks(right, dataclasses.replace(chosen, residual=0.006), config)
    assert not _passes_checks(dataclasses.replace(right, residual=np.nan), dataclasses.replace(chosen, residual=np.nan),
                              config)  # without alignment: never


@pytest.mark.slow
def test_a_rival_the_signature_does_not_choose_is_taken_by_the_checks(figure_pair, monkeypatch):
    """The wrong matching of the test above, with the start without landmarks scored no better
    than it (so that the signature does not choose it): its map is made anyway and taken,
    being right where the matches' map is wholly wrong; with ``rival_by_checks`` off it is not."""
    import darcyan.dense.maps as maps

    shape_1, shape_2, _ = figure_pair
    tips = synthetic.figure_tips()
    wrong = tip_correspondence(tips, np.roll(tips, -1))
    real = maps.rival_start

    def tied(*args, **kwargs):
        rival, _, chosen_score = real(*args, **kwargs)
        return rival, chosen_score, chosen_score

    monkeypatch.setattr(maps, "rival_start", tied)
    # The matches' map is wholly wrong: the rival overturns all of it, which the checks alone may
    # not decide (rival_agreement); without that guard they do.
    config = dataclasses.replace(FAST_DENSE, landmarks="all", landmark_contradiction=0.0, rival_agreement=0.0)

    def rate(result):
        return evaluate_dense(shape_1.mesh, shape_2.mesh, result.target, sample=DENSE_SCORED,
                              target_solver=shape_2.solver).rate

    taken = dense_map(shape_1, shape_2, wrong, config)
    assert taken.check.start == "spectral" and not taken.check.trusted and rate(taken) >= DENSE_MIN_RATE
    assert taken.check.verdict.by_checks and taken.check.as_dict()["by_checks"] is True
    from darcyan.cli import _seed_verdict

    assert "agrees better with its landmarks' orientation" in _seed_verdict(taken.check.as_dict())
    kept = dense_map(shape_1, shape_2, wrong, dataclasses.replace(config, rival_by_checks=False))
    assert kept.check.start == "matches" and rate(kept) < 0.2
    guarded = dense_map(shape_1, shape_2, wrong, dataclasses.replace(config, rival_agreement=0.5))
    assert guarded.check.start == "matches" and rate(guarded) < 0.2


def test_two_maps_agree_where_their_images_lie_within_the_radius():
    """On a unit disc (area pi: its own sqrt(area) units after preparation), a map moving every
    vertex by a distance well below the radius agrees with the identity everywhere, one moving
    it by well above nowhere but near the rim, where the nearest vertex stays close."""
    from darcyan.dense.maps import map_agreement
    from darcyan.geometry.knn import nearest_rows
    from darcyan.geometry.shape import prepare_shape

    shape = prepare_shape(synthetic.flat_disc(rings=30))
    v = shape.mesh.vertices
    identity = np.arange(shape.mesh.n_vertices)
    assert map_agreement(shape, shape, identity, identity, 0.05) == pytest.approx(1.0)
    for shift, low, high in ((0.02, 0.999, 1.0), (0.3, 0.0, 0.05)):
        moved = nearest_rows(v, v + [shift, 0.0, 0.0])
        share = map_agreement(shape, shape, identity, moved, 0.05)
        assert low <= share <= high, (shift, share)
