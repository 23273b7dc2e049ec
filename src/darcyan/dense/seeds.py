"""The seed of a dense map: which matching (the sparse one or an alternative) it starts from.

The sparse matching competes with the alternatives the sparse stage weighed
(``Correspondence.alternatives``): each is turned into landmarks
(:func:`~darcyan.dense.landmarks.landmark_set`) and seeds a short ZoomOut, and the one whose map
best keeps the curvature signature
(:func:`~darcyan.dense.signatures.point_signature`) seeds the dense map. A mirrored seed keeps
every distance and, with the orientation coordinates, turns the body round, front onto back,
which the curvature of a face or a chest shows. :func:`verified_matches` gives that choice as
sparse matches, :func:`seed_scores` the scores it is made by.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from ..errors import DarcyanError
from ..geometry.knn import nearest_rows
from ..parallel import owns_threads
from .config import DenseConfig
from .landmarks import MIN_LANDMARKS, coordinates_of, landmark_set
from .signatures import point_signature, signature_score
from .zoomout import dense_basis, map_embeddings, seed_subset, zoomout, zoomout_samples


@owns_threads
def verified_matches(shape_1, shape_2, correspondence, config: DenseConfig = DenseConfig(),
                     full_basis: bool = False):
    """The matching a dense map would be seeded by: ``correspondence`` itself, or the alternative
    (``correspondence.alternatives``) whose short ZoomOut map keeps the curvature signature
    clearly better (see :class:`~darcyan.dense.config.DenseConfig`: ``candidates``, ``seed_margin``). Scored on a
    spectrum of the short ZoomOuts' size (:func:`seed_scoring_config`), where :func:`~darcyan.dense.maps.dense_map`
    scores on its full basis: the same seed on every pair compared (``docs/decisions/``), not
    by construction. Costs the two shapes' 30 first eigenfunctions and a short ZoomOut per
    candidate (choosing the seed of a 5k pair: 0.45 s, against 1.34 s on the full basis).
    ``full_basis``: score on the dense map's full basis instead, exactly as :func:`~darcyan.dense.maps.dense_map`
    does (when a dense map follows, which then reuses that basis).

    Returns ``(matches, about)``: a correspondence of the same kind as ``correspondence`` (its
    ``alternatives`` the others, the sparse matching first among them), and the
    :class:`SeedVerdict` as a dict (``seed``, ``signatures``, ``clear``: no other candidate
    within the margin; kept so in caches and JSON records).

    Raises:
        DarcyanError: when no candidate has :data:`~darcyan.dense.landmarks.MIN_LANDMARKS` consistent matches.
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    scoring, weighed = config, (shape_1, shape_2, correspondence)
    if not full_basis:
        scoring, weighed = seed_scoring_config(config), on_coarse_shapes(shape_1, shape_2, correspondence,
                                                                        config.verify_proxy_vertices)
    choice = choose_seed(*weighed, scoring, lambda stage: None, {}, spectral_start=False)
    verdict = check_of_seeds(choice.seed, choice.seeds, config.seed_margin)
    return matching_of_seed(correspondence, choice.seed.rank), verdict.as_dict()


def on_coarse_shapes(shape_1, shape_2, correspondence, vertices: int) -> tuple:
    """``(shape_1, shape_2, correspondence)`` with each shape of more than twice ``vertices``
    vertices replaced by its coarse copy (:meth:`~darcyan.geometry.shape.Shape.coarse_shape`) and
    the matchings' vertices (``correspondence`` and its ``alternatives``) moved to the copy's
    nearest ones: what a verification weighs its seeds on. A seed's short map is read at a
    thousand points, on smooth fields that the copy keeps (the basis and the signature of a
    large mesh come from that copy anyway), so the full mesh's fast marchings and per-vertex
    turns cost seconds for nothing (``docs/decisions/speed.md``). As given when ``vertices`` is
    0, no shape has a copy, or a matched vertex is not on its prepared mesh."""
    if vertices <= 0:
        return shape_1, shape_2, correspondence
    coarse = [shape.coarse_shape(vertices) for shape in (shape_1, shape_2)]
    if coarse == [None, None]:
        return shape_1, shape_2, correspondence
    matchings = [correspondence] + list(getattr(correspondence, "alternatives", ()))

    def carried(shape, copy, input_vertices):
        if copy is None:
            return np.asarray(input_vertices)
        local = shape.mesh_index(input_vertices)
        return None if (local < 0).any() else shape.proxy(vertices).nearest_vertices(local)

    moved = []
    for matching in matchings:
        source = carried(shape_1, coarse[0], matching.source_vertex)
        target = carried(shape_2, coarse[1], matching.target_vertex)
        if source is None or target is None:
            return shape_1, shape_2, correspondence
        moved.append(dataclasses.replace(matching, source_vertex=source, target_vertex=target, alternatives=()))
    first = dataclasses.replace(moved[0], alternatives=tuple(moved[1:]))
    return (coarse[0] or shape_1), (coarse[1] or shape_2), first


def seed_scoring_config(config: DenseConfig) -> DenseConfig:
    """``config`` with the basis cut to what scoring the seeds uses (``seed_basis``
    eigenfunctions, no margin): without a dense map to follow, a spectrum of that size is enough
    (choosing the seed of a 5k pair takes a third of the time). Its vectors are those of the full spectrum's first columns
    up to sign (which the short ZoomOuts' maps do not depend on), but for the last few, mixed
    with their neighbours beyond the cut: the seeds' scores move by up to 0.4% on the 5k sets'
    300 test pairs and 1.2% on 7 tosca-hires pairs, and the chosen seed is the same on all of
    them (``docs/decisions/``)."""
    short = min(config.seed_basis, config.basis_size)
    return dataclasses.replace(config, basis_size=short, basis_start=min(config.basis_start, short), basis_margin=0)


def matching_of_seed(correspondence, rank: int):
    """The matching of seed ``rank`` (0: ``correspondence`` itself; 1, 2, ...: its
    ``alternatives``), the others (the sparse matching first) as its alternatives."""
    matchings = [correspondence] + list(getattr(correspondence, "alternatives", ()))
    if not 0 <= rank < len(matchings):
        raise DarcyanError(f"seed {rank}: the matching has {len(matchings) - 1} alternatives")
    chosen = matchings[rank]
    if rank > 0:  # the sparse stage's doubt and margin are the matching's, whichever seed is taken
        chosen = dataclasses.replace(chosen, alternatives=tuple(m for m in matchings if m is not chosen),
                                     **{name: getattr(correspondence, name) for name in ("in_doubt", "margin", "to_verify")
                                        if hasattr(correspondence, name) and hasattr(chosen, name)})
    return chosen


def seed_scores(shape_1, shape_2, correspondence, config: DenseConfig = DenseConfig()) -> dict:
    """``{rank: score}``: the signature score of each usable seed (0: ``correspondence`` itself,
    1, 2, ...: its alternatives), lower is better; the scores :func:`~darcyan.dense.maps.dense_map` chooses its seed
    by (see :func:`chosen_seed`), without making the map (a map from them that is not trusted then
    meets the start without landmarks, :func:`rival_start`, not scored here). Raises DarcyanError like it."""
    return verified_matches(shape_1, shape_2, correspondence, config, full_basis=True)[1]["signatures"]


@dataclass(frozen=True)
class SeedVerdict:
    """Which seed a dense map (or a verification) took, and how plainly.

    Attributes:
        seed: the chosen seed's rank (0: the sparse matching; 1, 2, ...: its alternatives; one
            past them: the landmark-free start).
        seeds: how many usable, distinct seeds were weighed.
        signature: the chosen seed's signature score (lower is better; 0 when it had no rival
            and was not scored).
        runner_up: the best score of the others (``None`` without others).
        signatures: every usable seed's score (rank -> score).
        clear: whether no other seed scored within the margin (relative) of it.
        start: how the map was started: ``"matches"``, or ``"spectral"``: from the landmarks of
            the start without them (:mod:`darcyan.dense.start`), when no matching had three
            consistent landmarks, or when it won over a map from the matches that was not
            trusted (then ``rival`` is its rank).
        start_from: with a spectral start, the short map whose landmarks it used.
        rival: the rank of the start without landmarks when it competed with a map from the
            matches that was not trusted (``DenseConfig.start_in_doubt``; its score in
            ``signatures``), else ``None``.
        left_out: ``(source vertex, target vertex, displacement)`` (input numbering; sqrt(area)
            units) of the landmark pair the others contradicted (:func:`contradicted_landmark`),
            when the map made without it was taken, else ``None``.
        by_checks: the seed's map won by its own checks (orientation and residual), not by a
            clearly lower signature score: the start without landmarks'
            (``DenseConfig.rival_by_checks``), the sure sparse matching's over an alternative
            (``DenseConfig.rival_sure_matching``), or the best-scored seed's over the first
            seed the margin kept (``DenseConfig.rival_best_scored``).
        handles_cut: how many handles the map's shapes were cut open at: the map made on copies
            cut open (``DenseConfig.handle_length``) was taken over the map on the shapes as
            given, which was not trusted; 0 otherwise.
    """

    seed: int
    seeds: int
    signature: float
    runner_up: float | None
    signatures: dict
    clear: bool
    start: str = "matches"
    start_from: str = ""
    rival: int | None = None
    left_out: tuple | None = None
    by_checks: bool = False
    handles_cut: int = 0

    def as_dict(self) -> dict:
        """The fields as a dict (``start_from``, ``rival``, ``left_out``, ``by_checks`` and
        ``handles_cut`` only when set), as JSON records keep them."""
        fields = dataclasses.asdict(self)
        if not self.by_checks:
            del fields["by_checks"]
        if not self.handles_cut:
            del fields["handles_cut"]
        if not self.start_from:
            del fields["start_from"]
        if self.rival is None:
            del fields["rival"]
        if self.left_out is None:
            del fields["left_out"]
        else:
            fields["left_out"] = list(self.left_out)
        return fields


def seed_check(rank: int, signatures: dict, margin: float, start: str = "matches", start_from: str = "",
               rival: int | None = None) -> SeedVerdict:
    """The :class:`SeedVerdict` of the chosen seed's ``rank`` given every usable seed's score
    (``signatures``: rank -> score): ``clear`` when no other seed scores within ``margin``
    (relative) of it."""
    others = sorted(score for r, score in signatures.items() if r != rank)
    return SeedVerdict(rank, len(signatures), signatures[rank], others[0] if others else None, dict(signatures),
                       bool(not others or signatures[rank] <= (1.0 - margin) * others[0]), start, start_from, rival)


def check_of_seeds(seed, seeds: list, margin: float) -> SeedVerdict:
    """The :class:`SeedVerdict` of ``seed`` among the usable ``seeds`` (:class:`Seed` each)."""
    return seed_check(seed.rank, {s.rank: s.signature for s in seeds}, margin, seed.start, seed.start_from)


@dataclass(frozen=True)
class SeedChoice:
    """What :func:`choose_seed` decided: the ``seed`` chosen among the usable ``seeds``
    (:class:`Seed` each), and both shapes' ZoomOut ``samples`` ``((s_1,), (s_2,))`` and ``bases``
    ``((n_1, K), (n_2, K))`` the dense map goes on with (``(None, None)`` when none was needed),
    and ``feature_counts`` ``(k1, k2)``, the shapes' feature points (the correspondence's; empty:
    not known)."""

    seed: "Seed"
    seeds: list
    samples: tuple
    bases: tuple
    feature_counts: tuple = ()


def choose_seed(shape_1, shape_2, correspondence, config: DenseConfig, say, timings: dict,
                spectral_start: bool = True) -> SeedChoice:
    """The :class:`SeedChoice`: the ZoomOut samples and bases of both shapes, the usable seeds
    and the one chosen (see :func:`_chosen_seed`). When no matching gives
    :data:`~darcyan.dense.landmarks.MIN_LANDMARKS` consistent landmarks and ``spectral_start``,
    the one seed is the landmarks a short spectral map finds
    (:func:`~darcyan.dense.start.spectral_matching`; its ``start`` is ``"spectral"``)."""
    for shape in (shape_1, shape_2):
        if not hasattr(shape, "mesh_index"):
            raise DarcyanError(f"{shape.name}: a dense map works on prepared shapes, not on a description "
                               f"(darcyan.load_shape(path) or darcyan.prepare_shape(mesh) gives one)")
    t = time.perf_counter()
    samples = zoomout_samples(shape_1, shape_2, config)
    bases = (None, None)
    if config.method == "zoomout" or config.candidates > 1:
        say("basis")
        bases = dense_basis(shape_1, config), dense_basis(shape_2, config)
    timings["basis"] = time.perf_counter() - t
    t = time.perf_counter()
    say("landmarks")
    fields = ({}, {})
    seeds = _seeds(shape_1, shape_2, correspondence, config, samples, bases, fields)
    if not seeds and spectral_start:
        say("spectral start (too few consistent landmarks)")
        if bases[0] is None:
            bases = dense_basis(shape_1, config), dense_basis(shape_2, config)
        seeds = _spectral_seeds(shape_1, shape_2, correspondence, config, samples, bases, fields)
    if not seeds:
        raise DarcyanError(f"{shape_1.name} -> {shape_2.name}: fewer than {MIN_LANDMARKS} consistent landmark "
                           f"matches, a dense map needs at least {MIN_LANDMARKS}")
    timings["landmarks"] = time.perf_counter() - t
    return SeedChoice(_chosen_seed(seeds, config.seed_margin), seeds, samples, bases,
                      tuple(getattr(correspondence, "feature_counts", ())))


@dataclass(frozen=True)
class Seed:
    """One candidate matching turned into landmarks and their coordinates on both shapes
    (``(n, c)``), with the mean difference of the point signatures between source points and
    their images under a short ZoomOut from it (``signature``, lower is better; 0 when the
    matching has no alternatives). A seed that can no longer be chosen keeps its rank, landmarks
    and score, its per-vertex arrays ``None``."""

    rank: int
    source: np.ndarray
    target: np.ndarray
    fields_1: np.ndarray
    fields_2: np.ndarray
    turns_1: np.ndarray
    turns_2: np.ndarray
    coords_1: np.ndarray
    coords_2: np.ndarray
    signature: float
    start: str = "matches"
    start_from: str = ""


# A Seed's per-vertex arrays: dropped (None) from a seed that lost (its rank and score kept).
_PER_VERTEX = ("fields_1", "fields_2", "turns_1", "turns_2", "coords_1", "coords_2")


def _chosen_seed(seeds: list, margin: float) -> Seed:
    """The seed :func:`chosen_seed` picks by the seeds' signature scores."""
    return seeds[chosen_seed([s.signature for s in seeds], margin)]


def chosen_seed(scores: list, margin: float) -> int:
    """Index of the seed that seeds the map, given each usable seed's signature score (the
    sparse matching's first, when usable): the lowest score, unless it beats the first by less
    than ``margin`` (relative): then the first."""
    best = min(range(len(scores)), key=lambda i: scores[i])
    return best if scores[best] < (1.0 - margin) * scores[0] else 0


def _spectral_seeds(shape_1, shape_2, correspondence, config: DenseConfig, samples: tuple, bases: tuple,
                    fields: tuple) -> list:
    """``[seed]`` from the landmarks of :func:`~darcyan.dense.start.spectral_matching` (``[]``
    when the bases are too small for it), its rank one past the matchings'. The one or two
    matches the matching keeps do not join its short maps: too few to be checked against each
    other, a wrong one among them led the maps astray on glued copies of FAUST."""
    from .start import spectral_matching

    matching = spectral_matching(shape_1, shape_2, config, samples, bases, fields)
    if matching is None:
        return []
    landmarks = landmark_set(shape_1, shape_2, matching, config, fields)
    if landmarks is None:  # the map's own landmarks disagree: keep them all
        landmarks = landmark_set(shape_1, shape_2, matching, dataclasses.replace(config, landmarks="all"), fields)
    if landmarks is None:
        return []
    rank = 1 + len(getattr(correspondence, "alternatives", ()))
    return [Seed(rank, *landmarks, matching.signature, start="spectral", start_from=matching.start)]


def rival_start(shape_1, shape_2, correspondence, config: DenseConfig, choice: SeedChoice,
                scored: bool = True) -> tuple | None:
    """The start without landmarks as a rival of ``choice.seed`` (a map from the matches in doubt,
    ``DenseConfig.start_in_doubt``): ``(rival, rival_score, chosen_score)``, the
    :func:`_spectral_seeds` seed and both seeds' signature scores by one short ZoomOut each from
    their landmark coordinates, as :func:`_seeds` scores the matchings (``scored``: whether the
    chosen seed's ``signature`` is such a score already; a lone matching's seed is not scored),
    or ``None`` when the bases are too small for the start."""
    rivals = _spectral_seeds(shape_1, shape_2, correspondence, config, choice.samples, choice.bases, ({}, {}))
    if not rivals:
        return None
    scoring = _SeedScoring(shape_1, shape_2, config, choice.samples, choice.bases)
    rival, seed = rivals[0], choice.seed
    chosen_score = seed.signature if scored else scoring.score(seed.coords_1, seed.coords_2)
    return rival, scoring.score(rival.coords_1, rival.coords_2), chosen_score


def _seeds(shape_1, shape_2, correspondence, config: DenseConfig, samples: tuple, bases: tuple,
           fields: tuple | None = None) -> list:
    """The usable seeds among the correspondence and its first ``config.candidates - 1``
    alternatives (``correspondence.alternatives``, the other matchings the sparse stage
    weighed). With several, each seeds a short ZoomOut (``config.seed_basis`` eigenfunctions,
    ``config.seed_samples`` of the samples) scored by how well its map keeps the shapes'
    :func:`~darcyan.dense.signatures.point_signature`: a seed of mirrored landmarks yields a map that keeps their
    orientation only by turning the body round (front onto back), which no landmark coordinate
    sees and the curvature of a face or a chest does. A matching whose consistent landmarks are
    those of an earlier one is left out."""
    matchings = [correspondence] + list(getattr(correspondence, "alternatives", ()))[:max(config.candidates - 1, 0)]
    fields = ({}, {}) if fields is None else fields
    seeds = []
    seen = set()
    scoring = None
    turns = ({}, {})  # the landmark pairs' turns, made once for all the matchings
    for rank, matching in enumerate(matchings):
        landmarks = landmark_set(shape_1, shape_2, matching, config, fields, turns)
        if landmarks is None:
            continue
        # Matchings that differ only in matches the consistency test drops are one seed (the
        # same map): counted twice, a seed would be its own runner-up and never "clear".
        pairs = tuple(sorted(zip(landmarks[0].tolist(), landmarks[1].tolist())))
        if pairs in seen:
            continue
        seen.add(pairs)
        coords_1, coords_2 = landmarks[-2:]
        score = 0.0
        if len(matchings) > 1:
            if scoring is None:
                scoring = _SeedScoring(shape_1, shape_2, config, samples, bases)
            score = scoring.score(coords_1, coords_2)
        seeds.append(Seed(rank, *landmarks, score))
        seeds = _without_losers(seeds, config.seed_margin)
    return seeds


def best_scored(seeds: list) -> int:
    """Index in ``seeds`` (:class:`Seed` each) of the lowest signature score, the first of
    equal ones: the seed :func:`_without_losers` keeps beside the first (a map in doubt may
    still be made from it, ``DenseConfig.rival_best_scored``)."""
    return min(range(len(seeds)), key=lambda i: seeds[i].signature)


def _without_losers(seeds: list, margin: float) -> list:
    """``seeds`` with the per-vertex arrays of those that can no longer be chosen let go (kept:
    the first, which wins ties within the margin, and the lowest score so far): on a 210k mesh
    each seed's coordinates take 200 MB."""
    if len(seeds) < 3:
        return seeds
    best = best_scored(seeds)
    return [seed if i in (0, best) or seed.fields_1 is None else dataclasses.replace(seed, **dict.fromkeys(_PER_VERTEX))
            for i, seed in enumerate(seeds)]


class _SeedScoring:
    """What scoring a seed needs, built once per pair: ``seed_samples`` of the ZoomOut samples
    (:func:`~darcyan.dense.zoomout.seed_subset`), the bases there and the point signatures."""

    def __init__(self, shape_1, shape_2, config: DenseConfig, samples: tuple, bases: tuple):
        size = min(config.seed_basis, config.basis_size)
        self.config = dataclasses.replace(config, basis_size=size, basis_start=min(config.basis_start, size),
                                          basis_margin=0)
        self.points = []
        for shape, sample in zip((shape_1, shape_2), samples):
            self.points.append(seed_subset(shape, sample, config.seed_samples, config))
        self.bases = [basis[points, :self.config.basis_size] for basis, points in zip(bases, self.points)]
        self.signatures = [point_signature(shape, config)[points] for shape, points in zip((shape_1, shape_2),
                                                                                          self.points)]

    def score(self, coords_1: np.ndarray, coords_2: np.ndarray) -> float:
        """The signature score (lower is better) of the short map from landmark coordinates
        ``coords_i (n_i, c)``."""
        return signature_score(self.signatures[0], self.signatures[1][self.short_map(coords_1, coords_2)], self.config)

    def short_map(self, coords_1: np.ndarray, coords_2: np.ndarray, sampled: bool = False) -> np.ndarray:
        """``(p_1,)`` the short ZoomOut map from landmark coordinates ``coords_i (n_i, c)`` (with
        ``sampled``, ``(p_i, c)``: at the scoring points already), from each of shape 1's
        scoring points to one of shape 2's (positions in ``points``)."""
        (p_1, p_2), (b_1, b_2) = self.points, self.bases
        f_1, f_2 = (coords_1, coords_2) if sampled else (coords_1[p_1], coords_2[p_2])
        c_12, c_21 = zoomout(b_1, b_2, nearest_rows(f_2, f_1), nearest_rows(f_1, f_2), self.config, f_1, f_2)
        return map_embeddings(b_1, b_2, c_12, c_21, self.config, f_1, f_2).nearest()


def contradicted_landmark(shape_1, shape_2, seed: Seed, config: DenseConfig, samples: tuple,
                          bases: tuple) -> tuple[int, float] | None:
    """``(i, displacement)``: the landmark pair of ``seed`` (position ``i`` in ``seed.source``)
    that the others contradict most (the largest of :func:`landmark_displacements`), or
    ``None`` for a seed of fewer than ``MIN_LANDMARKS + 1`` pairs (leaving one out would leave
    too few)."""
    displacements = landmark_displacements(shape_1, shape_2, seed, config, samples, bases)
    if displacements is None:
        return None
    worst = int(np.argmax(displacements))
    return worst, float(displacements[worst])


def landmark_displacements(shape_1, shape_2, seed: Seed, config: DenseConfig, samples: tuple,
                           bases: tuple) -> np.ndarray | None:
    """``(k,)`` for each landmark pair of ``seed``, how far the others contradict it: the
    geodesic distance (sqrt(area) units) on shape 2 from its target to where the short ZoomOut
    map seeded by the other pairs alone sends its source (the scoring point nearest it, as
    :class:`_SeedScoring` maps them). A wrong pair the consistency test kept (a front paw sent
    to the other, whose distances to the remaining landmarks are alike by symmetry) is sent far
    from its target by the others; a right one stays near it, but for a thin part no other
    landmark holds in place (a tail tip: up to 0.19 on tosca-5k's dogs), or one whose short map
    lost it (measured with ``benchmarks/landmark_check.py``: ``docs/decisions/every-pair.md``).
    ``None`` for a seed of fewer than ``MIN_LANDMARKS + 1`` pairs. Costs one short ZoomOut per
    pair (the coordinates are the seed's own columns)."""
    count = len(seed.source)
    if count < MIN_LANDMARKS + 1 or seed.fields_1 is None:
        return None
    scoring = _SeedScoring(shape_1, shape_2, config, samples, bases)
    p_1, p_2 = scoring.points
    fields_1, turns_1, fields_2, turns_2 = seed.fields_1[p_1], seed.turns_1[p_1], seed.fields_2[p_2], seed.turns_2[p_2]
    out = np.empty(count)
    for i in range(count):
        others = np.delete(np.arange(count), i)
        map_12 = scoring.short_map(_coordinates(fields_1, turns_1, others, config),
                                   _coordinates(fields_2, turns_2, others, config), sampled=True)
        nearest = int(np.argmin(fields_1[:, i]))  # the scoring point nearest the source landmark
        out[i] = fields_2[map_12[nearest], i]
    return out


def without_landmark(seed: Seed, i: int, config: DenseConfig) -> Seed:
    """``seed`` without its landmark pair ``i``: the other pairs' distance and turn columns (the
    turns are computed pair by pair, so these are exactly what
    :func:`~darcyan.dense.landmarks.landmark_set` makes of the others); its rank kept, its
    signature score 0 (not scored)."""
    others = np.delete(np.arange(len(seed.source)), i)
    pairs = _pair_columns(len(seed.source), others)
    fields_1, fields_2 = seed.fields_1[:, others], seed.fields_2[:, others]
    turns_1, turns_2 = seed.turns_1[:, pairs], seed.turns_2[:, pairs]
    return Seed(seed.rank, seed.source[others], seed.target[others], fields_1, fields_2, turns_1, turns_2,
                coordinates_of(fields_1, turns_1, config), coordinates_of(fields_2, turns_2, config), 0.0,
                seed.start, seed.start_from)


def _pair_columns(count: int, kept: np.ndarray) -> np.ndarray:
    """Columns of :func:`~darcyan.dense.landmarks.orientation_coordinates`' ``(a, b)`` pairs of
    ``count`` landmarks (``np.triu_indices`` order) whose two landmarks are both among ``kept``
    (ascending, as ``np.delete`` leaves them): the order the kept landmarks' own pairs take."""
    a, b = np.triu_indices(count, k=1)
    return np.flatnonzero(np.isin(a, kept) & np.isin(b, kept))


def _coordinates(fields: np.ndarray, turns: np.ndarray, kept: np.ndarray, config: DenseConfig) -> np.ndarray:
    """The landmark coordinates (:func:`~darcyan.dense.landmarks.coordinates_of`) of the ``kept``
    landmarks (ascending) only, from all landmarks' distances ``(n, k)`` and turns ``(n, k (k - 1) / 2)``."""
    return coordinates_of(fields[:, kept], turns[:, _pair_columns(fields.shape[1], kept)], config)
