"""Built-in shapes: analytic surfaces with known geometry, and an articulated figure in poses.

The figure is a body with five limbs of different lengths pointing in irregular directions
(deliberately without symmetry). Its poses bend each limb at a joint, rigidly beyond it and
smoothly across it, so the surface bends nearly without stretching; every pose keeps the same
vertex numbering, so the ground-truth correspondence is the identity, and the limb tips, the
shape's extremities, are known by construction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .mesh import Mesh


def icosphere(subdivisions: int = 5, radius: float = 1.0) -> Mesh:
    """A sphere triangulated by subdividing an icosahedron (10 * 4**s + 2 vertices)."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return Mesh(s.vertices, s.faces, name=f"icosphere(r={radius})")


def _grid_faces(nu: int, nv: int, wrap_u: bool, wrap_v: bool) -> np.ndarray:
    """Triangles of a (nu x nv) vertex grid, index u * nv + v, optionally periodic."""
    faces = []
    for i in range(nu if wrap_u else nu - 1):
        for j in range(nv if wrap_v else nv - 1):
            a, b = i * nv + j, ((i + 1) % nu) * nv + j
            c, d = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
            faces += [(a, b, c), (a, c, d)]
    return np.array(faces, dtype=np.int64)


def cylinder(radius: float = 1.0, height: float = 4.0, sections: int = 96, rings: int = 97) -> Mesh:
    """An open cylinder around the z axis (two boundary circles), outward-facing."""
    theta = 2 * np.pi * np.arange(sections) / sections
    z = np.linspace(-height / 2, height / 2, rings)
    tt, zz = np.meshgrid(theta, z, indexing="ij")
    v = np.stack([radius * np.cos(tt), radius * np.sin(tt), zz], axis=-1).reshape(-1, 3)
    return Mesh(v, _grid_faces(sections, rings, True, False), name=f"cylinder(r={radius})")


def torus(major: float = 2.0, minor: float = 0.75, nu: int = 160, nv: int = 80, rings=None) -> Mesh:
    """A torus around the z axis: outer equator at distance major + minor from the axis. Its
    rings around the tube sit at the angles ``rings`` (increasing, in [0, 2 pi), 0 on the outer
    equator) when given, else at ``nv`` even steps."""
    u = 2 * np.pi * np.arange(nu) / nu
    w = 2 * np.pi * np.arange(nv) / nv if rings is None else np.asarray(rings, dtype=np.float64)
    nv = len(w)
    uu, ww = np.meshgrid(u, w, indexing="ij")
    ring = major + minor * np.cos(ww)
    v = np.stack([ring * np.cos(uu), ring * np.sin(uu), minor * np.sin(ww)], axis=-1).reshape(-1, 3)
    return Mesh(v, _grid_faces(nu, nv, True, True), name=f"torus(R={major}, r={minor})")


def flat_disc(radius: float = 1.0, rings: int = 40, seed: int = 0) -> Mesh:
    """A flat disc in the z = 0 plane, irregularly triangulated (Delaunay of jittered rings)."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    pts = [np.zeros(2)]
    for k in range(1, rings + 1):
        r = radius * k / rings
        count = max(6, int(round(2 * np.pi * k)))
        phase = rng.uniform(0, 2 * np.pi)
        a = phase + 2 * np.pi * np.arange(count) / count
        jitter = 0.0 if k == rings else 0.25 * radius / rings
        rr = r + rng.uniform(-jitter, jitter, count)
        pts.extend(np.stack([rr * np.cos(a), rr * np.sin(a)], axis=1))
    pts = np.array(pts)
    tri = Delaunay(pts).simplices
    v = np.column_stack([pts, np.zeros(len(pts))])
    # Orient every triangle counter-clockwise (normal +z).
    cross = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])[:, 2]
    tri[cross < 0] = tri[cross < 0][:, ::-1]
    return Mesh(v, tri, name=f"disc(r={radius})")


@dataclass(frozen=True)
class Limb:
    direction: tuple  # unit direction from the body centre
    length: float  # how far the tip reaches beyond the unit body
    width: float  # angular half-width (radians) of the limb's base
    bend_axis: tuple  # axis of the joint (made perpendicular to the direction)


LIMBS = (
    Limb((0.0, 0.05, 1.0), 1.1, 0.36, (1, 0, 0)),       # head: short and thick
    Limb((0.9, 0.1, -0.45), 1.9, 0.22, (0, 1, 0.3)),    # a long limb
    Limb((-0.8, 0.35, -0.5), 1.5, 0.27, (0.2, 1, 0)),   # a middle limb
    Limb((0.15, -0.95, -0.3), 1.7, 0.19, (1, 0, 0.2)),  # a thin limb
    Limb((-0.3, 0.85, 0.35), 1.3, 0.31, (1, 0.2, 0)),   # a short limb
)

# Bend angle (radians) of each limb's joint in each built-in pose.
POSES = (
    (0.0, 0.0, 0.0, 0.0, 0.0),
    (0.5, -0.9, 0.7, 0.8, -0.6),
    (-0.6, 0.6, -0.8, -0.5, 0.9),
)


def _unit(x) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return x / np.linalg.norm(x)


def _rotate(points: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues rotation of ``points (k, 3)`` about unit ``axis`` by per-point ``angle (k,)``."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return points * c + np.cross(axis, points) * s + axis * (points @ axis)[:, None] * (1 - c)


def figure(pose: int = 0, subdivisions: int = 5) -> Mesh:
    """The articulated figure in built-in pose ``pose`` (0, 1 or 2).

    Same vertex numbering in every pose (ground truth = identity); the limb tips are
    :func:`figure_tips`.
    """
    if not 0 <= pose < len(POSES):
        raise ValueError(f"pose must be in 0..{len(POSES) - 1}")
    base = icosphere(subdivisions)
    unit = base.vertices / np.linalg.norm(base.vertices, axis=1, keepdims=True)
    dirs = np.array([_unit(limb.direction) for limb in LIMBS])
    angle_to = np.arccos(np.clip(unit @ dirs.T, -1, 1))  # (n, limbs)
    radius = np.ones(len(unit))
    for i, limb in enumerate(LIMBS):
        # A limb: a Gaussian radial bump, long compared with its width, with a rounded tip.
        radius += limb.length * np.exp(-(angle_to[:, i] / limb.width) ** 2)
    v = unit * radius[:, None]
    owner = np.argmin(angle_to, axis=1)
    for i, (limb, bend) in enumerate(zip(LIMBS, POSES[pose])):
        if bend == 0.0:
            continue
        d = dirs[i]
        axis = _unit(np.asarray(limb.bend_axis, float) - d * np.dot(limb.bend_axis, d))
        joint = 1.0 + 0.3 * limb.length
        blend = 0.15 * limb.length
        t = v @ d
        mine = (owner == i) & (t > joint - blend)
        s = np.clip((t[mine] - (joint - blend)) / (2 * blend), 0, 1)
        weight = s * s * (3 - 2 * s)  # smoothstep: the bend spreads over the joint
        centre = joint * d
        v[mine] = centre + _rotate(v[mine] - centre, axis, bend * weight)
    return Mesh(v, base.faces, name=f"figure(pose={pose})")


def figure_tips(subdivisions: int = 5) -> np.ndarray:
    """``(5,)`` vertex indices of the limb tips (the figure's extremities) in every pose."""
    base = icosphere(subdivisions)
    unit = base.vertices / np.linalg.norm(base.vertices, axis=1, keepdims=True)
    return np.array([int(np.argmax(unit @ _unit(limb.direction))) for limb in LIMBS], dtype=np.int64)
