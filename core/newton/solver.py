"""Per-point evaluation of the barycentric kernels, compiled with numba.

For one point x this module
1. builds the quadrature (`core.newton.quadrature_nodes`): the periodic trapezoid rule on
   the N uniform samples (Sec. 4.1), refined near the boundary (a graded sinh rule around
   the closest point of every boundary stretch closer than `NEAR_SPACINGS` sample spacings),
2. evaluates the weight function omega_x (Eq. 18-20, 23 and Sec. 3.1, 3.4) or the
   explicit kernels (Eq. 5 and the three-point family of Sec. 1.1): `core.newton.kernel_weights`,
3. for the weighted maximum-likelihood kernels minimises the convex F(phi) of
   Eq. 16 by Newton's method with Armijo backtracking from phi = 0, every trial
   kept strictly inside the feasible set, and forms lambda by Eq. 14 and 17
   (`core.newton.minimisation`),
4. accumulates w_j lambda(x, t_j) into an output row (`core.newton.output_rows`): either
   lumped onto the N samples (the kernel values, `core.kernel`) or multiplied by the
   folded B-spline basis (the basis functions G, Sec. 4.3).

With phi_0 normalised to 1 the feasible set is {phi : 1 + phi . u_j > 0 for all
nodes}, which contains the unit disk.  The linear-precision residual
|sum_j c_j (p_j - x)| / sum_j c_j of the discrete kernel is exactly |grad F| / D
(D = sum a_j / (r_j s_j)), which is what the Newton loop drives below tolerance.
"""

from __future__ import annotations

import math

from numba import njit

from core.newton.codes import (
    MODIFIED_MEAN_VALUE_SQUARED,
    OUTPUT_BASIS,
    STATUS_CONVERGED,
    STATUS_OUTSIDE,
)
from core.newton.kernel_weights import kernel_weights
from core.newton.minimisation import (
    COARSE_SPACINGS,
    coarse_start,
    finish,
    maximum_likelihood,
    predicted_start,
)
from core.newton.output_rows import accumulate, accumulate_nodes, fold_onto_basis, output_parameter
from core.newton.point_rule import RULE_ON_BOUNDARY, RULE_OUTSIDE, RULE_SAMPLES, point_rule
from core.newton.quadrature_nodes import wrap
from core.newton.solver_state import Directions, thread_arrays

# A far point's Newton starts from the last minimisers of its block of BLOCK points (see
# solve_points and predicted_start) when they are closer than WARM_REACH times its distance to
# the boundary (phi varies on that scale); otherwise from a coarse solve.
WARM_REACH = 1.0


BLOCK = 64


# Near points start from every fourth node of their refined rule (the separation that gives it).
NEAR_START_SEPARATION = 4.0 * COARSE_SPACINGS


# Far points start from every other sample at least: nearer than 2 COARSE_SPACINGS spacings
# that subset is a cruder rule, but Newton from its minimiser still takes about 1 step
# on all N, against 4 to 6 from phi = 0.
FAR_START_SEPARATION = 2.0 * COARSE_SPACINGS


# Inlined into solve_points by numba: otherwise LLVM optimises and compiles the whole solver
# twice (once as this function, once linked into solve_points), and every point's call
# copies the scratch and curve tuples (tens of arrays, reference counts included).
@njit(cache=True, error_model="numpy", inline="always")
def solve_point(point, settings, samples, geometry, row, scratch, windows, start):
    """Evaluate one point; writes its output row and returns (iterations, status, residual, phix, phiy).

    `point` = (x, y); `settings`, `samples` and `geometry` are the shared tuples of
    `solve_points`, `scratch` (`Scratch`) and `windows` (`Windows`) per-thread work arrays.
    `start` holds the last two points of the block and their minimisers, from which a far
    point's Newton starts (`predicted_start`).
    phix, phiy is this point's minimiser of Eq. 16 on the plain rule, NaN where
    there is none to pass on (explicit kernels, near points).
    """
    x, y = point
    kernel, mode, diameter = settings.kernel, settings.mode, settings.diameter
    control_count, tolerance = settings.control_count, settings.tolerance
    coefficients, corners, runs = geometry.coefficients, geometry.corners, windows.runs
    plain, sample_t, step, out_step = samples.rule, samples.t, samples.step, samples.out_step
    work = scratch.work
    a, inv_r, inv_s = work.a, work.inv_r, work.inv_s
    t, ones, coarse = scratch.t, scratch.ones, scratch.coarse
    rays = Directions(work.ux, work.uy, inv_r)
    count = plain.x.shape[0]
    out_count = int(round(count * step / out_step))
    rule, value, nodes, run_count = point_rule((x, y), settings, samples, geometry, scratch, windows)
    if rule == RULE_OUTSIDE:
        return 0, STATUS_OUTSIDE, value, math.nan, math.nan
    if rule == RULE_ON_BOUNDARY:
        closest_t = output_parameter(coefficients, mode, wrap(value, count * step))
        accumulate(row, mode, 1.0, closest_t, out_step, out_count, control_count)
        return 0, STATUS_CONVERGED, 0.0, math.nan, math.nan
    if rule == RULE_SAMPLES:
        nearest = value
        # The common case: the plain trapezoid rule on the shared samples.
        total = kernel_weights(settings, plain, (x, y), count, corners, rays, nearest, a)
        likelihood = kernel <= MODIFIED_MEAN_VALUE_SQUARED
        if likelihood:
            phix, phiy, predicted = predicted_start(x, y, start, WARM_REACH * nearest)
            if not predicted:
                phix, phiy = coarse_start(
                    rays, a, count, max(nearest / samples.largest_spacing, FAR_START_SEPARATION),
                    coarse, tolerance * diameter, (phix, phiy),
                )  # fmt: skip
            # No sample is within NEAR_SPACINGS spacings: |u_(k+1) - u_k| <= chord / nearest
            # (2 |p - q| / (|p| + |q|) bounds |p / |p| - q / |q||), so the peak scan is skipped.
            iterations, status, residual, d, phix, phiy = maximum_likelihood(
                work, plain.weight, step, count, (tolerance * diameter, samples.largest_spacing / nearest),
                (phix, phiy),
            )  # fmt: skip
            if mode == OUTPUT_BASIS:
                # Eq. 17's normalisation folded into the basis sums: no pass of its own.
                fold_onto_basis(row, a, inv_r, inv_s, 1.0 / d, samples, control_count, coefficients)
                return iterations, status, residual, phix, phiy
            inverse = 1.0 / d
            for k in range(count):
                a[k] = a[k] * inv_r[k] * inv_s[k] * inverse
        else:
            iterations, status, residual = finish(
                kernel, work, total, plain, step, (x, y), (tolerance * diameter, math.inf), (0.0, 0.0)
            )
        if mode == OUTPUT_BASIS:
            fold_onto_basis(row, a, ones, ones, 1.0, samples, control_count, coefficients)
        elif out_count == count:
            for k in range(count):
                row[k] += a[k] / step
        else:
            for k in range(count):
                accumulate(row, mode, a[k], sample_t[k], out_step, out_count, control_count)
        if likelihood:
            return iterations, status, residual, phix, phiy
        return iterations, status, residual, math.nan, math.nan
    r_min = value  # RULE_NODES
    total = kernel_weights(settings, scratch.nodes, (x, y), nodes, corners, rays, r_min, a)
    phix, phiy = 0.0, 0.0
    if kernel <= MODIFIED_MEAN_VALUE_SQUARED:
        phix, phiy = coarse_start(
            rays, a, total, NEAR_START_SEPARATION, coarse, tolerance * diameter, (0.0, 0.0)
        )
    iterations, status, residual = finish(
        kernel,
        work,
        total,
        scratch.nodes,
        step,
        (x, y),
        (tolerance * diameter, math.inf),
        (phix, phiy),
    )
    accumulate_nodes(row, settings, samples, coefficients, a, t, total, (runs, run_count))
    return iterations, status, residual, math.nan, math.nan


@njit(cache=True, nogil=True, error_model="numpy")
def solve_points(points, settings, samples, geometry, output, first, stride):
    """Evaluate the points first, first + stride, ... of (M, 2) into output.values (M, columns).

    Per-point diagnostics go to output.iterations, .status and .residual, each (M,)
    (`solver_state.Output`).  The GIL is released, so that `core.kernels` runs one call per
    thread with `stride` threads: cheaper to compile than numba's parallel loops, and as
    fast.  Points are dealt out round-robin in blocks of BLOCK, so that the costlier
    near-boundary points spread evenly.  Within a block a far point's Newton starts
    from the last minimiser (`solve_point`): neighbours in a mesh's vertex order,
    their minimisers are close.  A block is solved in order by one thread, so the
    result depends on the points' order, never on the number of threads.

    `settings` (`solver_state.Settings`): the kernel, its parameters, the output mode,
    the orientation, the diameter, n and Newton's tolerance.  `samples`
    (`solver_state.Samples`): the N uniform boundary samples, their basis values (used in
    OUTPUT_BASIS mode), the sample step, the sinh step of the near-boundary rule, the step
    of the output samples (OUTPUT_SAMPLES lumps onto that grid, which may be coarser than
    the samples) and `core.curves.crossing_slabs.crossing_slabs(sample_y)` for the inside
    test of far points.  `geometry` (`solver_state.Geometry`): the exact curve between
    samples.
    """
    scratch, windows = thread_arrays(samples.rule.x.shape[0], geometry.corners.shape[0])
    count = points.shape[0]
    for block in range(first, (count + BLOCK - 1) // BLOCK, stride):
        nan = math.nan
        history = (nan, nan, nan, nan, nan, nan, nan, nan)
        for m in range(block * BLOCK, min(count, (block + 1) * BLOCK)):
            x = points[m, 0]
            y = points[m, 1]
            output.iterations[m], output.status[m], output.residual[m], phix, phiy = solve_point(
                (x, y), settings, samples, geometry, output.values[m], scratch, windows, history
            )
            if not math.isnan(phix):
                history = (x, y, phix, phiy, history[0], history[1], history[2], history[3])
