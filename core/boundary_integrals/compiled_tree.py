"""The Cauchy integrals of the panels of `cauchy_integrals.Levels` at many targets, as compiled
loops (`layer_rows`): the targets sorted into boxes, each box's far panels one matrix product,
the near ones walked down the panel tree to the near-field rule (`compiled_integrals.near_weights`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from core.boundary_integrals.compiled_integrals import near_weights
from core.boundary_integrals.gauss_legendre import ORDER


class PanelTree(NamedTuple):
    """The levels of `cauchy_integrals.Levels` concatenated, coarsest first, for `layer_rows`.

    Level k's panels are panel_start[k]..panel_start[k+1] - 1 (P in all), panel p's nodes
    p ORDER..(p + 1) ORDER - 1 (N in all); children[child_start[p]..child_start[p+1] - 1]
    are panel p's children (panel indices) on the next level.
    """

    node_z: np.ndarray  #: complex (N,)
    factors: (
        np.ndarray
    )  #: complex (N,): s w τ' / 2πi (`core.boundary_integrals.cauchy_integrals.layer_factors`)
    density: np.ndarray  #: (N, m): what each level's rule integrates
    centres: np.ndarray  #: complex (P,)
    reach: np.ndarray  #: (P,): the panel's radius plus its close range
    close_squared: np.ndarray  #: (P,): the close range, squared
    panel_start: np.ndarray  #: int (levels + 1,)
    children: np.ndarray  #: int (P - P_0,)
    child_start: np.ndarray  #: int (P + 1,)
    bounds: np.ndarray  #: (P_f, 2): the finest level's parameter intervals
    coefficients: np.ndarray  #: (n, 3, 2): the curve's spans (`ClosedBSpline.piecewise_polynomial`)
    orientation: float  #: +1 counter-clockwise, -1 clockwise
    touch: float  #: targets this close to the curve are on it
    stack_size: int  #: enough for the walk of one target


#: Targets per box of `layer_rows` at most: a box's far panels are one matrix product.  The
#: bench's mesh of 10,000 vertices (100,000) took 6.25 ms (52.5 ms) with 48 and 4 splits, 5.9-6.0
#: (47.4-47.9) with 128 and 5, 6.0 (46.8) with 96, 6.3 (52.0) with 256: bigger products, as long as
#: the splits keep the boxes at the boundary small.
BOX = 128


#: A box of more targets than this, with panels mixed for it, is split in four (`layer_rows`).
LEAF = 16


#: Splits of a box at most (`layer_rows`).
SPLITS = 5


#: Box classifications of a panel (`_box_side`).
FAR, NEAR, MIXED = 0, 1, 2


@njit(cache=True, nogil=True, error_model="numpy")
def _grid_index(position, count):
    """int(position) clamped to 0..count - 1, compared before converted (int() of NaN or inf is
    undefined in machine code); NaN gives 0."""
    if not position >= 0.0:
        return 0
    if position >= count - 1:
        return count - 1
    return int(position)


@njit(cache=True, nogil=True, error_model="numpy")
def target_boxes(targets, size):
    """Targets grouped by a grid of cells holding ~`size` each: (order int (M,), start int (B + 1,)),
    box b holding targets order[start[b]:start[b + 1]] (at most `size`, all in one cell).
    Non-finite targets (the callers refuse them; here they would index outside the grid) go
    to the first cell."""
    count = targets.shape[0]
    low_x, high_x, low_y, high_y = np.inf, -np.inf, np.inf, -np.inf
    for m in range(count):
        low_x, high_x = min(low_x, targets[m].real), max(high_x, targets[m].real)
        low_y, high_y = min(low_y, targets[m].imag), max(high_y, targets[m].imag)
    width, height = high_x - low_x, high_y - low_y
    if not (math.isfinite(width) and math.isfinite(height)):  # no targets, or none finite
        width = height = low_x = low_y = 0.0
    side = max(math.sqrt(width * height * size / max(count, 1)), max(width, height) * size / max(count, 1))
    if not side > 0.0:
        side = 1.0
    columns = int(width / side) + 1
    rows = int(height / side) + 1
    cell = np.empty(count, dtype=np.int64)
    filled = np.zeros(columns * rows + 1, dtype=np.int64)
    for m in range(count):
        column = _grid_index((targets[m].real - low_x) / side, columns)
        row = _grid_index((targets[m].imag - low_y) / side, rows)
        cell[m] = row * columns + column
        filled[cell[m] + 1] += 1
    boxes = 0
    for c in range(columns * rows):
        boxes += (filled[c + 1] + size - 1) // size
        filled[c + 1] += filled[c]
    order = np.empty(count, dtype=np.int64)
    at = filled[:-1].copy()
    for m in range(count):
        order[at[cell[m]]] = m
        at[cell[m]] += 1
    start = np.empty(boxes + 1, dtype=np.int64)
    b = 0
    for c in range(columns * rows):
        for first in range(filled[c], filled[c + 1], size):
            start[b] = first
            b += 1
    start[boxes] = count
    return order, start


@njit(cache=True, nogil=True, error_model="numpy")
def _bounding_circle(targets, members):
    """The centre of the bounding box of targets[members] and the radius of a circle there holding them."""
    low_x, high_x, low_y, high_y = np.inf, -np.inf, np.inf, -np.inf
    for k in range(members.shape[0]):
        z = targets[members[k]]
        low_x, high_x = min(low_x, z.real), max(high_x, z.real)
        low_y, high_y = min(low_y, z.imag), max(high_y, z.imag)
    centre = complex(0.5 * (low_x + high_x), 0.5 * (low_y + high_y))
    square = 0.0  # the largest squared distance: one square root, not a hypot a target
    for k in range(members.shape[0]):
        d = targets[members[k]] - centre
        square = max(square, d.real * d.real + d.imag * d.imag)
    return centre, math.sqrt(square)


@njit(cache=True, nogil=True, error_model="numpy")
def _quadrants(targets, members, centre):
    """Reorder `members` (int (K,), in place) by the quadrant of their targets about `centre`;
    returns the non-empty quadrants' ranges [(first, last), ...] within it."""
    quadrant = np.empty(members.shape[0], dtype=np.int64)
    counts = np.zeros(5, dtype=np.int64)
    for k in range(members.shape[0]):
        z = targets[members[k]]
        quadrant[k] = (2 if z.imag >= centre.imag else 0) + (1 if z.real >= centre.real else 0)
        counts[quadrant[k] + 1] += 1
    for i in range(4):
        counts[i + 1] += counts[i]
    at = counts[:4].copy()
    sorted_members = np.empty_like(members)
    for k in range(members.shape[0]):
        sorted_members[at[quadrant[k]]] = members[k]
        at[quadrant[k]] += 1
    for k in range(members.shape[0]):
        members[k] = sorted_members[k]
    return [(counts[i], counts[i + 1]) for i in range(4) if counts[i + 1] > counts[i]]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _set_row(table, at, values):
    """table[at] = values (a tuple) element by element: numba compiles a tuple assigned to an
    array's row as an array, with a shape check and its formatted message (~3 CPU-s)."""
    for i in range(len(values)):
        table[at, i] = values[i]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _box_side(p, centre, radius, node_z, centres, reach, close_squared):
    """Whether panel p is `FAR` from every target within `radius` of `centre`, `NEAR` every one
    (by `layer_rows`'s test: within `reach` of its centre and within its close range of a node),
    or `MIXED`.  The margins keep a box's answer the one its targets would get one by one."""
    # Square roots, not abs: a complex abs is a call of the C library's hypot (with the walk's,
    # 0.4 ms of the bench mesh's 5.2 ms; no coordinate here comes near overflowing a square).
    gap = centre - centres[p]
    distance = math.sqrt(gap.real * gap.real + gap.imag * gap.imag)
    margin = radius * (1.0 + 1e-9) + 1e-12 * (math.sqrt(centre.real**2 + centre.imag**2) + reach[p])
    if distance - margin >= reach[p]:
        return FAR
    close = math.sqrt(close_squared[p])
    far_squared = (close + margin) ** 2  # a node this far is far from every target
    near_squared = (close - margin) ** 2 if close > margin else -1.0  # this near, near every one
    every_far, one_near = True, False
    for q in range(p * ORDER, (p + 1) * ORDER):
        d = node_z[q] - centre
        square = d.real * d.real + d.imag * d.imag
        if square < far_squared:
            every_far = False
            if square < near_squared:
                one_near = True
                break
    if every_far:
        return FAR
    if one_near and distance + margin < reach[p]:
        return NEAR
    return MIXED


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _walk(z, tree, start, power, imaginary, rows, work):
    """Add C[φ](z) over the panels `start` (int (K,)) and their descendants to row (m,) (and
    row_imaginary): a panel far from z takes its plain rule, a near one its children, on the
    finest level `near_weights`.  `rows` = (row, row_imaginary), `work` = (stack, moments,
    weights) the walk's scratch.  Returns whether z is on the curve."""
    row, row_imaginary = rows
    stack, moments, weights = work
    node_z, factors, density, centres = tree.node_z, tree.factors, tree.density, tree.centres
    reach, close_squared = tree.reach, tree.close_squared
    children, child_start = tree.children, tree.child_start
    bounds, coefficients = tree.bounds, tree.coefficients
    columns = density.shape[1]
    finest = tree.panel_start[tree.panel_start.shape[0] - 2]
    n = coefficients.shape[0]
    on_curve = False
    top = 0
    for i in range(start.shape[0] - 1, -1, -1):
        stack[top] = start[i]
        top += 1
    while top > 0:
        top -= 1
        p = stack[top]
        first = p * ORDER
        near = False
        gap = z - centres[p]
        if gap.real * gap.real + gap.imag * gap.imag < reach[p] * reach[p]:  # as `_box_side`, no hypot
            for q in range(first, first + ORDER):
                d = node_z[q] - z
                if d.real * d.real + d.imag * d.imag < close_squared[p]:
                    near = True
                    break
        if not near:
            for q in range(first, first + ORDER):
                dx = node_z[q].real - z.real
                dy = node_z[q].imag - z.imag
                square = dx * dx + dy * dy
                if power == 1:  # f / d = f conj(d) / |d|^2
                    wr = (factors[q].real * dx + factors[q].imag * dy) / square
                    wi = (factors[q].imag * dx - factors[q].real * dy) / square
                else:
                    w = factors[q] / complex(dx, dy) ** 2
                    wr, wi = w.real, w.imag
                for c in range(columns):
                    row[c] += wr * density[q, c]
                if imaginary:
                    for c in range(columns):
                        row_imaginary[c] += wi * density[q, c]
        elif p >= finest:
            f = p - finest
            span = int(math.floor(bounds[f, 0] + 1e-12)) % n
            if near_weights(
                coefficients[span], bounds[f, 0], bounds[f, 1], z, power, tree.touch, weights, moments
            ):
                on_curve = True
            for j in range(ORDER):
                w = weights[j] * tree.orientation / (2j * np.pi)
                for c in range(columns):
                    row[c] += w.real * density[first + j, c]
                if imaginary:
                    for c in range(columns):
                        row_imaginary[c] += w.imag * density[first + j, c]
        else:
            for child in range(child_start[p + 1] - 1, child_start[p] - 1, -1):
                stack[top] = children[child]
                top += 1
    return on_curve


@njit(cache=True, nogil=True, error_model="numpy")
def _add_far(targets, members, tree, far, power, imaginary, out, out_imaginary):
    """out[members] (and out_imaginary) += the plain rules of the panels `far` (int (F,)) at
    targets[members], as one matrix (K, F ORDER) times the panels' densities (F ORDER, m)."""
    node_z, factors, density = tree.node_z, tree.factors, tree.density
    size, columns, nodes = members.shape[0], density.shape[1], far.shape[0] * ORDER
    x, y = np.empty(nodes), np.empty(nodes)
    fx, fy = np.empty(nodes), np.empty(nodes)
    gathered = np.empty((nodes, columns))
    for i in range(far.shape[0]):
        for j in range(ORDER):
            q, at = far[i] * ORDER + j, i * ORDER + j
            x[at], y[at] = node_z[q].real, node_z[q].imag
            fx[at], fy[at] = factors[q].real, factors[q].imag
            for c in range(columns):
                gathered[at, c] = density[q, c]
    rule = np.empty((size, nodes))
    rule_imaginary = np.empty((size if imaginary else 0, nodes))
    for k in range(size):
        zx, zy = targets[members[k]].real, targets[members[k]].imag
        if power == 1:  # f / d = f conj(d) / |d|^2
            for j in range(nodes):
                dx, dy = x[j] - zx, y[j] - zy
                rule[k, j] = (fx[j] * dx + fy[j] * dy) / (dx * dx + dy * dy)
            if imaginary:
                for j in range(nodes):
                    dx, dy = x[j] - zx, y[j] - zy
                    rule_imaginary[k, j] = (fy[j] * dx - fx[j] * dy) / (dx * dx + dy * dy)
        else:
            for j in range(nodes):
                w = complex(fx[j], fy[j]) / complex(x[j] - zx, y[j] - zy) ** 2
                rule[k, j] = w.real
                if imaginary:
                    rule_imaginary[k, j] = w.imag
    product = np.dot(rule, gathered)
    for k in range(size):
        for c in range(columns):
            out[members[k], c] += product[k, c]
    if imaginary:
        product = np.dot(rule_imaginary, gathered)
        for k in range(size):
            for c in range(columns):
                out_imaginary[members[k], c] += product[k, c]


@njit(cache=True, nogil=True, error_model="numpy")
def layer_rows(targets, tree, power, imaginary, out, boxes, first, shares):
    """C[φ](z) (power 1), or its z-derivative (power 2), at targets complex (M,), over the panels
    of `tree` (a `PanelTree`), for the boxes first, first + shares, ... of `boxes` (order int
    (M,), box_start int (B + 1,): `target_boxes`; `core.library_threads.in_shares`).

    Adds into out = (real parts (M, m), imaginary parts (M, m) if `imaginary` (else (0, m)),
    on-curve flags (M,)), all three zero before the first share.  Each target walks down from the
    coarsest level: a panel is near it when one of its nodes is within the panel's close
    range; a far panel takes its plain rule, a near one is replaced by its children, on the
    finest level by `near_weights` (a target it finds on the curve is flagged).

    The walk is shared by up to `BOX` targets close together (`target_boxes`): a panel far from
    all of them (`_box_side`) is far for each, one near all of them is replaced by its
    children for all.  The box's far panels' rules make one matrix, whose product with
    their densities is one BLAS call (`_add_far`); a box with panels mixed for it is split
    in four (`_quadrants`) down to `LEAF` targets, whose panels still mixed each target
    walks on its own (`_walk`).  The decisions are each target's own, so the sums are the
    same but for their order; at the bench's 10,000 mesh vertices the rows took ~5 ms
    instead of 13.4 ms one target at a time.
    """
    node_z, centres, reach, close_squared = tree.node_z, tree.centres, tree.reach, tree.close_squared
    children, child_start = tree.children, tree.child_start
    out, out_imaginary, on_curve = out
    order, box_start = boxes
    columns = tree.density.shape[1]
    finest = tree.panel_start[tree.panel_start.shape[0] - 2]
    total = node_z.shape[0] // ORDER
    for b in range(first, box_start.shape[0] - 1, shares):
        members = order[box_start[b] : box_start[b + 1]].copy()  # reordered as boxes split
        stack = np.empty(total + tree.stack_size, dtype=np.int64)  # a list of panels, then descents
        moments = np.empty((2, ORDER), dtype=np.complex128)
        weights = np.empty(ORDER, dtype=np.complex128)
        row = np.empty(columns)
        row_imaginary = np.empty(columns)
        far = np.empty(total, dtype=np.int64)
        mixed = np.empty(total, dtype=np.int64)
        # Boxes to do, depth first: members[first:last], their panels lists[start:start + count].
        lists = np.empty(SPLITS * total, dtype=np.int64)
        for i in range(tree.panel_start[1]):
            lists[i] = i
        boxes = np.empty((4 * SPLITS + 1, 5), dtype=np.int64)  # first, last, start, count, depth
        _set_row(boxes, 0, (0, members.shape[0], 0, tree.panel_start[1], 0))
        pending, used = 1, tree.panel_start[1]
        while pending > 0:
            pending -= 1
            first, last, list_start, list_count, depth = boxes[pending]
            box = members[first:last]
            centre, radius = _bounding_circle(targets, box)
            far_count, mixed_count, top = 0, 0, 0
            for i in range(list_count - 1, -1, -1):
                stack[top] = lists[list_start + i]
                top += 1
            while top > 0:
                top -= 1
                p = stack[top]
                side = _box_side(p, centre, radius, node_z, centres, reach, close_squared)
                if side == FAR:
                    far[far_count] = p
                    far_count += 1
                elif side == NEAR and p < finest:
                    for child in range(child_start[p + 1] - 1, child_start[p] - 1, -1):
                        stack[top] = children[child]
                        top += 1
                else:
                    mixed[mixed_count] = p
                    mixed_count += 1
            if far_count:
                _add_far(targets, box, tree, far[:far_count], power, imaginary, out, out_imaginary)
            if mixed_count == 0:
                continue
            if box.shape[0] > LEAF and depth < SPLITS - 1 and used + mixed_count <= lists.shape[0]:
                for i in range(mixed_count):
                    lists[used + i] = mixed[i]
                for a, z in _quadrants(targets, box, centre):
                    _set_row(boxes, pending, (first + a, first + z, used, mixed_count, depth + 1))
                    pending += 1
                used += mixed_count
                continue
            start = mixed[:mixed_count]
            for k in range(box.shape[0]):
                m = box[k]
                row[:] = 0.0
                row_imaginary[:] = 0.0
                # Inlined (numba cannot inline a call with *args): a call passing the tree's arrays
                # cost ~0.1 us a target (the bench's 10,000 mesh vertices: 5.3 -> 5.0 ms).
                if _walk(
                    targets[m], tree, start, power, imaginary, (row, row_imaginary), (stack, moments, weights)
                ):
                    on_curve[m] = True
                for c in range(columns):
                    out[m, c] += row[c]
                    if imaginary:
                        out_imaginary[m, c] += row_imaginary[c]
