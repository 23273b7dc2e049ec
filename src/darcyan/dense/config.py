"""The settings of a dense map: :class:`DenseConfig`, every number that changes one, typed and
documented in one place (``docs/decisions/dense.md`` shows how each default was chosen)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

LANDMARK_MODES = ("consistent", "all")
METHODS = ("zoomout", "pyfm")
SAMPLINGS = ("farthest", "random")  # DenseConfig.sampling
SEED_STATISTICS = ("median", "mean")  # DenseConfig.seed_statistic


@dataclass(frozen=True)
class DenseConfig:
    """Parameters of :func:`~darcyan.dense.maps.dense_map`.

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
        signature_lengths: diffusion lengths (sqrt(area)) of the mean curvature in that signature.
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
            chosen seed and of the final read-out (0: never). Along a limb the distances to all
            the landmarks grow alike on all its sides; the turn from that direction to the one in
            which the curvature changes differs from one side to another (``docs/decisions/dense.md``).
        seed_margin: an alternative replaces the sparse matching only when its score is lower
            by at least this share (``DenseMap.check["clear"]``: no other seed scored within
            this share of the chosen one's).
        trust_orientation: a map is ``trusted`` (``DenseMap.check``) when its orientation
            agreement is at least this (a map flipped against its landmarks scores -0.5 to -0.7,
            a right one 0.6 to 0.9) and it did not set aside a matching the sparse stage was sure
            of (:func:`~darcyan.dense.maps.trusted`).
        local_search_above: a target mesh with more vertices than this is searched coarse to
            fine for the final map (:func:`darcyan.geometry.knn.nearest_rows_near`: near the
            image's nearest ZoomOut sample) instead of over all its vertices: O(V) instead of
            O(V^2) work.
        local_search_reach: the coarse-to-fine search looks at the cells of this many samples
            around the nearest one.
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
        start_dimensions: when the matches give fewer than three consistent landmarks, the map
            starts from each choice of signs of this many first (non-constant) Laplace-Beltrami
            eigenfunctions, 2^d short maps (:mod:`darcyan.dense.start`).
        start_landmarks: farthest points of the source whose images under the chosen short map
            are the landmarks of such a start.
        start_checked: the short maps of best signature score whose orientation is read (each
            costs ``start_landmarks`` fast-marching solves on the target).
        alignment_slack: a vertex keeps ZoomOut's image where the aligned image's geodesic
            distances to the landmarks differ from the vertex's own by more than this (sqrt(area)
            units) beyond those of ZoomOut's image: two fingers side by side are near in space,
            not in their distances to the landmarks (``docs/decisions/dense.md``).
    """

    method: str = "zoomout"
    landmarks: str = "consistent"
    consistency: float = 0.3
    consistency_floor: float = 0.02
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
    candidates: int = 4
    seed_statistic: str = "median"
    seed_basis: int = 30
    seed_samples: int = 1000
    signature_lengths: tuple = (0.02, 0.05, 0.1)
    signature_weight: float = 3.0
    signature_until: int = 70
    signature_turns: float = 2.0
    seed_margin: float = 0.04
    trust_orientation: float = 0.3
    local_search_above: int = 20000
    local_search_reach: int = 16
    commutativity: float = 3.0
    seed: int = 0
    sampling: str = "random"
    alignment_rounds: int = 2
    alignment_length: float = 0.035
    alignment_normal_weight: float = 0.02
    alignment_iterations: int = 6
    alignment_slack: float = 0.04
    start_dimensions: int = 4
    start_landmarks: int = 6
    start_checked: int = 4

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ConfigError(f"dense: method must be one of {METHODS}, got {self.method!r}")
        if self.sampling not in SAMPLINGS:
            raise ConfigError(f"dense: sampling must be one of {SAMPLINGS}, got {self.sampling!r}")
        if self.seed_statistic not in SEED_STATISTICS:
            raise ConfigError(f"dense: seed_statistic must be one of {SEED_STATISTICS}, got {self.seed_statistic!r}")
        if self.landmarks not in LANDMARK_MODES:
            raise ConfigError(f"dense: landmarks must be one of {LANDMARK_MODES}, got {self.landmarks!r}")
        for name in ("basis_start", "basis_size", "basis_step", "local_search_reach", "candidates", "seed_basis",
                     "seed_samples", "ensemble", "alignment_iterations", "start_dimensions", "start_landmarks",
                     "start_checked"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"dense: {name} must be a positive integer, got {value!r}")
        if self.basis_start > self.basis_size:
            raise ConfigError(f"dense: basis_start ({self.basis_start}) exceeds basis_size ({self.basis_size})")
        for name in ("zoomout_samples", "local_search_above", "basis_proxy_vertices", "signature_until",
                     "basis_margin", "margin_from", "alignment_rounds"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise ConfigError(f"dense: {name} must be a non-negative integer, got {value!r}")
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
                     "orientation_weight", "basis_tolerance", "signature_weight", "signature_turns",
                     "commutativity", "alignment_normal_weight", "alignment_slack"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0
                    and np.isfinite(value)):
                raise ConfigError(f"dense: {name} must be non-negative, got {value!r}")
        length = self.alignment_length
        if not (isinstance(length, (int, float)) and not isinstance(length, bool) and length > 0 and np.isfinite(length)):
            raise ConfigError(f"dense: alignment_length must be a positive length, got {length!r}")
