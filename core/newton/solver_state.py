"""The state the compiled solver passes between its parts, as named tuples (numba compiles a
named tuple as a struct: no cost over a bare tuple, and a field is read by name, never by
position).  Built in Python by `core.kernels` and `core.gradients`, or inside the compiled loops
(`thread_arrays`, the work arrays of the value and the gradient solver).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from core.newton.quadrature_nodes import MAX_WINDOW_NODES, MAX_WINDOWS


class Settings(NamedTuple):
    """What every point of one evaluation shares, scalars only."""

    kernel: int  #: a kernel code of `core.newton.codes`
    power: float  #: the exponent of the power kernels (Eq. 19)
    shift: int  #: a shift code of `core.newton.codes` (Eq. 19-20)
    mode: int  #: `codes.OUTPUT_SAMPLES` or `codes.OUTPUT_BASIS`
    orientation: float  #: +1 for a counter-clockwise boundary, -1 clockwise
    diameter: float  #: the boundary's diameter
    control_count: int  #: n, the control points
    tolerance: float  #: Newton's tolerance relative to the diameter


class Nodes(NamedTuple):
    """A quadrature rule on the curve: p, p', p'' and the weight at every node, each (K,)."""

    x: np.ndarray
    y: np.ndarray
    tangent_x: np.ndarray
    tangent_y: np.ndarray
    second_x: np.ndarray
    second_y: np.ndarray
    weight: np.ndarray


class Samples(NamedTuple):
    """The N uniform boundary samples (`core.kernels.curve_arrays`): contiguous float64 (N,)
    arrays but for the scalars and `slabs`."""

    rule: Nodes  #: p, p', p'' at the samples and the trapezoid rule's weights: far points' rule
    spacing: np.ndarray  #: the larger distance to the two neighbours
    t: np.ndarray  #: the samples' parameters
    basis0: np.ndarray  #: the three non-zero B-spline basis values at t (`codes.OUTPUT_BASIS`)
    basis1: np.ndarray
    basis2: np.ndarray
    step: float  #: h, the parameter step of the samples
    sinh_step: float  #: the step of the near-boundary rule in the sinh variable
    out_step: float  #: the step of the output samples (`codes.OUTPUT_SAMPLES`)
    slabs: tuple  #: `core.curves.crossing_slabs.crossing_slabs(y)`, the inside test of far points
    largest_spacing: float  #: the largest of `spacing`


class Geometry(NamedTuple):
    """The exact curve between the samples."""

    coefficients: np.ndarray  #: (P, D + 1, 2) piecewise polynomial, or (P, 3, 3) in arc length
    piece_length: float
    corners: np.ndarray  #: (C, 5): the sharp corners' parameters and data (three-point kernels)


class Directions(NamedTuple):
    """From the point x to every node: the unit vector u_j and 1 / r_j, each (K,)."""

    ux: np.ndarray
    uy: np.ndarray
    inv_r: np.ndarray


class Work(NamedTuple):
    """The arrays of the minimisation of Eq. 16, each (K,): the directions, the normalised
    weights `a` (on return the quadrature-weighted kernel), s_j = 1 + phi . u_j and its
    inverse, a trial step's, and the blended weights of the path-following fallback."""

    ux: np.ndarray
    uy: np.ndarray
    inv_r: np.ndarray
    a: np.ndarray
    s: np.ndarray
    inv_s: np.ndarray
    trial: np.ndarray
    trial_inv: np.ndarray
    blend: np.ndarray


class Scratch(NamedTuple):
    """One thread's work arrays of `core.newton.solver.solve_point`, each of the largest rule's size."""

    nodes: Nodes  #: the rule's curve data and weights
    t: np.ndarray  #: the nodes' parameters
    work: Work  #: the minimisation's arrays
    ones: np.ndarray  #: c_k = a_k in `output_rows.fold_onto_basis` for the explicit kernels
    coarse: tuple  #: `minimisation.coarse_start`'s eight


class Windows(NamedTuple):
    """The boundary stretches near one point (`core.newton.quadrature_nodes.near_stretches`)."""

    start: np.ndarray  #: int (MAX_WINDOWS + 1,): first sample of each
    stop: np.ndarray  #: int (MAX_WINDOWS + 1,): last sample of each
    t: np.ndarray  #: (MAX_WINDOWS + 1,): the closest parameter in each
    d: np.ndarray  #: (MAX_WINDOWS + 1,): the distance there
    runs: np.ndarray  #: int (MAX_WINDOWS + 1, 3): runs of uniform samples among the nodes


class Output(NamedTuple):
    """Where `core.newton.solver.solve_points` writes, one entry or row per point."""

    values: np.ndarray  #: (M, columns)
    iterations: np.ndarray  #: int (M,)
    status: np.ndarray  #: int (M,): a status code of `core.newton.codes`
    residual: np.ndarray  #: (M,)


@njit(cache=True, nogil=True, error_model="numpy")
def thread_arrays(count, corner_count):
    """One thread's work arrays for N = `count` samples and C = `corner_count` sharp corners:
    (`Scratch`, `Windows`), each array of `Scratch` of the largest rule's size, N plus the
    near-boundary nodes plus C plus 8 (`core.newton.solver.solve_points` and
    `core.newton.gradient_solver.gradient_points` allocate them once per call: fresh arrays per
    point fault in new pages and serialise the threads).  Compiled once for both solvers."""
    capacity = count + MAX_WINDOWS * MAX_WINDOW_NODES + corner_count + 8
    scratch = Scratch(
        Nodes(
            np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
            np.empty(capacity), np.empty(capacity), np.empty(capacity),
        ),
        np.empty(capacity),
        Work(
            np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
            np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
            np.empty(capacity),
        ),
        np.ones(capacity),
        (
            np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
            np.empty(capacity), np.empty(capacity), np.empty(capacity), np.empty(capacity),
        ),
    )  # fmt: skip
    windows = Windows(
        np.empty(MAX_WINDOWS + 1, dtype=np.int64),
        np.empty(MAX_WINDOWS + 1, dtype=np.int64),
        np.empty(MAX_WINDOWS + 1),
        np.empty(MAX_WINDOWS + 1),
        np.empty((MAX_WINDOWS + 1, 3), dtype=np.int64),
    )
    return scratch, windows
