"""All parameters of the method in one typed, documented object.

Lengths are in units of ``sqrt(surface area)``: every mesh is scaled to total area 1 before
analysis (the paper's scale normalization), so a radius of 0.1 means one tenth of the square
root of the shape's area whatever the file's units. The defaults and how they were chosen are in
``docs/parameters.md``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass

from .errors import ConfigError

MATCHING_MODES = ("consistent", "nearest", "one-to-one")
# The fields that change how a mesh is prepared (checks, repair, denoising, normalization).
PREPARE_FIELDS = ("denoise_area_ratio",)


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
    """

    levels: int = 6
    radial_lines: int = 16
    radius: float = 0.12
    interpolation: int = 2
    curvature_smoothing: int = 4
    denoise_area_ratio: float = 1.1
    agd_sources: int = 24
    agd_smoothing: float = 0.14
    proxy_vertices: int = 6000
    extremity_radius: float = 0.25
    min_agd_quantile: float = 0.3
    tip_gain: float = 1.1
    tip_radius: float = 0.35
    tip_agd_drop: float = 0.03
    max_features: int = 0
    matching: str = "consistent"
    max_match_distance: float = 1.5

    def __post_init__(self) -> None:
        positive_ints = ("levels", "radial_lines", "interpolation", "agd_sources")
        for name in positive_ints:
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ConfigError(f"config: {name} must be a positive integer, got {value!r}")
        if self.radial_lines < 3:
            raise ConfigError("config: radial_lines must be at least 3")
        for name in ("curvature_smoothing", "max_features", "proxy_vertices"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
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

    def replace(self, **changes) -> "DarcyanConfig":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)

    def fingerprint(self, *fields: str) -> str:
        """A short hash of the named fields (all when none named), for cache keys."""
        values = self.as_dict()
        chosen = {k: values[k] for k in (fields or values)}
        return hashlib.sha1(json.dumps(chosen, sort_keys=True).encode()).hexdigest()[:16]

    def prepare_fingerprint(self) -> str:
        """:meth:`fingerprint` of the fields that change how a mesh is prepared
        (:func:`darcyan.geometry.shape.prepare_shape`)."""
        return self.fingerprint(*PREPARE_FIELDS)

    @classmethod
    def paper(cls, **changes) -> "DarcyanConfig":
        """The paper's method as published: plain AGD maxima, no denoising, nearest-descriptor matching.
        (Its AGD floor stays at the median, where the paper columns of the README were measured:
        the floor's default came down for diffused AGD, which the paper does not use.)"""
        return cls(agd_smoothing=0.0, extremity_radius=0.15, min_agd_quantile=0.5, denoise_area_ratio=0.0, tip_gain=0.0,
                   matching="nearest", max_match_distance=0.0).replace(**changes)

    @property
    def level_radii(self) -> "list[float]":
        """lambda_1..lambda_n: the geodesic radii of the level curves."""
        return [self.radius * (k + 1) / self.levels for k in range(self.levels)]
