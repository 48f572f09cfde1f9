"""Gauss–Legendre panels on a closed quadratic B-spline: the boundary quadrature of `cauchy_integrals`.

The curve is cut at every knot, so that each panel is one polynomial piece (the
B-spline basis N_i is a polynomial on it too), and each span is cut further:

- geometrically towards knots where the curvature jumps (`knot_levels`, cuts at h 4^k
  from the finest panel h, `KNOT_GROWTH`) and dyadically towards sharp corners, where
  the density of a layer potential is singular (``CORNER_LEVELS`` levels, the geometric
  grading of Helsing's and Bremer's corner schemes, here as plain Nyström panels);
- wherever a panel is long against its distance to the rest of the curve (a thin
  arm: the density varies on the scale of the arm's width), until each panel is at
  most `THIN_RATIO` times that distance.

Each panel carries ``ORDER`` Gauss–Legendre nodes in the curve parameter t.  The
Lagrange interpolant of a density on a panel's nodes (`interpolation_matrix`) lets
the near-field rule of `core.boundary_integrals.cauchy_integrals` integrate it on sub-panels.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from core.boundary_integrals import compiled_integrals
from core.boundary_integrals.gauss_legendre import NODES, ORDER, WEIGHTS
from core.curves.bspline import ClosedBSpline

#: Dyadic levels of panels towards a sharp corner (a doubled control point).  With 6, points
#: 1e-6 of the diameter from the curve and 0.005 in t from a corner had G down to -1.6e-10
#: (random corner cages 13 and 17); with 7, -6.4e-11 there but -1.3e-10 and -1.0e-10 at points
#: 0.003 in t from corners of 42° and 68° (random corner cages 559 and 496); with 8, -2.5e-13.
CORNER_LEVELS = 8
#: Towards a knot where the curvature jumps by Δκ, the density behaves like s^2 log s
#: times Δκ ℓ (ℓ the shorter adjacent span's length): each level of grading divides its
#: error by about 8.  Levels are added until Δκ ℓ 8^-levels <= KNOT_JUMP.
KNOT_JUMP = 5e-7
#: At least this many levels at every knot: with 2, the hook's G reached -1.5e-9 at points
#: 1e-6 of the diameter from a knot, with 3 -2.6e-10 (the U-shape -4.8e-10), with 4 -3.1e-11
#: (U-shape -3.4e-11); the blob's knots take 6-8 levels by `KNOT_JUMP` anyway.
MIN_KNOT_LEVELS = 4
MAX_KNOT_LEVELS = 9
#: From the smallest panel at a knot, h = 2^(1-levels) of its coarse panel, the fine panels are
#: cut at h KNOT_GROWTH^k towards the coarse panel's other end (lengths h, 3h, 12h, ..., the last
#: one whatever is left; at sharp corners at h 2^k).  The quadrature of
#: the knot's s^2 log s is exact to rounding either way (the singularity is a panel length or
#: more away); what the factor sets is the degree-15 interpolant's error on the panel [h, 4h]:
#: 4e-11 of the singular term's size (5e-15 on [h, 2h], 9e-9 on [h, 8h]).  Against 2, on the
#: test shapes, the examples, 25 random smooth and 100 random corner cages (900 points each) G
#: moved by at most 1.7e-11 with 4 and by 4.3e-10 with 8; the bench blob's knot blocks went
#: from 185 fine panels to 115, its density solve from 32 to 27 ms.
KNOT_GROWTH = 4.0
#: A panel is split while its arc length exceeds this multiple of its distance to the
#: curve beyond its neighbours (1 split more and measured worse next to sharp corners:
#: panels shorter than their neighbours there).
THIN_RATIO = 2.0
#: A panel longer than this many times its gap (`gaps`), though not split, has its density
#: vary too fast for its degree-15 interpolant at points within ~1e-4 of the diameter of it:
#: `core.boundary_integrals.poisson` gives its halves their densities by Nyström interpolation.  Gaps are
#: measured up to this many panel lengths.
REFINED_RATIO = 1.0
#: A node is beyond a panel (`gaps`) where the curve between them is this many times longer than
#: the straight distance.
TURN = 3.0
#: A panel is split while the curve turns more than this many radians along it (max |κ| × length).
#: With 1.0 the bench's blob had 42 coarse panels, with 1.5 35 (its solve 42 -> 37 ms); with 2.0 a
#: random smooth cage had G = -5.6e-10 next to a tight turn.
CURVED = 1.5
#: A sharp corner whose interior angle is below this (radians) is a wedge: the coarse panels at it
#: are split until their parameter width is at most `WEDGE_WIDTH` and half the angle (`_wedged`).
WEDGE_ANGLE = np.radians(20.0)
#: With 1/16, random corner cage 760 had G = -2.8e-9 at a point 0.033 in t from its 7.7° wedge, on
#: the pair's outer fine panel (0.3 long, the far side 0.04 away); with 1/32, -3.8e-12.
WEDGE_WIDTH = 1.0 / 32.0
#: Coarse panels a span on a cage with sharp corners (a power of two, at least 2).
COARSE_PER_SPAN = 4
#: Coarse panels a span on a cage without sharp corners.  Its density is smooth but at the
#: knots, whose compressed blocks take it: with 2, the smooth test shapes and 33 random and
#: example smooth cages kept G >= -2.5e-11 and linear precision 8.6e-10 of the diameter, with
#: half the unknowns (an LU an eighth as long: 0.84 s -> 0.1 s for a cage of 60 control points).
#: On the spans at a corner 2 left random corner cages at 1e-4 of the diameter (`coarse_per_span`).
SMOOTH_COARSE_PER_SPAN = 2
#: The two coarse panels at a knot differ in arc length by at most this factor.
BALANCE = 2.0
#: Pairs of panels `gaps` looks at a block (their node distances: 4 KiB a pair).
GAP_PAIRS = 4096
#: `interpolation_matrix` takes its compiled loop from this many parameters (fewer: numpy is as quick).
COMPILED_ROWS = 64
#: At most this many rounds of splitting for thin parts (and as many for balance and turns).
THIN_ROUNDS = 12


def _barycentric_weights(nodes: np.ndarray) -> np.ndarray:
    difference = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(difference, 1.0)
    weights = 1.0 / difference.prod(axis=1)
    return weights / np.abs(weights).max()


_BARYCENTRIC = _barycentric_weights(NODES)


def interpolation_matrix(u: np.ndarray) -> np.ndarray:
    """Lagrange basis of the panel nodes at local parameters u in [-1, 1], shape (..., ORDER).

    ``interpolation_matrix(u) @ values`` interpolates values given at the nodes
    (the second barycentric formula; exact at the nodes).  Compiled for many parameters
    (`compiled_integrals.interpolation_rows`: the density solve's 1,840 fine nodes of the bench
    blob, 149 -> 43 µs) where its machine code is at hand, else numpy.
    """
    u = np.asarray(u, dtype=np.float64)
    if u.ndim == 1 and u.size >= COMPILED_ROWS:
        rows = compiled_integrals.run_compiled(
            compiled_integrals.interpolation_rows, lambda: (np.ascontiguousarray(u), _BARYCENTRIC)
        )
        if rows is not None:
            return rows
    difference = u[..., None] - NODES
    exact = difference == 0.0
    difference[exact] = 1.0
    terms = _BARYCENTRIC / difference
    matrix = terms / terms.sum(axis=-1, keepdims=True)
    hit = exact.any(axis=-1)
    if hit.any():
        matrix[hit] = exact[hit].astype(np.float64)
    return matrix


@dataclass(frozen=True)
class Panels:
    """Gauss–Legendre panels of a closed curve, nodes in panel order.

    Attributes
    ----------
    bounds : ndarray of shape (P, 2)
        Parameter interval [t_a, t_b] of each panel (t_b - t_a <= 1, inside one span).
    t : ndarray of shape (P * ORDER,)
        Node parameters.
    z : ndarray of shape (P * ORDER,), complex
        Node positions x + iy.
    dz, d2z : ndarray of shape (P * ORDER,), complex
        dz/dt and d^2z/dt^2 at the nodes.
    weights : ndarray of shape (P * ORDER,)
        Gauss–Legendre weights in t.
    centres, radii, lengths : ndarray of shape (P,)
        A circle around each panel (complex centre) and its arc length.
    """

    bounds: np.ndarray
    t: np.ndarray
    z: np.ndarray
    dz: np.ndarray
    d2z: np.ndarray
    weights: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    lengths: np.ndarray

    @property
    def count(self) -> int:
        """P, the number of panels."""
        return self.bounds.shape[0]

    @property
    def size(self) -> int:
        """P * ORDER, the number of nodes."""
        return self.t.shape[0]


def curve_panels(curve: ClosedBSpline) -> Panels:
    """The panels of `curve`: graded towards knots and corners, split in thin parts."""
    return graded_panels(curve, coarse_panels(curve))[0]


def span_panels(curve: ClosedBSpline) -> Panels:
    """One panel a span: the coarsest level of `core.boundary_integrals.cauchy_integrals.Levels`."""
    starts = np.arange(curve.n, dtype=np.float64)
    return panels_on_intervals(curve, np.stack([starts, starts + 1.0], axis=1))


def coarse_panels(curve: ClosedBSpline) -> Panels:
    """`coarse_per_span` panels a span, split further in thin parts (`gaps`): the solve's unknowns."""
    return coarse_panels_and_gaps(curve)[0]


def coarse_panels_and_gaps(curve: ClosedBSpline) -> tuple[Panels, np.ndarray]:
    """`coarse_panels` and each one's distance to the curve beyond it (`gaps`), float (P,)."""
    per_span = coarse_per_span(curve)
    starts = np.arange(curve.n * per_span) / per_span
    bounds = np.stack([starts, starts + 1.0 / per_span], axis=1)
    corners = sharp_corners(curve).astype(float)
    wedge_widths = _wedge_widths(curve)
    wedges = np.flatnonzero(np.isfinite(wedge_widths))
    for _ in range(2 * THIN_ROUNDS):
        panels = panels_on_intervals(curve, bounds)
        # The rules that look at a panel and its neighbours first; the gaps (a search of the
        # whole curve, most of this function's time) once those hold.
        split = _unbalanced(panels) | _curved(panels)
        if wedges.size:
            split |= _wedged(panels, wedge_widths)
        if not split.any():
            gap = np.minimum(gaps(panels, corners), knots_across_wedges(curve, panels, wedges))
            split = panels.lengths > THIN_RATIO * gap
            if not split.any():
                return panels, gap
        middle = bounds[split].mean(axis=1)
        halves = np.concatenate(
            [np.stack([bounds[split, 0], middle], 1), np.stack([middle, bounds[split, 1]], 1)]
        )
        bounds = np.concatenate([bounds[~split], halves])
        bounds = bounds[np.argsort(bounds[:, 0])]
    panels = panels_on_intervals(curve, bounds)
    return panels, np.minimum(gaps(panels, corners), knots_across_wedges(curve, panels, wedges))


def graded_panels(curve: ClosedBSpline, coarse: Panels) -> tuple[Panels, np.ndarray, np.ndarray]:
    """The coarse panels cut geometrically towards the knots they touch (`knot_levels`).

    Returns the fine panels, the coarse panel of each fine panel (int (P_f,)) and
    the knot each coarse panel touches (int (P_c,), -1 for none).  A coarse panel of
    parameter length h at a knot with L levels is cut at h 2^(1-L) `KNOT_GROWTH`^k from
    the knot (at a sharp corner at h 2^(1-L) 2^k: L panels).
    """
    # The coarse panels at a knot already are the first (panels a span) / 2 - 1 levels.
    levels = knot_levels(curve) - int(np.log2(coarse_per_span(curve) // 2))
    corners = set(sharp_corners(curve).tolist())
    cuts = [_graded_cuts(int(levels[j]), j in corners) for j in range(curve.n)]  # by knot
    fine, parent = [], []
    knot = np.full(coarse.count, -1, dtype=np.int64)
    for c, (a, b) in enumerate(coarse.bounds.tolist()):
        local = {0.0, 1.0}
        if abs(a - round(a)) < 1e-12:
            knot[c] = round(a) % curve.n
            local.update(cuts[knot[c]])
        if abs(b - round(b)) < 1e-12:
            knot[c] = round(b) % curve.n
            local.update(1.0 - cut for cut in cuts[knot[c]])
        local = sorted(local)
        fine.extend(zip(local[:-1], local[1:], strict=True))
        parent.extend([c] * (len(local) - 1))
    parent = np.asarray(parent, dtype=np.int64)
    start, width = coarse.bounds[parent, 0], np.diff(coarse.bounds, axis=1)[parent, 0]
    bounds = start[:, None] + width[:, None] * np.array(fine)
    return panels_on_intervals(curve, bounds), parent, knot


@functools.cache
def _graded_cuts(levels: int, corner: bool) -> tuple[float, ...]:
    """Cuts of a coarse panel [0, 1] graded towards 0 with `levels` levels, K floats: the
    smallest piece 2^(1-levels) long, the cuts at its length times 2^k at a corner,
    `KNOT_GROWTH`^k at a knot (kept: a solve asks for each knot's)."""
    smallest = 0.5 ** (levels - 1)
    growth = 2.0 if corner else KNOT_GROWTH
    pieces = int(np.ceil(np.log(1.0 / smallest) / np.log(growth) - 1e-9))
    return tuple((smallest * growth ** np.arange(pieces)).tolist())


def coarse_per_span(curve: ClosedBSpline) -> int:
    """Coarse panels a span: `SMOOTH_COARSE_PER_SPAN` on a cage without sharp corners,
    `COARSE_PER_SPAN` on one with any.

    (With 2 a span except at the corners' own spans, random corner cages 88 and 93 had G down
    to -5.7e-8 at points 1.6e-6 of the diameter from a smooth knot between a corner's span and
    a span of 2 panels; with 4 everywhere, -1.1e-13.)"""
    return COARSE_PER_SPAN if sharp_corners(curve).size else SMOOTH_COARSE_PER_SPAN


def sharp_corners(curve: ClosedBSpline) -> np.ndarray:
    """The knots t = j that are sharp corners, int (K,), read-only: paper P_j = P_{j+1} (array rows
    j-1, j); `ClosedBSpline.doubled_knots`."""
    return curve.doubled_knots()


def knot_levels(curve: ClosedBSpline) -> np.ndarray:
    """Grading levels towards each knot t = j (the finest panel 2^(1-levels) of its coarse panel),
    int ndarray of shape (n,)."""
    coefficients = curve.piecewise_polynomial().coefficients  # span j: c0 + c1 u + c2 u^2
    before = _previous(coefficients)

    def curvature(first, second):
        cross = first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0]
        speed = np.linalg.norm(first, axis=1)
        return np.where(speed > 0, cross, 0.0) / np.maximum(speed, 1e-100) ** 3

    leaving = curvature(coefficients[:, 1], 2.0 * coefficients[:, 2])
    arriving = curvature(before[:, 1] + 2.0 * before[:, 2], 2.0 * before[:, 2])
    spans = np.linalg.norm(coefficients[:, 1] + coefficients[:, 2], axis=1)  # chord of each span
    jump = np.abs(leaving - arriving) * np.minimum(spans, _previous(spans))
    with np.errstate(divide="ignore"):
        levels = np.ceil(np.log(jump / KNOT_JUMP) / np.log(8.0))
    levels = np.clip(np.nan_to_num(levels, neginf=0.0), MIN_KNOT_LEVELS, MAX_KNOT_LEVELS).astype(np.int64)
    levels[sharp_corners(curve)] = CORNER_LEVELS
    return levels


def panels_on_intervals(curve: ClosedBSpline, bounds: np.ndarray) -> Panels:
    """The panels of `curve` on the parameter intervals `bounds` (P, 2), each inside the span of
    its start: compiled (`compiled_integrals.panel_geometry`) where its machine code is at hand,
    else numpy."""
    geometry = compiled_integrals.run_compiled(
        compiled_integrals.panel_geometry,
        lambda: (curve.piecewise_polynomial().coefficients, np.ascontiguousarray(bounds, dtype=np.float64)),
    )
    if geometry is not None:
        t, weights, z, dz, d2z, centres, radii, lengths = geometry
        return Panels(bounds, t, z, dz, d2z, weights, centres, radii, lengths)
    half = 0.5 * (bounds[:, 1] - bounds[:, 0])
    middle = 0.5 * (bounds[:, 1] + bounds[:, 0])
    t = (middle[:, None] + half[:, None] * NODES).ravel()
    z, dz, d2z = _evaluate(curve, t, bounds)
    weights = (half[:, None] * WEIGHTS).ravel()
    ends = _evaluate(curve, bounds.ravel(), np.repeat(bounds, 2, axis=0))[0].reshape(-1, 2)
    z_panels = z.reshape(-1, ORDER)
    lengths = (np.abs(dz) * weights).reshape(-1, ORDER).sum(axis=1)
    centres = 0.5 * (ends[:, 0] + ends[:, 1])
    radii = np.maximum(
        np.abs(z_panels - centres[:, None]).max(axis=1), np.abs(ends - centres[:, None]).max(axis=1)
    )
    return Panels(bounds, t, z, dz, d2z, weights, centres, radii, lengths)


def _evaluate(curve: ClosedBSpline, t: np.ndarray, bounds: np.ndarray):
    """p, p', p'' at t (K,) as complex numbers (K,), each piece taken from the span of its panel
    (`bounds` (P, 2), K / P parameters a panel; no wrap-around at t = n)."""
    pieces = curve.piecewise_polynomial().coefficients  # (n, 3, 2)
    c = pieces[..., 0] + 1j * pieces[..., 1]  # (n, 3)
    start = np.floor(bounds[:, 0] + 1e-12)
    span = start.astype(np.int64) % curve.n
    if t.shape[0] != bounds.shape[0]:
        span = np.repeat(span, t.shape[0] // bounds.shape[0])
        start = np.repeat(start, t.shape[0] // bounds.shape[0])
    u = t - start
    c0, c1, c2 = c[span, 0], c[span, 1], c[span, 2]
    return c0 + u * (c1 + u * c2), c1 + 2.0 * u * c2, 2.0 * c2


def _curved(panels: Panels) -> np.ndarray:
    """bool (P,): panels along which the curve turns more than `CURVED` radians (max |κ| × length).

    A tight turn of a smooth curve (a near-cusp, a hairpin of three control points) bends
    the density as fast as the curve: one coarse panel over it left the points next to it
    with 1e-7 of the diameter in linear precision.
    """
    turning = np.abs((panels.dz.conj() * panels.d2z).imag) / np.abs(panels.dz) ** 3
    return turning.reshape(-1, ORDER).max(axis=1) * panels.lengths > CURVED


def _wedge_widths(curve: ClosedBSpline) -> np.ndarray:
    """The widest a coarse panel at each knot may be in t, float (n,): min(`WEDGE_WIDTH`, α / 2)
    at a wedge (a sharp corner where the domain's angle α is below `WEDGE_ANGLE`), inf elsewhere.

    Across a wedge the far side is α r away at r from its tip, so the corner's compressed block
    (its two coarse panels and their neighbours as long) sees the far side closer than it is
    long, and `gaps` leaves the far side of a corner's wedge to that block.  With the quarter
    spans of other corners, random corner cages had G down to -8.0e-5 (a 1.8° spike), -4.0e-8
    (3.4°), -1.4e-9 (1°) and -6.1e-10 (8°) at points ~1e-5 of the diameter from the wedge; with
    these splits, -1.4e-11 to -1.2e-12.
    """
    widths = np.full(curve.n, np.inf)
    angles = curve.corner_angles()
    wedge = angles < WEDGE_ANGLE
    widths[curve.corners()[wedge, 0].astype(np.int64)] = np.minimum(WEDGE_WIDTH, 0.5 * angles[wedge])
    return widths


def _wedged(panels: Panels, wedge_widths: np.ndarray) -> np.ndarray:
    """bool (P,): panels with an end at a knot wider in t than that knot's `wedge_widths` (n,)."""
    limit = np.full(panels.count, np.inf)
    for end in panels.bounds.T:
        knot = np.round(end)
        at_knot = np.abs(end - knot) < 1e-12
        limit[at_knot] = np.minimum(
            limit[at_knot], wedge_widths[knot[at_knot].astype(np.int64) % wedge_widths.size]
        )
    return panels.bounds[:, 1] - panels.bounds[:, 0] > limit + 1e-12


def _unbalanced(panels: Panels) -> np.ndarray:
    """bool (P,): panels ending or starting at a knot, more than `BALANCE` times as long as the other.

    The compression of `core.boundary_integrals.poisson` interpolates the interactions of a knot's two
    panels with the rest of the curve over each of them; a long panel next to a short
    one at a knot puts the short side's neighbours too close for that.
    """
    lengths = panels.lengths
    at_knot = np.abs(panels.bounds[:, 0] - np.round(panels.bounds[:, 0])) < 1e-12
    split = np.zeros(panels.count, dtype=bool)
    split[at_knot] = lengths[at_knot] > BALANCE * _previous(lengths)[at_knot]
    previous = _following(at_knot)  # the panel ending at that knot
    split[previous] |= lengths[previous] > BALANCE * _following(lengths)[previous]
    return split


def _previous(values: np.ndarray) -> np.ndarray:
    """values[i - 1] at i, cyclically (np.roll(values, 1, axis=0), at a fifth of its ~6 µs)."""
    return np.concatenate([values[-1:], values[:-1]])


def _following(values: np.ndarray) -> np.ndarray:
    """values[i + 1] at i, cyclically (np.roll(values, -1, axis=0))."""
    return np.concatenate([values[1:], values[:1]])


def gaps(panels: Panels, corners: np.ndarray) -> np.ndarray:
    """float (P,): each panel's distance to the curve beyond it (inf where none is near); a panel
    longer than `THIN_RATIO` times it is thin (split by `coarse_panels`).

    "Beyond" means farther along the curve than twice the panel's own length, or than
    `TURN` times the straight distance with no sharp corner (`corners`, their
    parameters) in between: the curve turned back, as beside a short spike, whose far
    side and corner the long panel sees at that distance.  So a panel is not compared
    with its graded neighbours, nor with the other side of a corner's wedge (that is
    the corner's compressed block), but with the opposite side of a thin arm.

    Every pair of nodes at most `reach` (the first one's panel's length over
    min(`THIN_RATIO`, `REFINED_RATIO`)) apart counts: the pairs of panels
    whose circles are that close, then their nodes' distances, in blocks of `GAP_PAIRS` (a
    search tree over the nodes took 1.7 ms of the bench blob's 21 ms density solve, mostly
    building Python lists; this 0.3 ms).
    """
    count = panels.count
    middle = np.cumsum(panels.lengths) - 0.5 * panels.lengths
    total = panels.lengths.sum()
    starts_corner = np.isin(panels.bounds[:, 0], corners)  # each corner starts a panel
    corner_at = np.sort((middle - 0.5 * panels.lengths)[starts_corner])
    reach = panels.lengths / min(THIN_RATIO, REFINED_RATIO)
    circles = (panels.z, panels.centres, panels.radii, panels.lengths)
    found = compiled_integrals.run_compiled(
        compiled_integrals.panel_gaps, lambda: (circles, middle, float(total), corner_at, reach, float(TURN))
    )
    if found is not None:
        return found
    nodes = panels.z.reshape(count, ORDER)
    nearest = np.full(count, np.inf)
    for first in range(0, count, GAP_PAIRS // max(count, 1) + 1):
        rows = slice(first, first + GAP_PAIRS // max(count, 1) + 1)
        separation = np.abs(panels.centres[rows, None] - panels.centres[None, :])
        close = separation <= (panels.radii[rows] + reach[rows])[:, None] + panels.radii[None, :]
        pairs = np.argwhere(close)
        for chunk in range(0, pairs.shape[0], GAP_PAIRS):
            p, o = pairs[chunk : chunk + GAP_PAIRS].T
            p = p + first
            np.minimum.at(nearest, p, _nearest_beyond(panels, nodes, middle, total, corner_at, reach, p, o))
    return nearest


def knots_across_wedges(curve: ClosedBSpline, panels: Panels, wedges: np.ndarray) -> np.ndarray:
    """float (P,): each panel's distance to the knots across a wedge from it (inf for none), knots
    t = k whose shorter arc to the panel passes a wedge's tip (`wedges`, its knots, int (W,)),
    the tips themselves not counted.

    `gaps` leaves the far side of a wedge to the tip's compressed block: across a wedge of angle
    α the far side is α r away at r from the tip, and the density there is smooth in log r (the
    panels grow with r).  A knot on the far side is not: its curvature jump and the kink of the
    basis functions there put a bump as wide as the gap into the density across it.  A panel
    of random corner cage 645 (a 5.7° spike) 37 long, 2.5 across from a knot, left G = -6.3e-7
    at points 1e-5 of the diameter from the far side.
    """
    if wedges.size == 0:
        return np.full(panels.count, np.inf)
    start = np.cumsum(panels.lengths) - panels.lengths  # arc length at each panel's start
    total = panels.lengths.sum()
    middle = start + 0.5 * panels.lengths
    at_knot = np.abs(panels.bounds[:, 0] - np.round(panels.bounds[:, 0])) < 1e-12
    knot = np.round(panels.bounds[at_knot, 0]).astype(np.int64) % curve.n
    knot_at = start[at_knot]  # (n,): every knot starts a coarse panel
    tip_at = np.sort(knot_at[np.isin(knot, wedges)])
    counted = ~np.isin(knot, wedges)
    knot, knot_at = knot[counted], knot_at[counted]
    low = np.minimum(middle[:, None], knot_at[None, :])
    high = np.maximum(middle[:, None], knot_at[None, :])
    wraps = high - low > 0.5 * total
    between = np.searchsorted(tip_at, high, side="left") - np.searchsorted(tip_at, low, side="right")
    across = np.where(wraps, between < tip_at.size, between > 0)  # (P, K)
    point = curve.evaluate(knot.astype(np.float64))[0] @ np.array([1.0, 1j])
    distance = np.abs(panels.z.reshape(panels.count, ORDER)[:, :, None] - point[None, None, :]).min(axis=1)
    return np.where(across, distance, np.inf).min(axis=1, initial=np.inf)


def _nearest_beyond(panels, nodes, middle, total, corner_at, reach, p, o) -> np.ndarray:
    """For pairs of panels (p, o) (K,) of `gaps`: the least distance between a node of p and a
    node of o within p's `reach` and beyond p, float (K,) (inf for none)."""
    low = np.minimum(middle[o], middle[p])
    high = np.maximum(middle[o], middle[p])
    wraps = high - low > 0.5 * total  # the shorter arc runs through position 0
    along = np.where(wraps, total - (high - low), high - low) - 0.5 * (panels.lengths[o] + panels.lengths[p])
    # Corners strictly between the pair's positions (by bisection: pairs x corners booleans took
    # gigabytes for a cage of hundreds of corners); the shorter arc runs between them unless it
    # wraps, then it passes every corner outside.
    between = np.searchsorted(corner_at, high, side="left") - np.searchsorted(corner_at, low, side="right")
    through_corner = np.where(wraps, between < corner_at.size, between > 0)
    distance = np.abs(nodes[p][:, :, None] - nodes[o][:, None, :])  # (K, ORDER, ORDER)
    beyond = (along > 2.0 * panels.lengths[p])[:, None, None] | (
        (along[:, None, None] > TURN * distance) & ~through_corner[:, None, None]
    )
    counted = beyond & (distance <= reach[p][:, None, None])
    return np.where(counted, distance, np.inf).min(axis=(1, 2))
