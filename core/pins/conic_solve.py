"""The pins' map under a distortion bound: a second-order cone program (clarabel), over BDHM's active set.

With k = (K - 1) / (K + 1) and x as in `core.pins.linear_rows`, the program is

    minimise    W_PIN |pins(x) - targets|² + |departure(x)|²
    subject to  hard rows (fixed control points; a = 1, b = 0 for one pin),
                Re(f_z(z_j) conj(e_j)) >= FLOOR |A|                 (a linear inequality),
                |f_z̄(z_j)| <= k Re(f_z(z_j) conj(e_j))              (a 3-dimensional cone)

at the active samples z_j of Γ, e_j the sample's frame (Chen & Weber 2015, Sec. 5: the
non-convex |f_z̄| <= k |f_z| is replaced by its convex subset around a chosen direction of f_z).
(A the linear part of the pins' best similarity).
Both imply |f_z̄| <= k |f_z| and |f_z| >= FLOOR |A| there, so det J = |f_z|² - |f_z̄|² > 0 and
σ₁ / σ₂ = (1 + k') / (1 - k') <= K with k' = |f_z̄| / |f_z|.  The pins are a penalty `W_PIN` times
the departure's weight, so they land as close as the bound allows (to about 1 / W_PIN of the
diameter) and the departure decides the rest.  Cauchy-Green maps are holomorphic (f_z̄ = 0): only
the inequality applies.

Rounds (`ROUNDS` at most): solve; evaluate f_z, f_z̄ at every sample of Γ; samples where the bound
fails join the active set (BDHM's active set); every sample's frame becomes the direction of its
f_z in the solution (which keeps the solution feasible, so the objective cannot rise).  A solve
that settles (the certified one) stops when no sample fails and the objective fell by less than
`SETTLED` in the last round or the frames barely turned.  At drag rate (BDHM's interactive solve,
warm-started across a drag's solves by the kept active set, frames and limits) one program is
solved, again only while a sample fails its own bound; where the strip beside a pair of samples
exceeds the bound, their limits drop and the higher joins the active set for the next solve.

The unknowns are x and the pins' residuals (2m): the cone rows are dense in the 2n target
coordinates only (each costs clarabel's factorisation about (2n)² a row), and a sample's floor row
is held only where |f_z| came near the floor (`FLOOR_NEAR`).
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from core.injectivity.boundary_samples import STRIP_SAFETY
from core.injectivity.inner_curve import DEEPER
from core.pins.precompute import PinPrecompute

#: Weight of the pins' squared error against the departure energy (both in normalised units).
W_PIN = 1e5
#: Smallest Re(f_z conj(e)) at a sample, as a fraction of |A| of the pins' best similarity
#: z -> A z + t: the picture shrinks there at most 1 / FLOOR times more than the pins ask of it as a
#: whole (like BDHM's lower bound of σ₂; without it a curved cage can hide a hairpin of its boundary
#: in the thin strip outside Γ).
FLOOR = 0.25
#: Rounds of active set and frame updates; they end when the objective fell by less than `SETTLED`
#: (relative) or no frame turned by more than `FRAME_SETTLED` radians (a drag's next solve goes on).
ROUNDS = 10
SETTLED = 1e-2
FRAME_SETTLED = 0.02
#: The program holds a sample's floor row once its |f_z| came within this factor of the floor
#: (elsewhere the cone alone keeps Re(f_z conj(e)) >= 0, and a quarter of the rows are saved).
FLOOR_NEAR = 3.0
#: Clarabel's gap and feasibility tolerances (relative to the objective, which is >= 0), for a
#: solve that settles (the certified one) and for one at drag rate: the drag's pins land within a
#: few hundredths of a pixel at 1e-5 too, in 10-13 interior-point iterations instead of 12-18.
TOLERANCE = 1e-7
DRAG_TOLERANCE = 1e-5
#: A sample outside the active set joins it when it exceeds its bound by more than this fraction:
#: the active samples, held exactly at their bound, keep their neighbours within it, and the active
#: set stays small (the program's cost grows with it).  The first bound is below the goal by more
#: (`core.pins.pin_deform.FIRST_MARGIN`), and the certificate has the last word.
CHECK_SLACK = 0.05
#: k across the strip between Γ and the boundary is taken to be at most the larger of a sample's and
#: its deeper companion's plus `STRIP_RATE` times their difference (the certificate's A3); where that
#: exceeds k, both samples' own bounds drop by `STRIP_TIGHTEN` times the excess, to at least
#: `LOWEST_LIMIT` k.
STRIP_RATE = STRIP_SAFETY / (DEEPER - 1.0)
STRIP_TIGHTEN = 1.5
LOWEST_LIMIT = 0.25


def bounded_solution(
    precompute: PinPrecompute, pin_rows: np.ndarray, targets: np.ndarray, hard_rows: np.ndarray,
    hard_values: np.ndarray, k: float, similarity: complex, settle: bool = True,
) -> tuple[np.ndarray, int]:  # fmt: skip
    """The solution x (2n + 4,) and the number of cone programs solved.

    Parameters as `core.pins.exact_solve.exact_solution`'s, with `k` the bound on |f_z̄| / |f_z| at
    the samples and `similarity` the linear part A of the pins' best similarity: it meets the bound, its
    direction is every sample's frame when the kept frames leave the program infeasible, and
    `FLOOR` |A| is the floor of Re(f_z conj(e)).  `settle`: rounds until the objective settles, the
    strip's excess solved away (for the certificate); False: at drag rate (see the module's text).

    Raises
    ------
    ValueError
        When no map meets the bound with the hard rows (fixed control points) held.
    """
    import clarabel  # here, not at the top: `import core` (and the package's build) does without it

    width, residuals = pin_rows.shape[1], pin_rows.shape[0]
    # The pins' residuals r = pins(x) - targets are unknowns too: the objective is then
    # W_PIN |r|² + |departure(x)|² >= 0, without the constant -W_PIN |targets|² that made the
    # solver's relative gap tolerance a loose absolute one.
    objective_matrix = sparse.block_diag(
        [sparse.csc_matrix(np.triu(2.0 * precompute.departure.T @ precompute.departure)),
         sparse.identity(residuals) * (2.0 * W_PIN)],
        format="csc",
    )  # fmt: skip
    linear = np.zeros(width + residuals)
    hard_rows = np.block(
        [[hard_rows, np.zeros((hard_rows.shape[0], residuals))], [pin_rows, -np.eye(residuals)]]
    )
    hard_values = np.concatenate([hard_values, targets])
    floor = FLOOR * abs(similarity)
    limits = precompute.limits_for(k)
    paired = np.flatnonzero(precompute.companion >= 0)
    partner = precompute.companion[paired]
    previous, solves, reset = np.inf, 0, False
    x = None
    for _ in range(ROUNDS):
        solution = _solved(
            precompute, objective_matrix, linear, hard_rows, hard_values, limits, floor,
            TOLERANCE if settle else DRAG_TOLERANCE,
        )  # fmt: skip
        solves += 1
        if solution.status not in (clarabel.SolverStatus.Solved, clarabel.SolverStatus.AlmostSolved):
            if reset:
                raise ValueError(
                    f"no map keeps the distortion within the bound (k = {k:.3g}) with the fixed control "
                    "points where they are"
                )
            precompute.frames[:] = similarity / abs(similarity)
            reset = True
            continue
        x = np.asarray(solution.x)[:width]
        f_z = precompute.f_z[0] @ x + 1j * (precompute.f_z[1] @ x)
        f_zbar = precompute.f_zbar[0] @ x + 1j * (precompute.f_zbar[1] @ x)
        size = np.abs(f_z)
        low = size < floor * (1.0 - CHECK_SLACK)
        failing = (np.abs(f_zbar) > limits * (1.0 + CHECK_SLACK) * size) | low
        # Samples below the floor that the program did not hold there, and those outside the active set.
        own_failing = (failing & ~precompute.active) | (low & ~precompute.floored)
        precompute.floored |= size < FLOOR_NEAR * floor
        strip = _strip_ratios(precompute, f_z, f_zbar, floor)
        over = strip > k * (1.0 + CHECK_SLACK)
        for rows in (paired[over], partner[over]):
            lowered = limits[rows] - STRIP_TIGHTEN * (strip[over] - k)
            limits[rows] = np.maximum(np.minimum(limits[rows], lowered), LOWEST_LIMIT * k)
        # The higher of the two ratios sets the strip's bound: that sample joins the active set.
        ratio = np.abs(f_zbar) / np.maximum(size, floor)
        failing[paired[over & (ratio[paired] >= ratio[partner])]] = True
        moving = size > 0
        turn = np.abs(np.angle(f_z[moving] / precompute.frames[moving]))
        precompute.frames[moving] = f_z[moving] / size[moving]
        # At drag rate (not `settle`) a strip over its bound tightens the next solve, not this one.
        again = own_failing.any() or (settle and over.any())
        precompute.active |= failing
        if again:
            continue
        objective = solution.obj_val
        if not settle or (
            previous - objective <= SETTLED * objective or turn.max(initial=0.0) < FRAME_SETTLED
        ):
            break
        previous = objective
    if x is None:
        raise ValueError(f"the cone solver found no map within the distortion bound (k = {k:.3g})")
    return x, solves


def meets_bound(precompute: PinPrecompute, x: np.ndarray, k: float, similarity: complex) -> bool:
    """Whether a solution x (2n + 4,) meets the program's bounds at every sample (its frames the
    directions of its own f_z): the exact solution, when it does, is the answer."""
    f_z = precompute.f_z[0] @ x + 1j * (precompute.f_z[1] @ x)
    f_zbar = precompute.f_zbar[0] @ x + 1j * (precompute.f_zbar[1] @ x)
    floor = FLOOR * abs(similarity)
    return bool(
        np.all(np.abs(f_z) >= floor)
        and np.all(np.abs(f_zbar) <= k * np.abs(f_z))
        and np.all(_strip_ratios(precompute, f_z, f_zbar, floor) <= k)
    )


def _strip_ratios(precompute: PinPrecompute, f_z, f_zbar, floor: float) -> np.ndarray:
    """The strip's bound of k beside each sample of Γ that has a companion (`STRIP_RATE`)."""
    paired = np.flatnonzero(precompute.companion >= 0)
    partner = precompute.companion[paired]
    ratio = np.abs(f_zbar) / np.maximum(np.abs(f_z), floor)
    return np.maximum(ratio[paired], ratio[partner]) + STRIP_RATE * np.abs(ratio[paired] - ratio[partner])


def _solved(
    precompute: PinPrecompute, objective_matrix, linear, hard_rows, hard_values, limits, floor: float,
    tolerance: float,
):  # fmt: skip
    """Clarabel's solution of the program over the current active set and frames."""
    import clarabel

    active = np.flatnonzero(precompute.active)
    frames = precompute.frames[active]
    along = (
        frames.real[:, None] * precompute.f_z[0][active] + frames.imag[:, None] * precompute.f_z[1][active]
    )
    padding = np.zeros((active.size, hard_rows.shape[1] - along.shape[1]))
    along = np.hstack([along, padding])
    floored = precompute.floored[active]
    blocks, values = [hard_rows, -along[floored]], [hard_values, np.full(floored.sum(), -floor)]
    cones = [clarabel.ZeroConeT(hard_rows.shape[0]), clarabel.NonnegativeConeT(int(floored.sum()))]
    if precompute.kernel == "poisson":
        cone_rows = np.stack(
            [
                limits[active, None] * along,
                np.hstack([precompute.f_zbar[0][active], padding]),
                np.hstack([precompute.f_zbar[1][active], padding]),
            ],
            axis=1,
        )
        blocks.append(-cone_rows.reshape(-1, along.shape[1]))
        values.append(np.zeros(3 * active.size))
        cones.extend(clarabel.SecondOrderConeT(3) for _ in range(active.size))
    constraints = sparse.csc_matrix(np.vstack(blocks))
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = tolerance
    # One thread with QDLDL, and no iterative refinement: a third of the time of clarabel's default
    # (faer on every core) on these small, dense programs, on a shared machine too.
    settings.direct_solve_method, settings.max_threads = "qdldl", 1
    settings.iterative_refinement_enable = False
    solver = clarabel.DefaultSolver(
        objective_matrix, linear, constraints, np.concatenate(values), cones, settings
    )
    return solver.solve()


__all__ = ["FLOOR", "W_PIN", "bounded_solution", "meets_bound"]
