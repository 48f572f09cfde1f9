"""The quadrature of one point, shared by the value solver (`core.newton.solver.solve_point`)
and the gradient solver (`core.newton.gradient_solver`): where the point is (outside, on the
boundary, far, near) and, for a near point or the corners' point masses, its nodes.

Pass 1 takes the directions to the uniform samples and, for a point near the boundary, the
stretches closer than `NEAR_SPACINGS` sample spacings (`quadrature_nodes.near_stretches`);
the closest parameter in each decides whether the point is on the boundary (its Lagrange
limit) or outside, else the refined rule is built there (`quadrature_nodes.refined_nodes`)
and pass 2 evaluates the curve at its nodes (`quadrature_nodes.node_geometry`).
"""

from __future__ import annotations

from numba import njit

from core.curves.closest_parameter import closest_parameter, side_of_curve
from core.curves.crossing_slabs import inside_polygon
from core.newton.codes import LAPLACE, WACHSPRESS
from core.newton.quadrature_nodes import (
    MAX_WINDOWS,
    directions,
    largest,
    merge_windows,
    near_stretches,
    node_geometry,
    refined_nodes,
    sample_directions,
)

# Points closer than this (relative to the diameter) are on the boundary: Lagrange limit.
ON_BOUNDARY = 1e-12

#: What `point_rule` found: the point is outside (its distance), a far point takes the plain
#: trapezoid rule on the samples (its distance to the nearest sample), the point is on the
#: boundary (its closest parameter), the nodes are built (their r_min).
RULE_OUTSIDE, RULE_SAMPLES, RULE_ON_BOUNDARY, RULE_NODES = 0, 1, 2, 3


# Inlined into its callers, as `solver.solve_point` is into `solver.solve_points`.
@njit(cache=True, error_model="numpy", inline="always")
def point_rule(point, settings, samples, geometry, scratch, windows):
    """The rule of `point` = (x, y); returns (rule, value, nodes, run_count).

    RULE_OUTSIDE: `value` is the distance to the boundary.  RULE_SAMPLES: a far point
    without corner masses, the directions to the N samples are in `scratch.work` (u_x, u_y,
    1 / r) and `value` is the distance to the nearest sample.  RULE_ON_BOUNDARY: `value` is
    the closest parameter (not wrapped into the period).  RULE_NODES: `nodes` nodes and then
    the corner masses of the three-point kernels are in `scratch.nodes` and `scratch.t`, with
    their directions, `run_count` runs of uniform samples in `windows.runs`, and `value` is
    r_min.  The arguments are those of `solver.solve_point`.
    """
    x, y = point
    sample_x, sample_y, spacing, slabs = samples.rule.x, samples.rule.y, samples.spacing, samples.slabs
    sample_t, step = samples.t, samples.step
    coefficients, piece_length, corners = geometry
    window_start, window_stop, window_t, window_d, runs = windows
    px, py, w, t = scratch.nodes.x, scratch.nodes.y, scratch.nodes.weight, scratch.t
    ux, uy, inv_r = scratch.work.ux, scratch.work.uy, scratch.work.inv_r
    count = sample_x.shape[0]
    # Pass 1: directions to the samples and, for a point near the boundary, the
    # stretches closer than NEAR_SPACINGS (found in a second, sequential scan).
    near = sample_directions(sample_x, sample_y, spacing, x, y, ux, uy, inv_r)
    nearest = 1.0 / largest(inv_r, count) if near == 0 else 1e300
    window_count, nearest_index, nearest = near_stretches(
        sample_x, sample_y, spacing, x, y, near, nearest, windows
    )
    window_count = merge_windows(
        window_start, window_stop, min(window_count, MAX_WINDOWS), count, nearest_index
    )
    three_point = settings.kernel == WACHSPRESS or settings.kernel == LAPLACE
    corner_count = corners.shape[0] if three_point else 0
    if window_count == 0:
        if not inside_polygon(sample_x, sample_y, slabs, x, y):
            return RULE_OUTSIDE, nearest, 0, 0
        if corner_count == 0:
            return RULE_SAMPLES, nearest, 0, 0
        nodes = 0
        for k in range(count):
            t[nodes] = sample_t[k]
            w[nodes] = step
            nodes += 1
        runs[0, 0] = 0  # every sample, one run
        runs[0, 1] = 0
        runs[0, 2] = count
        run_count = 1
    else:
        closest_t = nearest_index * step
        closest_d = nearest
        for i in range(window_count):
            ti, di = closest_parameter(
                coefficients, piece_length, x, y, window_start[i] * step, window_stop[i] * step
            )
            window_t[i] = ti
            window_d[i] = di
            if di < closest_d:
                closest_d = di
                closest_t = ti
        if closest_d <= ON_BOUNDARY * settings.diameter:
            return RULE_ON_BOUNDARY, closest_t, 0, 0
        if side_of_curve(coefficients, piece_length, closest_t, x, y, settings.orientation) < 0:
            return RULE_OUTSIDE, closest_d, 0, 0
        nodes = refined_nodes(windows, window_count, samples, geometry, t, w)
        run_count = window_count
    # Pass 2 (near points, corners): the nodes' curve data and directions.
    node_geometry(t, scratch.nodes, nodes, runs, run_count, samples, geometry, corner_count)
    r_min = directions(px, py, x, y, nodes, ux, uy, inv_r)
    return RULE_NODES, r_min, nodes, run_count
