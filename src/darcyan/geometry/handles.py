"""Handles of a surface: its genus, and its shortest loops that go around a handle.

A person or an animal is a sphere, or a sphere with holes where a scan left some: genus 0. A
mesh of one often has handles all the same, where parts that touch were joined: a hand glued to
a hip or two fingers fused by a marching-cubes reconstruction, thighs pressed together in a
scan. Such a bridge changes the surface's geodesic distances and its Laplace-Beltrami
eigenfunctions far beyond itself. Cut along a short loop around it, the surface is a sphere
with holes again (:func:`darcyan.geometry.repair.cut_handles` makes the cut).

The loop is found by Erickson and Whittlesey's greedy homotopy basis (*Greedy optimal homotopy
and homology generators*, SODA 2005): from a root vertex, a shortest-path tree ``T``; over the
edges not in ``T``, a spanning tree of the faces that keeps the longest loops; the ``2g`` edges
left each close one loop (the tree paths from its end points), and the shortest loop through
the root that cannot be contracted to a point is the shortest of them. This module takes the
shortest such loop over farthest-point roots, then again from up to 12 vertices of the loop
found, for up to three rounds while it shortens: near the shortest loop of the whole surface,
which the exact algorithm (one root per vertex) would find at a cost quadratic in the vertices.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import DarcyanError
from .mesh import Mesh, boundary_loop_vertices, boundary_loops


@dataclass(frozen=True)
class HandleLoop:
    """A closed loop of mesh edges around a handle.

    Attributes:
        vertices: ``(k,)`` the loop's vertices in order (the last joined to the first by an edge).
        length: its length, in the mesh's units.
    """

    vertices: np.ndarray
    length: float


def genus(mesh: Mesh) -> int:
    """The genus (number of handles) of a connected, manifold, oriented mesh: from its Euler
    characteristic ``V - E + F = 2 - 2 g - b`` (``b`` boundary loops; vertices no face uses
    not counted)."""
    keys, _ = mesh.edge_counts()
    used = np.count_nonzero(np.bincount(mesh.faces.ravel(), minlength=mesh.n_vertices))
    euler = used - len(keys) + mesh.n_faces
    return int(2 - euler - len(boundary_loops(mesh)[1])) // 2


class HandleLoops:
    """The loops around the handles of a connected, manifold, consistently oriented mesh, from
    chosen roots.

    Each boundary loop is capped for the search by a cone to a vertex of its own whose edges are
    too long for any shortest path: the capped surface is closed, so every loop of the basis goes
    around a handle (on a surface with holes, some would go around a hole instead). A loop
    through a cap's apex is left out. Raises :class:`~darcyan.errors.DarcyanError` for a mesh
    with an edge of more than two faces (prepare it first).
    """

    def __init__(self, mesh: Mesh):
        import scipy.sparse as sp

        n = mesh.n_vertices
        self.mesh = mesh
        loops = boundary_loop_vertices(mesh)
        apexes = n + np.arange(len(loops))
        cones = [np.stack([np.full(len(loop), apex), np.roll(loop, -1), loop], axis=1)
                 for apex, loop in zip(apexes, loops)]
        faces = np.vstack([mesh.faces, *cones]) if loops else mesh.faces
        vertices = np.vstack([mesh.vertices, np.zeros((len(loops), 3))])
        capped = Mesh(vertices, faces, mesh.name)
        self._n_vertices = n  # the mesh's own; the apexes come after
        self._edges = capped.edges()
        e = self._edges
        self._lengths = np.linalg.norm(vertices[e[:, 0]] - vertices[e[:, 1]], axis=1)
        # too long for a shortest path, yet finite: the apexes are still reached (spanning tree)
        self._lengths[e[:, 1] >= n] = 10.0 * self._lengths[e[:, 1] < n].sum() + 1.0
        self._total = total = len(vertices)
        self._graph = sp.csr_matrix((np.r_[self._lengths, self._lengths], (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                                    shape=(total, total))
        # The two faces of each edge (the capped surface is closed).
        keys, counts = capped.edge_counts()
        if (counts != 2).any():
            raise DarcyanError(f"{mesh.name}: handles are sought on a manifold mesh (two faces on every edge "
                               f"once its holes are capped): prepare it first (darcyan.prepare_mesh)")
        a, b = faces.ravel(), faces[:, [1, 2, 0]].ravel()
        order = np.argsort(np.searchsorted(keys, np.minimum(a, b) * total + np.maximum(a, b)), kind="stable")
        self._edge_faces = np.repeat(np.arange(len(faces), dtype=np.int64), 3)[order].reshape(-1, 2)
        self._keys = keys
        self._n_faces = len(faces)

    def through(self, root: int, count: int = 8) -> list[HandleLoop]:
        """Up to ``count`` of the greedy homotopy basis's loops at ``root``, shortest first, each
        shortened to the simple cycle its edge closes (the tree paths from the edge's end points
        to where they meet)."""
        import scipy.sparse as sp
        from scipy.sparse.csgraph import dijkstra, minimum_spanning_tree

        n, n_faces = self._total, self._n_faces
        distance, parent = dijkstra(self._graph, indices=int(root), return_predecessors=True)
        reached = np.flatnonzero(parent >= 0)
        in_tree = np.zeros(len(self._edges), bool)
        in_tree[np.searchsorted(self._keys, np.minimum(reached, parent[reached]) * n
                                + np.maximum(reached, parent[reached]))] = True
        e = self._edges
        loop_length = distance[e[:, 0]] + self._lengths + distance[e[:, 1]]
        rest = np.flatnonzero(~in_tree & np.isfinite(loop_length))
        if not len(rest):  # a root on no face, or a surface without handles
            return []
        faces = self._edge_faces[rest]
        # The spanning tree of the faces that keeps the longest loops: minimum over reversed lengths.
        weight = loop_length[rest].max() + 1.0 - loop_length[rest]
        cotree = minimum_spanning_tree(sp.coo_matrix((weight, (faces[:, 0], faces[:, 1])),
                                                     shape=(n_faces, n_faces)).tocsr()).tocoo()
        pair = np.minimum(faces[:, 0], faces[:, 1]) * n_faces + np.maximum(faces[:, 0], faces[:, 1])
        # scipy gives int32 indices: in int64 before the product, which passes 2**31 above ~46k faces
        rows, cols = cotree.row.astype(np.int64), cotree.col.astype(np.int64)
        tree_pairs = np.minimum(rows, cols) * n_faces + np.maximum(rows, cols)
        # each pair of faces shares one edge: the cotree's edges found by a sorted search (np.isin
        # hashes, ten times slower on a large mesh)
        order = np.argsort(pair, kind="stable")
        in_cotree = np.zeros(len(rest), bool)
        in_cotree[order[np.searchsorted(pair, tree_pairs, sorter=order)]] = True
        left = rest[~in_cotree]
        left = left[np.argsort(loop_length[left], kind="stable")][:count]
        loops = [self._cycle(edge, parent) for edge in left]
        return [loop for loop in loops if loop.vertices.max() < self._n_vertices]  # none across a cap

    def _cycle(self, edge: int, parent: np.ndarray) -> HandleLoop:
        u, v = (int(x) for x in self._edges[edge])
        up = [u]
        while parent[up[-1]] >= 0:
            up.append(int(parent[up[-1]]))
        on_up = {x: i for i, x in enumerate(up)}
        vp = [v]
        while vp[-1] not in on_up:
            vp.append(int(parent[vp[-1]]))
        cycle = np.array(up[:on_up[vp[-1]] + 1] + vp[-2::-1], dtype=np.int64)  # u ... meet ... v
        if cycle.max() >= self._n_vertices:
            return HandleLoop(cycle, np.inf)
        ends = self.mesh.vertices[cycle]
        length = float(np.linalg.norm(np.roll(ends, -1, axis=0) - ends, axis=1).sum())
        return HandleLoop(cycle, length)

    def shortest(self, roots, accept: Callable[[HandleLoop], bool], rounds: int = 3,
                 refine: int = 12) -> HandleLoop | None:
        """The shortest loop that ``accept`` takes among the loops through ``roots``, then
        through up to ``refine`` vertices of the best loop so far, for up to ``rounds`` rounds
        while it shortens; ``None`` when none is accepted."""
        found: list[HandleLoop] = []
        tried: set[int] = set()
        seen: set[tuple] = set()  # several roots find one loop: judged once

        def add(vertices):
            for root in (int(x) for x in vertices):
                if root not in tried:
                    tried.add(root)
                    for loop in self.through(root):
                        key = tuple(np.sort(loop.vertices))
                        if key not in seen:
                            seen.add(key)
                            found.append(loop)

        def best():
            found.sort(key=lambda loop: loop.length)
            while found and not accept(found[0]):
                found.pop(0)
            return found[0] if found else None

        add(roots)
        loop = best()
        for _ in range(rounds):
            if loop is None:
                break
            pick = np.linspace(0, len(loop.vertices) - 1, min(refine, len(loop.vertices))).astype(int)
            add(loop.vertices[pick])
            shorter = best()
            if shorter is loop:
                break
            loop = shorter
        return loop
