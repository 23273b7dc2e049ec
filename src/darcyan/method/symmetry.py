"""Telling a correspondence from its mirror image.

An intrinsic left/right symmetry keeps every geodesic distance, so descriptors and distances
cannot tell a matching from its mirror image. Orientation can: a map between consistently
oriented surfaces that follows the true correspondence keeps the turning sense of small
triangles, a mirror map reverses it.

:func:`orientation_agreement` extends a landmark correspondence to a coarse map (each point goes
to the target point with the most similar geodesic distances to the matched landmarks) and
measures how many small triangles of sample points keep their orientation under it.

On the humans that coarse map is too rough to settle a swap of the hands or the feet alone (a
torso's front and back have the same distances to the extremities). :func:`handedness` reads
orientation where it is sharp: around a limb tip the curvature pattern is itself chiral (a
hand's thumb lies on one side), and read counter-clockwise about the outward normal it matches
the same tip's pattern on another pose turning the same way, and its mirror image's turning the
other way.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..config import MirrorTest
from ..geometry.heat import curvature_signature, shape_signature  # noqa: F401 (darcyan.method.symmetry.*)
from ..geometry.knn import NearestPoints, nearest_neighbours
from ..geometry.sampling import sample_vertices

# The test's settings (sample counts, weights, the handedness levels, ...) are DarcyanConfig.mirror:
# :class:`darcyan.config.MirrorTest`, where each is documented with how it was chosen.

# Rounds of orientation_agreement's votes (how soon a matching that cannot win is given up;
# the agreement it returns for the others is the same whatever the number).
AGREEMENT_ROUNDS = 4


@dataclass(frozen=True)
class OrientedSurface:
    """What the orientation test needs of one shape.

    Attributes:
        points: ``(n, 3)`` vertex positions (normalized mesh).
        normals: ``(n, 3)`` outward unit vertex normals.
        landmark_distances: ``(k, n)`` geodesic distance from each feature point to every vertex.
        signature: optional ``(n, h)`` intrinsic point signature (e.g. heat kernel signature),
            mirror-blind but telling apart points that landmark distances confuse (the front and
            back of a torso or a limb); scaled to be comparable with the distances.
        areas: optional ``(n,)`` vertex areas; the test's points are drawn in proportion to
            them (uniformly over the surface), else uniformly over the vertices.
        profiles: optional ``(k, 2, l, a)`` angular curvature profiles around the feature points
            (:func:`darcyan.method.descriptors.angular_profiles`), for :func:`handedness`.
    """

    points: np.ndarray
    normals: np.ndarray
    landmark_distances: np.ndarray
    signature: np.ndarray | None = None
    areas: np.ndarray | None = None
    profiles: np.ndarray | None = None


def choose_orientation(candidates, surface_1: OrientedSurface | None, surface_2: OrientedSurface | None,
                       test: MirrorTest = MirrorTest()):
    """The matches :func:`weigh_orientations` chooses (without its margin)."""
    return weigh_orientations(candidates, surface_1, surface_2, test)[0]


def weigh_orientations(candidates, surface_1: OrientedSurface | None, surface_2: OrientedSurface | None,
                       test: MirrorTest = MirrorTest(), near: float = 0.0) -> tuple:
    """``(matches, margin)``: among the first ``test.candidates`` of ``candidates``
    ``[(score, Matches), ...]`` (best first, from
    :func:`darcyan.method.matching.consistent_candidates`), the matches with the best total: score
    plus ``test.orientation_weight * orientation_agreement * len(matches)`` plus
    ``test.handedness_weight`` times the :func:`handedness` of its matches (when both surfaces
    carry profiles): a mirror image, whole or partial, loses against the orientation-preserving
    matching it ties with. Without surfaces: the best score, margin ``inf``.

    ``margin``: how far the chosen total stands above the runner-up's, exactly when it is below
    ``near``, else some value ``>= near`` (a candidate's test stops as soon as it cannot come
    within ``near`` of the best; ``near`` 0 measures no more than the choice needs). ``inf``
    with one candidate.
    """
    if surface_1 is None or surface_2 is None:
        return candidates[0][1], np.inf
    hand = None
    if surface_1.profiles is not None and surface_2.profiles is not None:
        hand = test.handedness_weight * handedness(surface_1.profiles, surface_2.profiles, test.profile_agreement)
    best, best_total, second_total = candidates[0][1], -np.inf, -np.inf
    points = mirror_test_points(surface_1, surface_2, test)  # the same for every candidate: drawn once
    for score, matches in candidates[:test.candidates]:
        if hand is not None:
            score = score + float(hand[matches.source, matches.target].sum())
        scale = test.orientation_weight * len(matches)
        if score + scale <= best_total - near:
            second_total = max(second_total, score + scale)  # at most this: even full agreement
            continue  # would not come within `near` of the best so far
        needed = (best_total - near - score) / scale if scale > 0 else -np.inf  # the agreement that would
        agreement = orientation_agreement(surface_1, surface_2, matches.source, matches.target, test, points,
                                          beyond=needed)  # come within `near` (a bound when it cannot)
        total = score + scale * agreement
        if total > best_total:
            best, best_total, second_total = matches, total, best_total
        else:
            second_total = max(second_total, total)
    return best, best_total - second_total


def handedness(profiles_1: np.ndarray, profiles_2: np.ndarray,
               agreement: float = MirrorTest().profile_agreement) -> np.ndarray:
    """``(k1, k2)`` in [-1, 1]: for feature points i of shape 1 and j of shape 2, how much better
    i's angular profile matches j's read in the same turning sense than read in the opposite one.

    With d_same and d_mirror the mean squared differences of the two profiles (each the least
    over all rotations) and e1 + e2 their mean squares (what two unrelated profiles differ by),
    the result is ``(d_mirror - d_same) / (d_mirror + d_same)`` times the
    trust ``clip(1 - min(d_same, d_mirror) / (agreement * (e1 + e2)), 0, 1)``: +1 for the same
    tip turned, -1 for its mirror image, 0 for a mirror-symmetric tip (a head on the plane of
    symmetry) or for profiles that agree in neither sense.

    Args:
        profiles_1, profiles_2: ``(k1, 2, l, a)``, ``(k2, 2, l, a)`` from
            :func:`darcyan.method.descriptors.angular_profiles` (angles counter-clockwise about the
            outward normal, from each grid's reference direction). Profiles of differently
            sized grids (descriptions made with other ``levels`` or ``radial_lines``) are no
            evidence: all zeros.
    """
    p1 = np.asarray(profiles_1, dtype=np.float64)[:, None]
    p2 = np.asarray(profiles_2, dtype=np.float64)[None]
    if p1.shape[0] == 0 or p2.shape[1] == 0 or p1.shape[2:] != p2.shape[2:]:
        return np.zeros((p1.shape[0], p2.shape[1]))
    def least_difference(q2):  # mean squared difference, least over every rotation of q2
        return np.min([np.nanmean((p1 - np.roll(q2, s, axis=-1)) ** 2, axis=(2, 3, 4))
                       for s in range(q2.shape[-1])], axis=0)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # pairs with no common grid point: NaN
        same = least_difference(p2)
        mirror = least_difference(p2[..., ::-1])  # read backwards: theta at -theta, up to a rotation
        unrelated = np.nanmean(p1**2, axis=(2, 3, 4)) + np.nanmean(p2**2, axis=(2, 3, 4))
        trust = np.clip(1.0 - np.minimum(same, mirror) / (agreement * unrelated), 0.0, 1.0)
        # (the tiny share of `unrelated` settles an exact tie, a symmetric tip against itself, as 0)
        out = (mirror - same) / (mirror + same + 1e-9 * unrelated) * trust
    return np.where(np.isfinite(out), out, 0.0)  # no evidence either way


@dataclass(frozen=True)
class MirrorTestPoints:
    """The points of :func:`orientation_agreement`, the same for every matching it tests.

    Attributes:
        samples: ``(s,)`` vertices of shape 1, the corners of the test triangles.
        targets: ``(t,)`` vertices of shape 2 among which the samples' images are looked for.
        neighbours: ``(s, k)`` each sample's ``k`` nearest other samples (positions in ``samples``).
        sines: ``(s * k (k - 1) / 2,)`` the signed sine of each test triangle's corner on shape 1
            (sample, then pairs of its neighbours in ``np.triu_indices`` order).
        rounds: ``(s,)`` the round (0, 1, ...) in which :func:`orientation_agreement` looks
            for each sample's image: the samples in slabs along shape 1's longest axis, so
            that most triangles are complete, and vote, before the last round.
        triangles: ``(p, q, r)``, each ``(s * k (k - 1) / 2,)``: every test triangle (a sample,
            two of its neighbours) as positions in ``samples``, in the order of ``sines``.
        ready: ``(s * k (k - 1) / 2,)`` the round in which each triangle votes: the round that
            finds the last of its three corners' images.
    """

    samples: np.ndarray
    targets: np.ndarray
    neighbours: np.ndarray
    sines: np.ndarray
    rounds: np.ndarray
    triangles: tuple
    ready: np.ndarray


def mirror_test_points(surface_1: OrientedSurface, surface_2: OrientedSurface,
                       test: MirrorTest = MirrorTest()) -> MirrorTestPoints:
    """The orientation test's ``test.samples`` vertices of shape 1, their ``test.neighbours``
    nearest samples, and the vertices of shape 2 among which their images are looked for, drawn
    with ``test.seed``."""
    rng = np.random.default_rng(test.seed)
    # Drawn by area: TOSCA's full-resolution humans carry most vertices in the face and hands
    # (vertex areas span a factor of 1000), and a draw by vertex left the torso and limbs,
    # where a left/right swap shows, almost untested.
    drawn = sample_vertices(len(surface_1.points), test.samples, rng, surface_1.areas)
    n2 = len(surface_2.points)
    # Images are looked for among at most test.target_points vertices: far finer than the test
    # triangles, and a 52k-vertex target costs no more than a 10k one.
    many = n2 > test.target_points
    targets = np.sort(sample_vertices(n2, test.target_points, rng, surface_2.areas)) if many else np.arange(n2)
    near = nearest_neighbours(surface_1.points[drawn], min(test.neighbours, len(drawn) - 1))
    p, q, r = _triangles(near)
    sines = _corner_sine(surface_1.points[drawn], surface_1.normals[drawn][p], p, q, r)
    position = surface_1.points[drawn].astype(np.float64)
    position -= position.mean(axis=0)
    along = position @ np.linalg.eigh(position.T @ position)[1][:, -1]
    rounds = np.empty(len(drawn), np.int64)
    rounds[np.argsort(along, kind="stable")] = np.arange(len(drawn)) * AGREEMENT_ROUNDS // len(drawn)
    ready = np.maximum(rounds[p], np.maximum(rounds[q], rounds[r]))
    return MirrorTestPoints(drawn, targets, near, sines, rounds, (p, q, r), ready)


def _triangles(near: np.ndarray) -> tuple:
    """``(p, q, r)`` every test triangle (a sample, two of its neighbours) as positions in the
    samples, from ``near (s, k)`` of :func:`mirror_test_points`."""
    first, second = np.triu_indices(near.shape[1], k=1)
    p = np.repeat(np.arange(len(near)), len(first))
    return p, near[:, first].ravel(), near[:, second].ravel()


def orientation_agreement(surface_1: OrientedSurface, surface_2: OrientedSurface, landmarks_1: np.ndarray,
                          landmarks_2: np.ndarray, test: MirrorTest = MirrorTest(),
                          points: MirrorTestPoints | None = None, beyond: float = -np.inf) -> float:
    """In [-1, 1]: +1 when the correspondence ``landmarks_1[i] <-> landmarks_2[i]`` (indices into
    the feature sets) preserves orientation everywhere, -1 when it is a mirror image; 0 when
    fewer than 3 landmarks make the test meaningless. ``test``: the settings (sample points,
    signature weight, ...); ``points``, the result of :func:`mirror_test_points` for ``test``,
    saves drawing them again.

    The triangles vote in ``AGREEMENT_ROUNDS`` rounds; as soon as the agreement cannot exceed
    ``beyond`` (all the triangles still to vote agreeing), the test stops and returns that
    bound (<= ``beyond``) instead of the agreement: a matching that cannot win is not measured
    to the end."""
    if len(landmarks_1) < 3:
        return 0.0
    if points is None:
        points = mirror_test_points(surface_1, surface_2, test)
    samples, targets = points.samples, points.targets
    # (s, m) and (t, m), row-major as the searches' sums expect (the same bits in every layout)
    embed_1 = np.ascontiguousarray(surface_1.landmark_distances[np.ix_(landmarks_1, samples)].T)
    embed_2 = np.ascontiguousarray(surface_2.landmark_distances[np.ix_(landmarks_2, targets)].T)
    if surface_1.signature is not None and surface_2.signature is not None:
        embed_1 = np.hstack([embed_1, test.signature_weight * surface_1.signature[samples]])
        embed_2 = np.hstack([embed_2, test.signature_weight * surface_2.signature[targets]])
    nearest_image = NearestPoints(embed_2)  # searched in every round
    # Every triangle (sample, two of its neighbours); on shape 1 they were measured once.
    p, q, r = points.triangles
    ready = points.ready
    image = np.zeros(len(samples), np.int64)  # each sample's image on shape 2 (found in rounds)
    votes = counted = 0  # sums of the votes (+1 kept, -1 reversed) and of the triangles that voted
    for now in range(int(points.rounds.max(initial=-1)) + 1):
        found = np.flatnonzero(points.rounds == now)
        image[found] = targets[nearest_image(embed_1[found])]
        voting = np.flatnonzero(ready == now)
        tp, tq, tr = p[voting], q[voting], r[voting]
        s1 = points.sines[voting]
        s2 = _corner_sine(surface_2.points[image], surface_2.normals[image][tp], tp, tq, tr)
        ok = (np.abs(s1) >= test.min_sine) & (np.abs(s2) >= test.min_sine)
        votes += int((np.sign(s1[ok]) * np.sign(s2[ok])).sum())
        counted += int(ok.sum())
        still = int((ready > now).sum())  # at most: they may all vote, and all agree
        if still and (votes + still) / (counted + still) <= beyond:
            return (votes + still) / (counted + still)
    return votes / counted if counted else 0.0


def _corner_sine(points, normals, p, q, r) -> np.ndarray:
    """Signed sine of the corner at p of triangles (p, q, r) about ``normals`` (one per triangle,
    the normal at p)."""
    u = points[q] - points[p]
    v = points[r] - points[p]
    cross = np.cross(u, v)
    denom = np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(denom > 0, np.einsum("ij,ij->i", cross, normals) / denom, 0.0)
