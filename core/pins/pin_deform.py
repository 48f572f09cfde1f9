"""Pins in the picture: `pin_deform`, the cage target that takes pins to where they were moved,
with a distortion bound the user sets, and its certificate.

The map is the harmonic (``"poisson"``) or Cauchy-Green map f = G Q of the cage onto target
control points Q, linear in Q (`core.basis_functions`).  What is solved:

- one pin: the translation that places it; two pins: the similarity that places both (exactly:
  Q = A P + t, so f = A x + t by linear precision); more pins: the Q of least departure from a
  similarity (the mean squared distance of Q from S(P) + t, minimised over the similarity too)
  among those that place all the pins (`core.pins.exact_solve`).  When the cage cannot place them
  all (more pins than it can follow apart, or fixed points in the way) the pins' least-squares
  images are placed instead, and `missed` says which pins miss and `pin_error` by how much;
- with ``max_distortion=K``: σ₁/σ₂ <= K and det J > 0 in the whole domain, the pins as close as
  that allows (`core.pins.conic_solve`: BDHM's cones at the active samples of the curve Γ inside
  the boundary).  Between the samples the bound is proven, not assumed: the result is certified
  (`core.certify_injective`: the argument principle and the maximum principle of ω = f_z̄ / f_z
  on Γ, with bounds between samples and across the strip to the boundary); where the certificate's
  bound k_max exceeds (K - 1) / (K + 1) the samples' bound is tightened by more than the excess
  and the program solved again (`CERTIFY_ROUNDS` at most).  K = 1 with the Poisson kernel and no
  fixed point is the pins' best similarity (the only harmonic maps of a generic curved cage
  without distortion).
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.injectivity.certificate import InjectivityCertificate, certify_injective
from core.pins.conic_solve import bounded_solution, meets_bound
from core.pins.exact_solve import best_similarity, exact_solution
from core.pins.linear_rows import control_points
from core.pins.precompute import PinPrecompute, precompute_for
from core.validation import as_points

#: Kernels `pin_deform` solves with.
PIN_KERNELS = ("poisson", "cauchy-green")
#: A pin misses when it lands farther than this fraction of the cage's diameter from its target.
MISS = 1e-5
#: Two pins closer than this fraction of the diameter are at one point.
SAME_POINT = 1e-9
#: Certify-and-tighten rounds, the samples' first bound as a fraction of (K - 1) / (K + 1), and
#: how many times the certificate's excess over (K - 1) / (K + 1) each tightening takes off (and
#: at least this fraction of the samples' bound).
CERTIFY_ROUNDS = 8
FIRST_MARGIN = 0.85
TIGHTEN = 3.0
LEAST_STEP = 0.02
#: The certificate's k_max may exceed (K - 1) / (K + 1) by this much (its own evaluation allowance,
#: `core.injectivity.certificate.EVALUATION`).
K_SLACK = 1e-6


class PinDeformation:
    """What `pin_deform` returns.

    Attributes
    ----------
    target : ndarray of shape (n, 2)
        The target control points.
    pin_error : ndarray of shape (m,)
        Distance of each pin's image from where it was moved, in the cage's units (pixels).
    missed : ndarray of shape (j,), int
        The pins that land farther than `MISS` of the diameter from their targets.
    max_distortion : float or None
        The bound K asked for (None: none).
    solves : int
        Cone programs solved (0 without a bound).
    certificate : InjectivityCertificate
        `core.certify_injective`'s proof for the result (computed on first use without a bound).
    """

    def __init__(self, curve, kernel, target, pin_error, max_distortion, solves, certificate=None):
        self.curve, self.kernel, self.target = curve, kernel, target
        self.pin_error = pin_error
        self.missed = np.flatnonzero(pin_error > MISS * curve.diameter)
        self.max_distortion, self.solves = max_distortion, solves
        if certificate is not None:
            self.certificate = certificate

    @cached_property
    def certificate(self) -> InjectivityCertificate:
        return _certificate(self.curve, self.target, self.kernel)

    @property
    def proven_distortion(self) -> float:
        """The bound of σ₁/σ₂ the certificate proves, (1 + k_max) / (1 - k_max); inf if none."""
        certificate = self.certificate
        if not certificate.injective or not certificate.k_max < 1.0:
            return math.inf
        return (1.0 + certificate.k_max) / (1.0 - certificate.k_max)

    @property
    def within_bound(self) -> bool:
        """Proven injective with σ₁/σ₂ <= `max_distortion` (up to `K_SLACK` on k)."""
        if self.max_distortion is None:
            return self.certificate.injective
        return _proves(self.certificate, _k_bound(self.max_distortion))


def pin_deform(
    curve: ClosedBSpline, pins, moved, *, max_distortion=None, fixed=None, kernel: str = "poisson",
    certify: bool = True,
) -> PinDeformation:  # fmt: skip
    """The cage target that moves `pins` to `moved`, within a distortion bound if one is given.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    pins : array_like of shape (m, 2)
        Points inside the cage, m >= 1, in the cage's coordinates (pixels).
    moved : array_like of shape (m, 2)
        Where each pin goes.
    max_distortion : float, optional
        K >= 1: σ₁/σ₂ <= K and det J > 0 in the whole domain.  None or inf: no bound.
    fixed : sequence of int, or mapping of int to (x, y), optional
        Control points held: at the source's position (a sequence of indices) or at the given one.
    kernel : str
        ``"poisson"`` (harmonic, the default) or ``"cauchy-green"`` (conformal: its maps have
        σ₁ = σ₂, K = 1, everywhere, and the bound only keeps f_z away from zero at the samples).
    certify : bool
        With a bound and the Poisson kernel: certify, tighten and solve again until the certificate
        proves the bound (`CERTIFY_ROUNDS` at most), from the cage's first active set (the result
        depends on the arguments only).  False: the bound holds at the samples of Γ only, the solve
        starts from what the last one on this cage learnt (a drag's frames), and the certificate is
        computed when first read.

    Returns
    -------
    PinDeformation

    Raises
    ------
    ValueError
        One line: a kernel other than `PIN_KERNELS`, a pin outside the cage, two pins at one point,
        non-finite numbers, K < 1, a bad fixed index, or no map within the bound that keeps the fixed
        points.
    """
    if kernel not in PIN_KERNELS:
        raise ValueError(f"pins work with the kernels {' and '.join(PIN_KERNELS)}, not {kernel!r}")
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    pins, moved = _checked_pins(curve, pins, moved)
    bound = _checked_distortion(max_distortion)
    held = _checked_fixed(curve, fixed)
    precompute = precompute_for(curve, kernel)
    if certify:
        # A certified target is a function of its inputs, not of the drag that led to it: the
        # viewer's release and `warp --session` (a fresh process) give the same cage.
        precompute.restart()
    x_rows, y_rows = precompute.pin_rows(pins)
    pin_rows = np.vstack([x_rows, y_rows])
    normalised = precompute.normalised(moved)
    targets = np.concatenate([normalised[:, 0], normalised[:, 1]])
    hard_rows, hard_values = _hard_rows(precompute, held, pins.shape[0])
    linear, translation = best_similarity(precompute.normalised(pins), normalised)
    solves, certificate = 0, None
    rows = (pin_rows, targets, hard_rows, hard_values)
    if bound is None:
        x = exact_solution(*rows, precompute.departure)
    elif bound == 1.0 and kernel == "poisson" and not held:
        x = _similarity(precompute, linear, translation)
    else:
        x, solves, certificate = _bounded(precompute, rows, bound, linear, certify)
    x = _joined_corners(precompute, x)
    target = precompute.cage_coordinates(control_points(x, precompute.n))
    reached = precompute.cage_coordinates(np.stack([x_rows @ x, y_rows @ x], axis=1))
    error = np.linalg.norm(reached - moved, axis=1)
    return PinDeformation(curve, kernel, target, error, bound, solves, certificate)


def _bounded(precompute, rows, bound, linear, certify):
    """Solve under the bound, certify, tighten the samples' bound where the certificate's exceeds it;
    `rows` are the pins' rows and targets and the hard rows and values."""
    goal = _k_bound(bound)
    k = goal * FIRST_MARGIN
    exact = _joined_corners(precompute, exact_solution(*rows, precompute.departure))
    if meets_bound(precompute, exact, k, linear):
        target = precompute.cage_coordinates(control_points(exact, precompute.n))
        certificate = _certificate(precompute.curve, target, precompute.kernel, goal) if certify else None
        if certificate is None or _proves(certificate, goal):
            return exact, 0, certificate
    total, certificate = 0, None
    for round_ in range(CERTIFY_ROUNDS):
        # The first round settles the frames; the tightened rounds after it solve as at drag rate
        # (from those frames), and the certificate judges each.
        x, solves = bounded_solution(precompute, *rows, k, linear, settle=certify and round_ == 0)
        x = _joined_corners(precompute, x)
        total += solves
        if not certify or precompute.kernel != "poisson":
            break
        target = precompute.cage_coordinates(control_points(x, precompute.n))
        certificate = certify_injective(precompute.curve, target, k_goal=goal)
        # At a reflex corner no harmonic map is proven (it folds in a tiny disc there, generically):
        # the bound proven outside the corners' discs is all there is to reach.
        if _proves(certificate, goal) or (
            certificate.away_from_corners and certificate.k_max <= goal + K_SLACK
        ):
            break
        if certificate.injective or certificate.away_from_corners:
            k = max(min(k - TIGHTEN * (certificate.k_max - goal), (1.0 - LEAST_STEP) * k), 0.5 * k)
        else:
            k *= 0.5
            _activate_near(precompute, certificate.where)
    return x, total, certificate


def _proves(certificate: InjectivityCertificate, goal: float) -> bool:
    return certificate.injective and certificate.k_max <= goal + K_SLACK


def _joined_corners(precompute: PinPrecompute, x: np.ndarray) -> np.ndarray:
    """x with the two copies of each doubled control point equal to the bit (the solvers hold them
    equal to rounding; a sharp corner needs them exactly equal)."""
    source, n = precompute.curve.control_points, precompute.n
    doubled = np.flatnonzero(np.all(source == np.roll(source, 1, axis=0), axis=1))
    if doubled.size == 0:
        return x
    x = x.copy()
    for offset in (0, n):
        x[offset + doubled] = x[offset + (doubled - 1) % n]
    return x


def _activate_near(precompute: PinPrecompute, where: np.ndarray) -> None:
    """Add the samples nearest to the points (j, 2) where a certificate failed to the active set."""
    for point in where:
        nearest = int(np.argmin(np.linalg.norm(precompute.points - point, axis=1)))
        precompute.active[max(nearest - 1, 0) : nearest + 2] = True


def _similarity(precompute: PinPrecompute, linear: complex, translation: complex) -> np.ndarray:
    """The solution x of the target Q = A P + t (normalised)."""
    source = precompute.source[:, 0] + 1j * precompute.source[:, 1]
    image = linear * source + translation
    return np.concatenate(
        [image.real, image.imag, [linear.real, linear.imag, translation.real, translation.imag]]
    )


def _certificate(curve: ClosedBSpline, target: np.ndarray, kernel: str, goal=None) -> InjectivityCertificate:
    if kernel == "poisson":
        return certify_injective(curve, target, k_goal=goal)
    return InjectivityCertificate(
        False, 0.0, 0.0, np.zeros((0, 2)),
        "certify_injective proves harmonic (poisson) maps; a Cauchy-Green map is conformal (k = 0) by "
        "construction, and f_z is kept from zero at the samples of Γ only",
    )  # fmt: skip


def _hard_rows(precompute: PinPrecompute, held: dict, pin_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows (h, 2n + 4) and values (h,) that hold exactly: fixed control points, the similarity's
    linear part 1 for a single pin (its best similarity is a translation), and the two copies of
    each doubled control point (a sharp corner) together."""
    n = precompute.n
    rows, values = [], []
    for index, point in held.items():
        x, y = precompute.normalised(point)
        rows.extend([np.eye(1, 2 * n + 4, index)[0], np.eye(1, 2 * n + 4, n + index)[0]])
        values.extend([x, y])
    if pin_count == 1:
        rows.extend([np.eye(1, 2 * n + 4, 2 * n)[0], np.eye(1, 2 * n + 4, 2 * n + 1)[0]])
        values.extend([1.0, 0.0])
    source = precompute.curve.control_points
    for j in np.flatnonzero(np.all(source == np.roll(source, 1, axis=0), axis=1)):
        for offset in (0, n):  # a sharp corner (a doubled point) stays one
            row = np.zeros(2 * n + 4)
            row[offset + j], row[offset + (j - 1) % n] = 1.0, -1.0
            rows.append(row)
            values.append(0.0)
    return np.array(rows).reshape(-1, 2 * n + 4), np.array(values, dtype=np.float64)


def _k_bound(bound: float) -> float:
    return (bound - 1.0) / (bound + 1.0)


def _checked_pins(curve: ClosedBSpline, pins, moved) -> tuple[np.ndarray, np.ndarray]:
    pins = as_points(pins, "pins", min_count=1)
    moved = as_points(moved, "moved", min_count=1)
    if moved.shape != pins.shape:
        raise ValueError(f"moved must give one point per pin: {pins.shape[0]} pins, {moved.shape[0]} moved")
    outside = np.flatnonzero(~curve.contains(pins))
    if outside.size:
        j = int(outside[0])
        raise ValueError(f"pin {j} at ({pins[j, 0]:.6g}, {pins[j, 1]:.6g}) is outside the cage")
    gaps = np.linalg.norm(pins[:, None] - pins[None], axis=2)
    np.fill_diagonal(gaps, np.inf)
    close = np.argwhere(gaps <= SAME_POINT * curve.diameter)
    if close.size:
        i, j = sorted(close[0])
        raise ValueError(f"pins {i} and {j} are at one point ({pins[i, 0]:.6g}, {pins[i, 1]:.6g})")
    return pins, moved


def _checked_distortion(value) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool):
        raise ValueError(f"max_distortion must be a number >= 1, got {value!r}")
    try:
        bound = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"max_distortion must be a number >= 1, got {value!r}") from None
    if math.isnan(bound) or bound < 1.0:
        raise ValueError(f"max_distortion must be a number >= 1 (σ₁/σ₂ is never below 1), got {value!r}")
    return None if math.isinf(bound) else bound


def _checked_fixed(curve: ClosedBSpline, fixed) -> dict[int, np.ndarray]:
    """`fixed` as a mapping of control point index to its held position (2,)."""
    if fixed is None:
        return {}
    items = fixed.items() if isinstance(fixed, dict) else ((index, None) for index in fixed)
    held = {}
    for index, point in items:
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < curve.n:
            raise ValueError(f"fixed control point {index!r} is not an index from 0 to {curve.n - 1}")
        position = (
            curve.control_points[index] if point is None else as_points(point, f"fixed point {index}")[0]
        )
        held[int(index)] = position
    return held


__all__ = ["PIN_KERNELS", "PinDeformation", "pin_deform"]
