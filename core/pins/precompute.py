"""What `core.pin_deform` computes once per cage: samples on the curve Γ inside the boundary, with
the rows of f_z and f_z̄ there, and the solver's state between drags (`PinPrecompute`).

The samples lie on the certificate's curve Γ (`core.injectivity.inner_curve`: offset pieces a
thousandth of the diameter inside the boundary, arcs around sharp corners), `PER_SPAN` per unit of
parameter and `PER_ARC` per corner arc, and on the offset pieces at the certificate's deeper
companions too.  Γ is where the bound is enforced: f_z has no zero inside
Γ and ω = f_z̄ / f_z is holomorphic there, so |ω| inside is at most its largest value on Γ (the
maximum principle, Chen & Weber 2015, Theorem 4).  The solver starts from every `ACTIVE_EVERY`-th
sample and adds those the map violates (BDHM's active set); the set and the samples' frames
(the argument of f_z in the last solution) persist between solves of the same cage, so a drag
starts where the last one ended.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from core.basis import basis_functions
from core.curves.bspline import ClosedBSpline
from core.gradients import basis_gradients
from core.injectivity import inner_curve
from core.pins.linear_rows import complex_rows, departure_rows, derivative_coefficients

#: Samples per unit of parameter on Γ's offset pieces, and per corner arc.
PER_SPAN = 8
PER_ARC = 12
#: The first active set: every this-many-th sample.
ACTIVE_EVERY = 8
#: Cages whose precompute `precompute_for` keeps, and pin sets whose basis rows each keeps.
KEPT_CAGES = 4
KEPT_PIN_SETS = 8


class PinPrecompute:
    """The per-cage part of `core.pin_deform`.

    Attributes
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    kernel : str
        ``"poisson"`` or ``"cauchy-green"``.
    centre, scale : ndarray of shape (2,), float
        Normalised coordinates are (p - centre) / scale (the cage's diameter 1).
    source : ndarray of shape (n, 2)
        The normalised source control points.
    points : ndarray of shape (N, 2)
        The samples on Γ and their deeper companions, in the cage's coordinates.
    companion : ndarray of shape (N,), int
        Each sample's companion (Γ's for a deeper one, and back); -1 on corner arcs.
    f_z, f_zbar : tuple of two ndarrays of shape (N, 2n + 4)
        Real and imaginary parts of f_z and f_z̄ at the samples, as rows acting on the solver's x.
    departure : ndarray of shape (2n, 2n + 4)
        `core.pins.linear_rows.departure_rows` of the source.
    active : ndarray of shape (N,), bool
        The active set: samples whose constraints the conic problem holds.
    floored : ndarray of shape (N,), bool
        Samples whose floor row the conic problem holds when they are active (all for Cauchy-Green).
    frames : ndarray of shape (N,), complex
        Unit frames: the samples' constraints bound Re(f_z conj(frame)) (BDHM's frames).
    limits : ndarray of shape (N,)
        Each sample's bound on |f_z̄| / |f_z| for the bound k last asked (`limits_for`).
    """

    def __init__(self, curve: ClosedBSpline, kernel: str):
        self.curve, self.kernel = curve, kernel
        controls = curve.control_points
        self.centre = controls.mean(axis=0)
        self.scale = float(curve.diameter)
        self.source = (controls - self.centre) / self.scale
        self.points, self.companion = gamma_samples(curve)
        gradients = basis_gradients(curve, self.points, kernel) * self.scale
        along, across = derivative_coefficients(gradients)
        self.f_z, self.f_zbar = complex_rows(along), complex_rows(across)
        self.departure = departure_rows(self.source)
        self.restart()
        self._pin_rows: OrderedDict[bytes, tuple[np.ndarray, np.ndarray]] = OrderedDict()

    def restart(self) -> None:
        """Forget what earlier solves learnt (active set, floor rows, frames, tightened limits), so
        that the next solve depends on its own inputs only."""
        count = self.points.shape[0]
        self.active = np.zeros(count, dtype=bool)
        self.active[::ACTIVE_EVERY] = True
        self.floored = np.full(count, self.kernel != "poisson")
        self.frames = np.ones(count, dtype=np.complex128)
        self.limits, self._limits_k = np.zeros(count), None

    @property
    def n(self) -> int:
        return self.curve.n

    def pin_rows(self, pins: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Real rows (m, 2n + 4) of the x and y images of pins (m, 2) (cage coordinates), kept
        for the last `KEPT_PIN_SETS` pin sets (a drag moves the pins' targets, not the pins)."""
        key = pins.tobytes()
        if key not in self._pin_rows:
            if len(self._pin_rows) >= KEPT_PIN_SETS:
                self._pin_rows.popitem(last=False)
            self._pin_rows[key] = complex_rows(basis_functions(self.curve, pins, self.kernel))
        self._pin_rows.move_to_end(key)
        return self._pin_rows[key]

    def limits_for(self, k: float) -> np.ndarray:
        """`limits`, all k again when k differs from the last one asked (a drag keeps the
        tightened ones)."""
        if self._limits_k != k:
            self.limits[:], self._limits_k = k, k
        return self.limits

    def normalised(self, points: np.ndarray) -> np.ndarray:
        return (points - self.centre) / self.scale

    def cage_coordinates(self, points: np.ndarray) -> np.ndarray:
        return points * self.scale + self.centre


def gamma_samples(curve: ClosedBSpline) -> tuple[np.ndarray, np.ndarray]:
    """Samples (N, 2) on the certificate's curve Γ just inside `curve`'s boundary and, on its offset
    pieces, their companions `inner_curve.DEEPER` times deeper (the certificate bounds the strip
    between Γ and the boundary from both), and each one's companion index (N,) (-1 on arcs)."""
    flip = np.array([1.0, 1.0 if curve.area > 0 else -1.0])
    source = curve if flip[1] > 0 else ClosedBSpline(curve.control_points * flip)
    found = inner_curve.corners(source)
    parts, partners, count_so_far = [], [], 0
    for piece in inner_curve.pieces(source, found):
        if piece.corner is not None:
            angles = np.linspace(piece.start, piece.stop, PER_ARC + 1)
            parts.append(inner_curve.arc_points(piece.corner, angles))
            partners.append(np.full(angles.size, -1))
            count_so_far += angles.size
            continue
        count = max(2, int(np.ceil(PER_SPAN * (piece.stop - piece.start))))
        parameters = np.linspace(piece.start, piece.stop, count + 1)
        points, deeper = inner_curve.offset_points(source, parameters, inner_curve.DEPTH * source.diameter)
        parts.extend([points, deeper])
        m = parameters.size
        partners.extend([count_so_far + m + np.arange(m), count_so_far + np.arange(m)])
        count_so_far += 2 * m
    return np.concatenate(parts) * flip, np.concatenate(partners)


_KEPT: OrderedDict[tuple[bytes, str], PinPrecompute] = OrderedDict()


def precompute_for(curve: ClosedBSpline, kernel: str) -> PinPrecompute:
    """The `PinPrecompute` of a cage and kernel, made on first use and kept for the last `KEPT_CAGES`."""
    key = (curve.control_points.tobytes(), kernel)
    if key not in _KEPT:
        if len(_KEPT) >= KEPT_CAGES:
            _KEPT.popitem(last=False)
        _KEPT[key] = PinPrecompute(curve, kernel)
    _KEPT.move_to_end(key)
    return _KEPT[key]


__all__ = ["PinPrecompute", "gamma_samples", "precompute_for"]
