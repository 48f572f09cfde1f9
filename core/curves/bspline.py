"""Closed uniform quadratic B-spline curves, the domain boundaries of the paper.

Sec. 4.1: for user control points P_1..P_n, the curve is
p(t) = sum_{i=0}^{n+1} P_i N_i^2(t) over the uniform knots (-2, -1, ..., n+2) with
P_0 = P_n and P_{n+1} = P_1, for t in [0, n).  On t in [j, j+1) with u = t - j only
N_j, N_{j+1}, N_{j+2} are non-zero:

    N_j = (1 - u)^2 / 2,   N_{j+1} = (-2u^2 + 2u + 1) / 2,   N_{j+2} = u^2 / 2.

Sec. 4.3 folds the n + 2 basis functions onto the n user points
(G_1 = Ĝ_1 + Ĝ_{n+1}, G_n = Ĝ_0 + Ĝ_n), which here means: paper index i belongs to
array row (i - 1) mod n.  Coordinates are (x, y) in whatever frame the caller
uses (image pixels with the origin top-left and y down in the app).
"""

from __future__ import annotations

import math

import numpy as np

from core.curves.arc_length import arc_length_boundary, checked_parameterization
from core.curves.boundary import Boundary, PiecewisePolynomial
from core.curves.diameter import point_set_diameter
from core.validation import as_parameters, as_points, checked_samples_per_segment


class ClosedBSpline:
    """A closed uniform quadratic B-spline with n >= 3 control points.

    Parameters
    ----------
    control_points : array_like of shape (n, 2)
        P_1..P_n.  A point repeated twice in a row makes a sharp corner, a polygon
        is the curve whose points are all doubled (the paper's Fig. 10).

    Raises
    ------
    ValueError
        Fewer than 3 points, non-finite values, a point repeated three or more
        times in a row, a curve of (nearly) zero area, or a curve that crosses or
        touches itself.
    """

    def __init__(self, control_points):
        points = as_points(control_points, "control_points", min_count=3)
        _check_range(points)
        self._points = points
        self._points.setflags(write=False)
        if np.all(points == points[0]):
            raise ValueError("control_points are all the same point; the curve has no area")
        _check_repeats(points)
        self.area = _signed_area(points)
        self.diameter = _diameter(points)
        centred = points - points.mean(axis=0)
        singular = np.linalg.svd(centred, compute_uv=False)
        if singular[1] <= 1e-12 * singular[0]:
            raise ValueError("control_points are collinear; the curve encloses no area")
        i = _first_knot_loop(points)
        j = None if i is None else (i + 1) % len(points)
        if i is not None and np.linalg.norm(points[j] - points[i]) < 1e-2 * self.diameter:
            raise ValueError(
                f"the curve crosses itself in a tiny loop between control points {i} and {j}, which "
                "are almost equal while the cage turns back over them; make them exactly equal "
                "(a sharp corner) or move them apart"
            )
        if i is not None:
            raise ValueError(
                f"the curve crosses or touches itself near control points {i} and {j}; "
                "move the control points so that it is a simple closed curve"
            )
        crossing = _first_self_intersection(points)
        if crossing is not None:
            i, j = crossing
            raise ValueError(
                f"the curve crosses or touches itself near control points {i} and {j}; "
                "move the control points so that it is a simple closed curve"
            )
        if abs(self.area) <= 1e-10 * self.diameter**2:
            raise ValueError(
                "the curve encloses (almost) no area: control_points are collinear or retrace themselves"
            )

    @property
    def control_points(self) -> np.ndarray:
        """ndarray of shape (n, 2): P_1..P_n (read-only)."""
        return self._points

    @property
    def n(self) -> int:
        """Number of control points, also the parameter period."""
        return self._points.shape[0]

    @property
    def is_counterclockwise(self) -> bool:
        """True if the curve runs counter-clockwise in a y-up frame (positive area)."""
        return self.area > 0

    def __repr__(self) -> str:
        return f"ClosedBSpline(n={self.n}, area={self.area:.6g})"

    def __call__(self, t) -> np.ndarray:
        """Points p(t), ndarray of shape (m, 2), for parameters t of shape (m,) (periodic)."""
        return self.evaluate(t)[0]

    def derivative(self, t, order: int = 1) -> np.ndarray:
        """p'(t) (order=1) or p''(t) (order=2), ndarray of shape (m, 2)."""
        if order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {order!r}")
        return self.evaluate(t)[order]

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p(t), p'(t), p''(t), each ndarray of shape (m, 2), for t of shape (m,)."""
        t = np.mod(as_parameters(t), self.n)
        index, weights = basis_weights(t, self.n)
        derivative_weights = _basis_derivative_weights(t)
        points = self._points[index]  # (m, 3, 2)
        value = np.einsum("mk,mkd->md", weights, points)
        first = np.einsum("mk,mkd->md", derivative_weights[0], points)
        second = np.einsum("mk,mkd->md", derivative_weights[1], points)
        return value, first, second

    def basis_matrix(self, t) -> np.ndarray:
        """Folded B-spline basis, ndarray of shape (m, n): row k holds N_i(t_k), rows sum to 1.

        ``basis_matrix(t) @ control_points == curve(t)`` (Sec. 4.3).
        """
        t = np.mod(as_parameters(t), self.n)
        index, weights = basis_weights(t, self.n)
        matrix = np.zeros((t.shape[0], self.n))
        # A row's three indices differ (n >= 3): set, not np.add.at (~10x slower).
        matrix[np.arange(t.shape[0])[:, None], index] = weights
        return matrix

    def sample(self, samples_per_segment: int = 100, parameterization: str = "natural") -> Boundary:
        """Sample N = samples_per_segment * n parameters t_k = k h, h = 1 / samples_per_segment.

        Returns a `Boundary` that also keeps the exact curve, so quadrature can be
        refined near the boundary at any parameter.  At the knots, where p'' jumps,
        the second derivative is the mean of its one-sided values.  With
        ``parameterization="arc-length"`` the N samples are uniform in the (normalised) arc
        length s instead, s_k = k n / N, and the boundary is the curve q(s) of
        `core.curves.arc_length` (Fig. 12c).
        """
        per = checked_samples_per_segment(samples_per_segment, self.n)
        count = per * self.n
        if checked_parameterization(parameterization) == "arc-length":
            return arc_length_boundary(self.piecewise_polynomial(), count, self.corners())
        t = np.arange(count) * (self.n / count)
        value, first, second = self.evaluate(t)
        # p'' jumps at the knots (every per-th sample); the trapezoid rule wants the
        # mean of both sides there, which p'' of the sample before (same span) gives.
        knots = np.arange(0, count, per)
        second[knots] = 0.5 * (second[knots] + second[knots - 1])
        return Boundary(
            value,
            first,
            second,
            self.n / count,
            _curve=self.piecewise_polynomial(),
            _corners=self.corners(),
        )

    def translated(self, offset) -> ClosedBSpline:
        """The curve moved by `offset` (2,), its area and diameter kept, without this
        constructor's checks again (a translation keeps a simple curve simple; they take
        ~1.5 ms, a tenth of a small cage's boundary-integral solve).  The checks run after
        all where rounding may change the curve: an offset more than 1000 times the curve's
        extent from the origin, coordinates out of range or not finite, or control points
        that coincide where they did not, or no longer where they did.

        Raises
        ------
        ValueError
            `offset` is not 2 numbers, or (from the checks) the moved curve is invalid.
        """
        offset = np.asarray(offset, dtype=np.float64)
        if offset.shape != (2,):
            raise ValueError(f"offset must be 2 numbers (dx, dy), got shape {offset.shape}")
        points = self._points + offset
        repeated = np.all(self._points == np.roll(self._points, 1, axis=0), axis=1)
        extent = self.diameter + np.abs(self._points).max()
        if (
            not np.all(np.isfinite(points))
            or np.abs(offset).max() > 1e3 * extent
            or np.abs(points).max() > MAX_COORDINATE
            or np.any(np.all(points == np.roll(points, 1, axis=0), axis=1) != repeated)
        ):
            return ClosedBSpline(points)
        moved = object.__new__(ClosedBSpline)
        moved._points = points
        moved._points.setflags(write=False)
        moved.area = self.area
        moved.diameter = self.diameter
        moved._doubled = _read_only(np.flatnonzero(repeated))
        return moved

    def piecewise_polynomial(self) -> PiecewisePolynomial:
        """The curve as n quadratic pieces in Bézier-free power form, u = t - j in [0, 1] (computed
        once: the boundary integrals ask for it hundreds of times a solve; callers must not write
        to it, and compiled callers need it writeable: numba types a read-only array apart)."""
        pieces = self.__dict__.get("_pieces")
        if pieces is None:
            pieces = self._pieces = self._piecewise_polynomial()
        return pieces

    def doubled_knots(self) -> np.ndarray:
        """The knots t = j that are sharp corners, paper P_j = P_{j+1} (array rows j - 1 and j), int
        (K,), read-only; computed once (a density solve asks eight times)."""
        doubled = self.__dict__.get("_doubled")
        if doubled is None:
            points = self._points
            previous = np.concatenate([points[-1:], points[:-1]])
            doubled = self._doubled = _read_only(np.flatnonzero((points == previous).all(axis=1)))
        return doubled

    def _piecewise_polynomial(self) -> PiecewisePolynomial:
        previous = np.roll(self._points, 1, axis=0)  # paper P_j, j = 0..n-1
        current = self._points  # P_{j+1}
        following = np.roll(self._points, -1, axis=0)  # P_{j+2}
        # p(u) = B0 + 2u(B1 - B0) + u^2 (B2 - 2 B1 + B0) with Bézier points below.
        b0 = 0.5 * (previous + current)
        b1 = current
        b2 = 0.5 * (current + following)
        coefficients = np.stack([b0, 2.0 * (b1 - b0), b2 - 2.0 * b1 + b0], axis=1)
        return PiecewisePolynomial(coefficients, 1.0)

    def corners(self) -> np.ndarray:
        """Sharp corners made by doubled control points.

        Returns ndarray of shape (C, 5): parameter t_c and the unit directions in
        which the curve arrives (2 values) and leaves (2 values).
        """
        doubled = np.sort((self.doubled_knots() - 1) % self.n)  # array rows i = i + 1
        rows = []
        for i in doubled:
            before = self._points[(i - 1) % self.n]
            after = self._points[(i + 2) % self.n]
            arrive = self._points[i] - before
            leave = after - self._points[i]
            # Array rows i, i+1 are paper P_{i+1} = P_{i+2}: the curve passes through
            # that point at the knot t = i + 1.
            rows.append(
                [(i + 1) % self.n, *(arrive / np.linalg.norm(arrive)), *(leave / np.linalg.norm(leave))]
            )
        return np.array(rows, dtype=np.float64).reshape(-1, 5)

    def corner_angles(self) -> np.ndarray:
        """The domain's angle at each sharp corner of `corners`, in its order, radians (C,): below
        π where the corner points out of the domain (a spike: a wedge of the domain), above where
        it points into it."""
        orientation = 1.0 if self.area > 0 else -1.0
        angles = []
        for _, *directions in self.corners():
            arrive, leave = np.array(directions[:2]), np.array(directions[2:])
            cross = arrive[0] * leave[1] - arrive[1] * leave[0]
            angles.append(math.pi - orientation * math.atan2(cross, float(arrive @ leave)))
        return np.array(angles, dtype=np.float64)

    def subdivide(self) -> ClosedBSpline:
        """The same curve with 2n control points (Chaikin's rule, exact for quadratics).

        The new curve q satisfies q(2t) = p(t) (parameters taken modulo 2n).
        """
        following = np.roll(self._points, -1, axis=0)
        refined = np.empty((2 * self.n, 2))
        refined[0::2] = 0.75 * self._points + 0.25 * following
        refined[1::2] = 0.25 * self._points + 0.75 * following
        # Chaikin's points give q(2t - 1) = p(t); one roll makes it q(2t) = p(t).
        return ClosedBSpline(np.roll(refined, 1, axis=0))

    def contains(self, x) -> np.ndarray:
        """Inside test against the exact curve: bool ndarray of shape (M,).

        Points on the curve count as inside (the domain is closed).
        """
        from core.curves.closest_point import distance_to_curve, winding_numbers

        points = as_points(x, "x")
        pieces = self.piecewise_polynomial()
        winding = winding_numbers(pieces, points)
        inside = winding != 0
        on_curve = distance_to_curve(pieces, points[~inside]) <= 1e-12 * self.diameter
        inside[np.flatnonzero(~inside)[on_curve]] = True
        return inside


def _read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def basis_weights(t: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Non-zero folded basis functions at parameters t in [0, n).

    Returns (index, weights), ndarrays of shape (m, 3): array rows and values of
    N_j, N_{j+1}, N_{j+2} for t in [j, j+1).
    """
    segment = np.minimum(np.floor(t).astype(np.int64), n - 1)
    u = t - segment
    index = np.stack([(segment - 1) % n, segment % n, (segment + 1) % n], axis=1)
    weights = np.stack([0.5 * (1 - u) ** 2, 0.5 * (-2 * u * u + 2 * u + 1), 0.5 * u * u], axis=1)
    return index, weights


def _basis_derivative_weights(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = t - np.floor(t)
    first = np.stack([u - 1, 1 - 2 * u, u], axis=1)
    second = np.broadcast_to(np.array([1.0, -2.0, 1.0]), first.shape)
    return first, second


#: Largest coordinate magnitude: squares (areas, distances) must stay finite.
MAX_COORDINATE = 1e150


def _check_range(points: np.ndarray) -> None:
    outside = np.flatnonzero(np.abs(points).max(axis=1) > MAX_COORDINATE)
    if outside.size:
        i = int(outside[0])
        raise ValueError(
            f"control_points[{i}] = {points[i].tolist()} is out of range: coordinates must lie within "
            f"+-{MAX_COORDINATE:g} ({outside.size} point(s) do not)"
        )


def _check_repeats(points: np.ndarray) -> None:
    same_as_next = np.all(points == np.roll(points, -1, axis=0), axis=1)
    triple = same_as_next & np.roll(same_as_next, -1)
    if triple.any():
        i = int(np.flatnonzero(triple)[0])
        raise ValueError(
            f"control points {i}, {(i + 1) % len(points)} and {(i + 2) % len(points)} "
            "coincide; repeat a point at most twice (twice makes a sharp corner)"
        )


def _signed_area(points: np.ndarray) -> float:
    """Exact signed area (positive counter-clockwise in a y-up frame) by Green's theorem.

    Per span the integrand x y' - y x' is a cubic in u, so Simpson's rule is exact.
    """
    previous = np.roll(points, 1, axis=0)
    following = np.roll(points, -1, axis=0)
    total = 0.0
    for u, weight in ((0.0, 1.0), (0.5, 4.0), (1.0, 1.0)):
        value = (
            (0.5 * (1 - u) ** 2) * previous
            + (0.5 * (-2 * u * u + 2 * u + 1)) * points
            + (0.5 * u * u) * following
        )
        first = (u - 1) * previous + (1 - 2 * u) * points + u * following
        cross = value[:, 0] * first[:, 1] - value[:, 1] * first[:, 0]
        total += weight * cross.sum()
    return 0.5 * total / 6.0


def _diameter(points: np.ndarray) -> float:
    """Largest distance between two points of the curve (it lies in the control hull).

    Uses dense samples; exact to a relative 1e-4, which is all tolerances need.
    O(n log n) time and O(n) memory (`core.curves.diameter`).
    """
    return point_set_diameter(_dense(points, 32))


def _dense(points: np.ndarray, per_span: int) -> np.ndarray:
    n = points.shape[0]
    t = np.arange(n * per_span) / per_span
    index, weights = basis_weights(t, n)
    return np.einsum("mk,mkd->md", weights, points[index])


def knot_loops(points: np.ndarray) -> np.ndarray:
    """Crossings of the two spans that meet at a knot, ndarray of shape (L, 3): i, s, v.

    The spans meeting at the knot between control points i and i + 1 (array rows)
    cross again, besides at the knot, when the two points are almost equal and the
    cage turns back over them: p(knot - s) == p(knot + v), the arc in between a loop
    that can be far smaller than a pixel, which polylines of the spans miss.

    With e = (P_{i+1} - P_i) / 2 and the knot K = P_i + e, the spans are
    K - 2 s e + s^2 a and K + 2 v e + v^2 b (s, v in (0, 1]), a and b their second
    differences.  The cross product with e gives s^2 (e x a) = v^2 (e x b), so
    s = rho v with rho = sqrt((e x b) / (e x a)), and the component along e gives
    v = 2 (rho + 1) |e|^2 / (rho^2 a.e - b.e).  These are all the crossings of two
    spans that share a knot (both are tangent to e there).
    """
    previous = np.roll(points, 1, axis=0)
    following = np.roll(points, -1, axis=0)
    after = np.roll(points, -2, axis=0)
    half = 0.5 * (following - points)
    knot = points + half
    a = 0.5 * (previous + points) - 2.0 * points + knot
    b = 0.5 * (following + after) - 2.0 * following + knot
    side_a = half[:, 0] * a[:, 1] - half[:, 1] * a[:, 0]
    side_b = half[:, 0] * b[:, 1] - half[:, 1] * b[:, 0]
    loops = []
    for i in np.flatnonzero((side_a * side_b > 0) & np.any(half != 0, axis=1)):
        rho = np.sqrt(side_b[i] / side_a[i])
        denominator = rho**2 * float(a[i] @ half[i]) - float(b[i] @ half[i])
        if denominator <= 0:
            continue
        v = 2.0 * (rho + 1.0) * float(half[i] @ half[i]) / denominator
        if 0 < rho * v <= 1 and 0 < v <= 1:
            loops.append([i, rho * v, v])
    return np.array(loops, dtype=np.float64).reshape(-1, 3)


def _first_knot_loop(points: np.ndarray) -> int | None:
    loops = knot_loops(points)
    return int(loops[0, 0]) if loops.shape[0] else None


def _first_self_intersection(points: np.ndarray) -> tuple[int, int] | None:
    """First pair of spans (array indices of their middle control point) that meet.

    Each span is a parabola arc (cannot cross itself); spans are compared as
    polylines of 24 chords, pruned by the bounding boxes of their Bézier hulls
    (`_overlapping_spans`, a sweep in x: memory linear in n).  Adjacent spans
    share one end point, which does not count; their other crossings, loops
    smaller than a chord, are found exactly by `knot_loops`.
    """
    n = points.shape[0]
    u = np.linspace(0.0, 1.0, _CHORDS + 1)
    previous = np.roll(points, 1, axis=0)
    following = np.roll(points, -1, axis=0)
    b0 = 0.5 * (previous + points)
    b2 = 0.5 * (points + following)
    hull = np.stack([b0, points, b2], axis=1)
    low, high = hull.min(axis=1), hull.max(axis=1)
    scale = max(float(np.ptp(points, axis=0).max()), 1e-300)
    pad = 1e-9 * scale
    degenerate = np.all(b0 == b2, axis=1)  # no repeated triples, but keep it safe
    for pairs in _overlapping_spans(low, high, pad):
        pairs = pairs[~(degenerate[pairs[:, 0]] | degenerate[pairs[:, 1]])]
        for start in range(0, pairs.shape[0], _PAIRS_PER_BATCH):
            batch = pairs[start : start + _PAIRS_PER_BATCH]
            i, j = batch[:, 0], batch[:, 1]
            a = _polyline(b0[i], points[i], b2[i], u)
            b = _polyline(b0[j], points[j], b2[j], u)
            # Neighbours share an end point: leave out the chords that end there.
            valid = np.ones((batch.shape[0], _CHORDS, _CHORDS), dtype=bool)
            follows = j == i + 1
            wraps = ~follows & (i == 0) & (j == n - 1)
            valid[follows, -1, :] = False
            valid[follows, :, 0] = False
            valid[wraps, 0, :] = False
            valid[wraps, :, -1] = False
            hits = np.flatnonzero(_chords_meet(a, b, valid, pad))
            if hits.size:
                return int(i[hits[0]]), int(j[hits[0]])
    return None


# Chords per span in the self-intersection test, and span pairs tested at once.
_CHORDS = 24
_PAIRS_PER_BATCH = 2048
# Candidate span pairs produced at once by the sweep (bounds its memory).
_PAIRS_PER_SWEEP = 1 << 20


def _overlapping_spans(low: np.ndarray, high: np.ndarray, pad: float):
    """Pairs (i, j), i < j, of boxes (n, 2) that overlap within `pad`.

    A sweep over the boxes sorted by their left side finds, for each box, the
    boxes that start before it ends; those are filtered by the other coordinate.
    Yields int64 arrays of shape (K, 2), each sorted, from blocks of at most about
    `_PAIRS_PER_SWEEP` candidates (at most n for one box), so memory stays linear
    in n however many pairs overlap.
    """
    n = low.shape[0]
    order = np.argsort(low[:, 0], kind="stable")
    starts = low[order, 0]
    stops = np.searchsorted(starts, high[order, 0] + pad, side="right")
    counts = np.maximum(stops - np.arange(n) - 1, 0)
    first = 0
    while first < n:
        total = np.cumsum(counts[first:])
        last = first + max(1, int(np.searchsorted(total, _PAIRS_PER_SWEEP, side="right")))
        sizes = counts[first:last]
        mine = np.repeat(np.arange(first, last), sizes)
        other = mine + 1 + np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)
        i, j = order[mine], order[other]
        overlap = (low[i, 1] <= high[j, 1] + pad) & (low[j, 1] <= high[i, 1] + pad)
        pairs = np.sort(np.stack([i[overlap], j[overlap]], axis=1), axis=1)
        yield pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        first = last


def _polyline(b0: np.ndarray, b1: np.ndarray, b2: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points (K, len(u), 2) of K quadratic Bézier arcs with control points (K, 2) each."""
    return (
        ((1 - u) ** 2)[None, :, None] * b0[:, None, :]
        + (2 * u * (1 - u))[None, :, None] * b1[:, None, :]
        + (u**2)[None, :, None] * b2[:, None, :]
    )


def _chords_meet(a: np.ndarray, b: np.ndarray, valid: np.ndarray, tolerance: float) -> np.ndarray:
    """Whether polylines a[k] and b[k] (K, c + 1, 2) intersect or touch (within tolerance).

    Only the chord pairs where ``valid`` (K, c, c) is true count.  Returns bool (K,).
    """
    p, r = a[:, :-1, None, :], np.diff(a, axis=1)[:, :, None, :]
    q, s = b[:, None, :-1, :], np.diff(b, axis=1)[:, None, :, :]
    qp = q - p
    denominator = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    t_num = qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]
    u_num = qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]
    parallel = np.abs(denominator) <= 1e-12 * np.linalg.norm(r, axis=-1) * np.linalg.norm(s, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = t_num / denominator
        u = u_num / denominator
    proper = ~parallel & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    # Parallel chords meet only if collinear and overlapping (a retraced path).
    collinear = parallel & (np.abs(t_num) <= tolerance * (np.linalg.norm(s, axis=-1) + 1e-300))
    rr = (r * r).sum(-1)
    safe = np.where(rr > 0, rr, 1)
    start = (qp * r).sum(-1) / safe
    end = ((qp + s) * r).sum(-1) / safe
    overlapping = collinear & (np.maximum(start, end) >= 0) & (np.minimum(start, end) <= 1) & (rr > 0)
    return np.any(valid & (proper | overlapping), axis=(1, 2))
