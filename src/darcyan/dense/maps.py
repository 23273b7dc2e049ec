"""Dense correspondence: a target vertex for every source vertex, seeded by the sparse matches.

:func:`dense_map` puts the parts together, each in a module of its own:

1. the seed (:mod:`darcyan.dense.seeds`): the sparse matching or one of its alternatives, the
   one whose short ZoomOut best keeps the curvature signature (:mod:`darcyan.dense.signatures`;
   when an alternative's map is not trusted and the sparse stage was sure of its matching, that
   matching's own map is taken if its checks beat it, ``DenseConfig.rival_sure_matching``; when
   the first seed's map, which ``seed_margin`` kept over a seed that scored a little lower, is
   not trusted, that seed's map is taken if its checks beat it, ``DenseConfig.rival_best_scored``),
   or, when none gives three consistent landmarks, the landmarks of a short map started from
   the spectra or the axes of inertia (:mod:`darcyan.dense.start`); when the map from the
   matches (or from that start) is not trusted, a landmark pair the others contradict is left
   out (``DenseConfig.landmark_contradiction``), then that start competes with its seed, scored
   alike, and its map is taken when it scores clearly better and the alignment follows it more
   closely (``DenseConfig.start_in_doubt``), or else when its own checks beat the first map's
   and the two maps agree on half the surface (``DenseConfig.rival_by_checks``);
2. its landmarks (:mod:`darcyan.dense.landmarks`): the consistent matches, and each vertex's
   distances to them and their turns, whose nearest neighbours on the other shape give the
   first maps in both directions;
3. bijective ZoomOut (:mod:`darcyan.dense.zoomout`) from those maps, on surface samples, with
   the landmark coordinates, the curvature signature in the coarse steps and its turns beside
   the spectral terms; the final map is read out for every source vertex. Plain ZoomOut drifts
   on the less isometric TOSCA pairs (cat); the bijectivity term holds it.
4. its alignment (:mod:`darcyan.dense.alignment`): the source deformed as rigidly as possible
   onto the map's images, each vertex then sent to the nearest target vertex in space.

``DenseMap.check`` says which seed was used, how far the map keeps its landmarks' orientation
(:func:`map_check`) and whether it is trusted. :func:`pyfm_own_map` is pyFM's own pipeline
without darcyan's landmarks, the baseline of ``darcyan bench --dense``; maps are scored by
:mod:`darcyan.eval.dense_scores`.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import DarcyanError
from ..geometry.knn import nearest_rows
from ..geometry.mesh import Mesh
from ..parallel import owns_threads
from .alignment import align
from .config import DenseConfig
from .landmarks import distance_fields
from .pyfm import DENSE_PIPELINE, pyfm_point_map
from .seeds import SeedVerdict, best_scored, check_of_seeds, choose_seed, contradicted_landmark, rival_start, seed_check, without_landmark
from .signatures import point_signature, signature_coordinates, signature_turn_coordinates, signature_turn_weight
from .zoomout import consensus_map, dense_eigenvalues, dense_spectrum, read_out_map, zoomout, zoomout_samples

UNMAPPED = -1  # source vertices the analysis left out (outside the largest component)
# What a dense map may raise on a pair it cannot map (too few consistent landmarks, an eigensolver
# that does not converge): callers report it and go on (the bench records the pair as failed).
DENSE_FAILURES = (DarcyanError, ArithmeticError, ValueError, RuntimeError, np.linalg.LinAlgError)


@dataclass(frozen=True)
class MapCheck:
    """What a dense map's own checks say of it.

    Attributes:
        orientation: the area-weighted agreement in [-1, 1] of the landmarks' orientation
            coordinates at each vertex and its image (1: kept everywhere, -1: a mirror image;
            :func:`map_check`).
        distortion: the area-weighted mean change of the geodesic distances to the landmarks
            from a vertex to its image (sqrt(area) units).
        verdict: which seed the map took and how plainly
            (:class:`~darcyan.dense.seeds.SeedVerdict`: ``seed``, ``signatures``, ``clear``,
            ``start``, ...).
        trusted: whether the map is trusted (:func:`trusted`).
        residual: how far the alignment's as-rigid-as-possible deformation of the source stayed
            from the images it was pulled towards (sqrt(area) units; NaN without alignment;
            :class:`~darcyan.dense.alignment.Alignment`).
        doubts: why it is not trusted, one phrase per condition it fails
            (:func:`distrust_reasons`; empty when trusted).
    """

    orientation: float
    distortion: float
    verdict: SeedVerdict
    trusted: bool = False
    residual: float = float("nan")
    doubts: tuple = ()

    @property
    def seed(self) -> int:
        """The chosen seed's rank (0: the sparse matching)."""
        return self.verdict.seed

    @property
    def start(self) -> str:
        """How the map was started: ``"matches"`` or ``"spectral"``."""
        return self.verdict.start

    def as_dict(self) -> dict:
        """Flat, as JSON records keep it: ``orientation``, ``distortion``, the verdict's fields,
        ``trusted``, ``residual`` (``None`` for NaN) and ``doubts`` (a list)."""
        residual = None if np.isnan(self.residual) else self.residual  # JSON has no NaN
        return {"orientation": self.orientation, "distortion": self.distortion, **self.verdict.as_dict(),
                "trusted": self.trusted, "residual": residual, "doubts": list(self.doubts)}


@dataclass
class DenseMap:
    """A dense map and how it was made.

    Attributes:
        target: ``(n1,) int64``, for each source vertex (input numbering) a target vertex (input
            numbering), :data:`UNMAPPED` for source vertices outside the analysed mesh.
        landmarks: ``(k, 2) int64`` (source, target) landmark pairs used, input numbering.
        timings: seconds per stage.
        check: the map's :class:`MapCheck` (orientation, distortion, the seed's verdict, trust);
            ``None`` for a map made without darcyan's checks (:func:`pyfm_own_map`).
    """

    target: np.ndarray
    landmarks: np.ndarray
    timings: dict = field(default_factory=dict)
    check: MapCheck | None = None


@owns_threads
def dense_map(shape_1, shape_2, correspondence, config: DenseConfig = DenseConfig(),
              progress=None) -> DenseMap:
    """A target vertex for every source vertex, seeded by sparse ``correspondence``.

    Args:
        shape_1: the prepared source shape (:class:`~darcyan.geometry.shape.Shape`, or a
            :class:`~darcyan.method.pipeline.ShapeAnalysis`, whose shape is used): its area-1
            mesh, geodesic solver and spectrum.
        shape_2: the prepared target shape, likewise.
        correspondence: anything with ``source_vertex (k,)`` and ``target_vertex (k,)`` in input
            numbering (a :class:`~darcyan.method.pipeline.Correspondence`; ``distance (k,)``
            breaks ties between landmark sets).
        config: see :class:`~darcyan.dense.config.DenseConfig`.

    Returns:
        a :class:`DenseMap`; ``.target`` is ``(n_input_vertices of shape_1,) int64`` in the input
        numbering of shape 2 (:data:`UNMAPPED` for vertices outside the analysed mesh).

    Raises:
        DarcyanError: when a shape is a description only, or too small for any start. A
            correspondence with fewer than :data:`~darcyan.dense.landmarks.MIN_LANDMARKS`
            consistent landmark pairs leaves the map to the best usable alternative, and when
            none has them, to landmarks found by a short map started without them
            (:func:`~darcyan.dense.start.spectral_matching`); a map from the matches that is not
            trusted meets that start too (:func:`~darcyan.dense.seeds.rival_start`).
    """
    shape_1, shape_2 = getattr(shape_1, "shape", shape_1), getattr(shape_2, "shape", shape_2)
    result = _dense_map(shape_1, shape_2, correspondence, config, progress)
    # Without the alignment there is no residual (NaN) to judge the second map by.
    if (result.check.trusted or config.handle_length <= 0 or config.method != "zoomout"
            or config.alignment_rounds <= 0
            or max(shape_1.mesh.n_vertices, shape_2.mesh.n_vertices) > config.handle_max_vertices):
        return result
    t = time.perf_counter()
    (cut_1, cuts_1), (cut_2, cuts_2) = _cut_open(shape_1, config), _cut_open(shape_2, config)
    if cuts_1 + cuts_2 > 0:
        if progress:
            progress("handles cut open (the map is not trusted)")
        rival = _dense_map(cut_1, cut_2, correspondence, config, progress)
        # The judges of the start without landmarks (rival_by_checks), without its trust
        # thresholds: a map on a surface joined where it touches rarely passes them either way.
        if _beats(rival.check, result.check):
            verdict = dataclasses.replace(rival.check.verdict, handles_cut=cuts_1 + cuts_2)
            result = dataclasses.replace(rival, timings=result.timings,
                                         check=dataclasses.replace(rival.check, verdict=verdict))
    # The first map's stages, and all the second chance cost (the loops' search, the second map).
    result.timings["handles cut"] = time.perf_counter() - t
    return result


def dense_shape(shape, config: DenseConfig):
    """The shape a dense map with ``config`` makes its second map on when its first is not
    trusted: ``shape`` itself, or, with ``config.handle_length`` > 0 and handles on its surface, a
    copy cut open along the shortest loop around each handle shorter than that length
    (:func:`~darcyan.geometry.repair.cut_handles`; the small holes it leaves capped as
    :func:`~darcyan.geometry.repair.prepare_mesh` caps them). The copy has the same vertices
    first, in the same order, and a copy appended for each vertex of a loop (its
    ``input_index`` the original's), so that the feature points, the input numbering and a map
    read out on it are those of ``shape``. The loops' search and the capping take the
    :class:`~darcyan.config.Repairing` settings the shape was prepared with
    (``Shape.repairing``: ``handle_roots``, ``hole_length``, ``hole_edges``, ``degenerate_area``;
    a ``--config``'s). Made once per shape
    (:meth:`~darcyan.geometry.shape.Shape.derived`). :func:`dense_map` makes its second map on
    it only with ZoomOut and its alignment, between meshes of at most
    ``config.handle_max_vertices`` vertices."""
    return _cut_open(shape, config)[0]


def _cut_open(shape, config: DenseConfig) -> tuple:
    """``(dense_shape(shape, config), handles cut)``."""
    if config.handle_length <= 0:
        return shape, 0

    def compute():
        from ..geometry.repair import cap_small_holes, cut_handles

        mesh, lengths, _ = cut_handles(shape.mesh, config.handle_length, shape.repairing.handle_roots)
        if not lengths:
            return None, 0  # not the shape itself: its memo would hold a cycle to it
        mesh, _, _, _ = cap_small_holes(mesh, shape.repairing)
        return dataclasses.replace(shape, mesh=mesh, _memo={}), len(lengths)

    cut, cuts = shape.derived(("cut open", config.handle_length), compute)
    return (shape, 0) if cut is None else (cut, cuts)


def _dense_map(shape_1, shape_2, correspondence, config: DenseConfig, progress) -> DenseMap:
    say = progress or (lambda stage: None)
    timings: dict = {}
    choice = choose_seed(shape_1, shape_2, correspondence, config, say, timings)
    seed = choice.seed
    local, residual = _map_of_seed(shape_1, shape_2, seed, config, choice, say, timings)
    check = _checked(shape_1, local, seed, check_of_seeds(seed, choice.seeds, config.seed_margin), residual,
                     correspondence, config)
    pairs = (seed.source, seed.target)
    # (the two rules exclude each other: one replaces an alternative's map, the other the first seed's)
    replaced = (_sure_matching_rival(shape_1, shape_2, choice, check, correspondence, config, say, timings)
                or _best_scored_rival(shape_1, shape_2, choice, check, correspondence, config, say, timings))
    if replaced is not None:
        local, residual, check, seed = replaced
        pairs = (seed.source, seed.target)
        choice = dataclasses.replace(choice, seed=seed)
    doubted = not check.trusted and config.method == "zoomout"  # from the matches or started without them
    scored = len(choice.seeds) > 1 or seed.signature > 0  # a lone seed is not scored (0)
    if doubted and config.landmark_contradiction > 0:
        mended = _without_contradicted(shape_1, shape_2, seed, residual, check, correspondence, config, choice, say,
                                       timings)
        if mended is not None:
            local, residual, check, seed = mended
            pairs = (seed.source, seed.target)
            choice = dataclasses.replace(choice, seed=seed)
            scored = False  # its signature is not yet scored: the rival start scores it
    in_doubt = doubted and check.start == "matches" and config.start_in_doubt
    if in_doubt:
        # The map from the matches is in doubt: the start without landmarks competes with its seed.
        say("spectral start (the map from the matches is not trusted)")
        scores = {s.rank: s.signature for s in choice.seeds}
        choice = dataclasses.replace(choice, seeds=[seed])  # the losers' per-vertex arrays let go
        t = time.perf_counter()
        rival = rival_start(shape_1, shape_2, correspondence, config, choice, scored)
        timings["rival start"] = time.perf_counter() - t
        del seed  # its landmark pairs are kept (pairs); its per-vertex arrays go with the choice below
        if rival is not None:
            rival_seed, rival_score, chosen_score = rival
            scores.update({check.seed: chosen_score, rival_seed.rank: rival_score})
            taken = False
            by_signature = rival_score < (1.0 - config.seed_margin) * chosen_score
            if by_signature or config.rival_by_checks:
                choice = dataclasses.replace(choice, seed=rival_seed, seeds=[rival_seed])
                rival_local, rival_residual = _map_of_seed(shape_1, shape_2, rival_seed, config, choice, say, timings,
                                                           "rival ")
                verdict = seed_check(rival_seed.rank, scores, config.seed_margin, rival_seed.start,
                                     rival_seed.start_from, rival_seed.rank)
                rival_check = _checked(shape_1, rival_local, rival_seed, verdict, rival_residual, correspondence, config)
                if by_signature:
                    # Two judges: the signature chose the rival; its map is taken only when the
                    # alignment also follows it more closely (NaN without alignment: the signature alone).
                    taken = not rival_residual >= residual
                else:
                    taken = (_passes_checks(rival_check, check, config)
                             and map_agreement(shape_1, shape_2, local, rival_local, config.rival_agreement_radius)
                             >= config.rival_agreement)
                    if taken:
                        rival_check = dataclasses.replace(rival_check, verdict=dataclasses.replace(verdict, by_checks=True))
            if taken:
                local, residual, pairs = rival_local, rival_residual, (rival_seed.source, rival_seed.target)
                check = rival_check
            else:  # the same map: only the verdict gains the rival (a map not trusted stays so)
                verdict = seed_check(check.seed, scores, config.seed_margin, check.start, check.verdict.start_from,
                                     rival_seed.rank)
                check = dataclasses.replace(check, verdict=dataclasses.replace(
                    verdict, left_out=check.verdict.left_out, by_checks=check.verdict.by_checks))
    target = input_map(shape_1, shape_2, local)
    landmarks = np.stack([shape_1.mesh.input_index[pairs[0]], shape_2.mesh.input_index[pairs[1]]], axis=1)
    return DenseMap(target, landmarks, timings, check)


def map_agreement(shape_1, shape_2, map_a: np.ndarray, map_b: np.ndarray, radius: float) -> float:
    """The share of ``shape_1``'s area (its mixed Voronoi areas) whose images under the maps
    ``map_a`` and ``map_b`` ``(n1,)`` (prepared numbering) lie within ``radius`` (sqrt(area)
    units, in space) of each other on ``shape_2``."""
    positions = shape_2.mesh.vertices
    apart = np.linalg.norm(positions[map_a] - positions[map_b], axis=1)
    area = shape_1.vertex_areas
    return float(area[apart <= radius].sum() / area.sum())


def _sure_matching_rival(shape_1, shape_2, choice, check: MapCheck, correspondence, config: DenseConfig, say,
                         timings: dict) -> tuple | None:
    """``(local (n1,), residual (sqrt(area) units), check, seed)`` of the map from the sparse
    matching itself (seed rank 0) when it is taken over the map ``check`` of an alternative the
    signature chose (``DenseConfig.rival_sure_matching``): that map is not trusted, the sparse stage was sure of
    its matching (``correspondence.in_doubt`` false), and the sure matching's map passes the
    checks of a trusted map and beats the alternative's on orientation and residual
    (:func:`_passes_checks`; such a map is then trusted). ``None`` otherwise (nothing made
    unless the first three hold, with ZoomOut and its alignment). The signature scores a short
    map; an alternative that moves one landmark pair to a neighbouring extremity can score a
    few percent lower and still turn a limb or the head round, which the whole map's
    orientation and alignment show. Unlike the start without landmarks
    (``DenseConfig.rival_agreement``), the two maps need not agree on part of the surface: the
    sure matching has passed the sparse stage's own judges, and the map it replaces may be
    wrong over most of the body."""
    # (without alignment the residuals are NaN and the checks never pass: no map is made)
    if not (config.rival_sure_matching and config.method == "zoomout" and config.alignment_rounds > 0
            and not check.trusted and check.start == "matches" and check.seed != 0
            and not getattr(correspondence, "in_doubt", True)):
        return None
    # (the first usable seed keeps its per-vertex arrays: seeds._without_losers)
    sure = next((s for s in choice.seeds if s.rank == 0), None)
    if sure is None:  # the sparse matching gave no usable seed
        return None
    say("the sure matching's map (the alternative's is not trusted)")
    local, residual = _map_of_seed(shape_1, shape_2, sure, config, choice, say, timings, "sure ")
    verdict = dataclasses.replace(check_of_seeds(sure, choice.seeds, config.seed_margin), by_checks=True)
    sure_check = _checked(shape_1, local, sure, verdict, residual, correspondence, config)
    if _passes_checks(sure_check, check, config):
        return local, residual, sure_check, sure
    return None


def _best_scored_rival(shape_1, shape_2, choice, check: MapCheck, correspondence, config: DenseConfig, say,
                       timings: dict) -> tuple | None:
    """``(local (n1,), residual (sqrt(area) units), check, seed)`` of the map from the seed
    that scored lowest when it is taken over the map ``check`` of the first seed, which
    ``seed_margin`` kept although the other scored lower (``DenseConfig.rival_best_scored``):
    that map is not trusted, and the best-scored seed's map agrees better with its landmarks'
    orientation and its alignment follows it more closely (:func:`_beats`). ``None`` otherwise
    (nothing made unless the first two hold, with ZoomOut and its alignment). The margin
    favours the sparse matching for the evidence of the sparse stage; a map from it that fails
    the checks has lost that favour, and two seeds a few percent apart are a knife's edge that
    whole maps decide better than short ones. Unlike the sure matching's map
    (:func:`_sure_matching_rival`, which is then trusted and so must pass a trusted map's
    checks), a map taken here stays untrusted: its seed did not stand clear of the first (or it
    set aside a matching the sparse stage was sure of), so beating the first map is enough."""
    # (without alignment the residuals are NaN and _beats never holds: no map is made)
    if not (config.rival_best_scored and config.method == "zoomout" and config.alignment_rounds > 0
            and not check.trusted and check.start == "matches" and choice.seeds
            and check.seed == choice.seeds[0].rank):
        return None
    best = choice.seeds[best_scored(choice.seeds)]  # it kept its per-vertex arrays (seeds._without_losers)
    if best.rank == check.seed or best.fields_1 is None:
        return None
    say("the best-scored seed's map (the first seed's is not trusted)")
    local, residual = _map_of_seed(shape_1, shape_2, best, config, choice, say, timings, "best-scored ")
    verdict = dataclasses.replace(check_of_seeds(best, choice.seeds, config.seed_margin), by_checks=True)
    best_check = _checked(shape_1, local, best, verdict, residual, correspondence, config)
    if _beats(best_check, check):
        return local, residual, best_check, best
    return None


def _passes_checks(rival: MapCheck, chosen: MapCheck, config: DenseConfig) -> bool:
    """Whether the map ``rival`` replaces ``chosen`` although the signature did not choose it
    (the start without landmarks' map, ``DenseConfig.rival_by_checks``, or the sure sparse
    matching's, ``DenseConfig.rival_sure_matching``): it passes the orientation and residual
    conditions of :func:`trusted` and beats ``chosen`` on both (without alignment, NaN
    residuals: never)."""
    return (rival.orientation >= config.trust_orientation and rival.residual <= config.trust_residual
            and _beats(rival, chosen))


def _beats(rival: MapCheck, chosen: MapCheck) -> bool:
    """Whether the map ``rival`` agrees better with its landmarks' orientation than ``chosen``
    and its alignment follows it more closely (without alignment, NaN residuals: never)."""
    return rival.orientation > chosen.orientation and rival.residual < chosen.residual


def _without_contradicted(shape_1, shape_2, seed, residual: float, check: MapCheck, correspondence,
                          config: DenseConfig, choice, say, timings: dict) -> tuple | None:
    """``(local (n1,), residual, check, seed)`` of the map made without the landmark pair of
    ``seed`` the others contradict (:func:`~darcyan.dense.seeds.contradicted_landmark`: beyond
    ``config.landmark_contradiction``), when it is taken: its alignment follows it at least as
    closely as the map of ``seed`` (``residual``; NaN without alignment: not a judge) and it
    agrees at least as well with its own landmarks' orientation as that map did with all of
    them (``check.orientation``). ``None`` otherwise (no pair contradicted, too few pairs to
    leave one out, or the map refused). One pair, once: of two wrong pairs one is left. The map
    without the pair weighs its signature turns by its own landmarks
    (:func:`~darcyan.dense.signatures.signature_turn_weight`): one extremity fewer is anchored."""
    t = time.perf_counter()
    found = contradicted_landmark(shape_1, shape_2, seed, config, choice.samples, choice.bases)
    timings["landmark check"] = time.perf_counter() - t
    if found is None or not found[1] > config.landmark_contradiction:
        return None
    say("a map without the landmark pair the others contradict")
    i, displacement = found
    reduced = without_landmark(seed, i, config)
    local, reduced_residual = _map_of_seed(shape_1, shape_2, reduced, config, choice, say, timings, "reduced ")
    left_out = (int(shape_1.mesh.input_index[seed.source[i]]), int(shape_2.mesh.input_index[seed.target[i]]),
                round(displacement, 4))
    reduced_check = _checked(shape_1, local, reduced, dataclasses.replace(check.verdict, left_out=left_out),
                             reduced_residual, correspondence, config)
    # Two judges beside the contradiction, which a right pair a short map lost also shows.
    if not reduced_residual > residual and reduced_check.orientation >= check.orientation:
        return local, reduced_residual, reduced_check, reduced
    return None


def _map_of_seed(shape_1, shape_2, seed, config: DenseConfig, choice, say, timings: dict, stage: str = "") -> tuple:
    """``(local (n1,), residual)``: the map from ``seed`` (prepared numbering; pyFM's, or
    ZoomOut's then aligned) and the alignment's residual (NaN without it); each stage's seconds
    in ``timings`` under ``stage`` + its name."""
    t = time.perf_counter()
    residual = float("nan")
    if config.method == "pyfm":
        say("pyfm")
        local = pyfm_point_map(shape_1.mesh, shape_2.mesh, DENSE_PIPELINE, seed.source, seed.target)
        timings[stage + "pyfm"] = time.perf_counter() - t
        return local, residual
    say("zoomout")
    turns = signature_turn_weight(len(seed.source), choice.feature_counts, config)
    local = _zoomout_map(shape_1, shape_2, seed, config, choice.samples, choice.bases, turns)
    timings[stage + "zoomout"] = time.perf_counter() - t
    if config.alignment_rounds > 0:
        say("alignment")
        t = time.perf_counter()
        alignment = align(shape_1, shape_2, local, config, seed.fields_1, seed.fields_2)
        local, residual = alignment.map_12, alignment.residual
        timings[stage + "alignment"] = time.perf_counter() - t
    return local, residual


def _checked(shape_1, local: np.ndarray, seed, verdict: SeedVerdict, residual: float, correspondence,
             config: DenseConfig) -> MapCheck:
    """The :class:`MapCheck` of the map ``local (n1,)`` from ``seed``, its trust decided."""
    orientation, distortion = map_check(shape_1, local, seed.fields_1, seed.fields_2, seed.turns_1, seed.turns_2)
    check = MapCheck(orientation, distortion, verdict, residual=residual)
    doubts = distrust_reasons(check, correspondence, config)
    return dataclasses.replace(check, trusted=not doubts, doubts=doubts)


def _zoomout_map(shape_1, shape_2, seed, config: DenseConfig, samples: tuple, bases: tuple,
                 turns: float) -> np.ndarray:
    """``(n1,)`` ZoomOut's map from ``seed``'s landmarks (prepared numbering), read out at every
    source vertex, with the signature turns weighed by ``turns``; the medoid of
    ``config.ensemble`` runs when it asks for three or more."""
    (sample_1, sample_2), (basis_1, basis_2) = samples, bases
    mesh_1, mesh_2 = shape_1.mesh, shape_2.mesh
    coords_1, coords_2 = seed.coords_1, seed.coords_2
    # A medoid needs three runs; on every vertex (no draw of samples) the runs would be one map.
    every_vertex = len(sample_1) == mesh_1.n_vertices and len(sample_2) == mesh_2.n_vertices
    runs = config.ensemble if config.ensemble >= 3 and not every_vertex else 1
    everywhere = np.arange(mesh_1.n_vertices), np.arange(mesh_2.n_vertices)
    signature_1, signature_2 = signature_coordinates(shape_1, shape_2, config, *everywhere)
    steady_1, steady_2 = signature_turn_coordinates(shape_1, shape_2, config, seed.fields_1, seed.fields_2, turns)
    values = (None, None)  # the commutativity term's eigenvalues
    if config.commutativity > 0:
        values = dense_eigenvalues(shape_1, config), dense_eigenvalues(shape_2, config)
    maps = []
    for member in range(runs):
        if member > 0:
            sample_1, sample_2 = zoomout_samples(shape_1, shape_2, config, member)
        first_12 = nearest_rows(coords_2[sample_2], coords_1[sample_1])  # first maps by the landmark coordinates
        first_21 = nearest_rows(coords_1[sample_1], coords_2[sample_2])
        coarse_1, coarse_2 = (None, None) if signature_1 is None else (signature_1[sample_1], signature_2[sample_2])
        turns = (None, None) if steady_1 is None else (steady_1[sample_1], steady_2[sample_2])
        c_12, c_21 = zoomout(basis_1[sample_1], basis_2[sample_2], first_12, first_21, config,
                             coords_1[sample_1], coords_2[sample_2], coarse_1, coarse_2, *turns, *values)
        maps.append(read_out_map(shape_2, basis_1, basis_2, c_12, c_21, config, coords_1, coords_2, sample_2,
                                 steady_1, steady_2, sample_1, mesh_1.vertices))
    return consensus_map(mesh_2.vertices, maps)


def shape_operators(shape, feature_vertices=None, *, config: DenseConfig = DenseConfig()) -> None:
    """Build on ``shape`` (a prepared :class:`~darcyan.geometry.shape.Shape`) what a dense map
    with ``config`` needs of it alone, and keep it there: its basis and eigenvalues
    (:func:`~darcyan.dense.zoomout.dense_spectrum`), its point signature and, given its
    ``feature_vertices`` ``(k,)`` (input numbering: a description's), their distance fields
    (:meth:`~darcyan.geometry.shape.Shape.distance_field`), from which the map's landmarks are
    drawn. A shape made ready in a worker process carries them back
    (:func:`darcyan.method.pipeline.describe_and_prepare`), so that two shapes' eigenproblems and
    fast marchings run at once."""
    if config.method == "zoomout" or config.candidates > 1:
        dense_spectrum(shape, config)
    if (config.signature_weight > 0 or config.signature_turns > 0 or config.signature_turns_partial > 0
            or config.candidates > 1):
        point_signature(shape, config)
    if feature_vertices is not None and config.method == "zoomout":
        for vertex in shape.mesh_index(feature_vertices):
            if vertex >= 0:  # a feature point the preparation left out has no field here
                shape.distance_field(vertex)


def trusted(check: MapCheck, correspondence, config: DenseConfig) -> bool:
    """Whether a map's ``check`` lets it be trusted. All of:

    - its orientation agrees with its landmarks (at least ``config.trust_orientation``);
    - it started from the feature matches (a map started without them, :mod:`darcyan.dense.start`,
      took its landmarks from a short map nothing else checked);
    - it did not set aside a matching the sparse stage was sure of (not ``in_doubt``) for an
      alternative: two independent judgments, the sparse stage's orientation test and the dense
      stage's curvature signature, would disagree;
    - a matching the sparse stage was in doubt of stood clear of its rivals in the dense stage
      (``check.verdict.clear``): then the dense stage's judgment is the only one, and it must be plain;
    - no landmark pair was left out (``check.verdict.left_out``): a map mended so came from a
      map in doubt, and only its own checks vouch for it;
    - the alignment's deformation could follow it: its residual (``check.residual``) is at most
      ``config.trust_residual`` (a map that needs the source mirrored or torn cannot be followed
      as rigidly as possible; without alignment, NaN, this condition holds).

    Measured on the shared sets and the hard copies: ``docs/decisions/every-pair.md``. Which
    conditions a map fails: :func:`distrust_reasons`."""
    return not distrust_reasons(check, correspondence, config)


def distrust_reasons(check: MapCheck, correspondence, config: DenseConfig) -> tuple:
    """The conditions of :func:`trusted` that a map's ``check`` fails, each as a phrase a person
    can act on (empty: trusted), in the order :func:`trusted` lists them."""
    in_doubt = getattr(correspondence, "in_doubt", True)
    from_matches = check.start == "matches"
    reasons = []
    if not check.orientation >= config.trust_orientation:
        reasons.append(f"its orientation agrees with its landmarks by {check.orientation:.2f}, below "
                       f"{config.trust_orientation:g}")
    if not from_matches:
        reasons.append("it started without the feature matches")
    elif check.seed != 0 and not in_doubt:
        reasons.append("it set aside feature matches the sparse stage was sure of")
    if in_doubt and not check.verdict.clear:
        reasons.append("the feature matches were in doubt and its seed did not stand clear of the others")
    if check.verdict.left_out is not None:
        reasons.append("a landmark pair the others contradicted was left out")
    if check.residual > config.trust_residual:  # NaN (no alignment): not a reason
        reasons.append(f"the alignment stayed {check.residual:.4f} sqrt(area) from its images, more than "
                       f"{config.trust_residual:g}")
    return tuple(reasons)


def input_map(shape_1, shape_2, local: np.ndarray) -> np.ndarray:
    """``(n_input_vertices of shape_1,) int64``: a map ``local (n1,)`` between the prepared meshes
    in the input numbering of both shapes (welded copies of a vertex mapped like it,
    :data:`UNMAPPED` for vertices outside the analysed mesh)."""
    target = np.full(shape_1.n_input_vertices, UNMAPPED, dtype=np.int64)
    on_mesh = shape_1.mesh_index(np.arange(shape_1.n_input_vertices))
    target[on_mesh >= 0] = shape_2.mesh.input_index[local[on_mesh[on_mesh >= 0]]]
    return target


def matching_of_map(correspondence, made: DenseMap, description_1, description_2, shape_2):
    """The feature matches that a dense map started without them (or made without a landmark
    pair the others contradicted) reads: each feature point of
    the source paired with the target's feature point nearest its image (geodesic distance on
    the target), where that feature point's nearest image is this one's: mutual nearest, so no
    distance threshold is needed, and a feature point whose image lies between two of the
    target's, or nearer another's image, stays unmatched.

    Args:
        correspondence: the sparse matching (a :class:`~darcyan.method.pipeline.Correspondence`).
        made: the dense map (:class:`DenseMap`, input numbering).
        description_1, description_2: the shapes' :class:`~darcyan.method.pipeline.ShapeDescription`
            (feature points in input numbering, their descriptors).
        shape_2: the prepared target (:class:`~darcyan.geometry.shape.Shape`): its geodesics.

    Returns:
        a :class:`~darcyan.method.pipeline.Correspondence` whose distances are the descriptors'
        (as the sparse stage measures them), with the sparse matching and its alternatives as
        its alternatives, and the sparse matching's ``margin``, ``in_doubt`` and ``to_verify``.
    """
    from ..method.matching import Matches, descriptor_distances
    from ..method.pipeline import Correspondence

    images = made.target[np.asarray(description_1.feature_vertices, dtype=np.int64)]
    mapped = np.flatnonzero(images != UNMAPPED)
    targets = shape_2.mesh_index(np.asarray(description_2.feature_vertices, dtype=np.int64), nearest=True)
    source = target = np.zeros(0, dtype=np.int64)
    if len(mapped) and len(targets):
        # (mapped source features, target features): the geodesic distance from each image to each target feature
        gaps = distance_fields(shape_2, {}, targets)[shape_2.mesh_index(images[mapped], nearest=True)]
        nearest_target = np.argmin(gaps, axis=1)  # per image, the target feature nearest it
        nearest_image = np.argmin(gaps, axis=0)  # per target feature, the image nearest it
        rows = np.arange(len(mapped))
        keep = (nearest_image[nearest_target] == rows) & np.isfinite(gaps[rows, nearest_target])
        source, target = mapped[keep], nearest_target[keep]
    distance = descriptor_distances(description_1.descriptors, description_2.descriptors)[source, target]
    return Correspondence(np.asarray(description_1.feature_vertices)[source],
                          np.asarray(description_2.feature_vertices)[target], distance,
                          Matches(source, target, distance),
                          alternatives=(correspondence, *getattr(correspondence, "alternatives", ())),
                          margin=getattr(correspondence, "margin", np.inf),
                          in_doubt=getattr(correspondence, "in_doubt", False),
                          to_verify=getattr(correspondence, "to_verify", False),
                          feature_counts=(len(description_1.feature_vertices), len(description_2.feature_vertices)))


def map_check(shape_1, local: np.ndarray, distances_1, distances_2, turns_1, turns_2) -> tuple[float, float]:
    """How far a map ``local (n1,)`` (prepared numbering) keeps what its landmarks say:
    ``orientation``, the area-weighted correlation of the
    :func:`~darcyan.dense.landmarks.orientation_coordinates` at each source vertex and at its
    image (1: kept everywhere, -1: a mirror image); ``distortion``, the area-weighted mean change
    of the geodesic distances to the landmarks from a vertex to its image (sqrt(area) units):
    ``(orientation, distortion)``."""
    area = shape_1.vertex_areas / shape_1.vertex_areas.sum()
    a, b = turns_1, turns_2[local]
    a, b = a - area @ a, b - area @ b
    covariance = (area @ (a * b)).sum()
    scale = np.sqrt((area @ (a * a)).sum() * (area @ (b * b)).sum())
    orientation = float(covariance / scale) if scale > 0 else 0.0
    distortion = float(area @ np.abs(distances_1 - distances_2[local]).mean(axis=1))
    return orientation, distortion


def pyfm_own_map(mesh_1: Mesh, mesh_2: Mesh, n_input_vertices: int | None = None) -> DenseMap:
    """pyFM's own dense pipeline between two analysed meshes, *without* darcyan's landmarks (the
    baseline of ``darcyan bench --dense``): :func:`darcyan.dense.pyfm.pyfm_point_map` with no landmarks.

    ``mesh_i``: prepared, area-1 meshes (``ShapeDescription.mesh``); ``n_input_vertices``: of
    the source file (default: from ``mesh_1.input_index``). Returns a :class:`DenseMap` in input
    numbering like :func:`dense_map` (no landmarks; ``timings["pyfm"]``: the whole pipeline)."""
    t = time.perf_counter()
    local = pyfm_point_map(mesh_1, mesh_2, DENSE_PIPELINE)
    n_input = int(mesh_1.input_index.max()) + 1 if n_input_vertices is None else n_input_vertices
    target = np.full(n_input, UNMAPPED, dtype=np.int64)
    target[mesh_1.input_index] = mesh_2.input_index[local]
    return DenseMap(target, np.zeros((0, 2), dtype=np.int64), {"pyfm": time.perf_counter() - t})


def dense_map_to_csv(target: np.ndarray) -> str:
    """CSV ``source_vertex,target_vertex``, one row per source vertex (0-based, input numbering)."""
    lines = ["source_vertex,target_vertex"] + [f"{s},{t}" for s, t in enumerate(np.asarray(target).tolist())]
    return "\n".join(lines) + "\n"
