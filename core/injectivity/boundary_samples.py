"""Samples of f_z and f_z̄ along the inner curve Γ, refined where the bounds between them are thin.

`PieceSamples` holds, piece by piece of Γ (`core.injectivity.inner_curve`), the sample parameters,
points and the derivatives there; `segment_bounds` turns the closed polygon through them into
bounds on each of its segments.  Between two samples a and b at distance ℓ, with Lipschitz
constants L_h, L_g of h' and g' along the segment,

    |h'| >= (|h'_a| + |h'_b| - L_h ℓ) / 2,   |g'| <= (|g'_a| + |g'_b| + L_g ℓ) / 2

(the nearer end's bound, at its worst point), and h' stays in the disc of radius L_h ℓ about
h'_a, which misses 0 when L_h ℓ < |h'_a|: then the argument of h' turns by less than π along
the segment and the principal value of arg(h'_b / h'_a) is its true turn (the argument
principle's count is exact).  L is estimated from the samples: `SAFETY` times the largest
difference quotient of the segment and its two neighbours (an estimate, not a bound: see the
certificate's documentation).  On offset pieces each sample has a companion `DEEPER` times
deeper; across the strip from the sample to the boundary σ₂ = |h'| - |g'| is taken to drop by at
most `STRIP_SAFETY` times its mean rate between the two, and on the segment by at most
(L_h + L_g) ℓ / 2.  Where that strip bound is thin the certificate moves the sample closer
to the boundary (its depth is per sample).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.injectivity.harmonic_parts import complex_derivatives
from core.injectivity.inner_curve import DEEPER, DEPTH, Piece, arc_points, offset_points

#: Lipschitz constants between samples: this many times the largest neighbouring difference quotient.
SAFETY = 2.0
#: Across the strip between Γ and the boundary σ₂ varies by at most this many times its variation
#: between Γ and the deeper companion, divided by (DEEPER - 1) (its mean rate over that interval).
STRIP_SAFETY = 2.0
#: The allowance for a sample's evaluation error: this many times the identity map's error there
#: (`core.injectivity.harmonic_parts.complex_derivatives`), taken off σ₂ twice (|h'| and |g'|).
ERROR_SAFETY = 10.0
#: Times a sample's depth is quartered where its deeper companion lies outside the domain.
INSIDE_TRIES = 6
#: First samples: per unit of parameter on offset pieces, and per corner arc.
PER_SPAN = 8
PER_ARC = 16


@dataclass
class PieceSamples:
    """Samples of one piece: parameters (m,) in the piece's order, points (m, 2) of Γ, h' and f_z̄
    (complex (m,), |f_z̄| = |g'|), the lower bound of σ₂ = |h'| - |g'| across the strip from the
    sample to the boundary (m,), on offset pieces the depth of each sample (m,) (None on arcs), the
    allowance for the evaluation error of h' and g' (m,), and the upper bound of k = |g'| / |h'|
    across the strip (m,; at the sample itself on arcs)."""

    parameters: np.ndarray
    points: np.ndarray
    h: np.ndarray
    g: np.ndarray
    sigma_strip: np.ndarray
    depths: np.ndarray | None = None
    allowance: np.ndarray | None = None
    k_strip: np.ndarray | None = None


def first_parameters(piece: Piece) -> np.ndarray:
    """The first sample parameters of a piece, both ends included."""
    if piece.corner is not None:
        return np.linspace(piece.start, piece.stop, PER_ARC + 1)
    return np.linspace(
        piece.start, piece.stop, max(PER_SPAN, int(np.ceil(PER_SPAN * (piece.stop - piece.start)))) + 1
    )


def evaluate(
    curve: ClosedBSpline, target: np.ndarray, piece: Piece, parameters: np.ndarray, depths=None
) -> PieceSamples:
    """The samples of `piece` at `parameters` (m,) for the harmonic map of `curve` (counter-clockwise)
    onto target control points (n, 2); `depths` (m,) of offset samples as fractions of the
    diameter (`DEPTH` if None)."""
    if piece.corner is not None:
        points = arc_points(piece.corner, parameters)
        h, g, error = complex_derivatives(curve, target, points)
        allowance = ERROR_SAFETY * error
        return PieceSamples(
            parameters, points, h, g, np.abs(h) - np.abs(g) - 2.0 * allowance, None, allowance,
            _ratio_high(h, g, allowance),
        )  # fmt: skip
    depths = np.full(parameters.size, DEPTH) if depths is None else np.asarray(depths, dtype=np.float64)
    points, deeper = offset_points(curve, parameters, depths * curve.diameter)
    try:
        h_both, g_both, error = complex_derivatives(curve, target, np.concatenate([points, deeper]))
    except ValueError:  # a thin part: some deeper points left the domain (rare: only now the test)
        for _ in range(INSIDE_TRIES):
            outside = np.flatnonzero(~curve.contains(deeper))
            if outside.size == 0:
                break
            depths = depths.copy()
            depths[outside] *= 0.25
            points[outside], deeper[outside] = offset_points(
                curve, parameters[outside], depths[outside] * curve.diameter
            )
        h_both, g_both, error = complex_derivatives(curve, target, np.concatenate([points, deeper]))
    m = parameters.size
    allowance = ERROR_SAFETY * np.maximum(error[:m], error[m:])
    sigma = np.abs(h_both) - np.abs(g_both)
    near, far = sigma[:m], sigma[m:]
    strip = np.minimum(near, far) - STRIP_SAFETY / (DEEPER - 1.0) * np.abs(near - far) - 2.0 * allowance
    ratio = _ratio_high(h_both, g_both, np.concatenate([allowance, allowance]))
    near, far = ratio[:m], ratio[m:]
    k_strip = np.maximum(near, far) + STRIP_SAFETY / (DEEPER - 1.0) * np.abs(near - far)
    return PieceSamples(parameters, points, h_both[:m], g_both[:m], strip, depths, allowance, k_strip)


def _ratio_high(h: np.ndarray, g: np.ndarray, allowance: np.ndarray) -> np.ndarray:
    """Upper bounds of |g'| / |h'| from samples (M,) with their allowances (inf where |h'| is not
    above its allowance)."""
    low = np.abs(h) - allowance
    return np.where(low > 0, (np.abs(g) + allowance) / np.where(low > 0, low, 1.0), np.inf)


def merged(old: PieceSamples, new: PieceSamples) -> PieceSamples:
    """Two sample sets of one piece in the piece's order (its parameters run up on offset pieces,
    down on arcs); where both hold a parameter, the new sample wins."""
    parameters = np.concatenate([new.parameters, old.parameters])
    _, first = np.unique(parameters, return_index=True)
    order = first[np.argsort(parameters[first], kind="stable")]
    if old.parameters.size > 1 and old.parameters[0] > old.parameters[-1]:
        order = order[::-1]
    fields = [
        None if a is None else np.concatenate([b, a])[order]
        for a, b in zip(_fields(old), _fields(new), strict=True)
    ]
    return PieceSamples(*fields)


def _fields(samples: PieceSamples) -> tuple:
    return (
        samples.parameters, samples.points, samples.h, samples.g, samples.sigma_strip, samples.depths,
        samples.allowance, samples.k_strip,
    )  # fmt: skip


@dataclass(frozen=True)
class SegmentBounds:
    """Bounds on the segments of the closed polygon Γ, segment j from sample j to j + 1 (cyclic),
    all of shape (N,): lower bound of |h'| and upper bound of |g'| on the segment, lower bound of
    σ₂ across the strip beside it, the argument turn of h', whether that turn is exact, the
    Lipschitz constants used and the lengths."""

    h_low: np.ndarray
    g_high: np.ndarray
    sigma_strip: np.ndarray
    turn: np.ndarray
    turn_exact: np.ndarray
    lipschitz_h: np.ndarray
    lipschitz_g: np.ndarray
    length: np.ndarray


def segment_bounds(
    points: np.ndarray, h: np.ndarray, g: np.ndarray, sigma_strip: np.ndarray, allowance: np.ndarray
) -> SegmentBounds:
    """`SegmentBounds` of the closed polygon through points (N, 2) with samples h, g (N,) complex,
    strip bounds sigma_strip (N,) and the allowances (N,) for the samples' evaluation error."""
    following = np.roll(np.arange(points.shape[0]), -1)
    length = np.linalg.norm(points[following] - points, axis=1)
    safe = np.where(length > 0, length, 1.0)
    quotient_h = np.where(length > 0, np.abs(h[following] - h) / safe, 0.0)
    quotient_g = np.where(length > 0, np.abs(g[following] - g) / safe, 0.0)
    lipschitz_h = SAFETY * np.maximum.reduce([quotient_h, np.roll(quotient_h, 1), np.roll(quotient_h, -1)])
    lipschitz_g = SAFETY * np.maximum.reduce([quotient_g, np.roll(quotient_g, 1), np.roll(quotient_g, -1)])
    size_h, size_g = np.abs(h) - allowance, np.abs(g) + allowance
    lower = 0.5 * (size_h + size_h[following] - lipschitz_h * length)
    upper = 0.5 * (size_g + size_g[following] + lipschitz_g * length)
    strip = 0.5 * (sigma_strip + sigma_strip[following] - (lipschitz_h + lipschitz_g) * length)
    exact = lipschitz_h * length < np.minimum(size_h, size_h[following])
    turn = np.angle(h[following] / h)
    return SegmentBounds(lower, upper, strip, turn, exact, lipschitz_h, lipschitz_g, length)


__all__ = ["PieceSamples", "SegmentBounds", "evaluate", "first_parameters", "merged", "segment_bounds"]
