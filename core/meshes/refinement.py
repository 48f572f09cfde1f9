"""The conforming Delaunay refinement of `core.triangulate` (steps 2-5 of
`core.meshes.triangulation`): boundary vertices on the curve, a hexagonal lattice core, and the
band between them refined until every triangle is small enough and well shaped.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.meshes.band_regions import band_sides, band_triangles
from core.meshes.chord_crossing import first_chords_crossed
from core.meshes.core_front import core_front
from core.meshes.delaunay import Triangulation, delaunay
from core.meshes.encroachment import encroached_chords
from core.meshes.hex_lattice import HexLattice
from core.meshes.mesh import Mesh
from core.meshes.mesh_assembly import assembled_triangles
from core.meshes.sizing import GRADATION, Sizing
from core.meshes.smoothing import smoothing_pass
from core.meshes.spread_points import spread_points
from core.meshes.triangle_shapes import circumcentres, triangle_shapes

# Triangles whose circumradius / shortest edge exceeds this are refined (min angle 20.7 deg).
RADIUS_EDGE_RATIO = math.sqrt(2.0)


# A triangle is too large when its circumradius exceeds this times h (an equilateral
# triangle of edge 1.3 h).
SIZE_FACTOR = 0.75


# No refinement for quality of triangles whose shortest edge is below this times h(x):
# only next to a sharp corner, where small angles are unavoidable.
QUALITY_FLOOR = 0.05


# Lattice triangles whose corners are this many h from the curve are final (the core);
# the lattice nodes nearer than that stay free to move in the smoothing.
CORE_CLEARANCE = 1.2


MAX_ROUNDS = 200


class Refinement:
    """State of the refinement: boundary parameters, the lattice core and the band's points.

    The lattice triangles marked `core` are final; the band (the rest of the
    domain) is triangulated by Delaunay from the boundary vertices, the lattice
    nodes not inside the core, and the inserted (Steiner) points.  A core
    triangle whose circumdisk a band point enters, or whose corner encroaches a
    boundary chord, is demoted to the band, so that the core's border (the
    front) is always a set of Delaunay edges of the band's points.
    """

    def __init__(self, curve: ClosedBSpline, sizing: Sizing):
        self.curve = curve
        self.sizing = sizing
        self.orientation = 1.0 if curve.is_counterclockwise else -1.0
        self.parameters = sizing.boundary_parameters(curve.corners()[:, 0])
        self.boundary_points = curve(self.parameters)
        self.lattice, nodes, self.core = _lattice(sizing, self.boundary_points)
        self.node_index = np.full(self.lattice.node_count, -1, dtype=np.int64)
        self.node_index[nodes] = np.arange(nodes.size)
        self.core_ids = np.flatnonzero(self.core)  # (C,) the lattice triangles core at first
        self.core_corners = self.node_index[self.lattice.triangle_corners(self.core_ids)]  # (C, 3)
        self.core_kept = np.ones(self.core_ids.size, dtype=bool)  # (C,) not demoted since
        self._front_cache = None
        self.nodes = self.lattice.node_points(nodes)  # (K, 2); smoothing moves the free ones
        self.alive = np.ones(nodes.size, dtype=bool)
        self.steiner = np.zeros((0, 2))
        # A ring of far points keeps the curve off the convex hull, where the triangulation would
        # make flat triangles out of collinear boundary vertices (the straight spans at corners)
        # or leave out slivers (core.meshes.delaunay).
        low, high = self.boundary_points.min(axis=0), self.boundary_points.max(axis=0)
        angles = 2.0 * np.pi * np.arange(16) / 16
        self.frame = 0.5 * (low + high) + (np.linalg.norm(high - low) + sizing.max_edge) * np.stack(
            [np.cos(angles), np.sin(angles)], axis=1
        )
        self.tri: Triangulation | None = None
        self.chord: np.ndarray | None = None  # (T, 3) the boundary chord each side of self.tri is, or -1
        self.inside: np.ndarray | None = None
        self.band: np.ndarray | None = None  # indices into self.nodes of the band's nodes
        self.conformed = False  # self.tri is the triangulation of the current points

    def _front(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The band's nodes (Nb,), which nodes are core corners (K,) bool, and the front.

        The front is the directed edges (F, 2) of core triangles that no other core
        triangle shares, with the core on their left (`core.meshes.core_front`).  A node
        with six core triangles is inside the core and not in the band.
        """
        if self._front_cache is None:
            self._front_cache = core_front(self.core_corners[self.core_kept], self.nodes.shape[0])
        count, front = self._front_cache
        return np.flatnonzero(self.alive & (count < 6)), count > 0, front

    def _demote(self, positions: np.ndarray) -> None:
        """Move the core triangles at `positions` of self.core_ids to the band."""
        self.core[self.core_ids[positions]] = False
        self.core_kept[positions] = False
        self._front_cache = None

    def _demote_at(self, nodes: np.ndarray) -> None:
        """Move the core triangles with a corner among `nodes` (indices into self.nodes) to the band."""
        self._demote(np.flatnonzero(self.core_kept & np.isin(self.core_corners, nodes).any(axis=1)))

    def _split(self, chords: np.ndarray) -> None:
        """Insert the curve point at the middle arc length of each boundary chord k -> k+1."""
        chords = np.unique(chords)
        count = self.parameters.shape[0]
        start = self.parameters[chords]
        stop = self.parameters[(chords + 1) % count]
        stop = np.where(stop <= start, stop + self.curve.n, stop)
        middle = self.sizing.parameter(0.5 * (self.sizing.arc_length(start) + self.sizing.arc_length(stop)))
        self.parameters = np.unique(np.concatenate([self.parameters, middle]))
        self.boundary_points = self.curve(self.parameters)
        self.conformed = False

    def _conform(self) -> None:
        """Triangulate the band until every boundary chord and front edge is a Delaunay edge.

        Free points inside the diametral circle of a chord are deleted first
        (Ruppert's encroachment); chords that are still not Delaunay edges (other
        parts of the curve too near) are split.  Nothing to do if nothing moved since
        the last call.
        """
        if self.conformed:
            return
        for _ in range(MAX_ROUNDS):
            count = self.parameters.shape[0]
            if count < 3 or np.diff(self.parameters).min(initial=np.inf) <= 1e-12 * self.curve.n:
                raise RuntimeError("boundary refinement did not converge (boundary edges collapsed)")
            band, fixed, front = self._front()
            middle, half = _chord_circles(self.boundary_points)
            self.steiner = self.steiner[encroached_chords(self.steiner, middle, half) < 0]
            encroaching = band[encroached_chords(self.nodes[band], middle, half) >= 0]
            if encroaching.size:
                self.alive[encroaching[~fixed[encroaching]]] = False
                self._demote_at(encroaching[fixed[encroaching]])
                continue
            entered = self.lattice.circumdisk_hits(np.vstack([self.boundary_points, self.steiner]), self.core)
            if entered.size:
                self._demote(np.searchsorted(self.core_ids, entered))
                continue
            tri = delaunay(np.vstack([self.boundary_points, self.nodes[band], self.steiner, self.frame]))
            if tri.duplicates.size:
                dropped = tri.duplicates - count
                if (dropped < 0).any() or (dropped >= band.size + self.steiner.shape[0]).any():
                    raise RuntimeError("boundary vertices coincide; the curve is degenerate")
                nodes = band[dropped[dropped < band.size]]
                self.alive[nodes[~fixed[nodes]]] = False
                self._demote_at(nodes[fixed[nodes]])
                self.steiner = np.delete(self.steiner, dropped[dropped >= band.size] - band.size, axis=0)
                continue
            local = np.full(self.nodes.shape[0], -1, dtype=np.int64)
            local[band] = count + np.arange(band.size)
            chord, front_side = band_sides(tri.simplices, count, local[front])
            found = np.zeros(count, dtype=bool)
            found[chord[chord >= 0]] = True
            if not found.all():
                self._split(np.flatnonzero(~found))
                continue
            found = np.zeros(front.shape[0], dtype=bool)
            found[front_side[front_side >= 0]] = True
            if not found.all():  # only if a point sits on a core circumcircle: rare
                self._demote_at(front[~found].ravel())
                continue
            self.tri = tri
            self.chord = chord
            self.band = band
            self.inside = band_triangles(
                tri.points, tri.simplices, tri.neighbors, chord, local[front], front_side, self.orientation
            )
            self.conformed = True
            return
        raise RuntimeError("boundary refinement did not converge")

    @property
    def band_points(self) -> np.ndarray:
        """Points (B + Nb + S, 2) of the last band triangulation: boundary, band nodes, Steiner."""
        return np.vstack([self.boundary_points, self.nodes[self.band], self.steiner])

    def refine(self, round_done: Callable[[int], None] | None = None) -> None:
        """Conform, then insert circumcentres of bad band triangles until none is left.

        `round_done` is called with the number of bad triangles after each round's
        triangulation.
        """
        for _ in range(MAX_ROUNDS):
            self._conform()
            bad = self._improve()
            if round_done is not None:
                round_done(bad)
            if not bad:
                return
        raise RuntimeError("mesh refinement did not converge")

    def _improve(self) -> int:
        """One batch of Ruppert insertions; returns the number of bad triangles (0: none left)."""
        points = self.band_points
        simplices = self.tri.simplices[self.inside]
        radius, shortest, centroids = triangle_shapes(points, simplices)
        h = self.sizing(centroids)
        bad = (radius > SIZE_FACTOR * h) | (
            (radius > RADIUS_EDGE_RATIO * shortest) & (shortest > QUALITY_FLOOR * h)
        )
        if not bad.any():
            return 0
        bad = np.flatnonzero(bad)
        priority = bad[np.argsort(-(radius[bad] / shortest[bad]))]
        centres = circumcentres(points, simplices[priority])
        middle, half = _chord_circles(self.boundary_points)
        encroached = encroached_chords(centres, middle, half)
        hit = encroached >= 0
        splits = [encroached[hit]]
        free = np.flatnonzero(~hit)
        # Ruppert: a circumcentre that a boundary chord hides from its triangle (outside the
        # domain, or behind a concave stretch of it) is not inserted; the chord is split.
        crossed = first_chords_crossed(
            np.vstack([points, self.frame]),  # the points of self.tri, smoothed
            self.tri.simplices,
            self.tri.neighbors,
            self.chord,
            self.inside[priority[free]],
            centres[free],
        )
        outside = crossed >= 0
        splits.append(crossed[outside])
        accepted = spread_points(centres[free[~outside]], radius[priority][free[~outside]])
        splits = np.concatenate(splits)
        # Splitting a boundary edge for quality alone stops at the floor (sharp corners).
        if splits.size:
            lengths = 2.0 * half[splits]
            splits = splits[lengths > QUALITY_FLOOR * self.sizing(middle[splits])]
        if not splits.size and not accepted.size:
            return 0
        if splits.size:
            self._split(splits)
        self.steiner = np.vstack([self.steiner, accepted])
        self.conformed = False
        return bad.size

    def smooth(self, passes: int, pass_done: Callable[[float], None] | None = None) -> None:
        """Laplacian smoothing of the band: move free points to the mean of their neighbours.

        Free points are the Steiner points and the band's nodes that are no core
        corner.  Each pass keeps every band triangle at least a tenth of its area
        before the pass (moves that would not are undone), so the triangles stay
        valid; the next `refine` checks their quality and triangulates again only
        if one is bad.  `pass_done` gets the fraction of the passes done after
        each one.
        """
        points = self.band_points
        count = self.parameters.shape[0]
        _, fixed, _ = self._front()
        simplices = self.tri.simplices[self.inside]  # counter-clockwise
        # Boundary vertices and core corners stay; the rest are inside the band (off its border).
        movable = np.ones(points.shape[0], dtype=bool)
        movable[:count] = False
        movable[count : count + self.band.size] = ~fixed[self.band]
        for done in range(passes):
            points = smoothing_pass(points, simplices, movable)
            if pass_done is not None:
                pass_done((done + 1) / passes)
        self.nodes[self.band] = points[count : count + self.band.size]
        self.steiner = points[count + self.band.size :]

    def mesh(self) -> Mesh:
        """The core triangles and the band's triangles inside the curve, as one `Mesh`."""
        count = self.parameters.shape[0]
        nodes = self.nodes.shape[0]
        points = np.vstack([self.boundary_points, self.nodes, self.steiner])
        index = np.concatenate(
            [np.arange(count), count + self.band, count + nodes + np.arange(self.steiner.shape[0])]
        )
        band = self.tri.simplices[self.inside]  # counter-clockwise (smoothing keeps them so)
        vertices, triangles, used = assembled_triangles(
            points, count + self.core_corners[self.core_kept], index, band
        )
        if not used[:count].all():  # then the boundary vertices are the first, in order
            raise RuntimeError("a boundary vertex is in no triangle")
        return Mesh(
            vertices=vertices,
            triangles=triangles,
            boundary=np.arange(count, dtype=np.int64),
            boundary_parameters=self.parameters.copy(),
        )


class Progress:
    """Monotone progress of `triangulate` for an optional callback.

    Parameters
    ----------
    callback : callable or None
        Takes the fraction done in [0, 1].
    """

    def __init__(self, callback: Callable[[float], None] | None):
        self.callback = callback
        self.done = 0.0
        self.refinement = None  # start of the refinement phase under way
        self.most_bad = 0

    def phase(self, fraction: float) -> None:
        """A phase ended at `fraction`."""
        if self.callback is not None and fraction >= self.done:
            self.done = fraction
            self.callback(fraction)

    def rounds(self, bad: int, start: float, stop: float) -> None:
        """A refinement round of the phase [start, stop] left `bad` triangles to refine.

        The fraction of the phase is the share of the most bad triangles seen so far
        that is done (an estimate: fixing triangles near the curve can make more).
        """
        if start != self.refinement:  # a new refinement phase
            self.refinement, self.most_bad = start, 0
        self.most_bad = max(self.most_bad, bad, 1)
        self.phase(start + (stop - start) * (1.0 - bad / self.most_bad) * 0.99)


def _lattice(sizing: Sizing, polygon: np.ndarray) -> tuple[HexLattice, np.ndarray, np.ndarray]:
    """The hexagonal lattice of spacing max_edge inside the polygon (B, 2) and its core triangles.

    Nodes nearer to the curve than 0.6 h, or where h is below 0.75 max_edge, are
    left to the refinement.  A lattice triangle is core (final) when its corners
    are at least `CORE_CLEARANCE` h from the curve and h at its corners is large
    enough for its circumradius (h is GRADATION-Lipschitz, so the bound holds at
    its centroid too).

    Returns
    -------
    lattice : HexLattice
    nodes : ndarray of shape (K,), int64
        Ids of the nodes kept, increasing.
    core : ndarray of shape (lattice.triangle_count,), bool
    """
    spacing = sizing.max_edge
    lattice = HexLattice(polygon.min(axis=0), polygon.max(axis=0), spacing)
    nodes = np.flatnonzero(lattice.inside(polygon))
    points = lattice.node_points(nodes)
    # Only nodes near the curve (or near where h is fine) need the tree queries.
    h = np.full(nodes.size, spacing)
    if sizing.fine_points.shape[0]:
        near = lattice.nodes_near(sizing.fine_points, sizing.reach)[nodes]
        h[near] = sizing(points[near])
    reach = CORE_CLEARANCE * spacing
    distance = np.full(nodes.size, np.inf)
    near = lattice.nodes_near(sizing.points, reach)[nodes]
    distance[near] = sizing.distance_to_curve(points[near], reach)
    keep = (h >= 0.75 * spacing) & (distance >= 0.6 * h)
    clear = np.zeros(lattice.node_count, dtype=bool)
    large_enough = h >= lattice.circumradius * (1.0 / SIZE_FACTOR + GRADATION)
    clear[nodes] = keep & large_enough & (distance >= CORE_CLEARANCE * h)
    return lattice, nodes[keep], lattice.triangles_within(clear)


def _chord_circles(boundary_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (B, 2) and radii (B,) of the diametral circles of the boundary chords k -> k+1."""
    following = np.roll(boundary_points, -1, axis=0)
    return 0.5 * (boundary_points + following), 0.5 * np.linalg.norm(following - boundary_points, axis=1)
