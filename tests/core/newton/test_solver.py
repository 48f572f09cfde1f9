"""core.newton.solver: the Newton solve of Eq. 16 and its warm start, below the public kernels.

The answer must not depend on where Newton starts: from phi = 0 (the paper), from
the minimiser on a subset of the nodes (`_coarse_start`) or from an infeasible
guess (replaced by phi = 0), the minimiser of the full rule is the same to the
Newton tolerance.  The backtracking test must bound the true change of F from above.
"""

from __future__ import annotations

import numpy as np
import pytest
from support.shapes import interior_points

from core.newton import codes, minimisation, quadrature_nodes, solver
from core.newton.solver_state import Directions, Geometry, Output, Settings, Work

TOLERANCE = 1e-11  # of the diameter, as core.kernels.DEFAULT_TOLERANCE


def _problem(curve, x):
    """Directions, 1 / r and normalised harmonic-like weights (Eq. 20) of x, each (N,)."""
    boundary = curve.sample(100)
    offset = boundary.points - x
    r = np.linalg.norm(offset, axis=1)
    omega = (r.min() / r) ** 4
    a = boundary.step * (omega + boundary.step * omega.sum())
    return offset[:, 0] / r, offset[:, 1] / r, 1.0 / r, a / a.sum(), boundary


def _newton(ux, uy, inv_r, a, tolerance, phi):
    work = [np.empty(ux.size) for _ in range(4)]
    return minimisation.newton_steps((ux, uy, inv_r), a, tuple(work), ux.size, tolerance, tuple(phi))


def test_change_bound_is_an_upper_bound_close_to_the_exact_change():
    rng = np.random.default_rng(5)
    count = 500
    angle = rng.uniform(0.0, 2.0 * np.pi, count)
    ux, uy = np.cos(angle), np.sin(angle)
    a = rng.uniform(0.0, 1.0, count)
    inv_s = rng.uniform(0.5, 2.0, count)
    for length in (1e-6, 1e-2, 0.3, 0.9):
        for direction in rng.uniform(0.0, 2.0 * np.pi, 20):
            delta = length * np.array([np.cos(direction), np.sin(direction)])
            z = (delta[0] * ux + delta[1] * uy) * inv_s
            alpha = min(1.0, 0.999 / -z.min()) if z.min() <= -1.0 else 1.0
            exact = -(a * np.log1p(alpha * z)).sum()
            bound = minimisation.change_bound(a, ux, uy, inv_s, delta[0], delta[1], alpha, count)
            scale = (a * np.abs(alpha * z)).sum()
            assert bound >= exact - 1e-15 * scale
            # The polynomial bounds are off by at most |z|^3 / 3 (z >= 0) or
            # |z|^3 / (3 (1 + z)) <= 2 |z|^3 / 3 (-1/2 <= z < 0); below -1/2 exact.
            assert bound <= exact + (a * np.abs(alpha * z) ** 3).sum() * 2.0 / 3.0 + 1e-15 * scale


def test_an_infeasible_start_falls_back_to_phi_zero(blob):
    x = interior_points(blob, 5, seed=3)
    for point in x:
        ux, uy, inv_r, a, _ = _problem(blob, point)
        tolerance = TOLERANCE * blob.diameter
        _, status, _, *cold, _ = _newton(ux, uy, inv_r, a, tolerance, (0.0, 0.0))
        _, infeasible_status, _, *fallback, _ = _newton(ux, uy, inv_r, a, tolerance, (3.0, -2.0))
        assert status == infeasible_status == codes.STATUS_CONVERGED
        np.testing.assert_allclose(fallback, cold, rtol=0.0, atol=1e-12)


def test_coarse_warm_start_reaches_the_full_minimiser_in_fewer_steps(blob):
    x = interior_points(blob, 40, seed=4, margin=0.1)
    tolerance = TOLERANCE * blob.diameter
    cold_steps, warm_steps = [], []
    for point in x:
        ux, uy, inv_r, a, boundary = _problem(blob, point)
        spacing = np.linalg.norm(np.diff(boundary.points, axis=0, append=boundary.points[:1]), axis=1).max()
        separation = (1.0 / inv_r.max()) / spacing
        coarse = tuple(np.empty(ux.size) for _ in range(8))
        start = minimisation.coarse_start(
            Directions(ux, uy, inv_r), a, ux.size, separation, coarse, tolerance, (0.0, 0.0)
        )  # as the solver calls it (a plain tuple would be compiled again, ~1.5 CPU-s)
        assert start != (0.0, 0.0), "points this far from the boundary get a coarse start"
        assert (1.0 + start[0] * ux + start[1] * uy).min() > 0.0  # feasible for the full rule
        cold, status, residual, *phi, d = _newton(ux, uy, inv_r, a, tolerance, (0.0, 0.0))
        warm, warm_status, warm_residual, *warm_phi, _ = _newton(ux, uy, inv_r, a, tolerance, start)
        assert status == warm_status == codes.STATUS_CONVERGED
        assert max(residual, warm_residual) <= tolerance
        s = 1.0 + phi[0] * ux + phi[1] * uy
        # D of Eq. 17 comes back at the returned phi: Eq. 17's normaliser needs no pass of its own.
        assert abs(d - (a * inv_r / s).sum()) <= 1e-14 * d
        # Both meet |grad F| / D <= tolerance, so they differ by at most
        # 2 tolerance D / lambda_min(H) (H, D of Eq. 16 at the minimiser), plus rounding.
        u = np.stack([ux, uy], axis=1)
        hessian = (u.T * (a / s**2)) @ u
        allowed = 2.0 * tolerance * (a * inv_r / s).sum() / np.linalg.eigvalsh(hessian)[0]
        assert np.linalg.norm(np.subtract(warm_phi, phi)) <= allowed + 1e-14
        cold_steps.append(cold)
        warm_steps.append(warm)
    assert max(warm_steps) <= 2
    assert np.median(warm_steps) < np.median(cold_steps)


def test_a_newton_step_within_the_full_step_radius_meets_the_armijo_bound():
    # _newton takes a Newton step delta = -H^-1 g with |delta| <= FULL_STEP (1 - |phi|) without
    # its trial pass: the trial's log-free bound -sum a z + sum a z^2 max(1, s / s') / 2 must
    # then meet the Armijo condition g . delta ARMIJO for sure.  Random problems of Eq. 16
    # (weights over six decades, phi anywhere in the unit disk); the steps near the
    # radius are the hard cases, and there must be some.
    rng = np.random.default_rng(7)
    count = 64
    near_the_edge = 0
    for _ in range(4000):
        angle = rng.uniform(0.0, 2.0 * np.pi, count)
        ux, uy = np.cos(angle), np.sin(angle)
        a = 10.0 ** rng.uniform(-6.0, 0.0, count)
        phi = np.sqrt(rng.uniform(0.0, 0.9)) * np.array([np.cos(angle[0]), np.sin(angle[0])])
        phi = -phi if rng.uniform() < 0.5 else phi
        s = 1.0 + phi[0] * ux + phi[1] * uy
        if s.min() <= 0.0:
            continue
        g = -np.array([(a * ux / s).sum(), (a * uy / s).sum()])
        h = a / s**2
        hessian = np.array(
            [[(h * ux * ux).sum(), (h * ux * uy).sum()], [(h * ux * uy).sum(), (h * uy * uy).sum()]]
        )
        delta = -np.linalg.solve(hessian, g)
        radius = minimisation.FULL_STEP * (1.0 - np.linalg.norm(phi))
        if np.linalg.norm(delta) > radius:
            continue
        near_the_edge += np.linalg.norm(delta) > 0.5 * radius
        z = (delta[0] * ux + delta[1] * uy) / s
        assert z.min() > -1.0  # feasible
        bound = -(a * z).sum() + 0.5 * (a * z * z * np.maximum(1.0, 1.0 / (1.0 + z))).sum()
        slope = g @ delta
        assert bound <= minimisation.ARMIJO * slope
    assert near_the_edge >= 20


def test_the_graded_side_solves_its_end_spacing_equation():
    # _graded_side picks m intervals and the sinh scale s' <= scale with
    # sqrt(s'^2 + edge^2) asinh(edge / s') = m h: the rule t = s' sinh(sigma), sigma = i dsigma,
    # ends at the window edge with the node spacing of the samples there.
    rng = np.random.default_rng(11)
    for _ in range(300):
        step = 10.0 ** rng.uniform(-3.0, -1.0)
        edge = step * rng.uniform(2.0, 40.0)
        scale = edge * 10.0 ** rng.uniform(-12.0, 0.0)
        intervals, sinh_scale, sigma_step = quadrature_nodes.graded_side(edge, scale, step)
        if intervals == quadrature_nodes.MAX_WINDOW_NODES // 2 - 1:
            continue  # over the node budget: no exact end spacing (documented)
        assert 0.0 < sinh_scale <= scale
        length = np.hypot(sinh_scale, edge) * np.arcsinh(edge / sinh_scale)
        assert abs(length - intervals * step) <= 1e-13 * intervals * step
        np.testing.assert_allclose(sinh_scale * np.sinh(intervals * sigma_step), edge, rtol=1e-13)


def test_the_peak_scan_is_skipped_only_where_it_passes_for_sure(blob):
    # _maximum_likelihood skips the scan for the peak of 1 / s when spread^2 < 2 (1 - |phi|),
    # spread bounding |u_(k+1) - u_k|; for the samples that is the largest chord over the
    # distance to the nearest sample.  On far points, with weights whose peaks the scan does
    # flag (the unshifted power 8 of Sec. 3.3), the result must be that of the forced scan.
    boundary = blob.sample(100)
    chords = np.linalg.norm(np.roll(boundary.points, -1, axis=0) - boundary.points, axis=1)
    weights = np.full(boundary.count, boundary.step)
    tolerance = TOLERANCE * blob.diameter
    skipped = flagged = 0
    for power in (4.0, 8.0):
        for point in interior_points(blob, 60, seed=12, margin=0.03):
            ux, uy, inv_r, _, _ = _problem(blob, point)
            omega = (inv_r / inv_r.max()) ** power
            a = omega / omega.sum()
            spread = chords.max() * inv_r.max()
            assert spread < 1.0 / quadrature_nodes.NEAR_SPACINGS  # a far point
            results = []
            for bound in (spread, np.inf):
                work = [np.empty(ux.size) for _ in range(5)]
                results.append(
                    minimisation.maximum_likelihood(
                        Work(ux, uy, inv_r, a, *work),
                        weights,
                        boundary.step,
                        ux.size,
                        (tolerance, bound),
                        (0.0, 0.0),
                    )
                )
            np.testing.assert_array_equal(results[0], results[1])  # NaN phi after path-following
            _, status, _, phix, phiy, _ = _newton(ux, uy, inv_r, a, tolerance, (0.0, 0.0))
            if status == codes.STATUS_CONVERGED:
                skipped += spread**2 < 2.0 * (1.0 - np.hypot(phix, phiy))
            flagged += results[1][1] == codes.STATUS_AT_FEASIBLE_EDGE
    assert skipped > 0 and flagged > 0  # both branches are exercised


def _solve_points(curve, x, first=0, stride=1, out=None):
    """`solver.solve_points` of the harmonic-like basis at x (M, 2); returns (G, iterations)."""
    from core import kernels

    boundary = curve.sample(100)
    arrays = kernels.curve_arrays(boundary, codes.OUTPUT_BASIS, curve.n, 1, boundary.step)
    settings = Settings(
        codes.HARMONIC_LIKE, 0.0, 0, codes.OUTPUT_BASIS, 1.0 if boundary.area > 0 else -1.0,
        boundary.diameter, curve.n, TOLERANCE,
    )  # fmt: skip
    geometry = Geometry(boundary.curve.coefficients, boundary.curve.piece_length, boundary.corners)
    count = x.shape[0]
    out = np.zeros((count, curve.n)) if out is None else out
    iterations = np.zeros(count, dtype=np.int64)
    status = np.zeros(count, dtype=np.int64)
    residual = np.zeros(count)
    solver.solve_points(
        x, settings, arrays, geometry, Output(out, iterations, status, residual), first, stride
    )
    return out, iterations


def test_mesh_order_starts_reach_the_cold_minimiser_and_the_thread_split_does_not_matter(blob):
    # Far points start Newton from the last minimisers of their block (_predicted_start): in
    # a mesh's vertex order that saves the coarse solve.  Any start reaches the same minimiser
    # to the Newton tolerance, so G agrees with a shuffled order (no useful neighbours) to
    # about the tolerance; and one thread or two, the blocks are the same: bitwise equal.
    import core

    mesh = core.triangulate(blob, max_edge=0.02 * blob.diameter)
    x = np.ascontiguousarray(mesh.vertices[mesh.interior])
    ordered, iterations = _solve_points(blob, x)
    order = np.random.default_rng(13).permutation(x.shape[0])
    shuffled, cold_iterations = _solve_points(blob, np.ascontiguousarray(x[order]))
    np.testing.assert_allclose(shuffled, ordered[order], rtol=0.0, atol=1e-9)
    # Predicted starts skip the coarse solve and take a step or two more on all N; shuffled, none is.
    assert np.median(iterations) >= 2 and np.median(cold_iterations) == 1
    split = np.zeros_like(ordered)
    for first in (0, 1):
        _solve_points(blob, x, first, 2, out=split)
    np.testing.assert_array_equal(split, ordered)


def test_the_predicted_start_extrapolates_along_the_last_two_points():
    nan = np.nan
    history = (1.0, 0.0, 0.3, 0.1, 0.0, 0.0, 0.2, 0.1)  # phi grows by 0.1 in x per unit
    assert minimisation.predicted_start(2.0, 0.0, history, 1.5) == (pytest.approx(0.4), 0.1, True)
    assert minimisation.predicted_start(1.5, 0.5, history, 1.5)[:2] == pytest.approx((0.35, 0.1))
    # Too far from the last point: phi = 0; the last two too far apart: the last phi, no prediction.
    assert minimisation.predicted_start(3.0, 0.0, history, 1.5) == (0.0, 0.0, False)
    assert minimisation.predicted_start(1.5, 0.0, (1.0, 0.0, 0.3, 0.1, -2.0, 0.0, 0.0, 0.0), 1.5) == (
        0.3,
        0.1,
        False,
    )
    assert minimisation.predicted_start(1.5, 0.0, (1.0, 0.0, 0.3, 0.1, nan, nan, nan, nan), 1.5) == (
        0.3,
        0.1,
        False,
    )
    assert minimisation.predicted_start(0.0, 0.0, (nan,) * 8, 1.5) == (0.0, 0.0, False)
