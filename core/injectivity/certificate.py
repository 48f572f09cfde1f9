"""A certificate that the harmonic map of a cage onto a target is injective: `certify_injective`.

The map is f = Σ G_i P'_i with the exact harmonic coordinates (`poisson`): the harmonic
map of the source domain Ω whose boundary values are the target curve at the same parameter.
Write f = h + conj(g), h and g holomorphic on the simply connected Ω (Chen & Weber,
"Bounded distortion harmonic mappings in the plane", 2015, Theorem 4 and its validation):
f is locally injective and orientation-preserving where |g'| < |h'|, and

(a) h' has no zero inside a closed curve Γ when its argument does not turn along Γ
    (the argument principle);
(b) then ω = g'/h' is holomorphic inside Γ, |ω| <= max_Γ |ω| and |h'| >= min_Γ |h'| there
    (the maximum principle, for ω and 1/h'), so σ₂ = |h'| (1 - |ω|) >= min_Γ|h'| (1 - max_Γ|ω|);
(c) a locally injective map of the closed domain that takes its boundary one-to-one onto a
    simple closed curve of the same orientation is a bijection onto that curve's inside (a
    degree argument): the target must be proven simple (`core.injectivity.simple_curve`).

Γ runs just inside the boundary (`core.injectivity.inner_curve`), at a depth δ = 10⁻³ of the
diameter to start with (on the boundary itself h' has only log-Lipschitz behaviour at the knots,
and gradients lose accuracy as the distance shrinks).  What is left:

- the strip between Γ and the boundary: each sample has a companion 4δ deep, and σ₂ on the strip
  is taken to drop by at most twice its mean rate between the two, and k = |f_z̄| / |f_z| to rise
  by at most twice its mean rate (A3 below);
- a sharp corner P of the source (a doubled control point) must be a sharp corner of the target.
  Both sides at P are straight spans, the data on them linear in position, so
  f = P' + L(z - P) + E with L the real linear map of the source's sides onto the target's and
  E harmonic, zero on both sides within the radius ρ of Γ's arc there.  Taking w^(π/α) to a
  half disc and reflecting, E_w and E_w̄ are bounded inside the sector by (r/ρ)^(π/α - 1) times
  their largest value on the arc.  At a convex corner (α < π) this factor is at most 1, so the
  sector has |f_z| >= |L_z| - ε and |f_z̄| <= |L_z̄| + ε with ε the largest |f_z - L_z|,
  |f_z̄ - L_z̄| on the arc: proven.  At a reflex corner (α > π) the factor grows without bound
  towards P, the leading term of E (r^(π/α) sin(πθ/α)) makes |ω| tend to 1 and, unless its
  coefficient is aligned with L, the map folds in a disc around P of radius ~|E|^(α/(α-π));
  the certificate proves the rest of the domain and reports the reflex corners as unproven
  (`away_from_corners`).  So it does for a convex corner whose sector bound fails, among them one
  that turns past a straight angle between source and target (L reverses orientation: the map folds
  in the disc around P where L outweighs E, r < ~ρ·(|L|/ε)^(α/(π-α)), vanishingly small near
  α = π): a composite (`core.fold_free_deform`) whose corner opens from convex to reflex passes
  through such steps.

What is proven, and under which assumptions (the constants are `boundary_samples`'): the
conclusion holds if (A1) the evaluated f_z, f_z̄ at each sample are within its allowance of the
exact ones: `ERROR_SAFETY` (10) times the error with which the same gradients reproduce the
identity map there (their linear precision), plus `EVALUATION` relative to the target's scale
(where that error is a good part of σ₂ the sample moves away from the curve); (A2) the
Lipschitz constants of h' and g' along each segment of Γ are at most `SAFETY` (2) times the
largest difference quotient of the segment and its neighbours (refinement halves segments until
the margin holds); (A3) across the strip between Γ and the boundary σ₂ drops, and k rises, by at
most `STRIP_SAFETY` (2) times its mean rate between Γ and the companion 4δ deep (samples move closer to
the boundary where that bound is thin).  The argument principle, the maximum principle, the
corner sectors' bound and the simple-target proof are exact; A1-A3 are estimates, checked against
a dense evaluation of the exact Jacobian on 200 random deformations
(tests/core/injectivity/test_certificate.py).  When in doubt the answer is `injective=False`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.injectivity import inner_curve
from core.injectivity.boundary_samples import evaluate, first_parameters, merged, segment_bounds
from core.injectivity.harmonic_parts import linear_parts
from core.injectivity.simple_curve import first_crossing

#: Allowance for the evaluation error of f_z and f_z̄ besides the estimated one (A1), relative to the
#: target's diameter over the source's.
EVALUATION = 1e-6
#: Refinement rounds and total samples before giving up.
ROUNDS = 14
MAX_SAMPLES = 40_000
#: Samples move towards the boundary (their strip thinner) down to this fraction of the diameter,
#: and away from it (where their evaluation is not accurate enough) up to this one.
MIN_DEPTH = 2e-6
MAX_DEPTH = 0.02
#: Kernels the certificate supports.
SUPPORTED_KERNELS = ("poisson",)


@dataclass(frozen=True)
class InjectivityCertificate:
    """What `certify_injective` proved about the harmonic map of a cage onto a target.

    Attributes
    ----------
    injective : bool
        Proven locally injective and orientation-preserving on the closed domain, and a bijection
        onto the target's inside.
    sigma2_min : float
        A proven lower bound of the smaller singular value σ₂ of the Jacobian over the domain
        (over the domain outside the unproven corners' discs when only `away_from_corners`); 0 when
        nothing is proven.
    k_max : float
        A proven upper bound of |f_z̄| / |f_z| over the same region; inf when nothing is proven.
    where : ndarray of shape (K, 2)
        Points of the source domain where the proof fails (for a viewer to mark).
    reason : str
        One sentence: what was proven, or why not.
    samples : int
        Points at which the derivatives were evaluated.
    away_from_corners : bool
        Proven everywhere except within `corner_radius` of the points in `where`, which are
        sharp corners, reflex or not proven in their sector (`injective` is then False).
    corner_radius : float
    extra : dict
        What `core.fold_free_deform` adds: ``"steps"``, and of a mesh ``"moved"``,
        ``"largest_move"``, ``"turned_over"``, ``"path"``.
    on_mesh : bool
        What is proven is the mesh's piecewise-linear map, not a continuous one: every triangle
        keeps its orientation and the boundary polygon is simple, so that it is a bijection onto
        that polygon (`core.injectivity.mesh_bijection`); `sigma2_min` and `k_max` are then its
        triangles' (exact).
    """

    injective: bool
    sigma2_min: float
    k_max: float
    where: np.ndarray
    reason: str
    samples: int = 0
    away_from_corners: bool = False
    corner_radius: float = 0.0
    extra: dict = field(default_factory=dict, compare=False, repr=False)
    on_mesh: bool = False

    def __str__(self) -> str:
        # `core.fold_free_deform` notes the mesh vertices it moved to unfold straight edges, and
        # the triangles that stay turned over.
        moved = self.extra.get("moved", 0)
        repair = (
            f"; {moved} mesh vertices moved, by at most {self.extra['largest_move']:.2g} of the "
            "diameter, to unfold straight edges"
            if moved
            else ""
        )
        turned = self.extra.get("turned_over", 0)
        if turned:
            repair += (
                f"; {turned} mesh triangles still turned over (their straight edges are too coarse "
                "to follow the map there)"
            )
        if self.on_mesh and self.injective:
            return f"fold-free on the mesh, proven ({self.reason}){repair}"
        if turned:  # what is drawn folds, whatever is proven of the continuous map
            return f"not fold-free on the mesh{repair}"
        if self.injective:
            bounds = f"σ₂ ≥ {self.sigma2_min:.3g}, k ≤ {self.k_max:.3g}"
            return f"fold-free, proven ({bounds}; {self.samples} samples){repair}"
        if self.away_from_corners:
            return (
                f"fold-free away from {len(self.where)} sharp corner(s), proven outside a radius of "
                f"{self.corner_radius:.3g} (σ₂ ≥ {self.sigma2_min:.3g}; {self.samples} samples){repair}"
            )
        return f"not proven fold-free: {self.reason}"


def certify_injective(
    curve: ClosedBSpline, target, kernel: str = "poisson", *, k_goal: float | None = None
) -> InjectivityCertificate:
    """Prove (or fail to prove) that the harmonic map of `curve`'s domain onto `target` is injective.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    target : ClosedBSpline or array_like of shape (n, 2)
        The target control points: the map takes the source's boundary point at parameter t to
        the target curve's point at t.
    kernel : str
        ``"poisson"`` (the exact harmonic coordinates); other kernels raise ValueError.
    k_goal : float, optional
        Also refine the samples of Γ where the bound of k = |f_z̄| / |f_z| between them is above this
        (`core.pin_deform` asks for its distortion bound), as long as the refinement limits allow.

    Returns
    -------
    InjectivityCertificate
        See the module's documentation for what is proven under which assumptions.
    """
    if kernel not in SUPPORTED_KERNELS:
        raise ValueError(
            f"certify_injective supports the kernel(s) {', '.join(SUPPORTED_KERNELS)} "
            f"(harmonic maps), got {kernel!r}"
        )
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    points = (
        target.control_points if isinstance(target, ClosedBSpline) else np.asarray(target, dtype=np.float64)
    )
    if points.shape != curve.control_points.shape:
        raise ValueError(
            f"target must have shape {curve.control_points.shape} like the cage, got {points.shape}"
        )
    refused = _refused_target(curve, points, target)
    if refused is not None:
        return refused
    flip = np.array([1.0, 1.0 if curve.area > 0 else -1.0])
    source = curve if flip[1] > 0 else ClosedBSpline(curve.control_points * flip)
    found = inner_curve.corners(source)
    refused = _refused_corners(source, points * flip, found)
    if refused is not None:
        return _flipped(refused, flip)
    for depth in inner_curve.DEPTHS:
        try:
            return _flipped(_proof(source, points * flip, found, depth, k_goal), flip)
        except ValueError:  # Γ left the domain where it is thinner than the depth
            continue
    return _flipped(
        _failure("the curve Γ inside the boundary leaves the domain (a part thinner than 1e-5 of it)"), flip
    )


def _failure(reason: str, where=None, samples: int = 0) -> InjectivityCertificate:
    where = np.zeros((0, 2)) if where is None else np.asarray(where, dtype=np.float64).reshape(-1, 2)
    return InjectivityCertificate(False, 0.0, math.inf, where, reason, samples)


def _flipped(certificate: InjectivityCertificate, flip: np.ndarray) -> InjectivityCertificate:
    if flip[1] > 0:
        return certificate
    return InjectivityCertificate(
        certificate.injective, certificate.sigma2_min, certificate.k_max, certificate.where * flip,
        certificate.reason, certificate.samples, certificate.away_from_corners, certificate.corner_radius,
        certificate.extra,
    )  # fmt: skip


def _refused_target(curve: ClosedBSpline, points: np.ndarray, given) -> InjectivityCertificate | None:
    """A failed certificate if the target is not a simple curve of the source's orientation."""
    try:
        target = given if isinstance(given, ClosedBSpline) else ClosedBSpline(points)
    except ValueError as error:
        return _failure(f"the target is not a valid cage: {error}")
    crossing = first_crossing(points)
    if crossing is not None:
        j, k = crossing
        where = curve(np.array([j + 0.5, k + 0.5]))
        return _failure(f"the target curve is not proven simple (spans {j} and {k} may meet)", where)
    if (target.area > 0) != (curve.area > 0):
        return _failure(
            "the target curve runs the other way round than the cage (the map reverses orientation)"
        )
    return None


def _refused_corners(source: ClosedBSpline, target: np.ndarray, found) -> InjectivityCertificate | None:
    """A failed certificate if the sharp corners of source and target differ.  (A corner whose sides'
    linear map reverses orientation is left to `_combined`: unproven in a disc, like a reflex one.)"""
    doubled = np.all(target == np.roll(target, 1, axis=0), axis=1)
    source_doubled = np.all(source.control_points == np.roll(source.control_points, 1, axis=0), axis=1)
    differ = np.flatnonzero(doubled != source_doubled)
    if differ.size:
        j = int(differ[0])
        return _failure(
            f"control points {(j - 1) % source.n} and {j} make a sharp corner in one cage "
            "and not in the other",
            source.control_points[j],
        )
    return None


def corner_linear_map(source: np.ndarray, target: np.ndarray, corner: inner_curve.Corner) -> np.ndarray:
    """The real linear map (2, 2) taking a corner's straight sides in the source (n, 2) onto the target's."""
    n = source.shape[0]
    j = int(round(corner.knot)) % n
    rows = [(j + 1) % n, (j - 2) % n]
    sides = (source[rows] - source[j]).T
    images = (target[rows] - target[j]).T
    return images @ np.linalg.inv(sides)


def _proof(
    source: ClosedBSpline, target: np.ndarray, found, depth: float, k_goal=None
) -> InjectivityCertificate:
    """Sample Γ at `depth` (a fraction of the diameter), refine (halve segments, move samples towards
    the boundary), then combine the bounds of (a), (b), the strip and the corners."""
    pieces = inner_curve.pieces(source, found)
    samples = []
    for piece in pieces:
        parameters = first_parameters(piece)
        samples.append(evaluate(source, target, piece, parameters, np.full(parameters.size, depth)))
    scale = float(np.ptp(target, axis=0).max() / np.ptp(source.control_points, axis=0).max())
    tolerance = EVALUATION * scale
    for _ in range(ROUNDS):
        flat = _concatenated(samples)
        bounds = segment_bounds(flat["points"], flat["h"], flat["g"], flat["sigma_strip"], flat["allowance"])
        failing = (
            ~(np.minimum(bounds.h_low - bounds.g_high, bounds.sigma_strip) > tolerance) | ~bounds.turn_exact
        )
        raw = np.abs(flat["h"]) - np.abs(flat["g"])
        # Where the evaluation error is a good part of σ₂ the sample is too close to the curve for
        # its accuracy: it moves away; where it is small and the strip's bound thin, closer.
        inaccurate = ~(flat["allowance"] <= 0.25 * np.abs(raw))
        hopeless = np.flatnonzero(~inaccurate & ~(raw - 2.0 * flat["allowance"] > tolerance))
        if hopeless.size:
            where = flat["points"][hopeless]
            return _failure("the Jacobian is not positive near the marked points", where, flat["count"])
        thin = np.zeros_like(failing) if k_goal is None else ~(bounds.g_high <= k_goal * bounds.h_low)
        if not failing.any() and not (thin & flat["refinable"]).any():
            return _combined(source, target, found, samples, flat, bounds, tolerance)
        offset = flat["depth"] > 0
        factor = np.ones(raw.size)
        factor[inaccurate & offset & (flat["depth"] < MAX_DEPTH)] = 4.0
        closer = (flat["sigma_strip"] <= tolerance) & (flat["allowance"] <= 0.05 * np.abs(raw))
        factor[closer & offset & (flat["depth"] > MIN_DEPTH)] = 0.25
        refinable = (failing | thin) & flat["refinable"]
        if not (refinable.any() or (factor != 1).any()) or flat["count"] > MAX_SAMPLES:
            if not failing.any():
                return _combined(source, target, found, samples, flat, bounds, tolerance)
            break
        samples = _refined(source, target, pieces, samples, flat, refinable, factor)
    if not failing.any():  # only the bound of k stayed above k_goal
        return _combined(source, target, found, samples, flat, bounds, tolerance)
    failing_samples = np.flatnonzero(failing)
    where = flat["points"][failing_samples]
    if np.any(inaccurate[failing_samples] | inaccurate[(failing_samples + 1) % inaccurate.size]):
        reason = (
            "the map's derivatives are not evaluated accurately enough near the marked points "
            "(their error estimate is a good part of σ₂ there)"
        )
    else:
        reason = "the bounds between samples stay too thin near the marked points"
    return _failure(reason, where, flat["count"])


def _concatenated(samples) -> dict:
    """The samples of all pieces as one closed polygon, with each segment's piece and whether it
    lies inside one piece (refinable: a new sample can go in the middle)."""
    piece = np.concatenate([np.full(s.parameters.size, k) for k, s in enumerate(samples)])
    following = np.roll(piece, -1)
    return {
        "points": np.concatenate([s.points for s in samples]),
        "h": np.concatenate([s.h for s in samples]),
        "g": np.concatenate([s.g for s in samples]),
        "sigma_strip": np.concatenate([s.sigma_strip for s in samples]),
        "allowance": np.concatenate([s.allowance for s in samples]),
        "k_strip": np.concatenate([s.k_strip for s in samples]),
        "depth": np.concatenate(
            [np.zeros(s.parameters.size) if s.depths is None else s.depths for s in samples]
        ),
        "piece": piece,
        "refinable": (piece == following) & (np.arange(piece.size) != piece.size - 1),
        "offset": np.concatenate([[0], np.cumsum([s.parameters.size for s in samples])]),
        "count": int(sum(s.parameters.size * (1 if s.depths is None else 2) for s in samples)),
    }


def _refined(source, target, pieces, samples, flat, refinable, factor):
    """The samples with a new one in the middle of every refinable failing segment (at the smaller
    depth of its ends), and those whose depth `factor` (N,) is not 1 again at their depth times it."""
    result = list(samples)
    for k in np.unique(flat["piece"][np.flatnonzero(refinable | (factor != 1))]):
        first = flat["offset"][k]
        local = np.flatnonzero(refinable[first : first + samples[k].parameters.size])
        parameters, depths = samples[k].parameters, samples[k].depths
        middles = 0.5 * (parameters[local] + parameters[local + 1])
        new_depths = None if depths is None else np.minimum(depths[local], depths[local + 1])
        moved = np.flatnonzero(factor[first : first + parameters.size] != 1)
        if moved.size:
            middles = np.concatenate([middles, parameters[moved]])
            new_depths = np.concatenate([new_depths, factor[first + moved] * depths[moved]])
        result[k] = merged(samples[k], evaluate(source, target, pieces[k], middles, new_depths))
    return result


def _combined(source, target, found, samples, flat, bounds, tolerance) -> InjectivityCertificate:
    """The certificate from segment bounds that all hold: winding, interior, strip, corners."""
    winding = int(round(bounds.turn.sum() / (2.0 * math.pi)))
    count = flat["count"]
    if winding != 0:
        return _failure(
            f"f_z has {winding} zero(s) inside the domain (the argument principle on Γ)", None, count
        )
    k_gamma = float(np.max(bounds.g_high / bounds.h_low))
    interior = float(bounds.h_low.min()) * (1.0 - k_gamma)
    strip = float(bounds.sigma_strip.min())
    sigma2, k_max = min(interior, strip), max(k_gamma, _strip_ratio(flat, bounds))
    unproven = []
    for index, corner in enumerate(found):
        sector = None
        if corner.angle <= math.pi:
            sector = _sector_bound(source, target, corner, samples[2 * index], bounds, flat, 2 * index)
        if sector is None or sector[0] <= tolerance:
            unproven.append(corner)
            continue
        sigma2, k_max = min(sigma2, sector[0]), max(k_max, sector[1])
    if unproven:
        where = np.array([corner.point for corner in unproven])
        radius = max(corner.radius for corner in unproven)
        reason = (
            f"{len(unproven)} sharp corner(s) not proven (reflex, or turning past a straight angle): "
            f"proven outside a radius of {radius:.3g} around them"
        )
        return InjectivityCertificate(False, sigma2, k_max, where, reason, count, True, radius)
    return InjectivityCertificate(True, sigma2, k_max, np.zeros((0, 2)), "proven", count)


def _strip_ratio(flat: dict, bounds) -> float:
    """Upper bound of k across the strip between Γ and the boundary: on each segment the larger of
    its ends' strip bounds (A3 for ω = g'/h'), plus what the segment's bound g_high / h_low adds to
    the larger of its ends' ratios (A2)."""
    ratio = (np.abs(flat["g"]) + flat["allowance"]) / (np.abs(flat["h"]) - flat["allowance"])
    following = np.roll(np.arange(ratio.size), -1)
    between = np.maximum(bounds.g_high / bounds.h_low - np.maximum(ratio, ratio[following]), 0.0)
    return float(np.max(np.maximum(flat["k_strip"], flat["k_strip"][following]) + between))


def _sector_bound(source, target, corner, arc, bounds, flat, piece) -> tuple[float, float]:
    """Lower bound of σ₂ and upper bound of k in the sector |z - P| < ρ of a convex corner."""
    along, across = linear_parts(corner_linear_map(source.control_points, target, corner))
    deviation = np.maximum(np.abs(arc.h - along), np.abs(arc.g - across))
    on_arc = np.flatnonzero(flat["piece"] == piece)[:-1]
    lipschitz = np.maximum(bounds.lipschitz_h[on_arc], bounds.lipschitz_g[on_arc])
    epsilon = float(np.max(0.5 * (deviation[:-1] + deviation[1:] + lipschitz * bounds.length[on_arc])))
    lower = abs(along) - abs(across) - 2.0 * epsilon
    if abs(along) <= epsilon:
        return lower, math.inf
    return lower, (abs(across) + epsilon) / (abs(along) - epsilon)


__all__ = ["InjectivityCertificate", "certify_injective", "corner_linear_map"]
