"""All parameters of the method in one typed, documented object.

Lengths are in units of ``sqrt(surface area)``: every mesh is scaled to total area 1 before
analysis (the paper's scale normalization), so a radius of 0.1 means one tenth of the square
root of the shape's area whatever the file's units. The defaults and how they were chosen are in
``docs/decisions/``.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import json
import math
import re
from dataclasses import dataclass

from .errors import ConfigError

MATCHING_MODES = ("consistent", "nearest", "one-to-one")


# Which stage a setting changes: "prepare" (the prepared mesh), "describe" (a shape's
# description, cached on disk), "match" (matching two descriptions) or "dense" (a dense map and
# the verification of a matching; the fields of DenseConfig, a section of its own). Cache keys are derived
# from the fields of the stages a result depends on (see DarcyanConfig.fingerprint).
PREPARE, DESCRIBE, MATCH, DENSE = "prepare", "describe", "match", "dense"


def _stage(default, stage: str):
    return dataclasses.field(default=default, metadata={"stage": stage})


@dataclass(frozen=True)
class Denoising:
    """How a crumpled surface is smoothed (see :func:`darcyan.geometry.denoise.denoise_mesh`);
    ``DarcyanConfig.denoise_area_ratio`` decides whether it is.

    Attributes:
        block: Taubin steps between two area measurements.
        max_steps: at most this many steps in all.
        settled: a block that shrinks the area by less than this factor ends the smoothing.
        noise_roughness: the surface roughness (median |L L x| / median |L x|, umbrella L) above
            which a surface counts as noisy: white vertex noise measures ~1.25, clean meshes
            0.4-0.9 (regular) up to 1.05 (TOSCA's remeshed 5k set).
        taubin_lambda, taubin_mu: Taubin's lambda|mu pair (pass-band ~0.1): smooths without the
            shrinkage of plain Laplacian steps.
    """

    block: int = _stage(10, PREPARE)
    max_steps: int = _stage(200, PREPARE)
    settled: float = _stage(1.02, PREPARE)
    noise_roughness: float = _stage(1.15, PREPARE)
    taubin_lambda: float = _stage(0.5, PREPARE)
    taubin_mu: float = _stage(-0.53, PREPARE)

    def __post_init__(self) -> None:
        _check(self, ("block", "max_steps"), lambda v: _integer(v) and v >= 1, "a positive integer")
        _check(self, ("settled", "noise_roughness"), lambda v: _number(v) and v >= 1, "a factor >= 1")
        _check(self, ("taubin_lambda",), lambda v: _number(v) and 0 < v < 1, "in (0, 1)")
        _check(self, ("taubin_mu",), lambda v: _number(v) and -1 < v < 0, "in (-1, 0)")


@dataclass(frozen=True)
class Repairing:
    """How a mesh is repaired: what ``--repair`` / ``repair=True`` takes for one point and for no face
    (:func:`darcyan.geometry.repair.prepare_mesh`).

    Attributes:
        weld_tolerance: boundary vertices closer than this fraction of the mean edge length are
            one point: copies of a vertex written by one program agree to the last digits, real
            edges are ~1e6 times longer. 0: never weld.
        degenerate_area: a face whose area is below this fraction of the mean face area is
            degenerate (dropped, with a note).
        strict: refuse the ordinary imperfections that are otherwise repaired with a note
            (duplicate and degenerate faces, unreferenced vertices, non-manifold edges,
            inconsistent orientation, a surface that cannot be oriented): ``--strict``.
        outward_cap_share: with or without repair, a surface whose faces enclose a negative
            volume (it is inside out) gets every face flipped: its orientation decides left from
            right. A surface with holes or cuts is closed for that test by a fan across each
            boundary loop, and tested only when those fans' area is at most this share of its
            own: closed but for holes and cut limbs. A patch or a one-sided scan has no inside
            to tell (the same dent is concave from one side and convex from the other), and is
            left as it comes.
        hole_length, hole_edges: with or without repair, a boundary loop of at most
            ``hole_edges`` edges and shorter than ``hole_length`` (sqrt(area)) is a hole where a
            face or two were lost (by a scanner, an exporter), not a cut or an opening of the
            model, and is closed by a fan of faces between its own vertices (no vertex is added),
            with a note. Left open, a hole inside a feature point's grid cuts its level curves
            and changes its descriptor: three one-face holes, two of them 0.11 from a feature
            point, turned 4 of the 97 FAUST test pairs into left/right swaps. 4 edges: at 8, the
            six-edge holes of 19 tosca-hires meshes were closed too, which swapped one david pair
            and, by changing ZoomOut's random samples, cost michael0 -> michael10's dense map 10
            points (``docs/decisions/``, "Small holes"). Anything ``rims.min_length`` (0.1) or
            longer may be a cut's rim and stays open. 0: no hole is closed.
        handle_length: with or without repair, a handle (the surface has genus above 0) around
            which a loop shorter than this (sqrt(area)) runs is cut open along the shortest such
            loop, with a note (:func:`darcyan.geometry.repair.cut_handles`). A body is a sphere;
            a handle on one is where parts that touch were joined (a hand glued to a hip,
            fingers fused by a marching-cubes reconstruction), and it changes the geodesics and
            the eigenfunctions far beyond itself. 0 (the default): no handle is cut, since on
            the glued and marching-cubes copies cutting mended some maps and broke as many
            (``docs/decisions/every-pair.md``, "Handles cut open"); 0.05 cuts the bridges of
            fused fingers and of a hand that touches a hip at one spot, not a limb.
        handle_roots: the farthest points from which the loops around handles are sought
            (:class:`darcyan.geometry.handles.HandleLoops`; then again from the shortest loop's
            own vertices); 0: no handle is cut.
    """

    weld_tolerance: float = _stage(1e-6, PREPARE)
    degenerate_area: float = _stage(1e-12, PREPARE)
    strict: bool = _stage(False, PREPARE)
    outward_cap_share: float = _stage(0.25, PREPARE)
    hole_length: float = _stage(0.1, PREPARE)
    hole_edges: int = _stage(4, PREPARE)
    handle_length: float = _stage(0.0, PREPARE)
    handle_roots: int = _stage(40, PREPARE)

    def __post_init__(self) -> None:
        _check(self, ("weld_tolerance", "degenerate_area"), lambda v: _number(v) and 0 <= v < 1, "in [0, 1)")
        _check(self, ("outward_cap_share", "hole_length", "handle_length"), lambda v: _number(v) and v >= 0,
               "non-negative")
        _check(self, ("hole_edges", "handle_roots"), lambda v: _integer(v) and v >= 0, "a non-negative integer")
        _check(self, ("strict",), lambda v: isinstance(v, bool), "true or false")


@dataclass(frozen=True)
class HeatKernel:
    """The heat kernel that moves feature points to the sharpest tip of their extremity, and the
    heat diffusion behind the AGD smoothing and the mirror test's signature.

    Attributes:
        vertices: the kernel is computed on the AGD's proxy, or on a copy of at least this many
            vertices if the proxy is coarser: on 1500 vertices (tosca-5k michael) it moved a
            hand in 2 of 8 poses and missed the head in another, which 5000 do not.
        decay: eigenpairs are kept while ``exp(-lambda t)`` exceeds ``exp(-decay)`` (each one
            beyond weighs less than 2.5e-3 at decay 6; on a sphere the ones left out add 0.2%).
        tolerance: the eigensolver's relative accuracy: 1e-2 changes the kernel by 1e-5
            (tosca-5k cat0) and saves a third of its time.
        diffusion_steps: backward-Euler steps of a heat diffusion: one step is a wide,
            heavy-tailed kernel; a few approach a Gaussian at the cost of one factorization.
    """

    vertices: int = _stage(5000, DESCRIBE)
    decay: float = _stage(6.0, DESCRIBE)
    tolerance: float = _stage(1e-2, DESCRIBE)
    diffusion_steps: int = _stage(4, DESCRIBE)

    def __post_init__(self) -> None:
        _check(self, ("vertices", "diffusion_steps"), lambda v: _integer(v) and v >= 1, "a positive integer")
        _check(self, ("decay",), lambda v: _number(v) and v > 0, "positive")
        _check(self, ("tolerance",), lambda v: _number(v) and 0 <= v < 1, "in [0, 1)")


@dataclass(frozen=True)
class GeodesicMargins:
    """Where exact geodesics are computed around a feature point.

    Attributes:
        ball: the geodesic ball around a feature point reaches this share beyond the radius
            asked for, so that fast marching inside it is exact up to that radius.
        trace: radial geodesics are traced this many times the outermost level radius, so
            that they cross every level curve even where the surface bends.
    """

    ball: float = _stage(0.3, DESCRIBE)
    trace: float = _stage(1.5, DESCRIBE)

    def __post_init__(self) -> None:
        _check(self, ("ball",), lambda v: _number(v) and 0 <= v < 10, "a share >= 0")
        _check(self, ("trace",), lambda v: _number(v) and 1 <= v < 10, "a factor >= 1")


@dataclass(frozen=True)
class Consistency:
    """Weights of :func:`darcyan.method.matching.consistent_candidates`' score; all terms are
    dimensionless. Chosen on tosca-5k (``docs/decisions/``): geodesic distances between true
    corresponding feature points change by 4% (median) to 28% (99th percentile) between TOSCA
    poses, hence the wide tolerance.

    Attributes:
        geodesic_tolerance: relative change of a geodesic distance still counted as kept.
        geodesic: weight of one pair of matches keeping (+) or breaking (-) its distance.
        beam_width: matchings kept at each step of the beam search.
    """

    geodesic_tolerance: float = _stage(0.3, MATCH)
    geodesic: float = _stage(0.5, MATCH)
    beam_width: int = _stage(128, MATCH)

    def __post_init__(self) -> None:
        _check(self, ("geodesic_tolerance",), lambda v: _number(v) and v > 0, "positive")
        _check(self, ("geodesic",), lambda v: _number(v) and v >= 0, ">= 0")
        _check(self, ("beam_width",), lambda v: _integer(v) and v >= 1, "a positive integer")


@dataclass(frozen=True)
class MirrorTest:
    """The test that tells a matching from its mirror image (:mod:`darcyan.method.symmetry`).

    Attributes:
        samples: sample points on the source; their spacing sets the size of the test triangles
            (area 1: about 1/sqrt(samples) = 0.035 apart). Each makes a triangle with every two
            of its ``neighbours`` nearest samples, so most triangles are several spacings wide,
            larger than the coarse map's error (tosca-5k: with 200 samples and one triangle per
            sample 165 of the 203 test pairs got their true matching; with these, 190).
        neighbours: see ``samples``.
        target_points: images are looked for among at most this many target vertices (drawn
            by area; the 5k meshes keep all theirs). 5000 instead of 10000 halves the test's
            time; it gave the same matches on the 203 tosca-5k and 97 faust-5k test pairs and
            other matches on 12 of the 666 tosca-hires pairs, 57 right against 46.
        min_sine: a triangle votes only when |sin| of its corner is at least this on both shapes.
        signature_lengths: diffusion lengths (sqrt(area)) of the mean curvature making up the
            point signature (computed with the description).
        signature_weight: the signature's weight against landmark distances in the coarse map.
        candidates: candidate matchings (best first) whose orientation is tested (16 rather
            than 8: on tosca-hires the dog's true matching was sometimes ranked below 8).
        orientation_weight: the score of full orientation agreement, per match.
        profile_levels: the innermost level curves whose angular curvature profile gives a tip's
            handedness (computed with the description).
        profile_agreement: two profiles count only as far as they agree, in one turning sense,
            better than this times unrelated profiles would.
        handedness_weight: the weight of handedness, per match.
        seed: the seed of the sample points.
        verify_below: a matching whose total (score, handedness and orientation agreement)
            stands less than this above the runner-up's is in doubt
            (``Correspondence.in_doubt``): where the shapes themselves are at hand (``darcyan
            match``, ``darcyan bench``, :func:`darcyan.dense.verified_matches`), short dense maps
            seeded by it and by the other candidates decide, as ``--verify`` does for every
            pair. A dense map reads the doubt too: it then weighs its own start without
            landmarks, and trusts the map only when its seed stands clear
            (:func:`darcyan.dense.maps.trusted`). 0: never in doubt.
        verify_sparse_below: feature matches that no dense map follows (``darcyan match``
            without ``--dense``, ``darcyan bench``'s sparse records) are verified, as a
            matching in doubt is, when the margin is below this, in doubt or not
            (``Correspondence.to_verify``). On remeshed copies the test's orientation agreement
            is noisy on people (about +-0.2 for every candidate, times five matches), and
            wrong matchings won by margins up to about 0.7 that a margin of 0.25 left
            unverified (``docs/decisions/matching.md``). The dense stage's doubt stays
            ``verify_below``'s: a dense map weighs the alternatives itself.
    """

    samples: int = _stage(800, MATCH)
    neighbours: int = _stage(6, MATCH)
    target_points: int = _stage(5_000, MATCH)
    min_sine: float = _stage(0.3, MATCH)
    signature_lengths: tuple = _stage((0.05, 0.1, 0.2), DESCRIBE)
    signature_weight: float = _stage(0.9, MATCH)
    candidates: int = _stage(16, MATCH)
    orientation_weight: float = _stage(1.0, MATCH)
    profile_levels: int = _stage(2, DESCRIBE)
    profile_agreement: float = _stage(0.8, MATCH)
    handedness_weight: float = _stage(2.0, MATCH)
    seed: int = _stage(0, MATCH)
    verify_below: float = _stage(0.25, MATCH)
    verify_sparse_below: float = _stage(0.75, MATCH)

    def __post_init__(self) -> None:
        lengths = self.signature_lengths
        if not isinstance(lengths, (list, tuple)) or not all(_number(x) for x in lengths):
            raise ConfigError(f"config: MirrorTest.signature_lengths must be a list of lengths, got {lengths!r}")
        object.__setattr__(self, "signature_lengths", tuple(float(x) for x in lengths))
        _check(self, ("samples", "neighbours", "target_points", "candidates", "profile_levels"),
               lambda v: _integer(v) and v >= 1, "a positive integer")
        _check(self, ("min_sine",), lambda v: _number(v) and 0 <= v < 1, "in [0, 1)")
        _check(self, ("signature_weight", "orientation_weight", "handedness_weight", "verify_below",
                      "verify_sparse_below"),
               lambda v: _number(v) and v >= 0, ">= 0")
        _check(self, ("profile_agreement",), lambda v: isinstance(v, (int, float)) and v > 0,
               "positive (inf: trust every profile)")
        _check(self, ("seed",), lambda v: _integer(v) and v >= 0, "an integer >= 0")
        if not self.signature_lengths or min(self.signature_lengths) <= 0:
            raise ConfigError(f"config: mirror.signature_lengths must be positive lengths, got {self.signature_lengths!r}")


@dataclass(frozen=True)
class CutRims:
    """Partial shapes: where a part was cut away, the cut's rim is not an extremity.

    AGD grows toward the end of a limb; cut the limb and its largest value sits on the cut's rim,
    where no counterpart exists on a whole shape. Boundary loops at least ``min_length`` long
    count as cut rims, and no feature point is taken within ``clearance`` of one (nor is one moved
    there as a sharpest tip). Shorter loops are holes that leave the extremity in place: the
    mouth of TOSCA's men (0.05 from end to end, at 0.02 from the head's feature point), the
    cat's 0.079; limbs cut by the partial benchmark left rims of 0.12 to 2 (docs/decisions/).

    Attributes:
        min_length: a boundary loop this long (sqrt(area)) or longer is a cut's rim (0: none is).
        clearance: feature points stay at least this far (sqrt(area)) from a cut's rim.
    """

    min_length: float = _stage(0.1, DESCRIBE)
    clearance: float = _stage(0.05, DESCRIBE)

    def __post_init__(self) -> None:
        _check(self, ("min_length", "clearance"), lambda v: _number(v) and v >= 0, ">= 0")


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check(section, names, ok, what: str) -> None:
    for name in names:
        value = getattr(section, name)
        if not ok(value):
            raise ConfigError(f"config: {type(section).__name__}.{name} must be {what}, got {value!r}")


LANDMARK_MODES = ("consistent", "all")
METHODS = ("zoomout", "pyfm")
SAMPLINGS = ("farthest", "random")  # DenseConfig.sampling
LAPLACIANS = ("cotangent", "robust")  # DenseConfig.basis_laplacian
SEED_STATISTICS = ("median", "mean")  # DenseConfig.seed_statistic


@dataclass(frozen=True)
class DenseConfig:
    """Parameters of :func:`~darcyan.dense.maps.dense_map`, the ``dense`` section of
    :class:`DarcyanConfig` (``{"dense": {...}}`` in a ``--config`` file).

    Attributes:
        method: ``"zoomout"``: geodesic landmark coordinates, then the bijective ZoomOut below;
            ``"pyfm"``: pyFM's functional map with the landmarks as descriptors, then its ZoomOut
            (``pip install 'darcyan[pyfm]'``; slower, the ``basis_*``, ``margin_from``,
            ``zoomout_samples``, ``sampling``, ``bijectivity``, ``orthogonality``,
            ``signature_weight``, ``signature_until``, ``commutativity`` and ``ensemble`` fields do
            not apply).
        landmarks: ``"consistent"``: keep the largest set of matches whose pairwise geodesic
            distances agree on both shapes (see ``consistency``); ``"all"``: every match.
        consistency: two matches agree when their geodesic distances on the two shapes differ by
            at most this fraction of the larger one (plus ``consistency_floor``).
        consistency_floor: absolute slack of that test, in sqrt(area) units.
        exhaustive_landmarks: the largest consistent set is found by an exact maximum-clique
            search among up to this many matches; among more, greedily (the match with the most
            disagreements dropped until all agree).
        landmark_tie_weight: between consistent sets of one size, the least total distortion
            wins, plus this weight times the matches' descriptor distances (divided by their
            largest): a tie-break, small beside any distortion.
        basis_start: size of the first functional map of ZoomOut.
        basis_size: size of the last one (Laplace-Beltrami eigenfunctions computed per shape:
            this many plus ``basis_margin``).
        basis_step: growth of the basis per ZoomOut iteration.
        basis_margin: from ZoomOut's size ``margin_from`` on, the step of size k fits each
            functional map from k + ``basis_margin`` eigenfunctions of the shape it maps from to
            the k first of the other (a rectangular map), in the steps and in the final map.
            Between two bodies that are not isometric the eigenfunctions do not pair up index
            by index: near the cut at k, one shape's k-th is a mix of the other's on either side
            of it, which a square map must drop (``docs/decisions/dense.md``). The short ZoomOuts that
            score the seeds keep square maps.
        margin_from: the smallest size of ZoomOut that gets the margin (from the first size on,
            some FAUST maps lost: ``docs/decisions/dense.md``).
        zoomout_samples: ZoomOut iterates on this many surface samples of each shape (0 = on
            all vertices); the final map is always computed for every source vertex.
        ensemble: ZoomOut runs from this many different samples (the first as ``sampling``
            says, the others independent random draws, from ``seed``), combined by
            :func:`~darcyan.dense.zoomout.consensus_map` (per source vertex the medoid of the images; 1 or 2: one run, a
            medoid needs three).
        bijectivity, orthogonality: scales of the bijectivity (the map b -> a undoes a -> b)
            and orthogonality (area preservation) terms beside the coupling term in ZoomOut's
            nearest-neighbour searches: each term's coordinates are multiplied by its scale, so
            its squared residual weighs the square (bijectivity 2: 4; ``docs/decisions/dense.md``).
            0 and 0 = plain ZoomOut.
        landmark_weight: weight of the landmark coordinates (geodesic distances to the landmarks
            and, with ``orientation_weight``, their turns) beside the spectral terms in every
            ZoomOut step and in the final map: the landmarks hold the map throughout, not only
            at its start (3: ``docs/decisions/dense.md``).
        orientation_weight: weight of the :func:`~darcyan.dense.landmarks.orientation_coordinates` beside the geodesic
            distances to the landmarks in the first map and in the landmark term (0: distances
            only). Distances to five extremities of a human cannot tell its front from its back;
            the turns can (``docs/decisions/dense.md``).
        basis_tolerance: relative accuracy of the eigenvalues asked of the eigensolver (its
            start vector is seeded): 1e-3 gives the vectors of machine precision in half the
            time (``docs/decisions/dense.md``).
        basis_lanczos: Lanczos vectors the eigensolver keeps per eigenpair asked (ARPACK's
            ``ncv``; 0: scipy's default, max(2 k + 1, 20)): fewer make each restart cheaper and
            need more restarts; 1.5 took 12% less time than the default on six 5k meshes
            (``docs/decisions/speed.md``).
        basis_laplacian: the Laplacian whose eigenfunctions are the basis: ``"cotangent"``
            (the mesh's own cotangent Laplacian and mixed Voronoi areas) or ``"robust"`` (Sharp
            and Crane's intrinsic Delaunay Laplacian, from ``robust_laplacian`` in the ``bench``
            extra, which has no negative weights on a mesh of poor triangles). The robust one
            gained nothing on the marching-cubes copies and lost on the glued ones
            (``docs/decisions/every-pair.md``).
        basis_proxy_vertices: the basis of a mesh with more than twice this many vertices is
            computed on a decimated copy of about this many and interpolated
            (:meth:`darcyan.geometry.shape.Shape.smooth_basis`); 0: always on the mesh itself.
        candidates: the sparse matching and its first ``candidates - 1`` alternatives
            (``Correspondence.alternatives``) are each turned into a first map; the one whose
            map best keeps the :func:`~darcyan.dense.signatures.point_signature` seeds the dense map (1: the sparse
            matching alone). A seed of mirrored landmarks otherwise ruins a whole map.
        seed_statistic: how a seed's score sums the signature differences between the short map's
            source points and their images: ``"median"`` of the points' differences, or their
            ``"mean"``. Parts glued where they touch change the curvature over a few regions,
            which the median does not let decide (``docs/decisions/every-pair.md``).
        seed_basis, seed_samples: size of the short ZoomOut that scores each seed, and the
            samples it runs on.
        verify_proxy_vertices: a verification of feature matches that no dense map follows
            (:func:`darcyan.dense.verified_matches`) weighs the seeds of a mesh with more than
            twice this many vertices on its coarse copy of about this many, the matches moved to
            the copy's nearest vertices (:func:`darcyan.dense.seeds.on_coarse_shapes`); 0 (the
            default): on the mesh itself. Faster on large pairs, but at 6000 it chose worse
            on tosca-hires's 666 pairs (measured before the copies' vertices were read on their
            own part: 5 matches fewer right, two pairs more below 80% right, one of them 1 of 5;
            ``docs/decisions/speed.md``). Two matched vertices may fall on one copy vertex. A
            dense map weighs its seeds on the mesh itself.
        signature_lengths: diffusion lengths (sqrt(area)) of the mean curvature in that signature.
        signature_smoothing, signature_diffusion_steps: the Meyer curvatures' one-ring averagings and
            the diffusions' backward-Euler steps in that signature; ``None``: the describe stage's
            (``curvature_smoothing`` and ``heat.diffusion_steps``), as
            :meth:`DarcyanConfig.dense_for` fills them in, so that a dense map follows the
            caller's settings.
        signature_weight: weight of the :func:`~darcyan.dense.signatures.point_signature` (each length divided by its
            standard deviation over both shapes) beside the other terms of the chosen seed's
            ZoomOut steps up to ``signature_until`` eigenfunctions (0: never). At the coarse sizes
            the landmark coordinates cannot tell which way an arm or a chest is turned, and a
            map locks in a wrong turn there; the curvature of a face, a chest or an elbow can.
            At the fine sizes the signature (which changes with the pose) would bias the map,
            so it is dropped (``docs/decisions/dense.md``).
        signature_until: the largest basis size whose ZoomOut step uses the signature.
        signature_turns: weight of the :func:`~darcyan.dense.signatures.signature_turn_coordinates` (at each vertex, the
            turn from the gradient of the distance to each landmark to the gradient of each
            length of the point signature) beside the other terms of every ZoomOut step of the
            chosen seed and of the final read-out (0: none for such maps; with
            ``signature_turns_partial`` 0 too, never). Along a limb the distances to all
            the landmarks grow alike on all its sides; the turn from that direction to the one in
            which the curvature changes differs from one side to another (``docs/decisions/dense.md``).
            This weight holds when every feature point of the shape with fewer of them is a
            landmark of the map (:func:`~darcyan.dense.signatures.signature_turn_weight`).
        signature_turns_partial: the turns' weight when some feature point of the shape with fewer
            is not a landmark (a tail whose descriptors disagree, a hand glued to a hip): with a
            limb unanchored, strong turns let the map slide along it
            (``docs/decisions/every-pair.md``).
        seed_margin: an alternative replaces the sparse matching only when its score is lower
            by at least this share (``DenseMap.check.verdict.clear``: no other seed scored within
            this share of the chosen one's).
        trust_orientation: a map is ``trusted`` (``DenseMap.check``) only when its orientation
            agreement is at least this (a map flipped against its landmarks scores -0.5 to -0.7,
            a right one 0.6 to 0.9: 95% of the right maps of the benchmark sets at least 0.58),
            among other conditions (:func:`~darcyan.dense.maps.trusted`); a map from the matches
            that is not trusted meets the start without landmarks (``start_in_doubt``).
        trust_residual: a map is ``trusted`` only when the alignment's deformation stayed within
            this mean distance (sqrt(area)) of the images it was pulled to
            (``MapCheck.residual``): right maps of every benchmark set stayed within 0.0116, and
            every wholly wrong map the other conditions trusted went beyond 0.0126
            (``docs/decisions/every-pair.md``).
        local_search_above: a target mesh with more vertices than this is searched coarse to
            fine for the final map (:func:`darcyan.geometry.knn.nearest_rows_near`: in cells of
            equal vertex count, as many as ZoomOut's samples, near the image's nearest cell)
            instead of over all its vertices: O(V) instead of O(V^2) work.
        local_search_reach: the coarse-to-fine search looks at the cells of this many samples
            around the nearest one.
        local_search_guess: each vertex's nearest cell is sought among this many times
            ``local_search_reach`` cells around a guess (the image of the source sample nearest
            the vertex), not among all cells: 1 lost 0.4 to 1.5 points within 0.05 on TOSCA's
            52k humans, 4 is as the full search to 0.4 points (``docs/decisions/speed.md``).
        commutativity: weight of a Laplacian commutativity term in the functional maps of the
            chosen seed's ZoomOut (its steps and final map): each entry ``C[i, j]`` of a
            least-squares fit is shrunk by ``1 / (1 + commutativity ((l_i - l_j) / (l_i +
            l_j))^2)`` (``l`` the eigenvalues; :func:`~darcyan.dense.zoomout.commutativity_shrinkage`), so a map mixes
            eigenfunctions of unlike frequencies only where the point map insists. Between two
            bodies a point map's noise spreads over all the entries, and a plain fit carries it
            into the next step. 0: plain ZoomOut fits. The short ZoomOuts that score the seeds
            fit without it (``docs/decisions/dense.md``).
        seed: seed of the random surface samples (``sampling`` ``"random"``, and the other
            members of an ensemble).
        sampling: how the ``zoomout_samples`` are chosen: ``"random"``, drawn by area with
            ``seed``; ``"farthest"``, farthest-point samples (spread evenly, and the same whatever
            the vertices' numbering: a renumbered or re-welded file gets the same map; the other
            members of an ensemble still draw at random). Random stays the default: farthest
            points lost a tosca-hires map (``docs/decisions/dense.md``).
        alignment_rounds: rounds of :func:`~darcyan.dense.alignment.aligned_map` after ZoomOut:
            the source deformed as rigidly as possible towards the map's images, then each
            vertex sent to the target vertex nearest its deformed position and normal (0: the
            map ZoomOut reads out). Intrinsic refinements drift towards the most isometric map,
            which between two bodies is not the true one; the shape of the source's one-rings
            is information they do not use (``docs/decisions/dense.md``).
        alignment_length: the deformation follows the map on scales beyond this length (sqrt(area)
            units) and keeps the source's shape below it (the weight of its pull is
            ``2 / alignment_length^2`` per unit area, each edge counted twice in the rigidity term;
            :class:`~darcyan.geometry.deformation.ArapDeformation`).
        alignment_normal_weight: the normals' weight (a length, sqrt(area) units) beside the
            positions in the nearest-point search: a point near the surface of an arm is not
            sent across to the body beside it.
        alignment_iterations: local-global steps of the deformation per round.
        alignment_proxy_vertices: the source of at least twice this many vertices is deformed
            through its coarse copy of about this many (the one ``basis_proxy_vertices`` makes
            when they are equal), its vertices moving with the copy; 0: always the mesh itself
            (``docs/decisions/speed.md``).
        alignment_stretch: how much each one-ring of the deformed source may grow or shrink beside
            turning (its best scale, held within ``1 / (1 + stretch)`` and ``1 + stretch``): 0 keeps
            one-rings their size (as rigid as possible); above it the source may follow a target
            whose proportions differ (as similar as possible, within that range).
        start_dimensions: when the matches give fewer than three consistent landmarks, the map
            starts from each choice of signs of this many first (non-constant) Laplace-Beltrami
            eigenfunctions, 2^d short maps (:mod:`darcyan.dense.start`).
        start_landmarks: farthest points of the source whose images under the chosen short map
            are the landmarks of such a start.
        start_checked: the short maps of best signature score whose orientation is read (each
            costs ``start_landmarks`` fast-marching solves on the target).
        start_in_doubt: when the map started from the matches is not trusted, the start
            without landmarks competes with its seed: its landmarks seed a short ZoomOut scored
            like the matchings' (the curvature signature); when it scores lower by
            ``seed_margin``, a map is made from it, and taken (``MapCheck.start``
            ``"spectral"``) when the alignment also follows it more closely (a lower
            ``MapCheck.residual``). A wrong sparse matching (or an alternative that beat a right
            one by a hair) ruins a whole map, and the start without landmarks does not depend on
            it. Costs a clear pair nothing (``docs/decisions/every-pair.md``).
        rival_by_checks: when the start without landmarks does not score clearly lower
            (``start_in_doubt``), its map is made anyway and taken when it passes the checks a
            trusted map passes (orientation agreement at least ``trust_orientation``, residual
            at most ``trust_residual``) and beats the map from the matches on both. The
            signature scores a map that keeps a mirrored or misplaced landmark pair almost as
            well as the right one; its orientation and residual do not
            (``docs/decisions/every-pair.md``). Costs a map in doubt one more map, when the
            signature did not already choose the start.
        rival_agreement: the start's map is taken by ``rival_by_checks`` only when it and the
            first map send at least this share of the source's area to within
            ``rival_agreement_radius`` of each other: the rule mends a part of a map. A map that
            turns the whole body round keeps the orientation and residual of a right one, and
            overturning most of a map is left to the signature.
        rival_agreement_radius: that distance, in space on the target (sqrt(area) units).
        rival_sure_matching: when the map from an alternative matching (one the signature
            chose over the sparse matching) is not trusted and the sparse stage was sure of its
            own matching, that matching's map is made too (ZoomOut with alignment only), and
            taken when it passes the checks a trusted map passes and beats the alternative's on
            orientation and residual (the checks of ``rival_by_checks``, without its
            ``rival_agreement``: the sure matching has passed the sparse stage's judges;
            ``SeedVerdict.by_checks``). An alternative that moves one landmark pair to the next
            extremity can score a few percent lower by the signature of a short map and still
            turn a limb or the head round (``docs/decisions/every-pair.md``). Costs such a map
            one more map.
        rival_best_scored: when the map from the first usable seed (the sparse matching, which
            ``seed_margin`` kept although another seed scored lower by less than the margin) is
            not trusted, the map of the seed that scored lowest is made too (ZoomOut with
            alignment only), and taken when it beats the first map on orientation and residual
            (``SeedVerdict.by_checks``; it stays untrusted: its seed did not stand clear). Two seeds a few
            percent apart are a knife's edge that the margin settles for the sparse matching; a
            map from it that fails the checks has lost that favour
            (``docs/decisions/every-pair.md``). Costs such a map one more map.
        landmark_contradiction: a ZoomOut map that is not trusted (from the matches, or from
            the landmarks of the start without them) has its landmark pairs checked against each
            other, before the start without landmarks competes and whether or not it does: each
            pair's source is sent by the short map seeded by the other pairs alone (the seeds'
            scoring map: ``seed_basis``, ``seed_samples``), and when the farthest image lies
            more than this (geodesic, sqrt(area) units) from its pair's target, a map is made
            without that pair, and taken when its alignment follows it at least as closely and
            it agrees at least as well with its own landmarks' orientation (without alignment,
            the orientation alone) (``SeedVerdict.left_out``; one pair, once; 0: never). A wrong
            pair whose distances to the others are right by symmetry (a front paw sent to the
            other) survives the consistency test and ruins its region; right pairs mostly stay
            within 0.2 of their targets, but a short map that lost a limb sends one farther,
            hence the two judges (``docs/decisions/every-pair.md``).
        handle_length: a ZoomOut map that is still not trusted after the rules above is made
            again on copies of the shapes cut open along the shortest loop around each handle
            shorter than this (sqrt(area) units; :func:`~darcyan.dense.maps.dense_shape`; the
            sparse stage keeps the shapes as they are), when either shape has one, and taken
            when it agrees better with its landmarks' orientation and its alignment follows it
            more closely (``SeedVerdict.handles_cut``; 0: never; never without the alignment,
            whose residual is one of the two judges). A body is a sphere; where
            parts that touch were joined (a hand on a hip, clasped hands) the surface has a
            handle, which changes geodesics and eigenfunctions far beyond it
            (``docs/decisions/every-pair.md``). Costs such a map the search for the loops
            (0.4 s for a glued body's handle at 5,000 vertices) and one more map.
        handle_max_vertices: the cut of ``handle_length`` is made only when both meshes have at
            most this many vertices: beyond, the second map and the search for the loops (5.4 s
            for a glued body's handle at 80,000 vertices, 1.3 s at 20,000) cost more than a pair
            in doubt should (a 210k pair's map alone takes about 20 s).
        alignment_slack: a vertex keeps ZoomOut's image where the aligned image's geodesic
            distances to the landmarks differ from the vertex's own by more than this (sqrt(area)
            units) beyond those of ZoomOut's image: two fingers side by side are near in space,
            not in their distances to the landmarks (``docs/decisions/dense.md``).
    """

    method: str = "zoomout"
    landmarks: str = "consistent"
    consistency: float = 0.3
    consistency_floor: float = 0.02
    exhaustive_landmarks: int = 24
    landmark_tie_weight: float = 1e-3
    basis_start: int = 10
    basis_size: int = 120
    basis_step: int = 4
    basis_margin: int = 10
    margin_from: int = 40
    zoomout_samples: int = 2000
    ensemble: int = 1
    bijectivity: float = 2.0
    orthogonality: float = 1.0
    landmark_weight: float = 3.0
    orientation_weight: float = 1.0
    basis_proxy_vertices: int = 6000
    basis_tolerance: float = 1e-3
    basis_lanczos: float = 1.5
    basis_laplacian: str = "cotangent"
    candidates: int = 4
    seed_statistic: str = "median"
    seed_basis: int = 30
    seed_samples: int = 1000
    verify_proxy_vertices: int = 0
    signature_lengths: tuple = (0.02, 0.05, 0.1)
    signature_smoothing: int | None = None
    signature_diffusion_steps: int | None = None
    signature_weight: float = 3.0
    signature_until: int = 70
    signature_turns: float = 3.0
    signature_turns_partial: float = 2.0
    seed_margin: float = 0.04
    trust_orientation: float = 0.55
    trust_residual: float = 0.012
    local_search_above: int = 20000
    local_search_reach: int = 16
    local_search_guess: int = 4
    commutativity: float = 3.0
    seed: int = 0
    sampling: str = "random"
    alignment_rounds: int = 2
    alignment_length: float = 0.035
    alignment_normal_weight: float = 0.02
    alignment_iterations: int = 6
    alignment_proxy_vertices: int = 6000
    alignment_stretch: float = 0.0
    alignment_slack: float = 0.04
    start_dimensions: int = 4
    start_landmarks: int = 6
    start_checked: int = 4
    start_in_doubt: bool = True
    rival_by_checks: bool = True
    rival_agreement: float = 0.5
    rival_agreement_radius: float = 0.05
    rival_sure_matching: bool = True
    rival_best_scored: bool = True
    landmark_contradiction: float = 0.3
    handle_length: float = 0.05
    handle_max_vertices: int = 100_000

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"dense: method must be one of {METHODS}, got {self.method!r}")
        if self.basis_laplacian not in LAPLACIANS:
            raise ConfigError(f"dense: basis_laplacian must be one of {LAPLACIANS}, got {self.basis_laplacian!r}")
        if self.sampling not in SAMPLINGS:
            raise ConfigError(f"dense: sampling must be one of {SAMPLINGS}, got {self.sampling!r}")
        if self.seed_statistic not in SEED_STATISTICS:
            raise ConfigError(f"dense: seed_statistic must be one of {SEED_STATISTICS}, got {self.seed_statistic!r}")
        if self.landmarks not in LANDMARK_MODES:
            raise ConfigError(f"dense: landmarks must be one of {LANDMARK_MODES}, got {self.landmarks!r}")
        for name in ("basis_start", "basis_size", "basis_step", "local_search_reach", "candidates", "seed_basis",
                     "seed_samples", "ensemble", "alignment_iterations", "exhaustive_landmarks", "local_search_guess",
                     "start_dimensions", "start_landmarks",
                     "start_checked"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"dense: {name} must be a positive integer, got {value!r}")
        if self.basis_start > self.basis_size:
            raise ConfigError(f"dense: basis_start ({self.basis_start}) exceeds basis_size ({self.basis_size})")
        for name in ("start_in_doubt", "rival_by_checks", "rival_sure_matching", "rival_best_scored"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"dense: {name} must be true or false, got {getattr(self, name)!r}")
        for name in ("zoomout_samples", "local_search_above", "basis_proxy_vertices", "verify_proxy_vertices",
                     "signature_until",
                     "basis_margin", "margin_from", "alignment_rounds", "alignment_proxy_vertices",
                     "handle_max_vertices"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise ConfigError(f"dense: {name} must be a non-negative integer, got {value!r}")
        for name, least in (("signature_smoothing", 0), ("signature_diffusion_steps", 1)):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, int) or isinstance(value, bool) or value < least):
                raise ConfigError(f"dense: {name} must be None or an integer >= {least}, got {value!r}")
        lengths = self.signature_lengths
        if (not isinstance(lengths, (list, tuple)) or not lengths
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0 for x in lengths)):
            raise ConfigError(f"dense: signature_lengths must be a list of positive lengths, got {lengths!r}")
        object.__setattr__(self, "signature_lengths", tuple(float(x) for x in lengths))
        if not (isinstance(self.seed_margin, (int, float)) and 0 <= self.seed_margin < 1):
            raise ConfigError(f"dense: seed_margin must be in [0, 1), got {self.seed_margin!r}")
        if not (isinstance(self.trust_orientation, (int, float)) and -1 <= self.trust_orientation <= 1):
            raise ConfigError(f"dense: trust_orientation must be in [-1, 1], got {self.trust_orientation!r}")
        for name in ("consistency", "consistency_floor", "bijectivity", "orthogonality", "landmark_weight",
                     "orientation_weight", "basis_tolerance", "signature_weight", "signature_turns", "signature_turns_partial",
                     "commutativity", "alignment_normal_weight", "alignment_slack", "landmark_tie_weight",
                     "trust_residual", "landmark_contradiction", "basis_lanczos", "rival_agreement_radius",
                     "handle_length", "alignment_stretch"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0
                    and math.isfinite(value)):
                raise ConfigError(f"dense: {name} must be non-negative, got {value!r}")
        share = self.rival_agreement
        if not (isinstance(share, (int, float)) and not isinstance(share, bool) and 0 <= share <= 1):
            raise ConfigError(f"dense: rival_agreement must be a share in [0, 1], got {share!r}")
        length = self.alignment_length
        if not (isinstance(length, (int, float)) and not isinstance(length, bool) and length > 0 and math.isfinite(length)):
            raise ConfigError(f"dense: alignment_length must be a positive length, got {length!r}")


SECTIONS = {"repairing": Repairing, "denoising": Denoising, "heat": HeatKernel, "margins": GeodesicMargins,
            "consistency": Consistency, "mirror": MirrorTest, "rims": CutRims, "dense": DenseConfig}


@dataclass(frozen=True)
class DarcyanConfig:
    """Parameters of feature extraction, the Darcyan grid, the descriptor and matching.

    Attributes:
        levels: n, the number of geodesic level curves of the grid (the descriptor has 2n values).
        radial_lines: m, the number of radial geodesic lines, at equal angles 2*pi/m.
        radius: R, geodesic radius of the outermost level curve; level k sits at R*k/n.
        interpolation: the paper's interpolation step: each level curve is sampled at
            ``radial_lines * interpolation`` points (geodesics traced between the m radial lines)
            so the per-level mean sees more of the curve. 1 disables it.
        denoise_area_ratio: a mesh whose area exceeds this multiple of its area after a few
            Taubin smoothing steps, and whose roughness is that of vertex noise, is crumpled at
            the scale of its edges; it is analysed after Taubin smoothing (with a warning), vertex
            numbering kept (see :func:`darcyan.geometry.denoise.denoise_mesh`). Clean TOSCA meshes stay below
            1.04, vertex noise of half an edge gives 1.4 to 2.5. 0 disables the test.
        curvature_smoothing: iterations of area-weighted one-ring averaging applied to the Meyer
            principal curvatures before they are sampled (0 = raw Meyer operators).
        agd_sources: number of farthest-point-sampled sources whose fast-marching distances are
            averaged to approximate the Average Geodesic Distance (exact AGD would need V solves).
        agd_smoothing: length scale of a heat diffusion of the AGD field before its maxima are
            taken (0: the paper's plain AGD). Makes feature points repeat across poses.
        proxy_vertices: the smooth global fields of meshes with more than twice this many
            vertices (AGD's distances before their diffusion, the mirror test's signature, the
            distance estimate that cuts a geodesic ball around each feature point) are computed
            on a copy decimated to this many vertices and interpolated back (0: always on the
            full mesh).
        extremity_radius: a feature point is a vertex whose AGD is the largest within this
            geodesic radius (greedy non-maximum suppression over one-ring maxima).
        tip_gain: each feature point moves, within its extremity's top, to the vertex where the
            heat kernel at the time of ``agd_smoothing`` is largest, if it is at least this many
            times the point's own (see :func:`darcyan.method.features.sharpest_tips`): the cat's nose
            instead of whichever of nose and ears a stretched body makes highest; 0 disables it
            (as does ``agd_smoothing`` 0).
        tip_radius: the extremity's top lies within this geodesic distance of the feature point.
        tip_agd_drop: the extremity's top: the vertices within ``tip_radius`` whose AGD is at
            most this much below the feature point's (sqrt(area) units).
        min_agd_quantile: one-ring maxima whose AGD is below this quantile of the AGD over the
            vertices are discarded: extremities are far from everything, dents are not. Below
            the median because diffusion lowers the peak of a short limb most (a cat's front
            paw fell just under it).
        max_features: keep at most this many feature points (highest AGD first); 0 = no limit.
        matching: ``"consistent"`` (one-to-one, partial, trading descriptor distance against
            preserved geodesic distances and orientation: no left/right swaps), ``"nearest"``
            (the paper: each source point takes its nearest target descriptor) or
            ``"one-to-one"`` (optimal assignment on descriptor distance alone).
        max_match_distance: a match whose descriptor distance exceeds this multiple of the median
            distance over all (source, target) pairs of feature points is left out: its local
            shapes differ more than a typical pair of unrelated extremities, and only the layout
            kept it (mostly a feature point with no counterpart on the other shape, such as a
            cat's ear against its nose); 0 keeps every match.

    Sections (typed, each documented in its class), for settings below the method's parameters:
        repairing: :class:`Repairing`, what ``repair`` welds and drops.
        denoising: :class:`Denoising`, how a crumpled surface is smoothed.
        heat: :class:`HeatKernel`, the heat kernel of the sharpest tips and the heat diffusions.
        margins: :class:`GeodesicMargins`, how far exact geodesics reach around a feature point.
        consistency: :class:`Consistency`, the weights of the layout-keeping matcher.
        mirror: :class:`MirrorTest`, the test that rejects mirror-image matchings.
        rims: :class:`CutRims`, how a partial shape's cut is kept from being an extremity.
        dense: :class:`DenseConfig`, how a dense map is made (and a matching in doubt verified).

    Every field changes one stage: preparing a mesh, describing a shape or matching two;
    :meth:`fingerprint` derives cache keys from the fields of the stages a result depends on.
    """

    levels: int = _stage(6, DESCRIBE)
    radial_lines: int = _stage(16, DESCRIBE)
    radius: float = _stage(0.12, DESCRIBE)
    interpolation: int = _stage(2, DESCRIBE)
    curvature_smoothing: int = _stage(4, DESCRIBE)
    denoise_area_ratio: float = _stage(1.1, PREPARE)
    agd_sources: int = _stage(24, DESCRIBE)
    agd_smoothing: float = _stage(0.14, DESCRIBE)
    proxy_vertices: int = _stage(6000, DESCRIBE)
    extremity_radius: float = _stage(0.25, DESCRIBE)
    min_agd_quantile: float = _stage(0.3, DESCRIBE)
    tip_gain: float = _stage(1.1, DESCRIBE)
    tip_radius: float = _stage(0.35, DESCRIBE)
    tip_agd_drop: float = _stage(0.03, DESCRIBE)
    max_features: int = _stage(0, DESCRIBE)
    matching: str = _stage("consistent", MATCH)
    max_match_distance: float = _stage(1.5, MATCH)
    repairing: Repairing = _stage(Repairing(), PREPARE)
    denoising: Denoising = _stage(Denoising(), PREPARE)
    heat: HeatKernel = _stage(HeatKernel(), DESCRIBE)
    margins: GeodesicMargins = _stage(GeodesicMargins(), DESCRIBE)
    consistency: Consistency = _stage(Consistency(), MATCH)
    mirror: MirrorTest = _stage(MirrorTest(), MATCH)
    rims: CutRims = _stage(CutRims(), DESCRIBE)
    dense: DenseConfig = _stage(DenseConfig(), DENSE)

    def __post_init__(self) -> None:
        positive_ints = ("levels", "radial_lines", "interpolation", "agd_sources")
        for name in positive_ints:
            value = getattr(self, name)
            if not _integer(value) or value < 1:
                raise ConfigError(f"config: {name} must be a positive integer, got {value!r}")
        if self.radial_lines < 3:
            raise ConfigError("config: radial_lines must be at least 3")
        for name in ("curvature_smoothing", "max_features", "proxy_vertices"):
            value = getattr(self, name)
            if not _integer(value) or value < 0:
                raise ConfigError(f"config: {name} must be a non-negative integer, got {value!r}")
        if not (isinstance(self.agd_smoothing, (int, float)) and 0 <= self.agd_smoothing < 10):
            raise ConfigError(f"config: agd_smoothing must be a length >= 0, got {self.agd_smoothing!r}")
        if not (isinstance(self.denoise_area_ratio, (int, float)) and self.denoise_area_ratio >= 0):
            raise ConfigError(f"config: denoise_area_ratio must be >= 0 (0: off), got {self.denoise_area_ratio!r}")
        if not (isinstance(self.tip_gain, (int, float)) and (self.tip_gain == 0 or 1 <= self.tip_gain < 100)):
            raise ConfigError(f"config: tip_gain must be 0 (off) or a factor >= 1, got {self.tip_gain!r}")
        if not (isinstance(self.tip_agd_drop, (int, float)) and 0 <= self.tip_agd_drop < 10):
            raise ConfigError(f"config: tip_agd_drop must be a length >= 0, got {self.tip_agd_drop!r}")
        for name in ("radius", "extremity_radius", "tip_radius"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 < value < 10):
                raise ConfigError(f"config: {name} must be a positive length (in sqrt(area)), got {value!r}")
        if not 0 <= self.min_agd_quantile < 1:
            raise ConfigError(f"config: min_agd_quantile must be in [0, 1), got {self.min_agd_quantile!r}")
        if not (isinstance(self.max_match_distance, (int, float)) and math.isfinite(self.max_match_distance)
                and self.max_match_distance >= 0):
            raise ConfigError(f"config: max_match_distance must be >= 0 (0: off), got {self.max_match_distance!r}")
        if self.matching not in MATCHING_MODES:
            raise ConfigError(f"config: matching must be one of {MATCHING_MODES}, got {self.matching!r}")
        for name, kind in SECTIONS.items():
            value = getattr(self, name)
            if isinstance(value, dict):  # as read back from JSON
                value = kind(**value)
                object.__setattr__(self, name, value)
            if not isinstance(value, kind):
                raise ConfigError(f"config: {name} must be a {kind.__name__}, got {value!r}")

    def dense_for(self, section: "DenseConfig | None" = None) -> "DenseConfig":
        """``section`` (default this config's ``dense``) as a dense map runs it: its unset
        (``None``) point-signature settings taken from this config's ``curvature_smoothing`` and
        ``heat.diffusion_steps``, so that a dense map follows the caller's description settings
        (however this config was made: ``replace``, ``updated``, a ``--config`` file)."""
        section = self.dense if section is None else section
        derived = {"signature_smoothing": self.curvature_smoothing,
                   "signature_diffusion_steps": self.heat.diffusion_steps}
        unset = {name: value for name, value in derived.items() if getattr(section, name) is None}
        return dataclasses.replace(section, **unset) if unset else section

    def replace(self, **changes) -> "DarcyanConfig":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def updated(self, changes: dict, source: str = "config") -> "DarcyanConfig":
        """A copy with ``changes`` applied: method parameters by name, sections as dicts of the
        fields to change (``{"mirror": {"samples": 400}}``), as in a ``--config`` JSON file.
        An unknown name is a :class:`ConfigError` naming ``source``."""
        flat, nested = {}, {}
        names = {f.name for f in dataclasses.fields(self)}
        for name, value in changes.items():
            if name not in names:
                raise ConfigError(f"{source}: unknown setting {name!r} (known: {', '.join(sorted(names))})")
            if name in SECTIONS and isinstance(value, dict):
                section = getattr(self, name)
                known = {f.name for f in dataclasses.fields(section)}
                unknown = sorted(set(value) - known)
                if unknown:
                    raise ConfigError(f"{source}: unknown setting {name}.{unknown[0]} (known: {', '.join(sorted(known))})")
                nested[name] = dataclasses.replace(section, **value)
            else:
                flat[name] = value
        return self.replace(**flat, **nested)

    def as_dict(self) -> dict:
        """Every field, sections as nested dicts (JSON-ready; ``DarcyanConfig(**d)`` reads it back)."""
        return dataclasses.asdict(self)

    def fingerprint(self, *stages: str) -> str:
        """A short hash of every field that changes the given stages (all fields when none are
        named): the cache key of a result that depends on them. Derived from the fields'
        declared stage, sections included, so a new setting can never be left out of a key."""
        chosen = {name: value for name, value in _staged_fields(self)
                  if not stages or _stage_of(self, name) in stages}
        return hashlib.sha1(json.dumps(chosen, sort_keys=True).encode()).hexdigest()[:16]

    def prepare_fingerprint(self) -> str:
        """:meth:`fingerprint` of what changes how a mesh is prepared
        (:func:`darcyan.geometry.shape.prepare_shape`)."""
        return self.fingerprint(PREPARE)

    def describe_fingerprint(self) -> str:
        """:meth:`fingerprint` of what changes a shape's description (its preparation included)."""
        return self.fingerprint(PREPARE, DESCRIBE)

    @classmethod
    def paper(cls, **changes) -> "DarcyanConfig":
        """The paper's method as published: plain AGD maxima, no denoising, nearest-descriptor matching,
        no notion of a cut's rim.
        (Its AGD floor stays at the median, where the paper columns of the README were measured:
        the floor's default came down for diffused AGD, which the paper does not use.)"""
        return cls(agd_smoothing=0.0, extremity_radius=0.15, min_agd_quantile=0.5, denoise_area_ratio=0.0, tip_gain=0.0,
                   matching="nearest", max_match_distance=0.0, rims=CutRims(min_length=0.0)).replace(**changes)

    @property
    def level_radii(self) -> "list[float]":
        """lambda_1..lambda_n: the geodesic radii of the level curves."""
        return [self.radius * (k + 1) / self.levels for k in range(self.levels)]


def _staged_fields(config) -> list:
    """``[(dotted name, value), ...]`` of every leaf field of ``config``, sections flattened."""
    out = []
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            out += [(f"{f.name}.{name}", v) for name, v in _staged_fields(value)]
        else:
            out.append((f.name, list(value) if isinstance(value, tuple) else value))
    return out


def _stage_of(config, dotted: str) -> str:
    """The stage declared for the field ``dotted`` (``"mirror.samples"``) of ``config``; a field of
    a section that declares none (:class:`DenseConfig`'s) has its section's."""
    owner, stage = config, None
    for name in dotted.split("."):
        field = {f.name: f for f in dataclasses.fields(owner)}[name]
        stage = field.metadata.get("stage", stage)
        owner = getattr(owner, name)
    return stage


def field_docs(cls) -> dict:
    """``{field: text}``: each field's documentation, from the ``Attributes:`` section of
    ``cls``'s docstring (an entry ``a, b: text`` documents both); what the command-line help and
    the settings reference show, so that it is written once. Read once per class (the command
    line asks for every option's); an instance reads its class's."""
    return dict(_field_docs(cls if isinstance(cls, type) else type(cls)))


@functools.lru_cache(maxsize=None)
def _field_docs(cls) -> tuple:
    doc = inspect.cleandoc(cls.__doc__ or "")
    if "Attributes:" not in doc:
        return ()
    out: dict = {}
    names: list = []
    for line in doc.split("Attributes:", 1)[1].splitlines():
        if not line.strip():
            continue
        if not line.startswith(" "):
            break  # the section ended
        entry = re.match(r"^ {4}([a-z_][a-z0-9_, ]*):\s?(.*)$", line)
        if entry:
            names = [n.strip() for n in entry.group(1).split(",")]
            for name in names:
                out[name] = entry.group(2).strip()
        elif names:
            for name in names:
                out[name] += " " + line.strip()
    return tuple(out.items())


def field_summary(cls, name: str) -> str:
    """The first sentence of a field's :func:`field_docs`, its markup dropped (a one-line help)."""
    text = field_docs(cls).get(name, "").replace("``", "")
    text = re.sub(r":(?:class|func|meth|attr|mod):`~?([^`]+)`", lambda m: m.group(1).rsplit(".", 1)[-1], text)
    return re.split(r"(?<=[a-z0-9)])\. ", text, maxsplit=1)[0].rstrip(".")
