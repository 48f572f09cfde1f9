"""Transfinite harmonic coordinates: the domain's Poisson kernel by a boundary integral equation.

The paper's framework writes coordinates as G_i(x) = ∫ λ(x, t) N_i(t) dt (Eq. 2); the
kernel λ whose coordinates are exactly harmonic is the Poisson kernel of the domain
(the density of harmonic measure, Sec. 1.1 and Eq. 7 for the disk), which has no
closed form.  Instead of λ we compute the coordinates as double-layer potentials

    G_i(x) = ∫_Γ μ_i(y) K(x, y) ds_y,   K(x, y) = (y - x)·ν_y / (2π |y - x|²)
           = Re (1 / 2πi) ∮ μ_i(τ) / (τ - z) dτ      (counter-clockwise, z = x_1 + i x_2),

whose densities solve the second-kind equation (the interior limit of the layer)

    μ_i(x) + ∫_Γ (μ_i(y) - μ_i(x)) K(x, y) ds_y = N_i(t(x)),   x on Γ,

in the form with the density at x subtracted (Gauss's lemma ∫ K(z, y) ds_y = 1 for z
inside), so that constants are reproduced exactly at every corner and knot.  The
equation is discretised by Nyström on `core.boundary_integrals.panels` (graded towards knots and corners),
near-singular node-panel pairs by the adaptive rule of `cauchy_integrals`; one LU factorisation
per cage gives all n + 1 densities (the n basis functions and their sum).

Evaluation is a row of Cauchy weights per point (`cauchy_integrals`) times the densities, in
barycentric form:

    G_i(x) = Re C[μ_i](x) / Re C[Σ_j μ_j](x),

whose denominator is 1 up to the quadrature error, so that Σ_i G_i = 1 to rounding and
Σ_i G_i P_i = x to the quadrature error (both numerator and denominator carry it).
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.boundary_integrals import compiled_integrals, compiled_tree, two_grid
from core.boundary_integrals.cauchy_integrals import (
    CORNER_SAFE,
    DIRECT,
    SAFE,
    Levels,
    adaptive_weights,
    bisected,
    cauchy_derivatives,
    cauchy_integrals,
    fill_same_span,
    hierarchical_rows,
    layer_factors,
    near_pairs,
    restricted,
    same_span_coefficients,
    smooth_on_own_span,
    span_coefficients,
    span_parameters,
)
from core.boundary_integrals.gauss_legendre import NODES, ORDER
from core.boundary_integrals.panels import (
    REFINED_RATIO,
    Panels,
    coarse_panels_and_gaps,
    coarse_per_span,
    graded_panels,
    interpolation_matrix,
    panels_on_intervals,
    sharp_corners,
    span_panels,
)
from core.boundary_integrals.scratch_arrays import scratch
from core.curves.bspline import ClosedBSpline
from core.library_threads import one_blas_thread

#: Coarse boundary nodes at most (the dense solve's memory, 8 MAX_NODES^2 bytes, and time).
MAX_NODES = 10_000
#: Points per progress report.
CHUNK = 16_384
#: Points this close to the curve (fraction of the diameter) get the Lagrange limit.
ON_CURVE_DISTANCE = 1e-10
#: A point whose layer of the constant density, Re C[1], is outside [1 - ON_CURVE, 1 + ON_CURVE]
#: is on the curve (about 1/2 there) or outside it (0).
ON_CURVE = 0.25


@dataclass(frozen=True)
class Densities:
    """The double-layer densities of a cage's basis functions, compressed.

    Attributes
    ----------
    curve : ClosedBSpline
    levels : core.boundary_integrals.cauchy_integrals.Levels
        Spans, coarse panels (`core.boundary_integrals.panels.coarse_panels`) and fine panels graded
        towards the knots (`panels.graded_panels`), then `cauchy_integrals.bisected`
        halves of the fine panels; on the fine panels μ_1..μ_n and their sum, shape
        (P_f * ORDER, n + 1), on the halves their interpolants, on the coarser ones their
        weight-corrected restrictions (the coarse ones are R ρ̃ below).
    """

    curve: ClosedBSpline
    levels: Levels


#: The curves `densities` is solving for, by their points: `solved_densities`, cached by the points' bytes,
#: takes its curve from here rather than building (and checking) it again.
_solving: dict[bytes, ClosedBSpline] = {}
#: Every cage's densities still in memory (in `solved_densities`' cache or held elsewhere), by its points.
_held: weakref.WeakValueDictionary[bytes, Densities] = weakref.WeakValueDictionary()
#: The first combination `combined_levels` solved for alone, by the cage's points, for at most
#: `COMBINED_CAGES` cages (then it starts again).
_combined: dict[bytes, bytes] = {}
COMBINED_CAGES = 64
#: Control points from which a combination is solved alone: below, all the densities cost about as
#: much (CPU time, five-lobed circles, loaded: 16 points 0.025 s all, 0.031 s five combined; 80:
#: 0.30 s either way; 120: 0.65 s and 0.34 s; 200: 2.4 s and 0.8 s) and serve every later target.
COMBINED_FROM = 100


@one_blas_thread
def densities(curve: ClosedBSpline) -> Densities:
    """Solve the double-layer equation for every basis function of `curve` (cached per cage)."""
    key = curve.control_points.tobytes()
    _solving[key] = curve
    try:
        solution = _held[key] = solved_densities(key, curve.control_points.shape[0])
        return solution
    finally:
        _solving.pop(key, None)


def combined_levels(curve: ClosedBSpline, mix: np.ndarray) -> Levels:
    """The levels of `curve`'s densities combined, Σ_i μ_i M_ik for a mix M (n + 1, k) whose row n
    weighs the densities' sum: the layer is linear in its density, so their layers are the
    combinations' (`poisson_gradients` with weights).

    From the cage's densities where they are in memory; else, for a cage of `COMBINED_FROM` control
    points or more, its first combination of at most `two_grid.FEW_COLUMNS` columns is solved for
    those k right-hand sides 2 N M alone
    (`combined_densities`: a 200-point cage's 201 columns took 5.5 s, most of it in proportion to
    them or in the coarse LU that few columns do without).  A second combination of the same cage
    (another target of a certificate) solves all its densities, shared with the basis and any later one.
    """
    key, wanted = curve.control_points.tobytes(), np.ascontiguousarray(mix, dtype=np.float64)
    if len(_combined) > COMBINED_CAGES:
        _combined.clear()
    first = _combined.setdefault(key, wanted.tobytes())
    alone = curve.n >= COMBINED_FROM and wanted.shape[1] <= two_grid.FEW_COLUMNS
    if alone and key not in _held and first == wanted.tobytes():
        _solving[key] = curve
        try:
            return combined_densities(key, curve.n, first, wanted.shape[1]).levels
        finally:
            _solving.pop(key, None)
    levels = densities(curve).levels
    mixed = tuple(density @ wanted for density in levels.densities)
    return Levels(levels.panels, levels.parents, mixed, levels.safety)


@functools.lru_cache(maxsize=4)
def solved_densities(points: bytes, count: int) -> Densities:
    """The compressed Nyström solve (Helsing's RCIP, one level of compression, no recursion).

    The equation (I + K) μ = 2 N (K twice the double layer) on the fine panels is split
    into K*, the interactions within each knot's pair of coarse panels Γ*_j, and K°,
    the rest.  K° is smooth on the coarse panels, K° ≈ P K°_c Q with P the
    interpolation from coarse to fine nodes and Q = W_c^-1 P^T W_f, so that
    μ = (I + K*)^-1 P ρ̃ where ρ̃ solves the coarse equation

        (I + K°_c R) ρ̃ = 2 N_c,   R = Q (I + K*)^-1 P   (block diagonal, one block a knot).

    Near-singular pairs of K°_c (thin parts, the nodes next to a neighbour's panel)
    take the fine densities (I + K*)^-1 P ρ̃ with the adaptive rule, not R ρ̃.  The dense
    coarse equation is solved by `core.boundary_integrals.two_grid` (its LU where that does not contract).
    """
    return _solved(points, count, None)


@functools.lru_cache(maxsize=8)
def combined_densities(points: bytes, count: int, mix: bytes, columns: int) -> Densities:
    """`solved_densities` of the combinations Σ_i μ_i M_ik for a mix M (count + 1, columns) (its bytes),
    solved for their right-hand sides 2 N M alone (`combined_levels`)."""
    return _solved(points, count, np.frombuffer(mix).reshape(count + 1, columns))


def _solved(points: bytes, count: int, mix: np.ndarray | None) -> Densities:
    """`solved_densities` (`mix` None) or `combined_densities`."""
    curve = _solving.get(points)
    if curve is None:
        curve = ClosedBSpline(np.frombuffer(points).reshape(count, 2))
    # The coarse panels before any split are a lower bound: a cage far over the limit is refused
    # before its gaps are searched (quadratic in the panels: ~40 s for 1,000 control points).
    _refuse_beyond_the_limit(curve, curve.n * coarse_per_span(curve) * ORDER, "at least ")
    coarse, gap = coarse_panels_and_gaps(curve)
    _refuse_beyond_the_limit(curve, coarse.size)
    fine, parent, knot = graded_panels(curve, coarse)
    knot = widened_at_corners(curve, knot, coarse.lengths)
    width = ORDER * max(2, np.bincount(knot[knot >= 0]).max(initial=0))
    parent_node = np.repeat(parent, ORDER)
    widths = np.diff(coarse.bounds, axis=1)[:, 0]
    local = 2.0 * (fine.t - coarse.bounds[parent_node, 0]) / widths[parent_node] - 1.0
    interpolation = interpolation_matrix(local)  # fine node <- its coarse panel's nodes
    coarse_nodes = np.arange(coarse.size).reshape(-1, ORDER)
    # The fine densities from ρ̃, row by row: at most two coarse panels' nodes a row.
    expand = Expansion(np.zeros((fine.size, width)), np.zeros((fine.count, width), dtype=np.int64))
    expand.values[:, :ORDER] = interpolation
    expand.columns[:, :ORDER] = coarse_nodes[parent]
    blocks = _knot_blocks(curve, fine, coarse, knot, parent, interpolation, expand)
    group_of = np.where(knot >= 0, knot, -1 - np.arange(coarse.count))  # each free panel its own
    same = group_of[np.repeat(np.arange(coarse.count), ORDER)]
    target, panel = near_pairs(coarse, coarse.z, curve.diameter)
    # A free panel's own nodes, and same-span panels where the kernel is smooth: the plain rule.
    keep = (same[target] != group_of[panel]) & ~smooth_on_own_span(curve, coarse, coarse.t[target], panel)
    target, panel = target[keep], panel[keep]
    system = _coarse_system(curve, coarse, blocks, target, panel)
    if target.size:  # the near pairs' rows only (a dense copy of the system took 118 MB at 60 spans)
        near_rows, local = np.unique(target, return_inverse=True)
        near = np.zeros((near_rows.size, coarse.size))
        hierarchical_rows(
            curve, Levels((coarse, fine), (parent,), (None, expand)), coarse.z[near_rows], local, panel,
            np.zeros(near_rows.size, dtype=bool), near, touch=0.0,
        )  # fmt: skip
        system[near_rows] += 2.0 * near
    system[np.arange(coarse.size), np.arange(coarse.size)] += 1.0
    data = _data(curve, coarse.t, mix)
    transformed = two_grid.solve(system, data)
    del system
    mu = expand.apply(transformed)
    weighted = transformed.copy()  # R ρ̃
    for columns, block in blocks.values():
        weighted[columns] = block @ transformed[columns]
    spans = span_panels(curve)
    span_of = np.floor(coarse.bounds[:, 0] + 1e-12).astype(np.int64)
    span_density = restricted(spans, fine, span_of[parent], mu)
    # A corner's block carries restricted densities of its singular density: `CORNER_SAFE`.
    corner_block = np.isin(knot, sharp_corners(curve))
    safety = (None, np.where(corner_block, CORNER_SAFE, SAFE), None)
    levels = Levels((spans, coarse, fine), (span_of, parent), (span_density, weighted, mu), safety)
    refine = np.flatnonzero(fine.lengths > REFINED_RATIO * gap[parent])
    corrected = nystrom_halves(curve, fine, mu, refine, mix) if refine.size else None
    return Densities(curve, bisected(curve, levels, corrected=corrected))


def _refuse_beyond_the_limit(curve: ClosedBSpline, nodes: int, bound: str = "") -> None:
    """ValueError if `curve`'s solve needs `nodes` coarse boundary nodes, more than `MAX_NODES`."""
    if nodes > MAX_NODES:
        raise ValueError(
            f"the cage's {curve.n} control points need {bound}{nodes:,} boundary nodes with kernel "
            f"'poisson', more than its limit of {MAX_NODES:,} (a dense solve of "
            f"{8 * nodes**2 / 2**30:.1f} GiB); use kernel 'harmonic' (finite elements) for such cages"
        )


def _coarse_system(curve: ClosedBSpline, coarse: Panels, blocks: dict, target, panel) -> np.ndarray:
    """2 K°_c R (K, K) of the coarse equation (`solved_densities`) but for its near pairs: the plain rule
    at the coarse nodes, 0 within each knot's block (K*, in R) and at the near pairs (target
    nodes, panels (E,), sorted by target: the adaptive rule's, added by the caller), each
    block's columns times its R (`_knot_blocks`).  Compiled where at hand
    (`compiled_integrals.coarse_system`, into this thread's scratch array: `scratch_arrays`,
    overwritten by its next solve), else numpy.
    """

    def arguments():
        width = max(columns.size for columns, _ in blocks.values())
        block_columns = np.full((len(blocks), width), -1, dtype=np.int64)
        block_reduced = np.zeros((len(blocks), width, width))
        node_block = np.full(coarse.size, -1, dtype=np.int64)
        for b, (columns, reduced) in enumerate(blocks.values()):
            block_columns[b, : columns.size] = columns
            block_reduced[b, : columns.size, : columns.size] = reduced
            node_block[columns] = b
        c1, c2, scale = same_span_coefficients(curve)
        nodes = compiled_integrals.LayerNodes(
            coarse.z, layer_factors(curve, coarse), *span_parameters(curve, coarse.t), coarse.weights,
            np.ascontiguousarray(np.stack([c1.real, c1.imag, c2.real, c2.imag, scale], axis=1)),
        )  # fmt: skip
        span_order = np.argsort(nodes.span, kind="stable")
        span_start = np.searchsorted(nodes.span[span_order], np.arange(curve.n + 1)).astype(np.int64)
        return (
            nodes, (node_block, block_columns, block_reduced),
            np.searchsorted(target, np.arange(coarse.size + 1)).astype(np.int64), np.ascontiguousarray(panel),
            compiled_integrals.SpanNodes(span_start, span_order),
            scratch("coarse system", (coarse.size, coarse.size)),
        )  # fmt: skip

    runs = -(-coarse.size // compiled_integrals.SYSTEM_ROWS)
    found = blocks and compiled_integrals.run_compiled(
        compiled_integrals.coarse_system, arguments, items=runs
    )
    if found:  # no blocks ({}) or not at hand (None): numpy
        return found[5]
    system = layer_matrix(curve, coarse, coarse.z, coarse.t)
    system *= 2.0  # in place: a second dense matrix is fresh memory a solve (1.9 ms at 560 unknowns)
    for columns, _ in blocks.values():  # K*: within a knot's pair of panels, in R
        system[np.ix_(columns, columns)] = 0.0
    system[target[:, None], panel[:, None] * ORDER + np.arange(ORDER)] = 0.0
    for columns, block in blocks.values():  # K°_c R: R is the identity but on the knots' blocks
        system[:, columns] = system[:, columns] @ block
    return system


def _knot_blocks(curve, fine: Panels, coarse: Panels, knot, parent, interpolation, expand) -> dict:
    """The knots' compressed blocks: knot j -> (its coarse nodes (C,), R_j = Q (I + K*_j)^-1 P, (C, C)).

    Fills the rows of `expand` of the fine panels of each knot's pair of coarse panels with
    (I + K*_j)^-1 P (`solved_densities`); `knot` (P_c,) is each coarse panel's knot (-1 for none),
    `parent` (P_f,) each fine panel's coarse panel, `interpolation` (P_f ORDER, ORDER) each
    fine node's row of P on its coarse panel.  The blocks are solved together by the
    compiled `compiled_integrals.knot_blocks`, their adaptive entries too, where it is at
    hand (the bench blob's 12 blocks: 9 ms one at a time in numpy, 2.4 ms compiled on two
    threads), else by `_solved_blocks`.
    """
    coarse_nodes = np.arange(coarse.size).reshape(-1, ORDER)
    parent_node = np.repeat(parent, ORDER)
    block_of = knot[parent]  # the knot block of each fine panel, -1 for none
    knots = np.unique(knot[knot >= 0])
    width = expand.values.shape[1]
    # Each block's fine panels, in the order of their knots, and their nodes.
    members = np.flatnonzero(block_of >= 0)
    members = members[np.argsort(block_of[members], kind="stable")]
    rows = (members[:, None] * ORDER + np.arange(ORDER)).ravel()
    block_of_row = np.searchsorted(knots, block_of[rows // ORDER])
    start = np.concatenate([[0], np.cumsum(np.bincount(block_of_row, minlength=knots.size))])
    position = np.empty(fine.size, dtype=np.int64)  # a fine node's row in its block's matrix
    position[rows] = np.arange(rows.size) - start[block_of_row]
    # A knot's coarse panels in order (its group), and each one's rank in its group.
    grouped = np.flatnonzero(knot >= 0)
    grouped = grouped[np.argsort(knot[grouped], kind="stable")]
    group_start = np.concatenate(
        [[0], np.cumsum(np.bincount(np.searchsorted(knots, knot[grouped]), minlength=knots.size))]
    )
    rank = np.zeros(coarse.count, dtype=np.int64)
    rank[grouped] = np.arange(grouped.size) - np.repeat(group_start[:-1], np.diff(group_start))
    columns = [
        coarse_nodes[grouped[a:b]].ravel() for a, b in zip(group_start[:-1], group_start[1:], strict=True)
    ]
    # P's rows: each fine node's interpolation row, at its coarse panel's place in the group.
    interpolation_rows, offsets = interpolation[rows], rank[parent_node[rows]] * ORDER
    column_weights = np.ones((knots.size, width))
    for b, nodes in enumerate(columns):
        column_weights[b, : nodes.size] = coarse.weights[nodes]
    weighing = (interpolation_rows, offsets, fine.weights[rows], column_weights)
    solved = _compiled_blocks(curve, fine, members, start // ORDER, *weighing)
    if solved is None:
        prolongation = np.zeros((rows.size, width))
        prolongation[np.arange(rows.size)[:, None], offsets[:, None] + np.arange(ORDER)] = interpolation_rows
        restriction = prolongation * fine.weights[rows, None] / column_weights[block_of_row]
        entries = _correction_entries(_block_near_pairs(curve, fine, block_of), knots, position)
        solved = _solved_blocks(curve, fine, rows, start, *entries, prolongation, restriction)
    expand.values[rows] = solved[0]
    blocks = {}
    for b, j in enumerate(knots.tolist()):
        panels = members[start[b] // ORDER : start[b + 1] // ORDER]
        expand.columns[panels, : columns[b].size] = columns[b]
        blocks[j] = (columns[b], solved[1][b, : columns[b].size, : columns[b].size])
    return blocks


def _correction_entries(corrections: dict, knots: np.ndarray, position: np.ndarray):
    """`_block_near_pairs`'s entries as (row, column) in their block's matrix, int (E, 2), their
    values (E,), and each block's first entry, int (B + 1,), for the blocks of `knots` in order."""
    entries, values, counts = [np.zeros((0, 2), dtype=np.int64)], [np.zeros(0)], []
    for j in knots.tolist():
        target, source, value = corrections.get(
            j, (np.zeros(0, dtype=np.int64), np.zeros((0, ORDER), dtype=np.int64), np.zeros((0, ORDER)))
        )
        row = np.repeat(position[target], ORDER)
        entries.append(np.stack([row, position[source].ravel()], axis=1))
        values.append(value.ravel())
        counts.append(row.size)
    return (
        np.concatenate(entries),
        np.concatenate(values),
        np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
    )


def _compiled_blocks(curve, fine: Panels, panels, start, interpolation, offsets, weights, column_weights):
    """`compiled_integrals.knot_blocks` for the blocks of `_knot_blocks` (their fine panels
    panels[start[b]:start[b + 1]], P's rows given as interpolation (R, ORDER) at column offsets
    (R,), the rows' weights (R,) and each block's coarse weights (B, W)): (solution (R, W),
    reduced (B, W, W)), or None where its machine code is not at hand."""

    def arguments():
        c1, c2, scale = same_span_coefficients(curve)
        close_range = np.maximum(SAFE * fine.lengths, DIRECT * curve.diameter)
        node_span, node_u = span_parameters(curve, fine.t)
        blocks = compiled_integrals.KnotBlocks(
            z=fine.z, factors=layer_factors(curve, fine), span=node_span, u=node_u, weights=fine.weights,
            spans=np.ascontiguousarray(np.stack([c1.real, c1.imag, c2.real, c2.imag, scale], axis=1)),
            node_t=fine.t, bounds=np.ascontiguousarray(fine.bounds),
            close_squared=close_range**2, cross=span_coefficients(curve)[2],
            coefficients=np.ascontiguousarray(curve.piecewise_polynomial().coefficients, dtype=np.float64),
            orientation=1.0 if curve.area > 0 else -1.0,
        )  # fmt: skip
        nodes = np.diff(start).astype(np.float64) * ORDER  # an LU costs nodes^3
        sequence = compiled_integrals.balanced_sequence(nodes**3)
        width = column_weights.shape[1]
        written = np.zeros((interpolation.shape[0], width)), np.zeros((start.size - 1, width, width))
        solve = (panels, start, interpolation, offsets, weights, column_weights, sequence, *written)
        return blocks, compiled_integrals.BlockSolve(*solve)

    found = compiled_integrals.run_compiled(compiled_integrals.knot_blocks, arguments, items=start.size - 1)
    return None if found is None else (found[1].solution, found[1].reduced)


def _solved_blocks(curve, fine, rows, start, entries, values, entry_start, prolongation, restriction):
    """`compiled_integrals.knot_blocks`'s (solution (R, W), reduced (B, W, W)) in numpy, block by
    block, from the adaptive rule's entries (row, column) (E, 2) of each block's matrix and
    their values (E,), block b's from entry_start[b]."""
    solution = np.zeros_like(prolongation)
    reduced = np.zeros((start.size - 1, prolongation.shape[1], prolongation.shape[1]))
    for b in range(start.size - 1):
        mine = slice(start[b], start[b + 1])
        panels = np.unique(rows[mine] // ORDER)
        near_knot = _panels_of(curve, fine, panels)
        matrix = layer_matrix(curve, near_knot, near_knot.z, near_knot.t)
        own = slice(entry_start[b], entry_start[b + 1])
        matrix[entries[own, 0], entries[own, 1]] = values[own]
        matrix *= 2.0
        matrix[np.arange(matrix.shape[0]), np.arange(matrix.shape[0])] += 1.0
        solution[mine] = two_grid.solve_in_place(matrix, prolongation[mine])
        reduced[b] = restriction[mine].T @ solution[mine]
    return solution, reduced


def _data(curve: ClosedBSpline, t: np.ndarray, mix: np.ndarray | None = None) -> np.ndarray:
    """The right-hand sides 2 N_i(t) and their sum, shape (K, n + 1), or their combinations by a
    mix (n + 1, k), shape (K, k)."""
    basis = curve.basis_matrix(t)
    data = 2.0 * np.concatenate([basis, basis.sum(axis=1, keepdims=True)], axis=1)
    return data if mix is None else np.ascontiguousarray(data @ mix)


def nystrom_halves(curve: ClosedBSpline, fine: Panels, mu: np.ndarray, refine: np.ndarray, mix=None):
    """The densities at the nodes of the halves of the fine panels `refine` (K,), by Nyström
    interpolation: (node indices of `cauchy_integrals.bisected`'s first level, values (2K ORDER, n + 1),
    or (2K ORDER, k) for densities combined by a mix (n + 1, k), `mu` (P_f ORDER, k) then theirs).

    The equation holds at every point x of the curve, not only at the nodes, so

        μ(x) = 2 N(x) - 2 ∫_Γ μ(y) K(x, y) ds_y,

    with the integral by the fine panels' rule: plain where the kernel is smooth (far, or on
    x's own span, `smooth_on_own_span`, by its closed form), adaptive across knots.  Its error
    is the solve's, ~ρ^-32, where the halves' interpolant of μ has ~ρ^-16: a panel beside a
    narrow gap (0.19 long, 0.15 from the F polygon's middle arm) has its density's interpolant
    off by 5e-10 between nodes, which G carries to points 1e-4 of the diameter from the curve,
    while at the nodes the solve agrees with a finer one to 4e-14.

    μ solves the compressed equation, not this one: at the panel's own nodes the formula
    differs from μ by the fine equation's residual (2.3e-13 beside gaps, up to 2.5e-8 on a
    knot's graded panels).  That residual, interpolated, is taken off, so that the halves
    agree with μ at its nodes and only the variation between them is the formula's.  Panels
    where the integral meets the curve keep the interpolant: a near-cusp span, and a panel whose
    own span turns so tightly that its kernel is not smooth there (`smooth_on_own_span`, beside a
    spike's tip), where the adaptive rule at the panel's own points gives a one-sided limit of the
    layer, not the equation's value on the curve: off by half the density (beside a starfish arm
    pinched to 6.5 px the halves' densities were off by 0.2, G · P - x by pixels near the curve).
    """
    count = refine.size
    low, high = fine.bounds[refine, 0], fine.bounds[refine, 1]
    middle = 0.5 * (low + high)
    bounds = np.stack([np.stack([low, middle], 1), np.stack([middle, high], 1)], 1).reshape(-1, 2)
    halves = panels_on_intervals(curve, bounds)
    own = (refine[:, None] * ORDER + np.arange(ORDER)).ravel()  # the panels' own nodes
    z = np.concatenate([halves.z, fine.z[own]])
    t = np.concatenate([halves.t, fine.t[own]])
    matrix = layer_matrix(curve, fine, z, t)
    target, panel = near_pairs(fine, z, curve.diameter)
    target, panel, values, touching = _adaptive_entries(curve, fine, z, t, target, panel)
    owner = np.concatenate([np.repeat(refine, 2 * ORDER), np.repeat(refine, ORDER)])  # each z's panel
    touching |= panel == owner[target]
    matrix[target[:, None], panel[:, None] * ORDER + np.arange(ORDER)] = values
    formula = _data(curve, t, mix) - 2.0 * (matrix @ mu)
    split = 2 * count * ORDER
    residual = (mu[own] - formula[split:]).reshape(count, ORDER, -1)
    to_halves = interpolation_matrix(np.concatenate([0.5 * NODES - 0.5, 0.5 * NODES + 0.5]))
    values = formula[:split] + np.matmul(to_halves, residual).reshape(split, -1)
    hit = target[touching]  # panels whose integral met the curve, by their halves or own nodes
    met = np.unique(np.where(hit < split, hit // (2 * ORDER), (hit - split) // ORDER))
    keep = ~np.isin(np.repeat(np.arange(count), 2 * ORDER), met)
    nodes = ((2 * refine[:, None] + np.arange(2)).ravel()[:, None] * ORDER + np.arange(ORDER)).ravel()
    return nodes[keep], values[keep]


def widened_at_corners(curve: ClosedBSpline, knot: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """`knot` (P_c,) with each sharp corner's pair of coarse panels widened on each side by the
    free panels next to it, until they are as long as the pair's panel on that side
    (`lengths` (P_c,), arc lengths).

    RCIP compresses K° ≈ P K°_c Q, which needs K° smooth on the coarse panels of Γ*; at a
    sharp corner the density is singular, and the panels next to the corner's pair see it
    at distance zero.  Helsing's Γ* is two panels on each side of the corner for this
    reason: taking them into K* (one more panel on each side) brought random polygons
    with sharp corners from 1e-8..2e-7 of the diameter in linear precision to 1e-10.  His
    panels are of one size; here a panel split for a thin part next to the pair can be a
    quarter of the pair's, and then the first panel beyond is within a quarter of the pair's
    length of it, where neither side's coarse interpolation holds (random corner cage 23 with
    `panels.THIN_RATIO` 1.5: 2.5e-6 of the diameter): so the block takes the pair's length.
    """
    corner = sharp_corners(curve)
    out = knot.copy()
    count = knot.size
    for j in corner:
        for c in np.flatnonzero(knot == j):
            for step in (-1, 1):
                neighbour = (c + step) % count
                if knot[neighbour] == j:
                    continue  # the pair's other panel
                widened = 0.0
                while knot[neighbour] < 0 and out[neighbour] < 0 and widened < lengths[c]:
                    out[neighbour] = j
                    widened += lengths[neighbour]
                    neighbour = (neighbour + step) % count
    return out


@dataclass(frozen=True)
class Expansion:
    """A matrix of shape (P_f * ORDER, P_c * ORDER) with at most 2 ORDER entries a row, in the
    same columns for every node of a fine panel: the fine densities from the coarse unknowns.

    Attributes
    ----------
    values : ndarray of shape (P_f * ORDER, 2 ORDER)
    columns : int ndarray of shape (P_f, 2 ORDER)
        The coarse nodes of each fine panel's rows (padding columns hold zeros).
    """

    values: np.ndarray
    columns: np.ndarray

    def apply(self, coarse: np.ndarray) -> np.ndarray:
        """This matrix times `coarse` (P_c * ORDER, m): shape (P_f * ORDER, m)."""
        count, width = self.columns.shape
        rows = self.values.reshape(count, ORDER, width)  # one (ORDER, width) block a fine panel
        return np.matmul(rows, coarse[self.columns]).reshape(count * ORDER, coarse.shape[1])

    def add(self, out: np.ndarray, rows: np.ndarray, panel: int, rule: np.ndarray) -> None:
        """out[rows] += rule (K, ORDER) @ (this matrix's rows of fine panel `panel`)."""
        values = self.values[panel * ORDER : (panel + 1) * ORDER]
        np.add.at(out, (rows[:, None], self.columns[panel][None, :]), rule.real @ values)


def _block_near_pairs(curve: ClosedBSpline, fine: Panels, block_of: np.ndarray) -> dict:
    """The adaptive rule's entries of the knot blocks' matrices, for all blocks in one pass, on the
    numpy path (`_solved_blocks`; the compiled `compiled_integrals.knot_blocks` finds the same
    pairs itself, `_adaptive_entries` there: a change here belongs there too).

    Pairs of a fine node and a fine panel of the same block (`block_of` (P_f,), -1 outside
    any), near (as `near_pairs` judges: a panel node within `SAFE` of the panel's length, or
    `DIRECT` diameters), not the node's own panel and not on its span where the kernel is
    smooth (`smooth_on_own_span`): knot -> (target nodes (K,), their panels' nodes (K, ORDER),
    the Re C-weights (K, ORDER)), node indices of `fine`.  A block's nodes are tested against
    its panels directly (a block is a few hundred nodes; a search tree over all of them took
    twice as long).
    """
    close_range = np.maximum(SAFE * fine.lengths, DIRECT * curve.diameter)
    nodes = fine.z.reshape(-1, ORDER)
    order = np.argsort(block_of, kind="stable")
    starts = np.searchsorted(block_of[order], np.arange(block_of.max(initial=-1) + 2))
    targets, panels = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    for j in range(starts.size - 1):
        members = order[starts[j] : starts[j + 1]]
        node = (members[:, None] * ORDER + np.arange(ORDER)).ravel()
        difference = fine.z[node][:, None, None] - nodes[members][None]  # (nodes, panels, ORDER)
        square = difference.real**2 + difference.imag**2
        near = (square.min(axis=2) < close_range[members] ** 2) & (node[:, None] // ORDER != members)
        t, p = np.nonzero(near)
        targets.append(node[t])
        panels.append(members[p])
    target, panel = np.concatenate(targets), np.concatenate(panels)
    target, panel, values, _ = _adaptive_entries(curve, fine, fine.z, fine.t, target, panel)
    sources = panel[:, None] * ORDER + np.arange(ORDER)
    block = block_of[panel]
    return {int(j): (target[block == j], sources[block == j], values[block == j]) for j in np.unique(block)}


def _adaptive_entries(curve: ClosedBSpline, panels: Panels, z, t, target, panel):
    """The near pairs (target index into z and t (M,), a panel of `panels`) that need the
    adaptive rule, all but those on the target's span where the kernel is smooth
    (`smooth_on_own_span`), and their double layer's Re C-weights (K, ORDER) by that rule
    (`cauchy_integrals.adaptive_weights`) at the targets z on the curve at parameters t, and its
    on-curve flags (K,): (target, panel, weights, flags)."""
    adaptive = ~smooth_on_own_span(curve, panels, t[target], panel)
    target, panel = target[adaptive], panel[adaptive]
    weights, touching = adaptive_weights(curve, panels, z[target], panel, on_curve=0.0)
    orientation = 1.0 if curve.area > 0 else -1.0
    return target, panel, (orientation * weights / (2j * np.pi)).real, touching


def _panels_of(curve: ClosedBSpline, panels: Panels, indices: np.ndarray) -> Panels:
    """The panels `indices` of `panels` as a Panels of their own (their arrays sliced, not recomputed)."""
    nodes = (indices[:, None] * ORDER + np.arange(ORDER)).ravel()
    return Panels(
        panels.bounds[indices], panels.t[nodes], panels.z[nodes], panels.dz[nodes], panels.d2z[nodes],
        panels.weights[nodes], panels.centres[indices], panels.radii[indices], panels.lengths[indices],
    )  # fmt: skip


def layer_matrix(curve: ClosedBSpline, panels: Panels, z: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Re C-weights of every node of `panels` by the plain rule at targets z (M,) on the curve at
    parameters t (M,), shape (M, P * ORDER).

    Pairs on one span take the kernel's closed form (`cauchy_integrals.fill_same_span`), which at a
    node itself is the limit s Im(τ''/τ') w / 4π (the double layer's kernel at y = x, the
    curvature over 4π).  The caller replaces the pairs that need the adaptive rule
    (`_block_near_pairs`).
    """
    factors = layer_factors(curve, panels)

    def arguments():
        c1, c2, scale = same_span_coefficients(curve)
        spans = np.ascontiguousarray(np.stack([c1.real, c1.imag, c2.real, c2.imag, scale], axis=1))
        nodes = compiled_integrals.LayerNodes(
            panels.z, factors, *span_parameters(curve, panels.t), panels.weights, spans
        )
        out = np.empty((z.size, panels.size))
        return (np.ascontiguousarray(z, dtype=np.complex128), *span_parameters(curve, t), nodes, out)

    found = compiled_integrals.run_compiled(compiled_integrals.layer_matrix_rows, arguments, items=z.size)
    if found is not None:
        return found[-1]
    matrix = np.empty((z.size, panels.size))
    for first in range(0, z.size, 1024):  # real arithmetic, in blocks of rows: memory of one matrix
        dx = panels.z.real[None, :] - z[first : first + 1024, None].real
        dy = panels.z.imag[None, :] - z[first : first + 1024, None].imag
        with np.errstate(divide="ignore", invalid="ignore"):
            matrix[first : first + 1024] = (factors.real * dx + factors.imag * dy) / (dx * dx + dy * dy)
    fill_same_span(curve, matrix, t, panels)
    return matrix


@one_blas_thread
def poisson_basis(
    curve: ClosedBSpline,
    x: np.ndarray,
    progress: Callable[[float], None] | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Transfinite harmonic coordinates G_i(x), shape (M, n), for points x (M, 2) in the closed domain
    (written into `out` (M, n) if given: a caller's rows, no copy).

    Points within ~1e-10 of the diameter of the curve (`cauchy_integrals.ON_CURVE`) get
    the Lagrange limit, the B-spline basis at their closest parameter.

    Raises
    ------
    ValueError
        Some points are outside the domain (how many, and the first).
    """
    refuse_far_outside(curve, x)
    shown = x
    curve, x = centred(curve, x)
    solution = densities(curve)
    out = np.empty((x.shape[0], curve.n)) if out is None else out
    for first in range(0, x.shape[0], CHUNK):
        points = x[first : first + CHUNK]
        rows = scratch("layer rows", (points.shape[0], curve.n + 1))  # kept: fresh pages cost
        real, _, on_curve = cauchy_integrals(curve, solution.levels, points, out=rows)
        total = real[:, -1]
        boundary, t = _classify(curve, points, total, on_curve, shown, first)
        np.divide(
            real[:, :-1], total[:, None], out=out[first : first + CHUNK]
        )  # no temporary: fresh pages cost
        if boundary.size:
            out[first + boundary] = curve.basis_matrix(t)
        if progress is not None:
            progress(min(1.0, (first + CHUNK) / x.shape[0]))
    return out


def exercise_near_field(curve: ClosedBSpline, panels: Panels) -> None:
    """Run the near-field rule and the Nyström matrix rows once, for one node of `panels`: what a
    solve calls only beside thin parts (`nystrom_halves`, the coarse equation's near pairs), so
    that `load_compiled` and `core.newton.compilation.compile_all` bring them in too."""
    adaptive_weights(curve, panels, panels.z[:1] + 1e-3j, np.zeros(1, dtype=np.int64))
    layer_matrix(curve, panels, panels.z[:1], panels.t[:1])


def load_compiled() -> bool:
    """Read the compiled boundary integrals (`compiled_integrals`) from numba's cache now, for a
    program about to evaluate many points (~0.2 s once; never compiles).

    Returns whether all twelve are in memory afterwards: False where numba's cache lacks them
    (another CPU model or numba version than the install's, `TRANSFINITE_PRECOMPILE=0`),
    and the numpy path runs instead.
    """
    compiled_integrals.allow_reading()
    square = ClosedBSpline(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    solution = solved_densities.__wrapped__(square.control_points.tobytes(), square.n)  # solves, uncached
    cauchy_integrals(square, solution.levels, np.array([[0.5, 0.5]]))
    exercise_near_field(square, solution.levels.panels[-1])
    compiled = (
        compiled_integrals.adaptive_pairs, compiled_tree.layer_rows, compiled_tree.target_boxes,
        compiled_integrals.layer_matrix_rows, compiled_integrals.knot_blocks,
        compiled_integrals.coarse_system, compiled_integrals.panel_geometry,
        compiled_integrals.panel_gaps, compiled_integrals.close_pairs,
        compiled_integrals.galerkin_matrix, compiled_integrals.rows_product,
        compiled_integrals.interpolation_rows,
    )  # fmt: skip
    return all(dispatcher.overloads for dispatcher in compiled)


@one_blas_thread
def poisson_gradients(curve: ClosedBSpline, x: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """grad G_i(x), shape (M, n, 2), at interior points x (M, 2); NaN on the curve.

    G_i = Re F_i / Re F_s with F = C[μ] holomorphic and F_s the layer of the
    densities' sum, so grad Re F = (Re F', -Im F') and the quotient rule gives
    grad G_i = (grad Re F_i - G_i grad Re F_s) / Re F_s.

    With `weights` (n, k): the gradients of the k combinations Σ_i G_i w_ik instead, shape
    (M, k, 2), from the densities combined first (the layer is linear in its density, so
    Σ_i F_i w_ik is the layer of Σ_i μ_i w_ik): k columns evaluated instead of n, the cost of a
    map's derivatives (`core.injectivity.harmonic_parts`) rather than of every basis function's;
    without the cage's densities in memory, only those k are solved for (`combined_levels`).
    """
    refuse_far_outside(curve, x)
    shown = x
    curve, x = centred(curve, x)
    if weights is None:
        levels = densities(curve).levels
    else:
        mix = np.zeros((curve.n + 1, weights.shape[1] + 1))
        mix[: curve.n, :-1], mix[curve.n, -1] = weights, 1.0
        levels = combined_levels(curve, mix)
    real, _, on_curve = cauchy_integrals(curve, levels, x)
    derivative = cauchy_derivatives(curve, levels, x)
    total = real[:, -1:]
    values = real[:, :-1] / total
    gradient = np.stack([derivative.real, -derivative.imag], axis=2)  # (M, n + 1, 2)
    out = (gradient[:, :-1] - values[:, :, None] * gradient[:, -1:]) / total[:, :, None]
    boundary = _classify(curve, x, real[:, -1], on_curve, shown)[0]
    out[boundary] = np.nan
    return out


def centred(curve: ClosedBSpline, x: np.ndarray) -> tuple[ClosedBSpline, np.ndarray]:
    """`curve` and points x (M, 2) moved by one vector, the control points' bounding box then
    centred on the origin.

    The coordinates are translation invariant (and the Cauchy–Green ones too), but their
    sums are not: far from the origin, differences of positions lose digits (the F polygon,
    2.5 across, moved to (5000, 5000): linear precision 9.4e-7 of the diameter and G down to
    -2.1e-5 at points 1e-6 of it from the curve; centred, 1.2e-10 and -5.8e-11).  Cages
    moved by the same vector share their densities (`densities` is cached by the points).
    """
    points = curve.control_points
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    if not centre.any():
        return curve, x
    return curve.translated(-centre), x - centre


def refuse_far_outside(curve: ClosedBSpline, x: np.ndarray) -> None:
    """ValueError for points of x (M, 2) that are not finite (the compiled evaluation would index
    with them), or outside the control points' bounding box, which holds
    the curve (a B-spline lies in the convex hull of its control points): outside the domain,
    said at once however far they are (at 1e300 the boundary sums overflow); points outside
    the domain but inside the box are found later (`_classify`)."""
    margin = 1e-8 * curve.diameter  # points on the curve at a corner, rounded outward
    low, high = curve.control_points.min(axis=0) - margin, curve.control_points.max(axis=0) + margin
    if not np.isfinite(x).all():
        first = int(np.flatnonzero(~np.isfinite(x).all(axis=1))[0])
        raise ValueError(f"x has non-finite coordinates (first: index {first}, {x[first].tolist()})")
    beyond = (x < low) | (x > high)
    if not beyond.any():  # one pass over the flat array (by rows took 0.23 ms at 10,000 points)
        return
    outside = np.flatnonzero(beyond.any(axis=1))
    if outside.size:
        first = int(outside[0])
        raise ValueError(
            f"{outside.size} of {x.shape[0]} points of x are outside the domain, beyond its control "
            f"points' bounding box (first: index {first}, {x[first].tolist()})"
        )


def _classify(
    curve: ClosedBSpline,
    x: np.ndarray,
    total: np.ndarray,
    on_curve: np.ndarray,
    shown: np.ndarray | None = None,
    first_index: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the points on the curve and their parameters; ValueError for points outside.

    Inside, the layer of the densities' sum is 1; outside it is 0 and on the curve
    about 1/2 (the jump of a double layer).  x (K, 2) are the caller's points from index
    `first_index` of `shown` (M, 2), which the message quotes (the points before `centred`).
    """
    shown = x if shown is None else shown
    strange = on_curve | (np.abs(total - 1.0) > ON_CURVE) | ~np.isfinite(total)
    candidates = np.flatnonzero(strange)
    if candidates.size == 0:
        return candidates, np.zeros(0)
    t, distance = closest_point(curve, x[candidates])
    boundary = distance <= ON_CURVE_DISTANCE * curve.diameter
    outside = candidates[~boundary & ~(total[candidates] >= 0.5)]
    if outside.size:
        first = first_index + int(outside[0])
        counted = (
            f"{outside.size} of {x.shape[0]}" if x.shape[0] == shown.shape[0] else f"{outside.size} or more"
        )
        raise ValueError(
            f"{counted} points of x are outside the domain (first: index {first}, {shown[first].tolist()})"
        )
    return candidates, t


def boundary_limit_rows(
    curve: ClosedBSpline, x: np.ndarray, total: np.ndarray, shown: np.ndarray, first_index: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Points of x (M, 2) on the curve, and the points 1e-7 diameters inside from them (K, 2).

    `total` (M,) is the Cauchy integral of 1 (1 inside, 0 outside, 1/2 on the curve),
    which finds the candidates as in `poisson_basis`; a kernel without the Lagrange
    property takes its boundary rows as the limit from inside, approximated there.
    `shown` and `first_index` as in `_classify`.
    """
    on_curve = np.zeros(x.shape[0], dtype=bool)
    indices, t = _classify(curve, x, total, on_curve, shown, first_index)
    if indices.size == 0:
        return indices, np.zeros((0, 2))
    point, tangent, _ = curve.evaluate(t)
    speed = np.linalg.norm(tangent, axis=1, keepdims=True)
    # At a corner p' vanishes: step towards the inside along the bisector of the two sides.
    after, _, _ = curve.evaluate(t + 1e-6)
    before, _, _ = curve.evaluate(t - 1e-6)
    chord = np.where(speed > 1e-9 * curve.diameter, tangent, after - before)
    inward = np.stack([-chord[:, 1], chord[:, 0]], axis=1) * (1.0 if curve.area > 0 else -1.0)
    inward /= np.linalg.norm(inward, axis=1, keepdims=True)
    return indices, point + 1e-7 * curve.diameter * inward


def closest_point(curve: ClosedBSpline, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest parameters and distances to the curve, two ndarrays of shape (M,).

    Each span is sampled at 65 points, then the best sample is polished
    (`_polish`; plain numpy: no compilation).
    """
    coefficients = curve.piecewise_polynomial().coefficients  # (n, 3, 2)
    u = np.linspace(0.0, 1.0, 65)
    samples = coefficients[:, None, 0] + u[None, :, None] * (
        coefficients[:, None, 1] + u[None, :, None] * coefficients[:, None, 2]
    )  # (n, 65, 2)
    flat = samples.reshape(-1, 2)
    best = np.empty(x.shape[0], dtype=np.int64)
    for first in range(0, x.shape[0], 256):
        block = x[first : first + 256]
        best[first : first + 256] = ((block[:, None, :] - flat[None]) ** 2).sum(axis=2).argmin(axis=1)
    span = best // u.size
    # The closest point may lie on a neighbouring span (past a knot or a corner): polish
    # each point's best sample on the best span and on both its neighbours, keep the
    # nearest.
    results = []
    for shift in (0, -1, 1):
        candidate = (span + shift) % curve.n
        start = ((samples[candidate] - x[:, None, :]) ** 2).sum(axis=2).argmin(axis=1)
        results.append(_polish(coefficients, x, candidate, u[start]))
    t = np.stack([r[0] for r in results])
    distance = np.stack([r[1] for r in results])
    choice = distance.argmin(axis=0)
    columns = np.arange(x.shape[0])
    return np.mod(t[choice, columns], curve.n), distance[choice, columns]


def _polish(coefficients: np.ndarray, x: np.ndarray, span: np.ndarray, u: np.ndarray):
    """Minimise |p_span(u) - x|^2 near u within [0, 1] for each point; returns (span + u, distance).

    Golden-section search on the bracket of one sample spacing either side, then
    Newton steps where the second derivative is positive (at a corner p' vanishes
    and Newton alone can stall).
    """
    c = coefficients[span]

    def residual(t):
        return c[:, 0] + t[:, None] * (c[:, 1] + t[:, None] * c[:, 2]) - x

    low = np.clip(u - 1.0 / 64, 0.0, 1.0)
    high = np.clip(u + 1.0 / 64, 0.0, 1.0)
    ratio = 0.5 * (np.sqrt(5.0) - 1.0)
    for _ in range(60):
        a = high - ratio * (high - low)
        b = low + ratio * (high - low)
        left = (residual(a) ** 2).sum(axis=1) <= (residual(b) ** 2).sum(axis=1)
        high = np.where(left, b, high)
        low = np.where(left, low, a)
    t = 0.5 * (low + high)
    for _ in range(3):
        r = residual(t)
        first_derivative = c[:, 1] + 2.0 * t[:, None] * c[:, 2]
        gradient = (r * first_derivative).sum(axis=1)
        hessian = (first_derivative**2).sum(axis=1) + 2.0 * (r * c[:, 2]).sum(axis=1)
        step = np.where(hessian > 0, gradient / np.where(hessian > 0, hessian, 1.0), 0.0)
        t = np.clip(t - step, 0.0, 1.0)
    return span + t, np.linalg.norm(residual(t), axis=1)
