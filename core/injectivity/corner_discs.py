"""Radial maps in the corner discs that a step's certificate leaves unproven: `radial_discs`, `disc_images`.

`certify_injective` proves the harmonic map f of a cage onto the next one injective outside discs
|z - P| < ρ at some sharp corners P (reflex ones, and convex ones whose sector bound fails, e.g. one
turning past a straight angle); inside them f may fold (in a far smaller disc, but a fold all the
same).  A composite step (`core.fold_free_deform`) maps such a disc radially instead:

    F(P + r e^{iθ}) = P' + (r / ρ) c(θ),   c(θ) = f(P + ρ e^{iθ}) - P'   (0 <= r <= ρ, θ in [0, α]),

the cone from the corner's image P' over the image of the arc |z - P| = ρ.  It does so at every
sharp corner, proven or not: where a corner opens (its angle α grows to β) the harmonic map compresses
like r^(β/α), and over many steps points near the corner crowd together closer than the evaluation
resolves them (mesh triangles there turned over); the radial map is Lipschitz.  F equals f on the arc,
and on the two straight sides (where f is the real linear map L of the source's sides onto the
target's, `corner_linear_map`) F = f too, so F is continuous.  Its Jacobian determinant is
(r / ρ²) c × c', positive where the argument of c increases with θ: if it does along the whole
arc (the arc's image is star-shaped from P'), F is an orientation-preserving homeomorphism of the
sector onto the region between the target's sides and the arc's image.  Glued to f (proven locally
injective outside the disc) it gives a local homeomorphism of the closed domain that takes the
boundary one-to-one onto the (proven simple) next cage: a bijection (the certificate's degree
argument (c)).

The star-shape check samples c at `ARC_SAMPLES` angles (doubling up to `MAX_ARC_SAMPLES`, the
sides' samples exact from L) and asks that every sample-to-sample turn of arg c be positive and at
least `SAFETY` times the largest change between consecutive turns (the same kind of assumption as
the certificate's A2: the turn rate between samples varies by at most that), and that the turns add
up to the target's angle at P' (not one more full turn).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.basis import basis_functions
from core.curves.bspline import ClosedBSpline
from core.injectivity import inner_curve
from core.injectivity.certificate import InjectivityCertificate, corner_linear_map

#: Arc samples for the star-shape check, at first and at most.
ARC_SAMPLES = 128
MAX_ARC_SAMPLES = 2048
#: Each turn of arg c between samples must be at least this many times the largest change of turn.
SAFETY = 2.0


@dataclass(frozen=True)
class CornerDisc:
    """A corner disc mapped radially: the source corner `point` (2,), its image `image` (2,), the
    radius ρ, the unit direction `leave` (2,) of the side the curve leaves on, the domain's angle
    α there, `turn` (+1 if angles grow counter-clockwise into the domain, else -1) and the linear
    map `linear` (2, 2) of the corner's sides onto the target's."""

    point: np.ndarray
    image: np.ndarray
    radius: float
    leave: np.ndarray
    angle: float
    turn: float
    linear: np.ndarray


def radial_discs(
    current: ClosedBSpline, cage: np.ndarray, certificate: InjectivityCertificate
) -> list[CornerDisc] | None:
    """The discs of all sharp corners of `current`, each checked star-shaped for the map onto the
    control points `cage` (n, 2) (whose `certificate` proves it outside them at least); None if one
    is not proven so, [] if the certificate proves nothing."""
    if not (certificate.injective or certificate.away_from_corners):
        return []
    turn = 1.0 if current.area > 0 else -1.0
    discs = []
    for corner in inner_curve.corners(current):
        j = int(round(corner.knot)) % current.n
        leave = np.array([math.cos(corner.leave_angle), math.sin(corner.leave_angle)])
        disc = CornerDisc(
            corner.point, cage[j].copy(), corner.radius, leave, corner.angle, turn,
            corner_linear_map(current.control_points, cage, corner),
        )  # fmt: skip
        if not _star_shaped(current, cage, disc):
            return None
        discs.append(disc)
    return discs


def disc_images(
    current: ClosedBSpline, cage: np.ndarray, points: np.ndarray, discs: list[CornerDisc], harmonic=None
) -> np.ndarray:
    """Images (M, 2) of points (M, 2) of `current`'s closed domain: the harmonic map onto the
    control points `cage` (n, 2) (or the given `harmonic` images (M, 2)), and within a disc of
    `discs` its radial map (the module's F)."""
    images = np.empty_like(points) if harmonic is None else harmonic.copy()
    rest = np.ones(len(points), dtype=bool)
    for disc in discs:
        offsets = points - disc.point
        distances = np.linalg.norm(offsets, axis=1)
        inside = rest & (distances < disc.radius)
        rest &= ~inside
        if not inside.any():
            continue
        angles = _angles(disc, offsets[inside])
        images[inside] = disc.image + (distances[inside] / disc.radius)[:, None] * _arc_images(
            current, cage, disc, angles
        )
    if harmonic is None and rest.any():
        images[rest] = basis_functions(current, points[rest], "poisson") @ cage
    return images


def _angles(disc: CornerDisc, offsets: np.ndarray) -> np.ndarray:
    """Angles (M,) of offsets (M, 2) from the corner, measured from the leaving side into the
    domain, clipped to [0, α] (points at the corner itself get 0)."""
    cross = disc.leave[0] * offsets[:, 1] - disc.leave[1] * offsets[:, 0]
    angles = np.mod(disc.turn * np.arctan2(cross, offsets @ disc.leave), 2.0 * math.pi)
    # Rounding can put a point of a side a hair outside the angle: take the nearer side.
    outside = angles > disc.angle
    angles[outside] = np.where(
        angles[outside] - disc.angle < 2.0 * math.pi - angles[outside], disc.angle, 0.0
    )
    return angles


def _arc_images(current: ClosedBSpline, cage: np.ndarray, disc: CornerDisc, angles: np.ndarray) -> np.ndarray:
    """c(θ) = f(P + ρ e^{iθ}) - P' (M, 2) at angles (M,) in [0, α]: exact from the linear map on
    the sides (θ = 0 or α), the harmonic map's basis functions between."""
    cosines, sines = np.cos(disc.turn * angles), np.sin(disc.turn * angles)
    directions = np.stack(
        [cosines * disc.leave[0] - sines * disc.leave[1], sines * disc.leave[0] + cosines * disc.leave[1]],
        axis=1,
    )
    offsets = disc.radius * directions
    result = offsets @ disc.linear.T
    between = (angles > 0.0) & (angles < disc.angle)
    if between.any():
        arc = disc.point + offsets[between]
        result[between] = basis_functions(current, arc, "poisson") @ cage - disc.image
    return result


def _star_shaped(current: ClosedBSpline, cage: np.ndarray, disc: CornerDisc) -> bool:
    """Whether arg c(θ) increases (in the domain's sense) along the whole arc, by the module's check."""
    first, last = _arc_images(current, cage, disc, np.array([0.0, disc.angle]))
    cross = first[0] * last[1] - first[1] * last[0]
    target_angle = np.mod(disc.turn * math.atan2(cross, float(first @ last)), 2.0 * math.pi)
    count = ARC_SAMPLES
    while count <= MAX_ARC_SAMPLES:
        images = _arc_images(current, cage, disc, disc.angle * np.arange(count + 1) / count)
        complex_images = images[:, 0] + 1j * images[:, 1]
        if np.any(complex_images == 0):
            return False
        turns = disc.turn * np.angle(complex_images[1:] / complex_images[:-1])
        if turns.min() <= 0.0 or abs(turns.sum() - target_angle) > 1e-6:
            return False
        if turns.min() > SAFETY * np.max(np.abs(np.diff(turns)), initial=0.0):
            return True
        count *= 2
    return False


__all__ = ["CornerDisc", "disc_images", "radial_discs"]
