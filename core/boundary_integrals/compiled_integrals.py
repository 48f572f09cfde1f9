"""The Cauchy integrals of `cauchy_integrals` as compiled loops: the near-field rule, rows over a panel tree.

`cauchy_integrals` evaluates C[φ](z) = (1 / 2πi) ∮ φ(τ) / (τ - z) dτ with numpy, in batches
of (target, panel) pairs, and `core.boundary_integrals.poisson` assembles its density solve with numpy; their
cost is the bookkeeping of those batches (sorting, grouping, one small product per panel).
The same arithmetic as loops: here are

- `adaptive_pairs`, the near-field rule of `cauchy_integrals.adaptive_weights` (`near_weights`:
  exact product integration of the density's interpolant over a quadratic span), for a
  list of pairs;
- `compiled_tree.layer_rows`, Re C[φ](z) for many targets: the coarsest level's panels by their plain
  rule, near panels replaced by their children level by level, the finest level's near
  panels by the near-field rule, exactly the decisions of `cauchy_integrals.cauchy_integrals`
  (the same `near` test at every level, so the two agree to rounding), the walk shared
  by boxes of nearby targets and their far panels' rules one BLAS product a box;
- `layer_matrix_rows`, the Nyström matrix rows of `core.boundary_integrals.poisson.layer_matrix`;
- `interpolation_rows`, the Lagrange basis of a panel's nodes at many parameters;
- `panel_geometry` and `panel_gaps`, the nodes, weights and circles of a set of panels and
  their distances across the domain (`panels`), and `close_pairs`, the target-panel pairs
  that need the near-field rule (`core.boundary_integrals.cauchy_integrals.near_pairs`);
- `knot_blocks`, the density solve's compressed knot blocks (their matrices, their
  adaptive entries as `core.boundary_integrals.poisson._block_near_pairs` finds them, their LUs), and
  `coarse_system`, its coarse matrix;
- `galerkin_matrix` and `rows_product`, the two-grid solve's coarse matrix and residual
  products (`core.boundary_integrals.two_grid`).

The loops over many items take their share of them (`core.library_threads.in_shares`) and run
on every thread.

They are compiled by numba, which the package's build does at install
(`core.newton.compilation.compile_all`); their callers take them through `run_compiled`, only
where their machine code is in memory or in numba's cache (`loaded`), and their numpy path
otherwise, so that the
default kernel never waits for a compiler; and it reads the cache only once the work
repays the reading. Arrays are copied into slices by loops, not by slice assignment, here and
in `compiled_tree`: numba compiles a shape check with a formatted message into every slice
assignment from an array (~0.3-0.7 CPU-s of compiling each, ~4 for the first of a process).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numba.core.compiler_lock import global_compiler_lock

from core.boundary_integrals.dense_solve import solve
from core.boundary_integrals.gauss_legendre import LEGENDRE_VALUES, LEGENDRE_WEIGHTS, NODES, ORDER, WEIGHTS
from core.library_threads import in_shares, thread_count

#: How `cauchy_integrals` chooses: "auto" (compiled where loaded, `loaded`), "numpy", or "compiled"
#: (compile on first use if need be: tests and `core.newton.compilation.compile_all`).
mode = "auto"


#: Points evaluated in this process before numba's cache is first read (`worth_trying`).
#: The first read costs ~0.2 s (numba and LLVM starting up; later reads ~6 ms), which the
#: compiled evaluation repays at ~3 µs a point: a one-shot `warp` of a 4K image (a few ten
#: thousand points) measured 1.7 s with numpy and 2.0 s reading the cache first.
LOAD_AFTER_POINTS = 60_000


_points = 0


_read = False


#: Dispatchers whose cache entry failed to load (a damaged file): not tried again.
_unreadable = set()


def allow_reading() -> None:
    """Let `worth_trying` say yes from now on, whatever the points so far
    (`core.boundary_integrals.poisson.load_compiled`)."""
    global _read
    _read = True


def worth_trying(dispatcher, points: int = 0) -> bool:
    """Whether `loaded` may say yes for `dispatcher`, before its arguments are built.

    `points` (the targets of this call) add up over the process: numba's disk cache is read
    once this process has read one before or has evaluated `LOAD_AFTER_POINTS` points.
    False for a dispatcher whose cache entry failed to load.  With `mode` "numpy" always
    False, with "compiled" always True.
    """
    global _points
    if mode != "auto":
        return mode == "compiled"
    _points += points
    if dispatcher in _unreadable:
        return False
    return bool(dispatcher.overloads) or _read or _points >= LOAD_AFTER_POINTS


def run_compiled(dispatcher, arguments, points: int = 0, items: int | None = None):
    """dispatcher(*arguments()) where its machine code is at hand (`worth_trying` for `points`,
    then `loaded`), else None, and the caller takes its numpy path: every function here returns
    something.  `arguments` builds the tuple, only once the call is worth trying, or returns None
    where something it needs is not at hand (then so does this).

    With `items`, the dispatcher is a loop over that many items taking its share (``first,
    shares``, `core.library_threads.in_shares`) and writing into outputs among its arguments: it
    runs on threads, and the arguments' tuple is returned."""
    if not worth_trying(dispatcher, points):
        return None
    values = arguments()
    if values is None:
        return None
    if items is None:
        return dispatcher(*values) if loaded(dispatcher, *values) else None
    if not loaded(dispatcher, *values, 0, 1):
        return None
    in_shares(dispatcher, items, *values)
    return values


def loaded(dispatcher, *args) -> bool:
    """Whether `dispatcher` has machine code for these arguments' types without compiling (ask
    `worth_trying` first).

    Its own compiled specialisations count; otherwise numba's disk cache is tried, and a hit
    is loaded into the dispatcher, as a call would.  A miss, or an entry that fails to load
    (a damaged file; then never tried again), returns False and compiles nothing.  With
    `mode` "numpy" always False, with "compiled" always True (the call compiles).
    """
    global _read
    if mode != "auto":
        return mode == "compiled"
    key = _argument_key(args)
    if key is not None and (dispatcher, key) in _present and dispatcher.overloads:
        return True
    signature = _signatures.get((dispatcher, key)) if key is not None else None
    if signature is None:
        signature = tuple(dispatcher.typeof_pyval(a) for a in args)
        if key is not None:
            _signatures[(dispatcher, key)] = signature
    if signature in dispatcher.overloads:
        if key is not None:
            _present.add((dispatcher, key))
        return True
    if dispatcher in _unreadable:
        return False
    with global_compiler_lock:
        try:
            result = dispatcher._cache.load_overload(signature, dispatcher.targetctx)
            if result is None:
                return False
            dispatcher.targetctx.insert_user_function(result.entry_point, result.fndesc, [result.library])
            dispatcher.add_overload(result)
        except Exception:  # noqa: BLE001 - a damaged cache file: numpy, and not again in this process
            _unreadable.add(dispatcher)
            return False
    _read = True
    return True


#: numba's signature of the arguments, by (dispatcher, `_argument_key`): typing them costs ~40 µs
#: a call, and a density solve asks ~50 times.
_signatures = {}


#: The (dispatcher, `_argument_key`) pairs found with machine code (trusted while the dispatcher
#: has any): asking its overloads hashes numba's types, ~20 µs a call (0.3 ms of the bench blob's
#: solve).
_present = set()


def _argument_key(value):
    """What numba's type of `value` depends on, cheaply, for the kinds of argument core passes:
    an array's dtype, dimensions, layout and writeability, a tuple's items (named tuples with
    their class), a float's or bool's Python type, an int's (if it fits int64).  None for
    anything else (numba types it then, uncached)."""
    if isinstance(value, np.ndarray):
        f = value.flags
        return (value.dtype, value.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    if isinstance(value, tuple):
        items = tuple(map(_argument_key, value))
        return None if None in items else (type(value), *items)
    if isinstance(value, (bool, float)) or (isinstance(value, int) and -(2**63) <= value < 2**63):
        return type(value)
    return None


#: The forward recurrence's coefficients (2k + 1) / (k + 1) and k / (k + 1), (ORDER, 2).
_FORWARD = np.array([[(2 * k + 1) / (k + 1), k / (k + 1)] for k in range(ORDER)])


#: `legendre_moments` runs the recurrence forwards for roots whose Bernstein ellipse parameter
#: ρ is at most this (its error grows as ρ^k from the first moment's rounding), backwards from
#: a higher degree above it, and takes the panel's Gauss–Legendre rule from `PLAIN_ELLIPSE` on:
#: that rule integrates the interpolant over s - r with an error ~ρ^-16 (the best degree-16
#: approximation of 1 / (s - r)), 1e-16 at 10.
FORWARD_ELLIPSE = 1.5


PLAIN_ELLIPSE = 10.0


#: Miller's backward recurrence starts this many decimal digits of decay (ρ^-2k) above the last
#: moment wanted.
BACKWARD_DIGITS = 18.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def ellipse(r):
    """ρ > 1 of the Bernstein ellipse through r, |r ± sqrt(r^2 - 1)|, the larger."""
    root = np.sqrt(r - 1.0) * np.sqrt(r + 1.0)
    return max(abs(r + root), abs(r - root))


@njit(cache=True, nogil=True, error_model="numpy")
def legendre_moments(r, rho, out):
    """out[k] = ∫_{-1}^{1} P_k(s) / (s - r) ds, k < ORDER, for complex r off [-1, 1] (`ellipse`'s ρ).

    They obey the Legendre recurrence (k + 1) I_{k+1} = (2k + 1) r I_k - k I_{k-1} (k >= 1),
    with I_0 = log((r - 1) / (r + 1)) (principal branch: its cut is [-1, 1]) and
    I_1 = r I_0 + 2; I_k = -2 Q_k(r), Q_k the Legendre functions of the second kind, decay
    as ρ^-k, ρ = |r + sqrt(r^2 - 1)| > 1, so forwards the recurrence is stable only near the
    interval and backwards (Miller's algorithm, from a degree where ρ^-2k is below rounding,
    scaled to I_0) elsewhere."""
    if rho >= PLAIN_ELLIPSE:
        for k in range(ORDER):
            out[k] = 0.0
        for j in range(ORDER):
            d = NODES[j] - r
            scale = WEIGHTS[j] / (d.real * d.real + d.imag * d.imag)
            inverse = complex(d.real * scale, -d.imag * scale)  # w_j / (s_j - r)
            for k in range(ORDER):
                out[k] += LEGENDRE_VALUES[j, k] * inverse
        return
    first = np.log((r - 1.0) / (r + 1.0))
    if rho <= FORWARD_ELLIPSE:
        out[0] = first
        out[1] = r * first + 2.0
        for k in range(1, ORDER - 1):
            out[k + 1] = _FORWARD[k, 0] * (r * out[k]) - _FORWARD[k, 1] * out[k - 1]
        return
    top = ORDER + int(math.ceil(BACKWARD_DIGITS / (2.0 * math.log10(rho))))
    after, current = 0j, 1e-100 + 0j  # I_{k+1}, I_k up to a common factor
    for k in range(top, 0, -1):
        inverse = 1.0 / k
        before = ((2 * k + 1) * inverse) * (r * current) - ((k + 1) * inverse) * after
        after, current = current, before
        if k - 1 < ORDER:
            out[k - 1] = current
    scale = first / out[0]
    for k in range(ORDER):
        out[k] *= scale


@njit(cache=True, nogil=True, error_model="numpy")
def near_weights(coefficients, a, b, z, power, touch, weights, moments):
    """Weights (ORDER,) complex of ∫ φ(τ) / (τ - z)^power dτ on the panel [a, b] of the span of
    `coefficients` (3, 2) (p(u) = c0 + c1 u + c2 u^2, u the parameter within the span), exact
    for the interpolant of φ on the panel's nodes; returns True if z is within `touch` of the
    panel.  `moments` is scratch, complex (2, ORDER).

    The span is a quadratic: with u = m + h s on the panel, p - z = A (s - r1)(s - r2), so
    p' du / (p - z) = ds / (s - r1) + ds / (s - r2) exactly, and the integral of φ's
    interpolant Σ_k a_k P_k(s) against it is Σ_k a_k (I_k(r1) + I_k(r2)) with the moments
    I_k of `legendre_moments` (a product integration rule in the manner of Helsing and
    Ojala, 2008, but exact: no polynomial stands in for the curve).  For power 2, by parts,
    ∫ φ p' / (p - z)^2 du = -[φ / (p - z)]_{-1}^{1} + ∫ φ'(s) / (p - z) ds, with
    1 / (p - z) = (1 / (s - r1) - 1 / (s - r2)) / (A (r1 - r2)) and P_k' = Σ (2l + 1) P_l over
    l = k - 1, k - 3, ...  One root for a straight span (A = 0).
    """
    span = math.floor(a + 1e-12)
    half = 0.5 * (b - a)
    middle = 0.5 * (a + b) - span
    c0 = complex(coefficients[0, 0], coefficients[0, 1])
    c1 = complex(coefficients[1, 0], coefficients[1, 1])
    c2 = complex(coefficients[2, 0], coefficients[2, 1])
    quadratic = c2 * half * half  # p(m + h s) - z = quadratic s^2 + linear s + constant
    linear = (c1 + 2.0 * middle * c2) * half
    constant = c0 + middle * (c1 + middle * c2) - z
    if quadratic == 0.0:
        roots = 1
        near, far = -constant / linear, 0j
    else:
        root = np.sqrt(linear * linear - 4.0 * quadratic * constant)
        if (linear.conjugate() * root).real < 0.0:
            root = -root
        q = -0.5 * (linear + root)  # the larger root q / quadratic, the smaller constant / q
        roots = 2
        near, far = constant / q, q / quadratic
    # On the curve: the panel's point nearest the near root's real part, or an end, within touch.
    gap = np.inf
    for s in (min(max(near.real, -1.0), 1.0), -1.0, 1.0):
        gap = min(gap, abs(constant + s * (linear + s * quadratic)))
    if gap < touch:  # the caller takes the curve's own value there: no weights
        for j in range(ORDER):
            weights[j] = 0.0
        return True
    totals = moments[1]
    for k in range(ORDER):
        totals[k] = 0.0
    for j in range(ORDER):
        weights[j] = 0.0
    for which in range(roots):
        r = near if which == 0 else far
        rho = ellipse(r)
        if power == 1 and rho >= PLAIN_ELLIPSE:  # Σ_k L[j, k] (the rule's I_k) = w_j / (s_j - r)
            for j in range(ORDER):
                d = NODES[j] - r
                scale = WEIGHTS[j] / (d.real * d.real + d.imag * d.imag)
                weights[j] += complex(d.real * scale, -d.imag * scale)
            continue
        legendre_moments(r, rho, moments[0])
        if power == 1:
            for k in range(ORDER):
                totals[k] += moments[0, k]
        else:  # ∫ P_k' / (s - r) = J_k, J_{k+1} = J_{k-1} + (2k + 1) I_k, J_0 = 0, J_1 = I_0
            factor = (
                1.0 / linear if roots == 1 else (1.0 if which == 0 else -1.0) / (quadratic * (near - far))
            )
            before, current = 0j, 0j
            for k in range(ORDER):
                totals[k] += factor * current
                before, current = current, before + (2 * k + 1) * moments[0, k]
    if power == 2:
        high, low = 1.0 / (constant + linear + quadratic), 1.0 / (constant - linear + quadratic)
        for k in range(ORDER):
            totals[k] -= high - (low if k % 2 == 0 else -low)
    for j in range(ORDER):
        real, imaginary = 0.0, 0.0
        for k in range(ORDER):
            real += LEGENDRE_WEIGHTS[j, k] * totals[k].real
            imaginary += LEGENDRE_WEIGHTS[j, k] * totals[k].imag
        weights[j] += complex(real, imaginary)
    return False


@njit(cache=True, nogil=True, error_model="numpy")
def interpolation_rows(u, barycentric):
    """`panels.interpolation_matrix` for local parameters u (M,): the Lagrange basis of the
    panel nodes at each, (M, ORDER), by the second barycentric formula with the nodes' weights
    `barycentric` (ORDER,); a row at a node is that node's unit row.  No branch out of the
    terms' loop, and one division a row (to a rounding of numpy's quotients; the bench blob's
    1,840 fine nodes: 73 -> 43 µs)."""
    out = np.empty((u.shape[0], ORDER))
    for i in range(u.shape[0]):
        node, total = -1, 0.0
        for j in range(ORDER):
            difference = u[i] - NODES[j]
            if difference == 0.0:
                node = j
            out[i, j] = barycentric[j] / difference  # inf at a node: the row is replaced below
            total += out[i, j]
        if node >= 0:
            out[i] = 0.0
            out[i, node] = 1.0
        else:
            inverse = 1.0 / total
            for j in range(ORDER):
                out[i, j] *= inverse
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def panel_geometry(coefficients, bounds):
    """`panels.panels_on_intervals`'s arrays for the panels `bounds` (P, 2) of the curve whose spans are
    `coefficients` (n, 3, 2) (`ClosedBSpline.piecewise_polynomial`), each panel on the span of
    its start: t, weights (P ORDER,), z, dz, d2z complex (P ORDER,), centres complex (P,),
    radii and lengths (P,).  One pass, where numpy took ~20 array operations a call (a solve
    makes seven sets of panels: 0.66 ms in numpy for the bench blob's, 0.12 ms here)."""
    count, n = bounds.shape[0], coefficients.shape[0]
    t, weights = np.empty(count * ORDER), np.empty(count * ORDER)
    z = np.empty(count * ORDER, dtype=np.complex128)
    dz, d2z = np.empty_like(z), np.empty_like(z)
    centres = np.empty(count, dtype=np.complex128)
    radii, lengths = np.empty(count), np.empty(count)
    for p in range(count):
        a, b = bounds[p, 0], bounds[p, 1]
        half, middle = 0.5 * (b - a), 0.5 * (b + a)
        start = math.floor(a + 1e-12)
        span = int(start) % n
        c0x, c0y = coefficients[span, 0, 0], coefficients[span, 0, 1]
        c1x, c1y = coefficients[span, 1, 0], coefficients[span, 1, 1]
        c2x, c2y = coefficients[span, 2, 0], coefficients[span, 2, 1]
        low, high = a - start, b - start
        low_x, low_y = c0x + low * (c1x + low * c2x), c0y + low * (c1y + low * c2y)
        high_x, high_y = c0x + high * (c1x + high * c2x), c0y + high * (c1y + high * c2y)
        centre_x, centre_y = 0.5 * (low_x + high_x), 0.5 * (low_y + high_y)
        to_low = (low_x - centre_x) ** 2 + (low_y - centre_y) ** 2
        farthest = max(to_low, (high_x - centre_x) ** 2 + (high_y - centre_y) ** 2)
        length = 0.0
        for j in range(ORDER):  # real arithmetic: complex abs is a hypot, ~4x a square root
            k = p * ORDER + j
            t[k] = middle + half * NODES[j]
            u = t[k] - start
            x, y = c0x + u * (c1x + u * c2x), c0y + u * (c1y + u * c2y)
            dx, dy = c1x + 2.0 * u * c2x, c1y + 2.0 * u * c2y
            z[k], dz[k], d2z[k] = complex(x, y), complex(dx, dy), complex(2.0 * c2x, 2.0 * c2y)
            weights[k] = half * WEIGHTS[j]
            length += math.sqrt(dx * dx + dy * dy) * weights[k]
            farthest = max(farthest, (x - centre_x) ** 2 + (y - centre_y) ** 2)
        centres[p], radii[p], lengths[p] = complex(centre_x, centre_y), math.sqrt(farthest), length
    return t, weights, z, dz, d2z, centres, radii, lengths


@njit(cache=True, nogil=True, error_model="numpy")
def panel_gaps(circles, middle, total, corner_at, reach, turn):
    """`panels.gaps` from its arrays: for each panel p, the least distance from a node of p to
    a node of another panel o within reach[p] and beyond p (farther along the curve than twice
    p's length, or than `turn` times the distance with no corner (corner_at, sorted arc
    positions) between them), float (P,), inf for none.  Panels whose circles are farther apart
    than reach[p] are skipped, as there.  `circles` = (the nodes' z, the panels' centres, radii
    and lengths)."""
    node_z, centres, radii, lengths = circles
    count = centres.shape[0]
    nearest = np.full(count, np.inf)
    for p in range(count):
        for o in range(count):
            if abs(centres[p] - centres[o]) > radii[p] + reach[p] + radii[o]:
                continue
            low, high = min(middle[o], middle[p]), max(middle[o], middle[p])
            wraps = high - low > 0.5 * total  # the shorter arc runs through position 0
            along = (total - (high - low) if wraps else high - low) - 0.5 * (lengths[o] + lengths[p])
            between = np.searchsorted(corner_at, high, side="left") - np.searchsorted(
                corner_at, low, side="right"
            )
            through_corner = between < corner_at.shape[0] if wraps else between > 0
            far_along = along > 2.0 * lengths[p]
            if not far_along and (through_corner or along <= 0.0):
                continue  # no node of o is beyond p
            limit = reach[p] if far_along else min(reach[p], along / turn)
            limit = (min(limit, nearest[p]) * (1.0 + 1e-12)) ** 2  # squares first, loosely
            for i in range(p * ORDER, (p + 1) * ORDER):
                for j in range(o * ORDER, (o + 1) * ORDER):
                    dx, dy = node_z[i].real - node_z[j].real, node_z[i].imag - node_z[j].imag
                    if dx * dx + dy * dy > limit:
                        continue
                    distance = abs(node_z[i] - node_z[j])  # the rule itself, on numpy's distance
                    beyond = far_along or along > turn * distance
                    if beyond and distance <= reach[p] and distance < nearest[p]:
                        nearest[p] = distance
    return nearest


@njit(cache=True, nogil=True, error_model="numpy")
def close_pairs(targets, node_z, centres, reach, close_squared):
    """`cauchy_integrals.near_pairs` by comparing every target (M,) with every panel: (target, panel)
    int (E,) each, sorted by target then panel, for the pairs whose target is within `reach` of
    the panel's centre and closer than its close range (close_squared (P,)) to one of its nodes."""
    count, panels = targets.shape[0], centres.shape[0]
    close = np.zeros((count, panels), dtype=np.bool_)
    found = 0
    for m in range(count):
        z = targets[m]
        for p in range(panels):
            gap = z - centres[p]
            if gap.real * gap.real + gap.imag * gap.imag > reach[p] * reach[p]:
                continue
            for q in range(p * ORDER, (p + 1) * ORDER):
                d = node_z[q] - z
                if d.real * d.real + d.imag * d.imag < close_squared[p]:
                    close[m, p] = True
                    found += 1
                    break
    target, panel = np.empty(found, dtype=np.int64), np.empty(found, dtype=np.int64)
    e = 0
    for m in range(count):
        for p in range(panels):
            if close[m, p]:
                target[e], panel[e] = m, p
                e += 1
    return target, panel


class LayerNodes(NamedTuple):
    """The Nyström nodes of the double layer (`layer_matrix_rows`, `coarse_system`, `knot_blocks`)."""

    z: np.ndarray  #: complex (N,): the nodes
    factors: np.ndarray  #: complex (N,): `cauchy_integrals.layer_factors`
    span: np.ndarray  #: int (N,): each node's span
    u: np.ndarray  #: (N,): its parameter within the span
    weights: np.ndarray  #: (N,): quadrature weights in t
    spans: np.ndarray  #: (n, 5): each span's c1, c2 (real, imaginary) and kernel scale


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _layer_entry(x, y, own, u, k, nodes):
    """The Re C-weight of node k of `nodes` (`LayerNodes`, or `KnotBlocks` by the same names) at a
    target (x, y) on the curve, on span `own` at parameter u within it: the same-span closed
    form, else the plain rule (`layer_matrix_rows`)."""
    node_z, factors, node_span, node_u = nodes.z, nodes.factors, nodes.span, nodes.u
    weights, spans = nodes.weights, nodes.spans
    if node_span[k] == own:
        s = u + node_u[k]
        real = spans[own, 0] + spans[own, 2] * s
        imaginary = spans[own, 1] + spans[own, 3] * s
        return (spans[own, 4] * weights[k]) / (real * real + imaginary * imaginary)
    dx = node_z[k].real - x
    dy = node_z[k].imag - y
    return (factors[k].real * dx + factors[k].imag * dy) / (dx * dx + dy * dy)


@njit(cache=True, nogil=True, error_model="numpy")
def layer_matrix_rows(targets, target_span, target_u, nodes, out, first, shares):
    """The double layer's Re C-weights of `poisson.layer_matrix` into out (M, N), rows first,
    first + shares, ... (`core.library_threads.in_shares`), for targets z
    complex (M,) on the curve and nodes τ complex (N,) with their quadrature weights (N,).

    A pair on different spans takes the plain rule, Re(factor_k / (τ_k - z_m)); a pair on one
    span j (spans int (M,) and (N,), parameters u within it (M,) and (N,)) the kernel's closed
    form s w_k / |c1 + c2 (u_k + u_m)|^2 of `cauchy_integrals.fill_same_span`, with `spans` (n, 5)
    holding each span's c1 (real, imaginary), c2 (real, imaginary) and its scale s: the
    fields of `nodes` (`LayerNodes`).
    """
    node_z = nodes.z
    for m in range(first, targets.shape[0], shares):
        x, y, own, u = targets[m].real, targets[m].imag, target_span[m], target_u[m]
        for k in range(node_z.shape[0]):
            out[m, k] = _layer_entry(x, y, own, u, k, nodes)


class SpanNodes(NamedTuple):
    """Each span's nodes (`coarse_system`): span j's are nodes[start[j]:start[j + 1]]."""

    start: np.ndarray  #: int (n + 1,)
    nodes: np.ndarray  #: int (N,): node indices, span by span


class KnotBlocks(NamedTuple):
    """The fine panels of `poisson`'s knot blocks and what `knot_blocks` needs of them: the fields
    of `LayerNodes` (the fine nodes, N_f of them), then the panels' and the spans'."""

    z: np.ndarray  #: complex (N_f,): the fine nodes
    factors: np.ndarray  #: complex (N_f,): `cauchy_integrals.layer_factors`
    span: np.ndarray  #: int (N_f,): each node's span
    u: np.ndarray  #: (N_f,): its parameter within the span
    weights: np.ndarray  #: (N_f,): quadrature weights in t
    spans: np.ndarray  #: (n, 5): each span's c1, c2 (real, imaginary) and kernel scale
    node_t: np.ndarray  #: (N_f,): the nodes' parameters
    bounds: np.ndarray  #: (P_f, 2): the panels' parameter intervals
    close_squared: np.ndarray  #: (P_f,): squared distance within which a node needs the adaptive rule
    cross: np.ndarray  #: (n,): Im(c1 conj c2), 0 for a straight span (`cauchy_integrals.smooth_on_own_span`)
    coefficients: np.ndarray  #: (n, 3, 2): the spans (`ClosedBSpline.piecewise_polynomial`)
    orientation: float  #: +1 counter-clockwise, -1 clockwise


class BlockSolve(NamedTuple):
    """The knot blocks `knot_blocks` solves (B blocks, R rows in all) and where it writes."""

    panels: np.ndarray  #: int: the blocks' fine panels, block b's panels[start[b]:start[b + 1]]
    start: np.ndarray  #: int (B + 1,)
    interpolation: np.ndarray  #: (R, ORDER): P's rows
    offsets: np.ndarray  #: int (R,): each row's first column in P
    row_weights: np.ndarray  #: (R,)
    column_weights: np.ndarray  #: (B, W)
    sequence: np.ndarray  #: int (B,): the order the blocks are taken in (`balanced_sequence`)
    solution: np.ndarray  #: (R, W), written: X = (I + 2 K*)^-1 P
    reduced: np.ndarray  #: (B, W, W), written: Q X


@njit(cache=True, nogil=True, error_model="numpy")
def knot_blocks(fine, work, first, shares):
    """The compressed knot blocks of `core.boundary_integrals.poisson`, a block a thread at a time.

    Block b's fine panels are panels[start[b]:start[b + 1]] (of `fine`, a `KnotBlocks`; `work`
    a `BlockSolve`), its rows those panels' nodes in order (R rows in all).  Its matrix I + 2 K*_b takes
    `layer_matrix_rows`'s entries, but where a node is within its close range of another of
    the block's panels and the kernel is not smooth there (`_smooth_on_own_span`) the adaptive
    rule's (`near_weights`), as `poisson._block_near_pairs` finds them.  P, (R, W), has
    in row r the interpolation row (R, ORDER) at columns offsets[r]..offsets[r] + ORDER.
    Writes X = (I + 2 K*)^-1 P into solution (R, W) and Q X into reduced (B, W, W), with
    Q = W_c^-1 P^T W_f (row_weights (R,), column_weights (B, W)).  The blocks are taken in the
    order `sequence` (int (B,)), share `first` of `shares` (`core.library_threads.in_shares`)
    taking the first-th of its equal runs, so `balanced_sequence` puts as much work in each run
    (the bench blob's 12 blocks: 3.2 -> 2.95 ms on two threads).
    """
    nodes = fine  # a `LayerNodes` by its first fields' names
    panels, start, interpolation, offsets = work.panels, work.start, work.interpolation, work.offsets
    row_weights, column_weights, sequence = work.row_weights, work.column_weights, work.sequence
    solution, reduced = work.solution, work.reduced
    node_z, node_span, node_u = nodes.z, nodes.span, nodes.u
    width = column_weights.shape[1]
    blocks = start.shape[0] - 1
    run = -(-blocks // shares)
    for position in range(first * run, min(blocks, (first + 1) * run)):
        b = sequence[position]
        row, count = start[b] * ORDER, (start[b + 1] - start[b]) * ORDER
        prolongation = np.zeros((count, width))
        for i in range(count):
            for j in range(ORDER):
                prolongation[i, offsets[row + i] + j] = interpolation[row + i, j]
        matrix = np.empty((count, count))
        for i in range(count):
            m = panels[start[b] + i // ORDER] * ORDER + i % ORDER
            x, y, own, u = node_z[m].real, node_z[m].imag, node_span[m], node_u[m]
            for j in range(count):
                k = panels[start[b] + j // ORDER] * ORDER + j % ORDER
                matrix[i, j] = _layer_entry(x, y, own, u, k, nodes)
        _adaptive_entries(fine, panels[start[b] : start[b + 1]], matrix)
        for i in range(count):
            for j in range(count):
                matrix[i, j] *= 2.0
            matrix[i, i] += 1.0
        block = solve(matrix, prolongation)  # np.linalg.solve's LAPACK routine, cheaper to compile
        for i in range(count):
            for c in range(width):
                solution[row + i, c] = block[i, c]
        for i in range(count):
            for c in range(width):
                prolongation[i, c] *= row_weights[row + i] / column_weights[b, c]
        product = np.dot(prolongation.T.copy(), block)
        for i in range(width):
            for c in range(width):
                reduced[b, i, c] = product[i, c]


def balanced_sequence(costs: np.ndarray) -> np.ndarray:
    """An order of the items of `costs` (B,) whose equal runs, one a thread (`knot_blocks`), cost
    about the same, int (B,): the costliest first, each to the run with the least cost that still
    has room."""
    threads = thread_count(costs.size)
    size = -(-costs.size // max(1, threads))
    runs, loads = [[] for _ in range(max(1, threads))], np.zeros(max(1, threads))
    for item in np.argsort(-costs, kind="stable"):
        open_runs = [r for r in range(len(runs)) if len(runs[r]) < size]
        run = min(open_runs, key=lambda r: loads[r])
        runs[run].append(item)
        loads[run] += costs[item]
    return np.array([item for run in runs for item in run], dtype=np.int64)


@njit(cache=True, nogil=True, error_model="numpy")
def _adaptive_entries(fine, panels, matrix):
    """Set the entries of a knot block's matrix (its panels `panels` of `fine`) that need the
    adaptive rule: a node within `close_squared` of another panel's node, unless the kernel is
    smooth there (`_smooth_on_own_span`); Re of the rule's weights, oriented, over 2πi."""
    n = fine.coefficients.shape[0]
    # An int64 variable, not the constant 1: numba would compile `near_weights` once more for
    # the literal (its other callers pass a variable).
    power = np.int64(1)
    moments = np.empty((2, ORDER), dtype=np.complex128)
    weights = np.empty(ORDER, dtype=np.complex128)
    for a in range(panels.shape[0]):
        for i in range(ORDER):
            m = panels[a] * ORDER + i
            z = fine.z[m]
            for c in range(panels.shape[0]):
                p = panels[c]
                if c == a:
                    continue
                near = False
                for q in range(p * ORDER, (p + 1) * ORDER):
                    d = fine.z[q] - z
                    if d.real * d.real + d.imag * d.imag < fine.close_squared[p]:
                        near = True
                        break
                if not near or _smooth_on_own_span(fine, fine.node_t[m], p):
                    continue
                span = int(math.floor(fine.bounds[p, 0] + 1e-12)) % n
                near_weights(
                    fine.coefficients[span],
                    fine.bounds[p, 0],
                    fine.bounds[p, 1],
                    z,
                    power,
                    0.0,
                    weights,
                    moments,
                )
                for j in range(ORDER):
                    matrix[a * ORDER + i, c * ORDER + j] = (weights[j] * fine.orientation / (2j * np.pi)).real


@njit(cache=True, nogil=True, error_model="numpy")
def _smooth_on_own_span(fine, t, p):
    """`cauchy_integrals.smooth_on_own_span` for a node at parameter t and panel p of `fine`."""
    span = math.floor(fine.bounds[p, 0] + 1e-12)
    if math.floor(t + 1e-12) != span:
        return False
    s = int(span) % fine.coefficients.shape[0]
    if fine.cross[s] == 0.0:
        return True
    c1 = complex(fine.coefficients[s, 1, 0], fine.coefficients[s, 1, 1])
    c2 = complex(fine.coefficients[s, 2, 0], fine.coefficients[s, 2, 1])
    pole = -c1 / c2 - (t - span)
    low, high = fine.bounds[p, 0] - span, fine.bounds[p, 1] - span
    return abs(pole - min(max(pole.real, low), high)) >= high - low


#: Rows of `coarse_system` a thread fills at a time, then multiplies by the knot blocks' R.
SYSTEM_ROWS = 32


@njit(cache=True, nogil=True, error_model="numpy")
def coarse_system(nodes, blocks, near_start, near_panel, span_nodes, out, first, shares):
    """2 K°_c R of `poisson`'s coarse equation into out (N, N): `layer_matrix_rows`'s entries
    at the coarse nodes (arguments as there, targets the nodes themselves) times 2, with 0 in
    the columns of a node's own knot block (`blocks` = (node_block (N,), -1 for none;
    block_columns (B, W), -1 padding; block_reduced (B, W, W))) and in the nodes of its near
    panels (near_panel[near_start[m]:near_start[m + 1]]), then each block's columns times its
    R (block_reduced), `SYSTEM_ROWS` rows at a time
    (no two blocks share a column), the runs of rows first, first + shares, ...
    (`core.library_threads.in_shares`).  A row takes the plain rule at every node, in a loop without a
    branch that the compiler vectorises, then the same-span closed form at the nodes of its own
    span (span_nodes, `SpanNodes`).  A 200-point cage's 6,400 nodes: 2.0-2.5 s
    -> 0.36 s, where each entry asked which rule it takes and the blocks' products gathered their
    columns over all rows (a loaded 2-core machine; the same matrix, bit for bit)."""
    node_span, node_u, weights, spans = nodes.span, nodes.u, nodes.weights, nodes.spans
    span_start, span_order = span_nodes.start, span_nodes.nodes
    node_block, block_columns, block_reduced = blocks
    count = nodes.z.shape[0]
    z_real, z_imaginary = nodes.z.real.copy(), nodes.z.imag.copy()
    f_real, f_imaginary = nodes.factors.real.copy(), nodes.factors.imag.copy()
    block_count, width = block_columns.shape
    used = np.zeros(block_count, dtype=np.int64)
    for b in range(block_count):
        while used[b] < width and block_columns[b, used[b]] >= 0:
            used[b] += 1
    for run in range(first, (count + SYSTEM_ROWS - 1) // SYSTEM_ROWS, shares):
        low, high = run * SYSTEM_ROWS, min(count, (run + 1) * SYSTEM_ROWS)
        for m in range(low, high):
            row = out[m]
            x, y, own, u = z_real[m], z_imaginary[m], node_span[m], node_u[m]
            for k in range(count):
                dx = z_real[k] - x
                dy = z_imaginary[k] - y
                row[k] = 2.0 * ((f_real[k] * dx + f_imaginary[k] * dy) / (dx * dx + dy * dy))
            for i in range(span_start[own], span_start[own + 1]):
                k = span_order[i]
                s = u + node_u[k]
                real = spans[own, 0] + spans[own, 2] * s
                imaginary = spans[own, 1] + spans[own, 3] * s
                row[k] = 2.0 * ((spans[own, 4] * weights[k]) / (real * real + imaginary * imaginary))
            b = node_block[m]
            if b >= 0:
                for c in range(used[b]):
                    row[block_columns[b, c]] = 0.0
            for e in range(near_start[m], near_start[m + 1]):
                for j in range(ORDER):
                    row[near_panel[e] * ORDER + j] = 0.0
        for b in range(block_count):
            gathered = np.empty((high - low, used[b]))
            for m in range(high - low):
                for i in range(used[b]):
                    gathered[m, i] = out[low + m, block_columns[b, i]]
            product = np.dot(gathered, np.ascontiguousarray(block_reduced[b, : used[b], : used[b]]))
            for m in range(high - low):
                for c in range(used[b]):
                    out[low + m, block_columns[b, c]] = product[m, c]


@njit(cache=True, nogil=True, error_model="numpy")
def rows_product(matrix, x, out, first, shares):
    """out = matrix @ x, (K, m) for matrix (K, L) and x (L, m), C-ordered: the first-th of
    `shares` equal runs of rows (`core.library_threads.in_shares`), a BLAS product
    (`two_grid`'s residuals: the bench blob's 560 x 560 times 13 columns took 0.32-0.37 ms in
    one BLAS call, 0.18-0.20 ms in two runs)."""
    rows = matrix.shape[0]
    step = max(1, -(-rows // shares))
    low, high = min(rows, first * step), min(rows, (first + 1) * step)
    if high > low:
        product = np.dot(matrix[low:high], x)
        for k in range(high - low):
            for c in range(x.shape[1]):
                out[low + k, c] = product[k, c]


@njit(cache=True, nogil=True, error_model="numpy")
def galerkin_matrix(matrix, restrict, prolong, out, first, shares):
    """Ρ A Π of `two_grid` into out (P c, P c): for A (P ORDER, P ORDER) on P panels, Ρ
    (c, ORDER) on each panel's rows, then Π (ORDER, c) on each panel's columns; the row panels
    first, first + shares, ... (`core.library_threads.in_shares`), two BLAS products each."""
    panels = matrix.shape[0] // ORDER
    coarse = restrict.shape[0]
    for i in range(first, panels, shares):
        restricted = np.dot(restrict, matrix[i * ORDER : (i + 1) * ORDER])  # (c, P ORDER)
        product = np.dot(restricted.reshape(coarse * panels, ORDER), prolong).reshape(coarse, panels * coarse)
        for r in range(coarse):
            for c in range(panels * coarse):
                out[i * coarse + r, c] = product[r, c]


@njit(cache=True, nogil=True, error_model="numpy")
def adaptive_pairs(coefficients, bounds, pairs, power, touch, out, first, shares):
    """`cauchy_integrals.adaptive_weights` for K pairs (targets complex (K,), panel int (K,))
    into out = (weights complex (K, ORDER), touching bool (K,)), the pairs first,
    first + shares, ... (`core.library_threads.in_shares`).

    coefficients (n, 3, 2) are the curve's spans (`ClosedBSpline.piecewise_polynomial`),
    bounds (P, 2) the panels' parameter intervals.
    """
    targets, panel = pairs
    weights, touching = out
    count = targets.shape[0]
    n = coefficients.shape[0]
    for k in range(first, count, shares):
        moments = np.empty((2, ORDER), dtype=np.complex128)
        p = panel[k]
        span = int(math.floor(bounds[p, 0] + 1e-12)) % n
        touching[k] = near_weights(
            coefficients[span], bounds[p, 0], bounds[p, 1], targets[k], power, touch, weights[k], moments
        )
