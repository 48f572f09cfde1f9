"""A point's output row: its weights w_j lambda(x, t_j) lumped onto the N samples (the kernel
values, `core.kernel`) or multiplied by the folded B-spline basis (the basis functions G,
Sec. 4.3)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.curves.arc_length_compiled import natural_parameter, span_first_sample
from core.newton.codes import OUTPUT_BASIS, OUTPUT_SAMPLES
from core.newton.quadrature_nodes import wrap


@njit(cache=True, error_model="numpy")
def output_parameter(coefficients, mode, t):
    """The parameter at which a quadrature node enters the output row: the quadrature's
    own, except that the B-spline basis (OUTPUT_BASIS) of an arc-length curve is
    evaluated at the natural parameter t(s)."""
    if mode == OUTPUT_BASIS and coefficients.shape[2] == 3:
        span, u = natural_parameter(coefficients, t)
        return span + u
    return t


@njit(cache=True, error_model="numpy")
def accumulate(row, mode, value, t, step, count, control_count):
    """Add value * (lumping or basis weights at t) into the output row."""
    if mode == OUTPUT_SAMPLES:
        scaled = t / step
        k = int(math.floor(scaled))
        theta = scaled - k
        k = k % count
        row[k] += value * (1.0 - theta) / step
        if theta > 0.0:
            row[(k + 1) % count] += value * theta / step
    else:
        period = float(control_count)
        t = t - math.floor(t / period) * period
        segment = min(int(t), control_count - 1)  # t >= 0 here
        u = t - segment
        # The neighbouring spans, cyclically, without integer modulo (this runs per node).
        before = segment - 1 if segment > 0 else control_count - 1
        after = segment + 1 if segment + 1 < control_count else 0
        row[before] += value * 0.5 * (1.0 - u) * (1.0 - u)
        row[segment] += value * 0.5 * (-2.0 * u * u + 2.0 * u + 1.0)
        row[after] += value * 0.5 * u * u


@njit(cache=True, error_model="numpy")
def accumulate_nodes(row, settings, samples, coefficients, a, t, total, runs_used):
    """`accumulate` of a_j at the output parameter of every node t_j, j < total (each (total,)).

    For the B-spline basis (OUTPUT_BASIS) the `run_count` runs of uniform samples
    (`refined_nodes`) are folded with the samples' stored basis values
    (`_fold_run`); for the other nodes the three weights of a run of nodes on one
    span are summed in registers and added to the row when the span changes: the
    nodes come in increasing t but for the wrap and the appended corners, so this is
    a few additions per span instead of three read-modify-writes of the row per node.
    `settings`, `samples` (`solver_state`) and the curve's `coefficients` as in
    `core.newton.solver.solve_points`; `runs_used` = (runs, run_count).
    """
    mode, control_count = settings.mode, settings.control_count
    runs, run_count = runs_used
    count, step, out_step = samples.rule.x.shape[0], samples.step, samples.out_step
    period = count * step
    out_count = int(round(count * step / out_step))
    if mode != OUTPUT_BASIS:
        for j in range(total):
            accumulate(row, mode, a[j], wrap(t[j], period), out_step, out_count, control_count)
        return
    current = np.int64(-1)  # not a literal: one specialisation of _add_span
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    spans = float(control_count)
    arc_length = coefficients.shape[2] == 3  # a call per node costs more than the rest
    j = 0
    for r in range(run_count + 1):
        stop = runs[r, 0] if r < run_count else total
        for node in range(j, stop):
            # Most nodes are in range already: math.floor costs a library call, skip it.
            tj = t[node]
            if not 0.0 <= tj < period:
                tj = wrap(tj, period)
            if arc_length:
                tj = output_parameter(coefficients, mode, tj)
            if not 0.0 <= tj < spans:
                tj = wrap(tj, spans)
            segment = min(int(tj), control_count - 1)  # tj >= 0 here
            if segment != current:
                if current >= 0:
                    _add_span(row, current, control_count, s0, s1, s2)
                current = segment
                s0 = 0.0
                s1 = 0.0
                s2 = 0.0
            u = tj - segment
            value = 0.5 * a[node]
            s0 += value * (1.0 - u) * (1.0 - u)
            s1 += value * (-2.0 * u * u + 2.0 * u + 1.0)
            s2 += value * u * u
        if r < run_count:
            if current >= 0:
                _add_span(row, current, control_count, s0, s1, s2)
            current = -1
            _fold_run(row, a, runs[r, 0], runs[r, 1], runs[r, 2], control_count, coefficients, samples)
            j = runs[r, 0] + runs[r, 2]
    if current >= 0:
        _add_span(row, current, control_count, s0, s1, s2)


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def _fold_run(row, a, first, sample, length, control_count, coefficients, samples):
    """row_i += sum a_node N_i(t_k) over a run of uniform samples k = sample, sample + 1, ...
    (mod N) at nodes first, first + 1, ... (`length` of them), with the samples'
    stored basis values (basis0..2 of `samples`, see `fold_onto_basis`).
    """
    count = samples.rule.x.shape[0]
    basis0, basis1, basis2, step = samples.basis0, samples.basis1, samples.basis2, samples.step
    sample = sample % count
    while length > 0:  # at most twice: the run may wrap past sample N - 1
        end = min(count, sample + length)
        span = _span_of_sample(coefficients, count, control_count, step, sample)
        k = sample
        while k < end:
            stop = min(end, span_first_sample(coefficients, count, control_count, step, span + 1))
            offset = first - sample
            span_a = a[k + offset : stop + offset]
            span0 = basis0[k:stop]
            span1 = basis1[k:stop]
            span2 = basis2[k:stop]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for i in range(span_a.shape[0]):
                s0 += span_a[i] * span0[i]
                s1 += span_a[i] * span1[i]
                s2 += span_a[i] * span2[i]
            _add_span(row, span, control_count, s0, s1, s2)
            k = stop
            span += 1
        first += end - sample
        length -= end - sample
        sample = 0


@njit(cache=True, error_model="numpy")
def _span_of_sample(coefficients, count, control_count, step, k):
    """The span whose samples (`span_first_sample`) include sample k, 0 <= k < count."""
    span = min(k * control_count // count, control_count - 1)
    while span > 0 and span_first_sample(coefficients, count, control_count, step, span) > k:
        span -= 1
    while span_first_sample(coefficients, count, control_count, step, span + 1) <= k:
        span += 1
    return span


@njit(cache=True, error_model="numpy")
def _add_span(row, segment, control_count, s0, s1, s2):
    """Add the sums s0, s1, s2 of a span's nodes to N_(segment-1), N_segment, N_(segment+1) (cyclic)."""
    before = segment - 1 if segment > 0 else control_count - 1
    after = segment + 1 if segment + 1 < control_count else 0
    row[before] += s0
    row[segment] += s1
    row[after] += s2


@njit(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})
def fold_onto_basis(row, a, inv_r, inv_s, factor, samples, control_count, coefficients):
    """row_i += sum_k c_k N_i(t_k) over the N uniform samples (Sec. 4.3), shape (n,).

    c_k = factor a_k inv_r_k inv_s_k: for the maximum-likelihood kernels 1 / r_k,
    1 / s_k and factor = 1 / D (Eq. 14 and 17), so that the kernel needs no pass of
    its own; for the explicit kernels, whose `a` is the kernel, arrays of ones (a
    flag choosing the product would stop the loop vectorising).  The samples of
    span j (`span_first_sample`: N / n of them in the natural parameter, as many as
    its share of the length in arc length) touch only N_(j-1), N_j and N_(j+1),
    whose values at the samples are basis0, basis1 and basis2, each (N,).
    """
    basis0, basis1, basis2, step = samples.basis0, samples.basis1, samples.basis2, samples.step
    count = basis0.shape[0]
    first = 0  # span 0 starts at sample 0 in either parameter
    for j in range(control_count):
        last = span_first_sample(coefficients, count, control_count, step, j + 1)
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        # Views and an index from 0: a computed index first + i might be negative for all
        # numba knows, and the wrap-around check per element stops the loop vectorising.
        span_a = a[first:last]
        span_r = inv_r[first:last]
        span_s = inv_s[first:last]
        span0 = basis0[first:last]
        span1 = basis1[first:last]
        span2 = basis2[first:last]
        for i in range(span_a.shape[0]):
            c = span_a[i] * span_r[i] * span_s[i]
            s0 += c * span0[i]
            s1 += c * span1[i]
            s2 += c * span2[i]
        first = last
        row[(j - 1) % control_count] += factor * s0
        row[j] += factor * s1
        row[(j + 1) % control_count] += factor * s2
