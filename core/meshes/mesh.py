"""Quality triangle meshes of the domain bounded by a closed B-spline (`core.triangulate`).

The mesh carries the basis functions of the deformation (Sec. 4.3: G is computed
once at the vertices of "a triangulation of Omega"; Sec. 4.2: the harmonic
comparison is piecewise linear over such a triangulation).  Boundary vertices are
curve points p(t) at known parameters t, so their basis rows are exactly the
B-spline basis; interior vertices lie strictly inside the curve.

Method (a conforming Delaunay refinement in the spirit of Ruppert and Chew, built
on `scipy.spatial.Delaunay`):

1. A target edge length h(x): at most ``max_edge``, smaller where the curve turns
   (at most `TURNING_ANGLE` between the tangents at the ends of an edge) or where
   another part of the curve is near (a fraction of the radius of the largest
   empty disk tangent to the curve, the local feature size); grown away from the
   curve at rate `GRADATION`.
2. Boundary vertices at equal steps of the integral of ds / h(s) along the arc,
   with every sharp corner (a doubled control point) a vertex.
3. Interior vertices on a hexagonal lattice of spacing ``max_edge`` where h is
   coarse, away from the curve (`core.meshes.hex_lattice`).  The lattice's own
   equilateral triangles whose corners are at least `CORE_CLEARANCE` h from the
   curve are final (the core): their triangulation is known, so only the band
   between the core and the curve is triangulated, and its size grows with the
   curve's length, not the domain's area.
4. Repeat, in the band: Delaunay triangulation; delete free vertices inside the
   diametral circle of a boundary edge and split (at the curve point of the
   middle arc length) every boundary edge that is not a Delaunay edge, until the
   boundary polygon and the core's border are sets of Delaunay edges (a core
   triangle whose circumcircle a band vertex enters joins the band); then insert
   the circumcentre of every band triangle that is too large or whose
   circumradius exceeds sqrt(2) times its shortest edge (all angles >= 20.7
   degrees), or split the boundary edge that the circumcentre encroaches.
5. Laplacian smoothing of the band's free vertices, then step 4 again.

Coordinates are (x, y); "counter-clockwise" means in a y-up frame (positive
``cross(b - a, c - a)``), which is clockwise on screen when y points down.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay, cKDTree

from core.curves.bspline import ClosedBSpline
from core.meshes.hex_lattice import HexLattice
from core.validation import as_points, positive_float

# Largest angle (radians) between the curve tangents at the two ends of a boundary edge.
TURNING_ANGLE = 0.3
# Boundary spacing <= this times the local feature size (radius of the largest empty
# tangent disk, inside or outside): about three edges across the narrowest neck.
NECK_FRACTION = 0.7
# |grad h|: how fast the target edge length may grow with the distance to the curve.
GRADATION = 0.3
# Triangles whose circumradius / shortest edge exceeds this are refined (min angle 20.7 deg).
RADIUS_EDGE_RATIO = math.sqrt(2.0)
# A triangle is too large when its circumradius exceeds this times h (an equilateral
# triangle of edge 1.3 h).
SIZE_FACTOR = 0.75
# Corners with a smaller interior angle (radians) are sharp: the mesh is graded toward them.
WIDE_CORNER = math.pi / 3
# The dense curve samples that measure h are at most h / this apart...
SAMPLES_PER_EDGE = 4.0
# ...unless that takes more than this many samples or resampling rounds.
MAX_SAMPLES = 4_000_000
MAX_RESAMPLING = 12
# The sizing field never asks for edges below max_edge / this (conforming may still split
# further where the curve nearly touches itself).
SMALLEST_FRACTION = 1000.0
# No refinement for quality of triangles whose shortest edge is below this times h(x):
# only next to a sharp corner, where small angles are unavoidable.
QUALITY_FLOOR = 0.05
# Lattice triangles whose corners are this many h from the curve are final (the core);
# the lattice nodes nearer than that stay free to move in the smoothing.
CORE_CLEARANCE = 1.2
SMOOTHING_PASSES = 3
MAX_ROUNDS = 200
MAX_VERTICES = 5_000_000
DEFAULT_EDGES_PER_DIAMETER = 50


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh of a B-spline domain.

    Attributes
    ----------
    vertices : ndarray of shape (V, 2)
        float64 (x, y) positions.
    triangles : ndarray of shape (T, 3)
        int64 vertex indices, counter-clockwise in a y-up frame
        (``cross(b - a, c - a) > 0``).
    boundary : ndarray of shape (B,)
        int64 indices of the vertices on the curve, in increasing parameter order.
    boundary_parameters : ndarray of shape (B,)
        float64 parameters t in [0, n) with ``vertices[boundary] == curve(t)``.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    boundary: np.ndarray
    boundary_parameters: np.ndarray

    def __post_init__(self):
        vertices = as_points(self.vertices, "vertices", min_count=3)
        triangles = np.array(self.triangles, dtype=np.int64)
        boundary = np.array(self.boundary, dtype=np.int64).reshape(-1)
        parameters = np.array(self.boundary_parameters, dtype=np.float64).reshape(-1)
        if triangles.ndim != 2 or triangles.shape[1] != 3 or triangles.shape[0] == 0:
            raise ValueError(f"triangles must have shape (T, 3) with T >= 1, got {triangles.shape}")
        if triangles.min() < 0 or triangles.max() >= vertices.shape[0]:
            raise ValueError(f"triangles must index vertices 0..{vertices.shape[0] - 1}")
        if boundary.shape != parameters.shape:
            raise ValueError(
                f"boundary and boundary_parameters must have the same length, got "
                f"{boundary.shape[0]} and {parameters.shape[0]}"
            )
        if boundary.size and (boundary.min() < 0 or boundary.max() >= vertices.shape[0]):
            raise ValueError(f"boundary must index vertices 0..{vertices.shape[0] - 1}")
        for name, array in (
            ("vertices", vertices),
            ("triangles", triangles),
            ("boundary", boundary),
            ("boundary_parameters", parameters),
        ):
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    def __repr__(self) -> str:
        return (
            f"Mesh(vertices={self.vertices.shape[0]}, triangles={self.triangles.shape[0]}, "
            f"boundary={self.boundary.shape[0]})"
        )

    @property
    def interior(self) -> np.ndarray:
        """int64 ndarray of shape (V - B,): indices of the vertices not on the curve."""
        mask = np.ones(self.vertices.shape[0], dtype=bool)
        mask[self.boundary] = False
        return np.flatnonzero(mask)

    def edges(self) -> np.ndarray:
        """Unique undirected edges, int64 ndarray of shape (E, 2) with ``edges[:, 0] < edges[:, 1]``."""
        return unique_edges(self.triangles)

    def signed_areas(self, vertices=None) -> np.ndarray:
        """Signed triangle areas, ndarray of shape (T,), positive when counter-clockwise (y up).

        Parameters
        ----------
        vertices : array_like of shape (V, 2), optional
            Other positions of the same vertices (e.g. the deformed mesh);
            defaults to `self.vertices`.
        """
        if vertices is None:
            vertices = self.vertices
        else:
            vertices = as_points(vertices, "vertices")
            if vertices.shape[0] != self.vertices.shape[0]:
                raise ValueError(
                    f"vertices must have {self.vertices.shape[0]} rows like the mesh, got {vertices.shape[0]}"
                )
        return _signed_areas(vertices, self.triangles)

    def angles(self) -> np.ndarray:
        """Interior angles in radians, ndarray of shape (T, 3); column k is the angle at vertex k."""
        corners = self.vertices[self.triangles]  # (T, 3, 2)
        result = np.empty(self.triangles.shape)
        for k in range(3):
            u = corners[:, (k + 1) % 3] - corners[:, k]
            v = corners[:, (k + 2) % 3] - corners[:, k]
            result[:, k] = np.arctan2(np.abs(_cross(u, v)), np.einsum("td,td->t", u, v))
        return result


def folded_triangles(mesh: Mesh, deformed_vertices, tolerance: float = 1e-9) -> np.ndarray:
    """Triangles that the deformation folds over or collapses.

    Parameters
    ----------
    mesh : Mesh
        The undeformed mesh (all triangles counter-clockwise).
    deformed_vertices : array_like of shape (V, 2)
        The deformed vertex positions, in the same frame as ``mesh.vertices``.
    tolerance : float
        A triangle counts as collapsed when its deformed signed area is at most
        ``tolerance`` times its undeformed area.

    Returns
    -------
    ndarray of shape (T,), bool
        True where the signed area changed sign or became (almost) zero.
    """
    if not isinstance(mesh, Mesh):
        raise ValueError(f"mesh must be a core.Mesh, got {type(mesh).__name__}")
    tolerance = positive_float(tolerance, "tolerance")
    return mesh.signed_areas(deformed_vertices) <= tolerance * mesh.signed_areas()


def require_mesh_of(curve: ClosedBSpline, mesh: Mesh) -> None:
    """Raise `ValueError` unless `mesh` is a Mesh whose boundary vertices are ``curve(boundary_parameters)``.

    The tolerance, 1e-9 of the diameter, accepts meshes saved and reloaded as
    text but not a mesh of another cage.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    if not isinstance(mesh, Mesh):
        raise ValueError(f"mesh must be a core.Mesh, got {type(mesh).__name__}")
    if mesh.boundary.size == 0:
        raise ValueError("mesh has no boundary vertices; make it with core.triangulate(curve)")
    gap = np.abs(mesh.vertices[mesh.boundary] - curve(mesh.boundary_parameters)).max()
    if not gap <= 1e-9 * curve.diameter:
        raise ValueError(
            f"mesh was not made for this curve: its boundary vertices are up to {gap:.3g} away "
            "from curve(boundary_parameters); make it with core.triangulate(curve)"
        )


def triangulate(
    curve: ClosedBSpline, max_edge: float | None = None, progress: Callable[[float], None] | None = None
) -> Mesh:
    """Quality conforming triangle mesh of the domain bounded by `curve`.

    Parameters
    ----------
    curve : ClosedBSpline
        The domain boundary (either orientation).
    max_edge : float, optional
        Longest edge wanted, in the units of the control points; edges are shorter
        where the curve turns or where parts of it come close.  Defaults to
        ``curve.diameter / 50``.
    progress : callable, optional
        Called with the fraction done, in [0, 1], after each phase and each
        refinement round (an estimate: within a refinement, the share of the bad
        triangles fixed); it may raise to abandon the meshing.

    Returns
    -------
    Mesh
        A triangulation of the polygon through the boundary vertices: boundary
        vertices are ``curve(boundary_parameters)`` exactly (every sharp corner is
        one), interior vertices lie strictly inside the curve, all triangles are
        counter-clockwise, and away from sharp corners every angle is at least
        20 degrees.  Triangles along concave arcs of the curve reach outside it by
        at most the chord error, below 4 % of the edge length (`TURNING_ANGLE`).

    Raises
    ------
    ValueError
        If `curve` is not a ClosedBSpline, or `max_edge` is not a number > 0, is
        longer than the curve's diameter, or is so small that the mesh would
        exceed `MAX_VERTICES` vertices (estimated from the area; refinement near
        narrow features adds to that estimate).
        Also if the refinement fails (seen only for near-cusps made by two almost
        coincident control points): the message names them.
    """
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    if max_edge is None:
        max_edge = curve.diameter / DEFAULT_EDGES_PER_DIAMETER
    max_edge = positive_float(max_edge, "max_edge")
    if max_edge > curve.diameter:
        raise ValueError(
            f"max_edge={max_edge:.6g} is longer than the domain; use 0 < max_edge <= {curve.diameter:.6g} "
            "(the curve's diameter)"
        )
    # An equilateral mesh of edge h has 2 / (sqrt(3) h^2) vertices per unit area.
    estimate = 2.0 * abs(curve.area) / (math.sqrt(3.0) * max_edge**2)
    if estimate > MAX_VERTICES:
        smallest = math.sqrt(2.0 * abs(curve.area) / (math.sqrt(3.0) * MAX_VERTICES))
        raise ValueError(
            f"max_edge={max_edge:.6g} is too small: the mesh would have about {estimate:.3g} "
            f"vertices, more than the {MAX_VERTICES:,} allowed; use max_edge >= {smallest:.3g}"
        )
    report = _Progress(progress)
    try:
        # The fractions are the phases' shares of the time on dense meshes (300k vertices).
        sizing = _Sizing(curve, max_edge)
        report.phase(0.05)
        mesher = _Refinement(curve, sizing)
        report.phase(0.3)
        mesher.refine(lambda bad: report.rounds(bad, 0.3, 0.65))
        mesher.smooth(SMOOTHING_PASSES, lambda done: report.phase(0.65 + 0.07 * done))
        mesher.refine(lambda bad: report.rounds(bad, 0.72, 0.92))
        mesh = mesher.mesh()
        report.phase(1.0)
        return mesh
    except RuntimeError as error:
        raise ValueError(_unmeshable(curve, str(error))) from None


def _unmeshable(curve: ClosedBSpline, reason: str) -> str:
    """A message a person can act on when the refinement fails.

    The failures seen are near-cusps: two neighbouring control points almost (but
    not exactly) equal make the curve turn back within a tiny distance.
    """
    points = curve.control_points
    gaps = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    gaps[gaps == 0] = np.inf  # exact doubles are sharp corners, which mesh fine
    i = int(np.argmin(gaps))
    if gaps[i] < 1e-2 * curve.diameter:
        return (
            f"the curve cannot be meshed: control points {i} and {(i + 1) % len(points)} are almost "
            f"coincident ({gaps[i]:.3g} apart), which folds the curve into a near-cusp; make them "
            "exactly equal (a sharp corner) or move them apart"
        )
    return f"the curve cannot be meshed ({reason}); try a larger max_edge or smooth the cage"


class _Sizing:
    """Target edge length h at dense curve samples and, graded, anywhere in the plane."""

    def __init__(self, curve: ClosedBSpline, max_edge: float):
        self.max_edge = max_edge
        self.period = curve.n
        self.t = _dense_parameters(curve, max_edge)
        # Disks between samples farther apart than the feature are missed: sample more
        # densely where h is small until every sample step is below h / SAMPLES_PER_EDGE.
        for _ in range(MAX_RESAMPLING):
            self._measure(curve)
            target = np.minimum(self.h, np.roll(self.h, -1)) / SAMPLES_PER_EDGE
            extra = np.ceil(np.diff(self.arc) / target).astype(np.int64) - 1
            if extra.max() <= 0 or self.t.size + extra.sum() > MAX_SAMPLES:
                break
            following = np.append(self.t[1:], self.period)
            inserted = [
                self.t[i] + (following[i] - self.t[i]) * np.arange(1, count + 1) / (count + 1)
                for i, count in zip(np.flatnonzero(extra > 0), extra[extra > 0], strict=True)
            ]
            self.t = np.sort(np.concatenate([self.t, *inserted]))
        fine = self.h < max_edge
        self.fine_points = self.points[fine]  # (F, 2), where h < max_edge
        self._fine_h = self.h[fine]
        self._fine_tree = cKDTree(self.fine_points) if fine.any() else None
        # Farther than this from every fine sample, h is max_edge.
        self.reach = (max_edge - self._fine_h.min(initial=max_edge)) / GRADATION

    def _measure(self, curve: ClosedBSpline) -> None:
        """Samples, arc lengths and graded target lengths h at the parameters self.t."""
        self.points, first, second = curve.evaluate(self.t)
        speed = np.linalg.norm(first, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            tangents = first / speed[:, None]
            curvature = np.abs(_cross(first, second)) / speed**3
        stopped = speed <= 1e-12 * curve.diameter  # the knot of a sharp corner
        curvature[stopped] = 0.0
        chords = np.roll(self.points, -1, axis=0) - np.roll(self.points, 1, axis=0)
        tangents[stopped] = chords[stopped] / np.linalg.norm(chords[stopped], axis=1)[:, None]
        orientation = 1.0 if curve.is_counterclockwise else -1.0
        inward = orientation * np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
        steps = np.linalg.norm(np.roll(self.points, -1, axis=0) - self.points, axis=1)
        self.arc = np.concatenate([[0.0], np.cumsum(steps)])  # (S + 1,), closes the loop
        self.tree = cKDTree(self.points)
        outside_wedge, inside_wedge = _corner_wedges(curve, self.t)
        largest = 1.01 * self.max_edge / NECK_FRACTION  # larger disks do not limit h
        radius = np.minimum(
            _empty_disk_radii(self.points, inward, inside_wedge, self.tree, largest),
            _empty_disk_radii(self.points, -inward, outside_wedge, self.tree, largest),
        )
        with np.errstate(divide="ignore"):
            h = np.minimum(TURNING_ANGLE / curvature, NECK_FRACTION * radius)
        self.h = self._graded(np.clip(h, self.max_edge / SMALLEST_FRACTION, self.max_edge))

    def _graded(self, h: np.ndarray) -> np.ndarray:
        """Smallest h with h_i <= h_j + GRADATION |p_i - p_j| between nearby samples.

        Only samples within (max_edge - min h) / GRADATION of a sample with h below
        max_edge can be lowered, so only those are visited.
        """
        fine = h < self.max_edge
        if not fine.any():
            return h
        reach = (self.max_edge - h.min()) / GRADATION
        near = np.flatnonzero(
            cKDTree(self.points[fine]).query(self.points, distance_upper_bound=reach)[0] <= reach
        )
        k = min(32, h.shape[0])
        distance, index = self.tree.query(self.points[near], k=k)
        for _ in range(h.shape[0]):  # each pass carries the bound at least one sample on
            graded = np.minimum(h[near], (h[index] + GRADATION * distance).min(axis=1))
            if np.array_equal(graded, h[near]):
                break
            h = h.copy()
            h[near] = graded
        return h

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Target edge length at points x (M, 2), ndarray of shape (M,)."""
        result = np.full(x.shape[0], self.max_edge)
        if self._fine_tree is None or x.shape[0] == 0:
            return result
        k = min(8, self._fine_h.size)
        distance, index = self._fine_tree.query(x, k=k, distance_upper_bound=self.reach)
        distance = distance.reshape(-1, k)
        index = np.minimum(index.reshape(-1, k), self._fine_h.size - 1)  # misses: index == size
        return np.minimum(result, (self._fine_h[index] + GRADATION * distance).min(axis=1))

    def distance_to_curve(self, x: np.ndarray, reach: float) -> np.ndarray:
        """Distance to the nearest dense curve sample (within half a sample spacing of exact),
        or inf beyond `reach`."""
        return self.tree.query(x, distance_upper_bound=reach)[0]

    def arc_length(self, t: np.ndarray) -> np.ndarray:
        """Arc length from t = 0 along the dense polyline, for t in [0, 2 n)."""
        wrapped = np.concatenate([self.t, [self.period]])
        turns = np.floor(t / self.period)
        return np.interp(t - turns * self.period, wrapped, self.arc) + turns * self.arc[-1]

    def parameter(self, s: np.ndarray) -> np.ndarray:
        """Inverse of `arc_length`, parameters in [0, n) for arc lengths s (any real)."""
        total = self.arc[-1]
        turns = np.floor(s / total)
        wrapped = np.concatenate([self.t, [self.period]])
        return np.mod(np.interp(s - turns * total, self.arc, wrapped), self.period)

    def boundary_parameters(self, corner_parameters: np.ndarray) -> np.ndarray:
        """Parameters of the first boundary vertices, sorted in [0, n).

        Between consecutive corners (or around the whole curve if it has none) the
        vertices split the integral of ds / h(s) into equal parts of at most 1.
        """
        density = 1.0 / self.h
        steps = np.diff(self.arc)
        integral = np.concatenate(
            [[0.0], np.cumsum(0.5 * steps * (density + np.roll(density, -1)))]
        )  # (S + 1,)
        wrapped = np.concatenate([self.t, [self.period]])
        starts = np.sort(corner_parameters) if corner_parameters.size else np.zeros(1)
        stops = np.append(starts[1:], starts[0] + self.period)
        minimum_edges = 1 if corner_parameters.size else 3

        def cumulative(t):
            turns = np.floor(t / self.period)
            return np.interp(t - turns * self.period, wrapped, integral) + turns * integral[-1]

        parameters = []
        for start, stop in zip(starts, stops, strict=True):
            low, high = cumulative(start), cumulative(stop)
            edges = max(minimum_edges, math.ceil(high - low - 1e-9))
            targets = low + (high - low) * np.arange(edges) / edges
            turns = np.floor(targets / integral[-1])
            local = np.interp(targets - turns * integral[-1], integral, wrapped) + turns * self.period
            local[0] = start  # a corner exactly at its knot
            parameters.append(np.mod(local, self.period))
        result = np.unique(np.concatenate(parameters))
        return result[result < self.period]


def _dense_parameters(curve: ClosedBSpline, max_edge: float) -> np.ndarray:
    """Parameters of the first dense samples: every knot, at least 32 per span, ~max_edge / 8 apart."""
    nodes, weights = np.polynomial.legendre.leggauss(5)
    u = 0.5 * (nodes + 1.0)
    spans = np.arange(curve.n)
    first = curve.derivative((spans[:, None] + u[None, :]).ravel()).reshape(curve.n, 5, 2)
    lengths = 0.5 * (np.linalg.norm(first, axis=2) * weights).sum(axis=1)
    counts = np.clip(np.ceil(8.0 * lengths / max_edge).astype(np.int64), 32, 1 << 16)
    return np.concatenate([j + np.arange(c) / c for j, c in zip(spans, counts, strict=True)])


def _corner_wedges(curve: ClosedBSpline, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the sharp corner whose two straight spans hold each sample, or -1.

    The two spans next to a doubled control point are straight segments meeting
    at the corner, so samples on them need not limit each other's feature size.
    Returns the wedges for the disks outside the domain (every corner) and for
    the disks inside (only corners of interior angle at least `WIDE_CORNER`:
    inside a sharper corner the sides do limit each other, which grades the
    mesh toward the tip so that its triangles keep good angles).
    """
    outside = np.full(t.shape[0], -1, dtype=np.int64)
    inside = outside.copy()
    angles = curve.corner_angles()
    for index, corner in enumerate(curve.corners()[:, 0]):
        in_wedge = np.mod(t - corner + 1.0, curve.n) < 2.0
        outside[in_wedge] = index
        if angles[index] >= WIDE_CORNER:
            inside[in_wedge] = index
    return outside, inside


def _empty_disk_radii(points, normals, wedge, tree, largest) -> np.ndarray:
    """Radius (at most `largest`) of the largest disk touching each sample on the side of `normals`
    and empty of samples.

    The shrinking-ball iteration: start from radius `largest`, and while the disk holds a
    sample q, replace it by the disk tangent at p through q (radius
    |q - p|^2 / (2 (q - p) . n)).  Samples in the same corner wedge are ignored.
    """
    count = points.shape[0]
    k = min(32, count)
    radius = np.full(count, largest)
    active = np.arange(count)
    for _ in range(100):
        centres = points[active] + radius[active, None] * normals[active]
        # Samples beyond the largest radius cannot shrink any disk: the tree skips them.
        distance, neighbours = tree.query(centres, k=k, distance_upper_bound=radius[active].max())
        neighbours = np.minimum(neighbours, count - 1)  # misses: index == count, distance inf
        valid = (
            (neighbours != active[:, None])
            & ((wedge[active, None] < 0) | (wedge[neighbours] != wedge[active, None]))
            & (distance < radius[active, None] * (1.0 - 1e-9))
        )
        found = valid.any(axis=1)
        if not found.any():
            break
        active, valid, neighbours = active[found], valid[found], neighbours[found]
        nearest = neighbours[np.arange(active.size), np.argmax(valid, axis=1)]
        offset = points[nearest] - points[active]
        height = 2.0 * np.einsum("md,md->m", offset, normals[active])
        with np.errstate(divide="ignore"):
            shrunk = np.where(height > 0, np.einsum("md,md->m", offset, offset) / height, np.inf)
        radius[active] = np.minimum(radius[active], shrunk)
        active = active[shrunk < radius[active] * (1.0 + 1e-12)]
    return radius


class _Refinement:
    """State of the refinement: boundary parameters, the lattice core and the band's points.

    The lattice triangles marked `core` are final; the band (the rest of the
    domain) is triangulated by Delaunay from the boundary vertices, the lattice
    nodes not inside the core, and the inserted (Steiner) points.  A core
    triangle whose circumdisk a band point enters, or whose corner encroaches a
    boundary chord, is demoted to the band, so that the core's border (the
    front) is always a set of Delaunay edges of the band's points.
    """

    def __init__(self, curve: ClosedBSpline, sizing: _Sizing):
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
        # A ring of far points keeps the curve off the convex hull, where qhull would make
        # flat triangles out of collinear boundary vertices (the straight spans at corners).
        low, high = self.boundary_points.min(axis=0), self.boundary_points.max(axis=0)
        angles = 2.0 * np.pi * np.arange(16) / 16
        self.frame = 0.5 * (low + high) + (np.linalg.norm(high - low) + sizing.max_edge) * np.stack(
            [np.cos(angles), np.sin(angles)], axis=1
        )
        self.tri: Delaunay | None = None
        self.inside: np.ndarray | None = None
        self.band: np.ndarray | None = None  # indices into self.nodes of the band's nodes
        self.conformed = False  # self.tri is the triangulation of the current points

    def _front(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The band's nodes (Nb,), which nodes are core corners (K,) bool, and the front.

        The front is the directed edges (F, 2) of core triangles that no other core
        triangle shares, with the core on their left.  A node with six core
        triangles is inside the core and not in the band.
        """
        if self._front_cache is None:
            corners = self.core_corners[self.core_kept]
            count = np.bincount(corners.ravel(), minlength=self.nodes.shape[0])
            # A front edge has an end with fewer than six core triangles: look only there.
            near = corners[(count[corners] < 6).any(axis=1)]
            edges = near[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
            low, high = np.sort(edges, axis=1).T
            _, inverse, counts = np.unique(
                low * self.nodes.shape[0] + high, return_inverse=True, return_counts=True
            )
            # Both triangles of an edge with such an end are in `near`; other edges are inside.
            front = (counts[inverse] == 1) & (count[edges] < 6).any(axis=1)
            self._front_cache = count, edges[front]
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
            self.steiner = self.steiner[_encroached_chords(self.steiner, middle, half) < 0]
            encroaching = band[_encroached_chords(self.nodes[band], middle, half) >= 0]
            if encroaching.size:
                self.alive[encroaching[~fixed[encroaching]]] = False
                self._demote_at(encroaching[fixed[encroaching]])
                continue
            entered = self.lattice.circumdisk_hits(np.vstack([self.boundary_points, self.steiner]), self.core)
            if entered.size:
                self._demote(np.searchsorted(self.core_ids, entered))
                continue
            tri = Delaunay(np.vstack([self.boundary_points, self.nodes[band], self.steiner, self.frame]))
            if tri.coplanar.size:
                dropped = tri.coplanar[:, 0] - count
                if (dropped < 0).any() or (dropped >= band.size + self.steiner.shape[0]).any():
                    raise RuntimeError("boundary vertices coincide; the curve is degenerate")
                nodes = band[dropped[dropped < band.size]]
                self.alive[nodes[~fixed[nodes]]] = False
                self._demote_at(nodes[fixed[nodes]])
                self.steiner = np.delete(self.steiner, dropped[dropped >= band.size] - band.size, axis=0)
                continue
            chord = _chord_sides(tri.simplices, count)
            found = np.zeros(count, dtype=bool)
            found[chord[chord >= 0]] = True
            if not found.all():
                self._split(np.flatnonzero(~found))
                continue
            local = np.full(self.nodes.shape[0], -1, dtype=np.int64)
            local[band] = count + np.arange(band.size)
            front_side = _front_sides(tri.simplices, local[front])
            found = np.zeros(front.shape[0], dtype=bool)
            found[front_side[front_side >= 0]] = True
            if not found.all():  # only if a point sits on a core circumcircle: rare
                self._demote_at(front[~found].ravel())
                continue
            self.tri = tri
            self.band = band
            self.inside = _inside_triangles(tri, chord, count, self.orientation, local[front], front_side)
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
        corners = points[simplices]
        a = np.linalg.norm(corners[:, 1] - corners[:, 2], axis=1)
        b = np.linalg.norm(corners[:, 2] - corners[:, 0], axis=1)
        c = np.linalg.norm(corners[:, 0] - corners[:, 1], axis=1)
        area = 0.5 * np.abs(_cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
        radius = a * b * c / (4.0 * area)
        shortest = np.minimum(np.minimum(a, b), c)
        h = self.sizing(corners.mean(axis=1))
        bad = (radius > SIZE_FACTOR * h) | (
            (radius > RADIUS_EDGE_RATIO * shortest) & (shortest > QUALITY_FLOOR * h)
        )
        if not bad.any():
            return 0
        bad = np.flatnonzero(bad)
        priority = bad[np.argsort(-(radius[bad] / shortest[bad]))]
        centres = _circumcentres(corners[priority])
        middle, half = _chord_circles(self.boundary_points)
        encroached = _encroached_chords(centres, middle, half)
        hit = encroached >= 0
        splits = [encroached[hit]]
        free = np.flatnonzero(~hit)
        outside = ~_inside_polygon(centres[free], self.boundary_points)
        if outside.any():
            # Ruppert: a circumcentre outside the domain is cut off by a boundary edge; split it.
            splits.append(
                _first_crossing(
                    corners[priority[free[outside]]].mean(axis=1),
                    centres[free[outside]],
                    self.boundary_points,
                )
            )
        accepted = _spread(centres[free[~outside]], radius[priority][free[~outside]])
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
        simplices = _counter_clockwise(points, self.tri.simplices[self.inside])
        edges = unique_edges(simplices)
        total = points.shape[0]
        adjacency = coo_matrix(
            (np.ones(2 * edges.shape[0]), (np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]])),
            shape=(total, total),
        ).tocsr()
        degree = np.asarray(adjacency.sum(axis=1)).ravel()
        movable = np.ones(total, dtype=bool)
        movable[:count] = False
        movable[count : count + self.band.size] = ~fixed[self.band]
        movable = np.flatnonzero(movable & (degree > 0))
        for done in range(passes):
            moved = points.copy()
            moved[movable] = (adjacency @ points)[movable] / degree[movable, None]
            minimum_area = 0.1 * _signed_areas(points, simplices)
            for _ in range(20):
                collapsed = _signed_areas(moved, simplices) < minimum_area
                if not collapsed.any():
                    break
                undo = np.unique(simplices[collapsed])
                moved[undo] = points[undo]
            points = moved
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
        band = _counter_clockwise(self.band_points, self.tri.simplices[self.inside])
        simplices = np.vstack([count + self.core_corners[self.core_kept], index[band]])
        used = np.zeros(points.shape[0], dtype=bool)
        used[simplices] = True
        if not used[:count].all():
            raise RuntimeError("a boundary vertex is in no triangle")
        renumber = np.cumsum(used) - 1
        return Mesh(
            vertices=points[used],
            triangles=renumber[simplices],
            boundary=np.arange(count, dtype=np.int64),
            boundary_parameters=self.parameters.copy(),
        )


class _Progress:
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


def _lattice(sizing: _Sizing, polygon: np.ndarray) -> tuple[HexLattice, np.ndarray, np.ndarray]:
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


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _signed_areas(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    a, b, c = vertices[triangles[:, 0]], vertices[triangles[:, 1]], vertices[triangles[:, 2]]
    return 0.5 * _cross(b - a, c - a)


def _counter_clockwise(points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
    simplices = simplices.copy()
    negative = _signed_areas(points, simplices) < 0
    simplices[negative] = simplices[negative][:, [0, 2, 1]]
    return simplices


def unique_edges(triangles: np.ndarray) -> np.ndarray:
    """Each undirected edge of the triangles once, (low, high), in lexicographic order.

    Parameters
    ----------
    triangles : ndarray of shape (T, 3), non-negative integers

    Returns
    -------
    ndarray of shape (E, 2), int64

    Edges are keyed as one integer, low * V + high, sorted, and the repeats dropped:
    for 800k triangles ``np.unique(axis=0)`` on the pairs took 7.4 s (numpy 2.4),
    one sort of the keys takes 0.1 s.
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    pairs = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    low, high = pairs.min(axis=1), pairs.max(axis=1)
    stride = high.max() + 1
    keys = np.sort(low * stride + high)
    keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])]
    return np.stack([keys // stride, keys % stride], axis=1)


def _chord_circles(boundary_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (B, 2) and radii (B,) of the diametral circles of the boundary chords k -> k+1."""
    following = np.roll(boundary_points, -1, axis=0)
    return 0.5 * (boundary_points + following), 0.5 * np.linalg.norm(following - boundary_points, axis=1)


def _encroached_chords(points: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """For each point (M, 2), a chord whose diametral circle holds it strictly inside, or -1."""
    chord = np.full(points.shape[0], -1, dtype=np.int64)
    if points.shape[0] == 0:
        return chord
    hits = cKDTree(points).query_ball_point(centres, radii * (1.0 - 1e-12), return_sorted=False)
    lengths = np.fromiter(map(len, hits), dtype=np.int64, count=len(hits))
    total = int(lengths.sum())
    if total:
        inside = np.fromiter(itertools.chain.from_iterable(hits), dtype=np.int64, count=total)
        chord[inside] = np.repeat(np.arange(len(hits)), lengths)
    return chord


def _inside_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """bool (M,): crossing-number test of points against a closed polygon (B, 2)."""
    following = np.roll(polygon, -1, axis=0)
    inside = np.zeros(points.shape[0], dtype=bool)
    chunk = max(1, 4_000_000 // polygon.shape[0])
    for start in range(0, points.shape[0], chunk):
        x = points[start : start + chunk, None, 0]
        y = points[start : start + chunk, None, 1]
        straddle = (polygon[None, :, 1] > y) != (following[None, :, 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            crossing_x = polygon[None, :, 0] + (y - polygon[None, :, 1]) * (
                following[None, :, 0] - polygon[None, :, 0]
            ) / (following[None, :, 1] - polygon[None, :, 1])
        inside[start : start + chunk] = (straddle & (crossing_x > x)).sum(axis=1) % 2 == 1
    return inside


def _first_crossing(starts: np.ndarray, stops: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """For each segment start -> stop (M, 2), the polygon edge k -> k+1 it crosses first (M,)."""
    a = polygon
    edge = np.roll(polygon, -1, axis=0) - a
    direction = stops - starts
    offset = a[None, :, :] - starts[:, None, :]
    denominator = _cross(direction[:, None, :], edge[None, :, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        along = _cross(offset, edge[None, :, :]) / denominator
        across = _cross(offset, direction[:, None, :]) / denominator
    hits = (along >= 0) & (along <= 1) & (across >= 0) & (across <= 1)
    along = np.where(hits, along, np.inf)
    return np.argmin(along, axis=1)


def _circumcentres(corners: np.ndarray) -> np.ndarray:
    """Circumcentres (T, 2) of triangles given as corners (T, 3, 2)."""
    a = corners[:, 0]
    b = corners[:, 1] - a
    c = corners[:, 2] - a
    d = 2.0 * _cross(b, c)
    bb = np.einsum("td,td->t", b, b)
    cc = np.einsum("td,td->t", c, c)
    ux = (c[:, 1] * bb - b[:, 1] * cc) / d
    uy = (b[:, 0] * cc - c[:, 0] * bb) / d
    return a + np.stack([ux, uy], axis=1)


def _spread(candidates: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Greedy subset of candidates (in priority order) no two closer than half their radius."""
    if candidates.shape[0] == 0:
        return candidates
    tree = cKDTree(candidates)
    neighbours = tree.query_ball_point(candidates, 0.5 * radii, return_sorted=False)
    taken = np.zeros(candidates.shape[0], dtype=bool)
    blocked = np.zeros(candidates.shape[0], dtype=bool)
    for i, group in enumerate(neighbours):
        if blocked[i]:
            continue
        taken[i] = True
        blocked[group] = True
    return candidates[taken]


def _chord_sides(simplices: np.ndarray, boundary_count: int) -> np.ndarray:
    """Which boundary chord each triangle side is, int64 (T, 3) with -1 for none.

    Side k of a triangle is opposite its vertex k; chord j joins boundary vertices
    j and j + 1 (mod B), which are the first B points.
    """
    result = np.full(simplices.shape, -1, dtype=np.int64)
    for k in range(3):
        u = simplices[:, (k + 1) % 3]
        v = simplices[:, (k + 2) % 3]
        on_boundary = (u < boundary_count) & (v < boundary_count)
        forward = on_boundary & ((v - u) % boundary_count == 1)
        backward = on_boundary & ((u - v) % boundary_count == 1)
        result[forward, k] = u[forward]
        result[backward, k] = v[backward]
    return result


def _front_sides(simplices: np.ndarray, front: np.ndarray) -> np.ndarray:
    """Which front edge each triangle side is, int64 (T, 3) with -1 for none.

    Side k of a triangle is opposite its vertex k; `front` (F, 2) holds the
    front edges as pairs of point indices (either direction matches).
    """
    result = np.full(simplices.shape, -1, dtype=np.int64)
    if front.shape[0] == 0:
        return result
    size = simplices.max() + 1
    front_keys = np.minimum(front[:, 0], front[:, 1]) * size + np.maximum(front[:, 0], front[:, 1])
    order = np.argsort(front_keys)
    sorted_keys = front_keys[order]
    for k in range(3):
        u = simplices[:, (k + 1) % 3]
        v = simplices[:, (k + 2) % 3]
        keys = np.minimum(u, v) * size + np.maximum(u, v)
        position = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
        match = sorted_keys[position] == keys
        result[match, k] = order[position[match]]
    return result


def _inside_triangles(
    tri: Delaunay,
    chord: np.ndarray,
    boundary_count: int,
    orientation: float,
    front: np.ndarray,
    front_side: np.ndarray,
) -> np.ndarray:
    """Indices of the Delaunay triangles of the band: inside the boundary polygon, outside the core.

    Triangles are grouped into connected regions that no boundary chord or front
    edge separates; a region is inside when it lies to the interior side of a
    chord or to the right of a front edge (the core is on its left), outside when
    it lies on the other side of one or on the convex hull.  A region on both
    sides means the polygon is not simple (a refinement bug).

    Parameters
    ----------
    chord : ndarray of shape (T, 3)
        `_chord_sides` of the triangles.
    front : ndarray of shape (F, 2)
        Front edges (tail, head) as point indices, the core on their left.
    front_side : ndarray of shape (T, 3)
        `_front_sides` of the triangles.
    """
    simplices = tri.simplices
    neighbours = tri.neighbors
    points = tri.points
    count = simplices.shape[0]
    is_chord = chord >= 0
    is_front = front_side >= 0
    join = ~is_chord & ~is_front & (neighbours >= 0)
    rows = np.nonzero(join)[0]
    graph = coo_matrix((np.ones(rows.shape[0]), (rows, neighbours[join])), shape=(count, count))
    _, labels = connected_components(graph, directed=False)
    a = np.where(is_chord, chord, 0)
    b = (a + 1) % boundary_count
    side = orientation * _cross(points[b] - points[a], points[simplices] - points[a])
    edge = np.zeros((*simplices.shape, 2), dtype=np.int64)
    if front.shape[0]:
        edge = front[np.where(is_front, front_side, 0)]
    tail, head = points[edge[..., 0]], points[edge[..., 1]]
    core_side = _cross(head - tail, points[simplices] - tail) > 0
    interior_side = (is_chord & (side > 0)).any(axis=1) | (is_front & ~core_side).any(axis=1)
    exterior_side = (
        (is_chord & (side < 0)) | (is_front & core_side) | (~is_chord & ~is_front & (neighbours < 0))
    ).any(axis=1)
    inside_label = np.zeros(labels.max() + 1, dtype=bool)
    inside_label[labels[interior_side]] = True
    outside_label = np.zeros(labels.max() + 1, dtype=bool)
    outside_label[labels[exterior_side]] = True
    if (inside_label & outside_label).any():
        raise RuntimeError("the boundary polygon is not simple; mesh refinement failed")
    return np.flatnonzero(inside_label[labels])
