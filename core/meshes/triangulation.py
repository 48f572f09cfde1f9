"""Quality triangle meshes of the domain bounded by a closed B-spline (`core.triangulate`).

The mesh carries the basis functions of the deformation (Sec. 4.3: G is computed
once at the vertices of "a triangulation of Omega"; Sec. 4.2: the harmonic
comparison is piecewise linear over such a triangulation).  Boundary vertices are
curve points p(t) at known parameters t, so their basis rows are exactly the
B-spline basis; interior vertices lie strictly inside the curve.

Method (a conforming Delaunay refinement in the spirit of Ruppert and Chew, built
on the compiled Bowyer-Watson triangulation `core.meshes.delaunay`):

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
   degrees), or split the boundary edge that the circumcentre encroaches or that
   hides it from its triangle (the first one crossed on the way to it).
5. Laplacian smoothing of the band's free vertices, then step 4 again.

The loops of steps 1 and 4-5 are compiled with numba (`core.meshes.delaunay`,
`band_regions`, `chord_crossing`, `encroachment`, `empty_disks`, `point_grid`,
`smoothing`, `spread_points`, `triangle_shapes`, `core_front`); numpy and Python only
glue them, once per round.
6. No triangle is an ear at a sharp corner (the corner and its two boundary neighbours): its
   inner edge is flipped (`core.meshes.corner_ears`), so that a warp may open the corner past a
   straight angle without turning a triangle over.

Coordinates are (x, y); "counter-clockwise" means in a y-up frame (positive
``cross(b - a, c - a)``), which is clockwise on screen when y points down.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.jit_cache import compile_note
from core.meshes.corner_ears import opened_corner_ears
from core.meshes.mesh import Mesh
from core.meshes.refinement import Progress, Refinement
from core.meshes.sizing import Sizing
from core.validation import positive_float

SMOOTHING_PASSES = 3


MAX_VERTICES = 5_000_000


DEFAULT_EDGES_PER_DIAMETER = 50

#: Said once a process when the mesher's loops compile (their first use where the install's cache
#: does not apply: another CPU model or numba, ``NUMBA_CACHE_DIR``, ``TRANSFINITE_PRECOMPILE=0``).
COMPILING_NOTE = "note: compiling the mesher (first use, ~12 s of one core; numba caches it)"


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
    report = Progress(progress)
    try:
        with compile_note("core.meshes.", COMPILING_NOTE):
            return _mesh(curve, max_edge, report)
    except RuntimeError as error:
        raise ValueError(_unmeshable(curve, str(error))) from None


def _mesh(curve: ClosedBSpline, max_edge: float, report: Progress) -> Mesh:
    """The steps of `triangulate` (its docstring), reporting to `report`."""
    # The fractions are the phases' shares of the time on dense meshes (300k vertices).
    sizing = Sizing(curve, max_edge)
    report.phase(0.05)
    mesher = Refinement(curve, sizing)
    report.phase(0.3)
    mesher.refine(lambda bad: report.rounds(bad, 0.3, 0.65))
    mesher.smooth(SMOOTHING_PASSES, lambda done: report.phase(0.65 + 0.07 * done))
    mesher.refine(lambda bad: report.rounds(bad, 0.72, 0.92))
    mesh = opened_corner_ears(curve, mesher.mesh())
    report.phase(1.0)
    return mesh


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
