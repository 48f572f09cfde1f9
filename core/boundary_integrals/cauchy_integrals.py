"""Cauchy integrals over panels, with a near-field rule that holds down to the boundary.

Both boundary-integral kernels are Cauchy integrals over the source curve Γ,

    C[φ](z) = (1 / 2πi) ∮_Γ φ(τ) / (τ - z) dτ,

of a density φ given at the panel nodes of `core.boundary_integrals.panels`: the transfinite harmonic
coordinates are G_i = Re C[μ_i] for the double-layer densities μ_i (`core.boundary_integrals.poisson`),
the Cauchy–Green coordinates are C[N_i] (`core.boundary_integrals.cauchy_green`).  A row of *weights*
W(z) (one complex number a node) gives C[φ](z) = W(z) · φ.

Far from a panel the weights are its Gauss–Legendre rule, w_k τ'_k / (2πi (τ_k - z)).
Near it (closer than `SAFE` times its arc length) they integrate the Lagrange interpolant
of φ on the panel's nodes exactly against the exact curve (`adaptive_weights`): a span is a
quadratic, so dτ / (τ - z) is the sum of two simple poles in the panel's parameter, and
the interpolant's Legendre moments against them obey the Legendre recurrence (a product
integration rule in the manner of Helsing and Ojala, 2008, with no polynomial standing in
for the curve).  Its error is that of interpolating φ on the panel, so it holds at any
distance from Γ; targets within `ON_CURVE` diameters of a panel are reported as on the
curve, and left to the caller.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from core.boundary_integrals import compiled_integrals, compiled_tree
from core.boundary_integrals.compiled_integrals import (
    BACKWARD_DIGITS,
    FORWARD_ELLIPSE,
    PLAIN_ELLIPSE,
)
from core.boundary_integrals.gauss_legendre import LEGENDRE_VALUES, LEGENDRE_WEIGHTS, NODES, ORDER, WEIGHTS
from core.boundary_integrals.panels import (
    Panels,
    interpolation_matrix,
    panels_on_intervals,
    sharp_corners,
)
from core.curves.bspline import ClosedBSpline

#: Points per block of the far-field products (bounds the memory of a block's weights).
BLOCK = 512

#: A piece's Gauss–Legendre rule is used when the target is at least this many piece lengths
#: away from it (error below ~1e-13 of the piece's contribution for the values, 1e-11 for
#: the derivative).
SAFE = 0.5
#: `SAFE` of the coarsest level's far field on the spans next to a sharp corner (`span_safety`).
#: Its densities are weight-corrected restrictions (`restriction`), so its rule integrates the
#: kernel's degree-15 interpolant on the span, whose error falls as ρ^-16 rather than the plain
#: rule's ρ^-32, times the density's roughness: at half a span a corner's singular density left
#: G at -2e-9 (F polygon), at 0.75 spans -4e-11.  Smooth knots need no more than `SAFE`.
#: The same holds for `core.boundary_integrals.poisson`'s coarse panels in a corner's compressed block, whose
#: densities are restrictions too (`Levels.safety`): with `SAFE` there, a point 2.3e-3 of the
#: diameter from the F polygon, beside a corner, had G = -2.7e-10; with this, 3.7e-12.
CORNER_SAFE = 0.75
#: `SAFE` of the spans' far field (`span_safety`), whose densities are restrictions whatever the
#: density: their rule integrates the kernel's degree-15 interpolant on a whole span, error ~ρ^-16
#: times the density (ρ = 2.4 at half a span beside its middle: ~1e-6 relative).  With `SAFE`, a
#: point 1e-7 of the diameter from random corner cage 45, half a span's length from a long smooth
#: span (half the diameter), had G = -2.4e-7; with 1.0 (ρ >= 4.2), 4.5e-9, and random corner cages
#: 0-99 keep G >= -5.3e-11.  The default kernel's evaluation at 10,000 points is ~3 ms slower.
SPAN_SAFE = 1.0
#: Pairs closer than this fraction of the diameter get their weights directly: the far
#: field's expanded products lose ~1e-16 / distance^2 (relative, distance in diameters).
DIRECT = 1e-3
#: `near_pairs` compares every target with every panel's circle up to this many pairs (the density
#: solve's 560 coarse nodes and 35 panels: 0.05 ms, where a search tree's Python lists took 0.4 ms),
#: else searches a tree.
DIRECT_PAIRS = 1 << 16
#: A target this close to a panel (a fraction of the curve's diameter) is on the curve.
ON_CURVE = 1e-10
#: Levels of bisected panels below the finest one, for evaluation (`bisected`).
BISECTIONS = 2


def span_safety(curve: ClosedBSpline, panels: Panels) -> np.ndarray | float:
    """`SAFE` for each panel of the coarsest level, (P,): when the level is the spans,
    `SPAN_SAFE`, and at least `CORNER_SAFE` on the spans at a sharp corner (a doubled control
    point, at knot j: spans j - 1 and j)."""
    if panels.count != curve.n:
        return SAFE
    corner = sharp_corners(curve)
    safety = np.full(curve.n, SPAN_SAFE)
    safety[corner] = safety[(corner - 1) % curve.n] = max(CORNER_SAFE, SPAN_SAFE)
    return safety


def near_pairs(
    panels: Panels, targets: np.ndarray, diameter: float, safe: float | np.ndarray = SAFE
) -> tuple[np.ndarray, np.ndarray]:
    """(target index, panel index) pairs computed one by one, two int64 arrays sorted by target.

    A pair needs the adaptive rule when the target is closer to one of the panel's
    nodes than `SAFE` times the panel's arc length (otherwise the panel's own
    Gauss–Legendre rule holds), and it needs its weights computed directly, not by
    the far field's expanded products, within `DIRECT` diameters.
    """
    close_range = np.maximum(safe * panels.lengths, DIRECT * diameter)
    reach = panels.radii + close_range
    if panels.count * targets.size <= DIRECT_PAIRS:  # every pair's centre distance at once
        found = compiled_integrals.run_compiled(
            compiled_integrals.close_pairs,
            lambda: (
                np.ascontiguousarray(targets, dtype=np.complex128),
                panels.z,
                panels.centres,
                reach,
                close_range**2,
            ),
        )
        if found is not None:
            return found
        gap = targets[None, :] - panels.centres[:, None]
        panel, target = np.nonzero(gap.real * gap.real + gap.imag * gap.imag <= (reach * reach)[:, None])
    else:  # a search tree over the targets
        tree = cKDTree(np.stack([targets.real, targets.imag], axis=1))
        centres = np.stack([panels.centres.real, panels.centres.imag], axis=1)
        found = tree.query_ball_point(centres, reach, return_sorted=False)
        sizes = np.fromiter(map(len, found), dtype=np.int64, count=len(found))
        target = np.fromiter(itertools.chain.from_iterable(found), dtype=np.int64, count=int(sizes.sum()))
        panel = np.repeat(np.arange(panels.count), sizes)
    nodes = panels.z.reshape(-1, ORDER)
    dx = nodes.real[panel] - targets.real[target, None]
    dy = nodes.imag[panel] - targets.imag[target, None]
    close = (dx * dx + dy * dy).min(axis=1) < close_range[panel] ** 2
    target, panel = target[close], panel[close]
    order = np.lexsort((panel, target))
    return target[order], panel[order]


def smooth_on_own_span(curve: ClosedBSpline, panels: Panels, t: np.ndarray, panel: np.ndarray) -> np.ndarray:
    """bool (K,): pairs of a node at parameter t (K,) and a panel of the same span, where the double
    layer's kernel is smooth enough for the panel's plain rule, however near the node.

    On one span p(u) = c0 + c1 u + c2 u^2, and p(u) - p(s) = (u - s)(c1 + c2 (u + s)), so

        Im(p'(u) / (p(u) - p(s))) = -Im(c1 conj c2) / |c1 + c2 (u + s)|^2,

    a kernel with no singularity at u = s: its poles are at u = -c1/c2 - s and its conjugate's
    (complex; a straight span has c1 conj c2 real, the kernel 0).  The plain rule's error falls
    as ρ^-32 with ρ the Bernstein ellipse through the pole: a pole at least one panel length
    from the panel (ρ > 4) leaves < 1e-19 for a density polynomial on the panel (a restricted
    density, on a coarse panel of a knot's block, integrates only to ~ρ^-16 times its
    roughness: measured, G moves by 5e-13 at most).  Nyström matrices of `poisson` skip
    the adaptive rule for these pairs, most of the near pairs of a knot's graded panels, and
    take their weights from the closed form (`fill_same_span`).
    """
    c1, c2, cross = span_coefficients(curve)
    span = np.floor(panels.bounds[panel, 0] + 1e-12).astype(np.int64)
    same = np.floor(t + 1e-12).astype(np.int64) == span
    straight = cross[span % curve.n] == 0.0
    c1, c2 = c1[span % curve.n], c2[span % curve.n]
    with np.errstate(divide="ignore", invalid="ignore"):
        pole = -c1 / c2 - (t - span)
    low, high = panels.bounds[panel, 0] - span, panels.bounds[panel, 1] - span
    distance = np.abs(pole - np.clip(pole.real, low, high))
    return same & (straight | (distance >= high - low))


def span_coefficients(curve: ClosedBSpline) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """c1, c2 (complex (n,)) of each span p(u) = c0 + c1 u + c2 u^2, and Im(c1 conj c2) (n,), set
    to 0 where c1 and c2 are parallel to rounding (a straight span: its kernel is 0)."""
    pieces = curve.piecewise_polynomial().coefficients
    c1 = pieces[:, 1, 0] + 1j * pieces[:, 1, 1]
    c2 = pieces[:, 2, 0] + 1j * pieces[:, 2, 1]
    cross = (c1 * np.conj(c2)).imag
    cross[np.abs(cross) <= 1e-14 * np.abs(c1) * np.abs(c2)] = 0.0
    return c1, c2, cross


def same_span_coefficients(curve: ClosedBSpline) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """c1, c2 (complex (n,)) of each span and the scale -Im(c1 conj c2) / 2π of its double-layer
    kernel (n,), signed by the orientation (`fill_same_span`)."""
    c1, c2, cross = span_coefficients(curve)
    orientation = 1.0 if curve.area > 0 else -1.0
    return c1, c2, -orientation * cross / (2.0 * np.pi)


def span_parameters(curve: ClosedBSpline, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The span of each parameter t (M,), int (M,), and the parameter within it, (M,)."""
    floor = np.floor(t + 1e-12)
    return floor.astype(np.int64) % curve.n, t - floor


def fill_same_span(curve: ClosedBSpline, matrix: np.ndarray, t: np.ndarray, panels: Panels) -> None:
    """Set the double layer's Re C-weights of the pairs on one span from the kernel's closed form.

    `matrix` (M, P * ORDER) holds the weights of the nodes of `panels` at targets on the curve
    at parameters t (M,).  Where a target and a node are on the same span, the weight is

        s w_k (-Im(c1 conj c2)) / (2π |c1 + c2 (u_k + u)|^2)

    (`smooth_on_own_span`), exact, with no subtraction: Re(f / (τ - z)) computed from the
    positions loses ~1e-16 |τ - z|^-1 to rounding next to a node (1.8e-6 where the exact
    weight is 0, beside a corner; 4.5e-9 on a smooth cage), and is 0/0 at the node itself,
    where this is the curvature limit.
    """
    c1, c2, scale = same_span_coefficients(curve)
    target_span, target_u = span_parameters(curve, t)
    node_span, node_u = span_parameters(curve, panels.t)
    by_target = np.argsort(target_span, kind="stable")
    by_node = np.argsort(node_span, kind="stable")
    target_starts = np.searchsorted(target_span[by_target], np.arange(curve.n + 1))
    node_starts = np.searchsorted(node_span[by_node], np.arange(curve.n + 1))
    for j in np.flatnonzero((np.diff(target_starts) > 0) & (np.diff(node_starts) > 0)):
        rows = by_target[target_starts[j] : target_starts[j + 1]]
        columns = by_node[node_starts[j] : node_starts[j + 1]]
        u = target_u[rows, None] + node_u[columns]
        real = c1[j].real + c2[j].real * u
        imaginary = c1[j].imag + c2[j].imag * u
        values = (scale[j] * panels.weights[columns]) / (real * real + imaginary * imaginary)
        if rows[-1] - rows[0] + 1 == rows.size and columns[-1] - columns[0] + 1 == columns.size:
            matrix[rows[0] : rows[-1] + 1, columns[0] : columns[-1] + 1] = values  # in order: a block
        else:
            matrix[rows[:, None], columns] = values


def adaptive_weights(
    curve: ClosedBSpline,
    panels: Panels,
    targets: np.ndarray,
    panel: np.ndarray,
    power: int = 1,
    on_curve: float = ON_CURVE,
) -> tuple[np.ndarray, np.ndarray]:
    """Weights of ∫_panel φ(τ) / (τ - z)^power dτ on the panel's nodes, for target/panel pairs.

    Parameters
    ----------
    targets : complex ndarray of shape (K,)
        z of each pair.
    panel : int ndarray of shape (K,)
        The panel of each pair.
    power : int
        1 for the Cauchy integral, 2 for its z-derivative.
    on_curve : float
        Targets this close to the curve (a fraction of its diameter) are taken to be on
        it.  The solve's targets are nodes, on the curve by construction, and pass 0:
        next to a sharp corner the nodes of the two sides come within 1e-10 of the
        diameter of each other, and their interaction must be integrated, not dropped.

    Returns
    -------
    complex ndarray of shape (K, ORDER)
        ``weights @ φ[panel nodes]`` is the integral of φ's interpolant.
    bool ndarray of shape (K,)
        The target is on the curve: within `on_curve` diameters of its panel.
    """
    touch = on_curve * curve.diameter
    pieces = np.ascontiguousarray(curve.piecewise_polynomial().coefficients, dtype=np.float64)
    count = len(targets)
    found = compiled_integrals.run_compiled(
        compiled_integrals.adaptive_pairs,
        lambda: (
            pieces,
            np.ascontiguousarray(panels.bounds, dtype=np.float64),
            (np.ascontiguousarray(targets, dtype=np.complex128), np.ascontiguousarray(panel, dtype=np.int64)),
            int(power),
            float(touch),
            (np.zeros((count, ORDER), dtype=np.complex128), np.zeros(count, dtype=np.bool_)),
        ),
        items=count,
    )
    if found is not None:
        return found[-1]
    # `compiled_integrals.near_weights`, pair by pair there, for all pairs at once here.
    bounds = panels.bounds[panel]
    span = np.floor(bounds[:, 0] + 1e-12)
    half = 0.5 * (bounds[:, 1] - bounds[:, 0])
    middle = 0.5 * (bounds[:, 0] + bounds[:, 1]) - span
    c = pieces[span.astype(np.int64) % curve.n]  # (K, 3, 2)
    c0, c1, c2 = (c[:, i, 0] + 1j * c[:, i, 1] for i in range(3))
    quadratic = c2 * half * half
    linear = (c1 + 2.0 * middle * c2) * half
    constant = c0 + middle * (c1 + middle * c2) - targets
    straight = quadratic == 0.0
    root = np.sqrt(linear * linear - 4.0 * quadratic * constant)
    root = np.where((linear.conj() * root).real < 0.0, -root, root)
    q = -0.5 * (linear + root)
    with np.errstate(divide="ignore", invalid="ignore"):  # the unused branches of np.where
        near = np.where(straight, -constant / linear, constant / q)
        far = np.where(straight, 2.0 * PLAIN_ELLIPSE, q / np.where(straight, 1.0, quadratic))
    s = np.stack([np.clip(near.real, -1.0, 1.0), -np.ones(near.size), np.ones(near.size)], axis=1)
    gap = np.abs(constant[:, None] + s * (linear[:, None] + s * quadratic[:, None])).min(axis=1)
    touching = gap < touch
    weights = np.zeros((targets.size, ORDER), dtype=np.complex128)
    away = np.flatnonzero(~touching)  # the touching pairs get no weights
    near, far, straight = near[away], far[away], straight[away]
    moments_near = _legendre_moments(near)
    moments_far = np.where(straight[:, None], 0.0, _legendre_moments(far))
    if power == 1:
        totals = moments_near + moments_far
    else:  # by parts: see `core.boundary_integrals.compiled_integrals.near_weights`
        linear, quadratic, constant = linear[away], quadratic[away], constant[away]
        with np.errstate(divide="ignore", invalid="ignore"):
            factor = np.where(straight, 1.0 / linear, 1.0 / (quadratic * (near - far)))
        totals = factor[:, None] * ((moments_near - moments_far) @ _DERIVATIVE_MOMENTS.T)
        high, low = 1.0 / (constant + linear + quadratic), 1.0 / (constant - linear + quadratic)
        totals -= high[:, None] - low[:, None] * (-1.0) ** np.arange(ORDER)
    weights[away] = totals @ LEGENDRE_WEIGHTS.T
    return weights, touching


#: D (ORDER, ORDER): P_k' = Σ_l D[k, l] P_l, (2l + 1) for l = k - 1, k - 3, ... (J_k = Σ_l D[k, l] I_l)
_DERIVATIVE_MOMENTS = np.array(
    [[(2 * l + 1.0) if l < k and (k - l) % 2 else 0.0 for l in range(ORDER)] for k in range(ORDER)]
)


def _legendre_moments(r: np.ndarray) -> np.ndarray:
    """I_k(r) = ∫_{-1}^{1} P_k(s) / (s - r) ds, shape (K, ORDER), for complex r (K,) off [-1, 1]:
    `core.boundary_integrals.compiled_integrals.legendre_moments` for many r at once."""
    root = np.sqrt(r - 1.0) * np.sqrt(r + 1.0)
    rho = np.maximum(np.abs(r + root), np.abs(r - root))
    out = np.empty((r.size, ORDER), dtype=np.complex128)
    plain = rho >= PLAIN_ELLIPSE
    out[plain] = (WEIGHTS / (NODES - r[plain, None])) @ LEGENDRE_VALUES
    rest = ~plain
    first = np.log((r[rest] - 1.0) / (r[rest] + 1.0))
    forward = rho[rest] <= FORWARD_ELLIPSE
    x, start = r[rest][forward], first[forward]
    values = [start, x * start + 2.0]
    for k in range(1, ORDER - 1):
        values.append(((2 * k + 1) * x * values[k] - k * values[k - 1]) / (k + 1))
    out[np.flatnonzero(rest)[forward]] = np.stack(values, axis=1)
    backward = np.flatnonzero(rest)[~forward]
    if backward.size:
        x = r[backward]
        top = ORDER + int(np.ceil(BACKWARD_DIGITS / (2.0 * np.log10(rho[backward].min()))))
        after, current = np.zeros(x.size, dtype=np.complex128), np.full(x.size, 1e-100 + 0j)
        found = np.empty((x.size, ORDER), dtype=np.complex128)
        for k in range(top, 0, -1):
            after, current = current, ((2 * k + 1) * x * current - (k + 1) * after) / k
            if k - 1 < ORDER:
                found[:, k - 1] = current
        out[backward] = found * (first[~forward] / found[:, 0])[:, None]
    return out


def layer_factors(curve: ClosedBSpline, panels: Panels) -> np.ndarray:
    """s w_k τ'_k / 2πi at the nodes, complex (P * ORDER,): node k's Cauchy weight is factor_k / (τ_k - z).

    s = +1 for a counter-clockwise curve, -1 otherwise, so that C[1] = 1 inside.
    """
    orientation = 1.0 if curve.area > 0 else -1.0
    return orientation * panels.weights * panels.dz / (2j * np.pi)


@dataclass(frozen=True)
class Levels:
    """Panels of one curve at several resolutions, each with its densities.

    Attributes
    ----------
    panels : tuple of Panels
        Coarsest first; every panel of level k + 1 lies inside one panel of level k.
    parents : tuple of int ndarray
        parents[k] (P_{k+1},): the level-k panel of each level-(k + 1) panel.
    densities : tuple of ndarray
        densities[k] (P_k * ORDER, m): what the level's Gauss–Legendre rule integrates.
        On the finest level the densities themselves; on coarser ones their weight-
        corrected restrictions (`restricted`), which integrate what is smooth on their
        panels as the finest rule does.
    safety : tuple
        safety[k] None, or float ndarray (P_k,): how many panel lengths away a target must
        be for the level's plain rule (`level_safety` gives the default).  A restricted
        density's rule integrates the kernel's degree-15 interpolant, with an error that
        falls as ρ^-16, not ρ^-32: where that density is rough (a sharp corner's), its
        panels need `CORNER_SAFE`.
    """

    panels: tuple
    parents: tuple
    densities: tuple
    #: Per level, None or each panel's `SAFE` (P_k,) for the far field (`level_safety`).
    safety: tuple = ()
    #: What `_panel_tree` built from these levels, once, and (key "density") the one array
    #: whose views are the densities, if `bisected` made them: the tree takes it as it is.
    #: It stays writeable for numba, and writing to it changes the (read-only) densities.
    compiled: dict = field(default_factory=dict, compare=False, repr=False)


def bisected(
    curve: ClosedBSpline, levels: Levels, count: int = BISECTIONS, corrected: tuple | None = None
) -> Levels:
    """`levels` and `count` more levels below the finest, each bisecting its panels in t.

    A level's densities are the interpolants of the finest densities at its nodes: on
    each piece the same polynomial that `adaptive_weights` integrates.  Shared by every
    target, the halves' plain rule takes the pairs a panel length or so from the curve in
    batched products; only the pairs nearer than half a quarter-panel still need the
    near-field rule (at 100,000 mesh vertices of the bench's blob, 4x fewer, when that rule
    bisected panels and took a third of the evaluation's time).

    `corrected`, (node indices (K,), values (K, m)), replaces the first new level's densities
    at those nodes (better values than the interpolant: `core.boundary_integrals.poisson`'s Nyström
    interpolation); the levels below it interpolate the corrected ones.
    """
    panels, parents = list(levels.panels), list(levels.parents)
    halves = interpolation_matrix(np.concatenate([0.5 * NODES - 0.5, 0.5 * NODES + 0.5]))  # (2q, q)
    # Every level's densities in one array, coarsest first, each level a view of it: the panel
    # tree of `layer_rows` takes it as it is (concatenating 1.5 MB of fresh memory took 0.8 ms).
    rows = [d.shape[0] for d in levels.densities] + [
        levels.densities[-1].shape[0] * 2 ** (k + 1) for k in range(count)
    ]
    starts = np.concatenate([[0], np.cumsum(rows)])
    combined = np.empty((starts[-1], levels.densities[-1].shape[1]), dtype=np.result_type(*levels.densities))
    densities = [combined[a:b] for a, b in zip(starts[:-1], starts[1:], strict=True)]
    for given, view in zip(levels.densities, densities, strict=False):
        view[:] = given
    for _ in range(count):
        finest, density, child = panels[-1], densities[len(panels) - 1], densities[len(panels)]
        low, high = finest.bounds[:, 0], finest.bounds[:, 1]
        middle = 0.5 * (low + high)
        bounds = np.stack([np.stack([low, middle], axis=1), np.stack([middle, high], axis=1)], axis=1)
        columns = density.shape[1]
        np.matmul(
            halves,
            density.reshape(finest.count, ORDER, columns),
            out=child.reshape(finest.count, 2 * ORDER, columns),
        )
        if corrected is not None:
            child[corrected[0]] = corrected[1]
            corrected = None
        panels.append(panels_on_intervals(curve, bounds.reshape(-1, 2)))
        parents.append(np.repeat(np.arange(finest.count), 2))
    for density in densities:
        density.setflags(write=False)  # the combined array stays writeable: numba types it so
    return Levels(tuple(panels), tuple(parents), tuple(densities), levels.safety, {"density": combined})


def level_safety(curve: ClosedBSpline, levels: Levels, k: int) -> np.ndarray:
    """Each panel's `SAFE` on level k of `levels`, float ndarray (P_k,): ``levels.safety[k]`` where
    given, else `span_safety` on the coarsest level and `SAFE` below it."""
    panels = levels.panels[k]
    given = levels.safety[k] if k < len(levels.safety) else None
    if given is not None:
        return np.asarray(given, dtype=np.float64)
    default = span_safety(curve, panels) if k == 0 else SAFE
    return np.broadcast_to(np.asarray(default, dtype=np.float64), (panels.count,))


def restricted(coarse: Panels, fine: Panels, parent: np.ndarray, density: np.ndarray) -> np.ndarray:
    """Q φ for fine densities φ (P_f * ORDER, m): the weight-corrected coarse ones, (P_c * ORDER, m).

    Q = W_c^-1 P^T W_f with P the interpolation of a coarse panel's nodes at the nodes of the
    fine panels inside it (`parent` (P_f,), in order), so that
    Σ_c w_c f(y_c) (Q φ)_c = Σ_f w_f (P f)(y_f) φ_f for any f: exactly the fine rule for f
    polynomial of degree < ORDER on the coarse panels.  Applied panel by panel, not as a matrix.
    """
    if np.any(np.diff(parent) < 0):
        raise ValueError("the fine panels must follow their coarse panels' order")
    widths = np.diff(coarse.bounds, axis=1)[:, 0]
    parent_node = np.repeat(parent, ORDER)
    local = 2.0 * (fine.t - coarse.bounds[parent_node, 0]) / widths[parent_node] - 1.0
    interpolation = interpolation_matrix(local).reshape(fine.count, ORDER, ORDER)  # fine node <- coarse
    weighted = (density * fine.weights[:, None]).reshape(fine.count, ORDER, -1)
    each = np.matmul(interpolation.transpose(0, 2, 1), weighted)  # (P_f, ORDER, m), to the parent's nodes
    starts = np.flatnonzero(np.concatenate([[True], np.diff(parent) != 0]))
    out = np.zeros((coarse.count, ORDER, density.shape[1]))
    out[parent[starts]] = np.add.reduceat(each, starts, axis=0)
    return out.reshape(coarse.size, -1) / coarse.weights[:, None]


def cauchy_integrals(
    curve: ClosedBSpline,
    levels: Levels,
    x: np.ndarray,
    *,
    imaginary: bool = False,
    out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """C[φ](x) for the columns φ of the densities of `levels` at points x (M, 2).

    The coarsest level is summed over every node, by two small products per block:
    Re(e / (τ - z)) = (Re(e conj τ) - Re(e conj z)) / |τ - z|^2 in coordinates
    centred on the nodes and scaled by the diameter (cancellation at most ~1e-16 /
    (distance / diameter)^2, relative), then its panels near a point are replaced by
    their children, level by level (`hierarchical_rows`), the finest level by the
    adaptive rule.  Returns the real parts (M, m) (in `out` if given), the imaginary parts
    (M, m) if `imaginary` (else None) and the on-curve flags (M,).
    """
    z = np.ascontiguousarray(x[:, 0] + 1j * x[:, 1])
    rows = _compiled_rows(curve, levels, z, 1, imaginary, out)
    if rows is not None:
        return rows[0], (rows[1] if imaginary else None), rows[2]
    panels, density = levels.panels[0], levels.densities[0]
    factors = layer_factors(curve, panels)
    centre = panels.z.mean()
    scale = 1.0 / curve.diameter
    tau = (panels.z - centre) * scale
    e = factors * scale  # e / (τ_s - z_s) equals factors / (τ - z)
    real_rows = np.stack([(e * tau.conj()).real, -e.real, -e.imag])
    imaginary_rows = np.stack([(e * tau.conj()).imag, -e.imag, e.real])
    denominator_rows = np.stack([np.abs(tau) ** 2, -2.0 * tau.real, -2.0 * tau.imag, np.ones(tau.size)])
    target, panel = near_pairs(panels, z, curve.diameter, level_safety(curve, levels, 0))
    real = np.empty((z.size, density.shape[1])) if out is None else out
    imag = np.empty_like(real) if imaginary else None
    starts = np.searchsorted(target, np.arange(0, z.size + BLOCK, BLOCK))
    for block, first in enumerate(range(0, z.size, BLOCK)):
        w = (z[first : first + BLOCK] - centre) * scale
        left = np.stack([np.ones(w.size), w.real, w.imag], axis=1)
        denominator = np.concatenate([left, (np.abs(w) ** 2)[:, None]], axis=1) @ denominator_rows
        pairs = slice(starts[block], starts[block + 1])
        rows = target[pairs, None] - first
        columns = panel[pairs, None] * ORDER + np.arange(ORDER)
        for rows_of, out in ((real_rows, real), (imaginary_rows, imag)):
            if out is None:
                continue
            part = left @ rows_of
            part /= denominator
            part[rows, columns] = 0.0
            out[first : first + BLOCK] = part @ density
    on_curve = np.zeros(z.size, dtype=bool)
    if imaginary:
        extra = np.zeros(real.shape, dtype=np.complex128)
        hierarchical_rows(curve, levels, z, target, panel, on_curve, extra)
        real += extra.real
        imag += extra.imag
    else:
        hierarchical_rows(curve, levels, z, target, panel, on_curve, real)
    return real, imag, on_curve


def _compiled_rows(
    curve: ClosedBSpline,
    levels: Levels,
    z: np.ndarray,
    power: int,
    imaginary: bool,
    out: np.ndarray | None = None,
):
    """`compiled_tree.layer_rows` at targets z (M,) where its machine code is at hand
    (`compiled_integrals.run_compiled`): (real (in `out` if given), imaginary, on-curve), else
    None."""

    def arguments():
        boxes = (z, compiled_tree.BOX)
        if not compiled_integrals.loaded(compiled_tree.target_boxes, *boxes):
            return None
        tree = _panel_tree(curve, levels)
        rows = np.empty((z.size, tree.density.shape[1])) if out is None else out
        rows[:] = 0.0
        found = rows, np.zeros((z.size if imaginary else 0, rows.shape[1])), np.zeros(z.size, dtype=np.bool_)
        return z, tree, power, imaginary, found, compiled_tree.target_boxes(*boxes)

    found = compiled_integrals.run_compiled(compiled_tree.layer_rows, arguments, z.size, items=z.size)
    return None if found is None else found[4]


def _panel_tree(curve: ClosedBSpline, levels: Levels) -> compiled_tree.PanelTree:
    """`levels` concatenated for `compiled_tree.layer_rows` (built once per `levels`, kept in
    ``levels.compiled``)."""
    tree = levels.compiled.get("tree")
    if tree is not None:
        return tree
    panels = levels.panels
    counts = np.array([p.count for p in panels])
    panel_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    safety = [level_safety(curve, levels, k) for k in range(len(panels))]
    lengths = np.concatenate([p.lengths for p in panels])
    close = np.maximum(np.concatenate(safety) * lengths, DIRECT * curve.diameter)
    children, child_start = [], [0]
    for k, parent in enumerate(levels.parents):
        if np.any(np.diff(parent) < 0):
            raise ValueError("a level's panels must follow their parents' order")
        sizes = np.bincount(parent, minlength=counts[k])
        children.append(panel_start[k + 1] + np.arange(parent.size))
        child_start.extend((child_start[-1] + np.cumsum(sizes)).tolist())
    child_start.extend([child_start[-1]] * (counts[-1]))  # the finest level has no children
    most = max([1] + [int(np.bincount(parent).max()) for parent in levels.parents])
    orientation = 1.0 if curve.area > 0 else -1.0
    tree = compiled_tree.PanelTree(
        node_z=np.concatenate([p.z for p in panels]),
        factors=np.concatenate([layer_factors(curve, p) for p in panels]),
        density=np.ascontiguousarray(
            levels.compiled["density"] if "density" in levels.compiled else np.concatenate(levels.densities),
            dtype=np.float64,
        ),
        centres=np.concatenate([p.centres for p in panels]),
        reach=np.concatenate([p.radii for p in panels]) + close,
        close_squared=close**2,
        panel_start=panel_start,
        children=np.concatenate(children).astype(np.int64) if children else np.zeros(0, dtype=np.int64),
        child_start=np.asarray(child_start, dtype=np.int64),
        bounds=np.ascontiguousarray(panels[-1].bounds, dtype=np.float64),
        coefficients=np.ascontiguousarray(curve.piecewise_polynomial().coefficients, dtype=np.float64),
        orientation=float(orientation),
        touch=float(ON_CURVE * curve.diameter),
        stack_size=int(panels[0].count + len(panels) * most),
    )
    levels.compiled["tree"] = tree
    return tree


def cauchy_derivatives(curve: ClosedBSpline, levels: Levels, x: np.ndarray) -> np.ndarray:
    """d/dz C[φ](x), complex (M, m), for the densities of `levels` at points x (M, 2)."""
    z = np.ascontiguousarray(x[:, 0] + 1j * x[:, 1])
    rows = _compiled_rows(curve, levels, z, 2, True)
    if rows is not None:
        return rows[0] + 1j * rows[1]
    panels, density = levels.panels[0], levels.densities[0]
    factors = layer_factors(curve, panels)
    target, panel = near_pairs(panels, z, curve.diameter, level_safety(curve, levels, 0))
    out = np.empty((z.size, density.shape[1]), dtype=np.complex128)
    starts = np.searchsorted(target, np.arange(0, z.size + BLOCK, BLOCK))
    for block, first in enumerate(range(0, z.size, BLOCK)):
        part = factors / (panels.z[None, :] - z[first : first + BLOCK, None]) ** 2
        pairs = slice(starts[block], starts[block + 1])
        part[target[pairs, None] - first, panel[pairs, None] * ORDER + np.arange(ORDER)] = 0.0
        out[first : first + BLOCK] = part @ density
    hierarchical_rows(curve, levels, z, target, panel, np.zeros(z.size, dtype=bool), out, power=2)
    return out


def hierarchical_rows(curve, levels: Levels, z, target, panel, on_curve, out, power: int = 1, touch=ON_CURVE):
    """Add to `out` what replaces (target, coarsest-level panel) pairs, level by level.

    Each pair's panel is replaced by its children on the next level: children far
    from the target (as `near_pairs` judges) take their plain Gauss–Legendre rule and
    that level's densities, near ones go down another level; on the finest level
    every child takes `adaptive_weights`.  `out` (M, m) is complex, or real to take
    real parts only; sets `on_curve` for targets the adaptive rule finds on the curve.
    """
    finest = len(levels.panels) - 1
    for k in range(1, finest + 1):
        if target.size == 0:
            return
        children = levels.panels[k]
        target, child = _children(levels.parents[k - 1], target, panel)
        safety = level_safety(curve, levels, k)
        target, panel = _add_plain(out, curve, children, levels.densities[k], z, target, child, power, safety)
        if k == finest:
            weights, touching = adaptive_weights(curve, children, z[target], panel, power, touch)
            on_curve[target[touching]] = True
            _add_weights(out, curve, children, levels.densities[k], target, panel, weights)


def _groups(panel: np.ndarray):
    """(panel, indices) of each run of equal panels, for pairs sorted by panel (none for no pairs)."""
    if panel.size == 0:
        return []
    bounds = np.flatnonzero(np.diff(panel)) + 1
    starts = np.concatenate([[0], bounds])
    stops = np.concatenate([bounds, [panel.size]])
    return [(int(panel[a]), slice(a, b)) for a, b in zip(starts, stops, strict=True)]


def _add_plain(out, curve, panels, density, z, target, panel, power, safety):
    """out[target] += the panel's plain rule @ density, for pairs far from their panel (`safety`
    (P,) panel lengths away, or `DIRECT` diameters).

    Returns the pairs (target, panel) that are near (as `near_pairs` judges), untouched.
    """
    order = np.argsort(panel, kind="stable")
    target, panel = target[order], panel[order]
    factors = layer_factors(curve, panels)
    close_range = np.maximum(safety * panels.lengths, DIRECT * curve.diameter) ** 2
    # Pairs farther from the panel's centre than its radius plus the close range are far for
    # sure: only the others need their distance to the nearest node.
    reach = panels.radii + np.sqrt(close_range)
    sure = np.abs(z[target] - panels.centres[panel]) >= reach[panel]
    near = np.zeros(target.size, dtype=bool)
    real_only = not np.iscomplexobj(out)
    for p, group in _groups(panel):
        nodes = slice(p * ORDER, (p + 1) * ORDER)
        rows = target[group]
        dx = panels.z[nodes].real - z[rows, None].real
        dy = panels.z[nodes].imag - z[rows, None].imag
        square = dx * dx + dy * dy
        if not sure[group].all():
            close = ~sure[group]
            close[close] = square[close].min(axis=1) < close_range[p]
            near[group] = close
            far = ~close
            rows, dx, dy, square = rows[far], dx[far], dy[far], square[far]
        f = factors[nodes]
        if real_only and power == 1:
            # Re(f / (τ - z)) in real arithmetic (numpy's complex division is several times slower).
            rule = (f.real * dx + f.imag * dy) / square
        else:
            rule = f / (dx + 1j * dy) ** power
        _add_rule(out, rows, p, rule, density)
    return target[near], panel[near]


def _add_weights(out, curve, panels, density, target, panel, weights) -> None:
    """out[target] += weights (K, ORDER) of each pair @ density on its panel, one product a panel."""
    order = np.argsort(panel, kind="stable")
    target, panel, weights = target[order], panel[order], weights[order]
    orientation = 1.0 if curve.area > 0 else -1.0
    weights = weights * (orientation / (2j * np.pi))
    if not np.iscomplexobj(out):
        weights = weights.real
    for p, group in _groups(panel):
        _add_rule(out, target[group], p, weights[group], density)


def _add_rule(out, rows, panel: int, rule, density) -> None:
    """out[rows] += rule (K, ORDER) @ density on `panel`'s nodes; `density` is an array, or an
    operator with an ``add`` method of that signature (`core.boundary_integrals.poisson.Expansion`)."""
    if hasattr(density, "add"):
        density.add(out, rows, panel, rule)
    else:
        out[rows] += rule @ density[panel * ORDER : (panel + 1) * ORDER]


def _children(parent: np.ndarray, target: np.ndarray, panel: np.ndarray):
    """(target, child panel) for every child (`parent` (P_child,)) of each pair's panel."""
    order = np.argsort(parent, kind="stable")
    first = np.searchsorted(parent[order], np.arange(parent.max() + 2))
    counts = np.diff(first)[panel]
    offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return np.repeat(target, counts), order[np.repeat(first[panel], counts) + offsets]
