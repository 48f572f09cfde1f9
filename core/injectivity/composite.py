"""A fold-free warp: composite harmonic maps along the straight path of cages, each step certified.

Schneider, Hormann & Floater ("Bijective composite mean value mappings", SGP 2013) compose maps
along a path of cages: the control points move along P(s) = (1 - s) P + s P', and step k is the
map of the cage at s_k onto the cage at s_{k+1}.  Here each step is the harmonic map
(`poisson`) and is proven injective by `core.injectivity.certify_injective`; a bijection of
each domain onto the next composes to a bijection of the source domain onto the target's, and a
boundary point at parameter t goes to the target curve at t at every step.  The steps are adaptive:
the first tries the whole way, a step whose certificate fails is halved, a step that succeeds lets
the next one double.  Within a disc at each sharp corner a step maps radially instead
(`core.injectivity.corner_discs`), also where the certificate leaves the harmonic map unproven, so
that it is a bijection all the same.  σ₂ of
the composite is at least the product of the steps' bounds, and its
dilatation K = (1 + k) / (1 - k) at most the product of theirs.  Given a mesh, the triangles that
its straight edges still turn over are unfolded at the end by moving a few interior vertices' images
(`core.injectivity.mesh_unfolding`), and where rows of them turn over together, by moving all interior
vertices of a region at once (`core.injectivity.mesh_untangling`): the images change, by amounts the
certificate reports, the certificate (of the continuous map) does not.

Given a mesh with its boundary (what every caller gives), `fold_free_deform` takes the mesh's own
map instead (`core.injectivity.mesh_fold_free`): composite discrete harmonic steps proven a
bijection on the mesh, at a fraction of the cost of a certificate a step; the continuous composite
here is what points alone, or a mesh without its boundary, get.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from core.basis import basis_functions
from core.boundary_integrals.poisson import closest_point
from core.curves.bspline import ClosedBSpline
from core.injectivity import inner_curve
from core.injectivity.certificate import InjectivityCertificate, certify_injective
from core.injectivity.corner_discs import disc_images, radial_discs
from core.injectivity.mesh_fold_free import mesh_fold_free_map
from core.injectivity.mesh_unfolding import unfold_triangles
from core.injectivity.mesh_untangling import untangle_triangles
from core.meshes.mesh import FOLDED_AREA_SHARE, triangle_signed_areas
from core.validation import as_points

#: Steps at most (accepted ones), and the smallest step in s, before giving up.
MAX_STEPS = 64
SMALLEST_STEP = 1.0 / 1024
#: Cages at s = 1/PATH_CHECKS, 2/PATH_CHECKS, ... are checked for crossings before any step.
PATH_CHECKS = 16
#: A step that turns a triangle over is halved down to this size, then taken anyway.
SMALLEST_MESH_STEP = 1.0 / 64
#: Meshes of at least this many vertices try the continuous composite first, of at most
#: `CONTINUOUS_STEPS` steps, kept where the mesh's map is proven a bijection: its steps cost a
#: certificate of the cage and an evaluation of the basis, the mesh's a sparse factorisation on all
#: vertices (the bench's strong drag at 50k vertices: 0.82 s against 1.93 s, loaded machine).
#: Only for cages of at most `CONTINUOUS_MOST_POINTS` control points: the continuous steps need the
#: cage's densities (a solve of 0.14 s at 60 points, 0.55 s at 120, ~5 s at 200 on a loaded machine).
CONTINUOUS_FIRST = 20_000
CONTINUOUS_STEPS = 8
CONTINUOUS_MOST_POINTS = 120


def fold_free_deform(
    curve: ClosedBSpline,
    target,
    points,
    *,
    boundary: tuple | None = None,
    triangles=None,
    max_steps: int = MAX_STEPS,
    progress: Callable[[float], None] | None = None,
    basis=None,
) -> tuple[np.ndarray, InjectivityCertificate]:
    """Images of points of the source domain under a certified bijection onto the target's domain.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    target : array_like of shape (n, 2)
        The target control points; the map takes the source curve at parameter t to the target
        curve at t.
    points : array_like of shape (M, 2)
        Points of the closed source domain.
    boundary : (indices, parameters), optional
        Rows of `points` on the curve, int (B,), and their parameters t (B,) (as in `core.Mesh`):
        their images are the target curve at t exactly (others on it: at their closest t).
    triangles : array_like of shape (T, 3), optional
        Triangles over `points`, counter-clockwise (as in `core.Mesh`).  With `boundary` too, the
        mesh's own map, proven a bijection on the mesh (`core.injectivity.mesh_fold_free`; the
        certificate's ``on_mesh``), tried after the continuous composite of at most
        `CONTINUOUS_STEPS` steps on meshes of `CONTINUOUS_FIRST` vertices or more (cages of at
        most `CONTINUOUS_MOST_POINTS` control points).  Without,
        steps of the continuous map are halved while its interpolant turns a triangle over (down
        to `SMALLEST_MESH_STEP`), those left at the end unfolded (`_unfolded`); the certificate
        says how many moved, how far, how many stay over.
    max_steps : int
        The most steps to take before giving up.
    progress : callable, optional
        Called after every step tried with the share of the path proven so far (0 to 1); an
        exception it raises abandons the map (a caller's newer request).
    basis : array_like of shape (M, n), optional
        With `triangles` and `boundary`: G (``poisson``) at the points; the plain map G P' is the
        answer where it is a bijection on the mesh (``extra["path"]``: `core.PLAIN_HARMONIC_MAP`).

    Returns
    -------
    images : ndarray of shape (M, 2)
    certificate : InjectivityCertificate
        Of the composite map: injective if every step is; σ₂ and k bounds composed from the steps';
        ``extra``: ``"steps"``, with `triangles` ``"moved"``, ``"largest_move"``, ``"turned_over"``.

    Raises
    ------
    ValueError
        The target is not a valid cage, a cage on the straight path crosses itself, or no step down
        to `SMALLEST_STEP` is proven in `max_steps` steps; on a mesh, no path reaches the target.
    """
    goal, final, images = _checked(curve, target, points)
    triangles = None if triangles is None else np.asarray(triangles, dtype=np.int64)
    on_curve = np.zeros(images.shape[0], dtype=bool)
    if boundary is not None:
        boundary = np.asarray(boundary[0], dtype=np.int64), np.asarray(boundary[1], dtype=np.float64)
        on_curve[boundary[0]] = True
    if triangles is not None and boundary is not None:
        plain = None if basis is None else np.asarray(basis, dtype=np.float64) @ goal
        continuous = None
        if len(images) >= CONTINUOUS_FIRST and curve.n <= CONTINUOUS_MOST_POINTS:

            def continuous():
                try:
                    moved, steps = _composite(curve, goal, final, images.copy(), on_curve, boundary,
                                              None, CONTINUOUS_STEPS, progress)  # fmt: skip
                except ValueError:  # no composite within the steps: the mesh's own
                    return None
                return moved, len(steps)

        return mesh_fold_free_map(curve, final, images, triangles, boundary, progress, plain, continuous)
    images, steps = _composite(curve, goal, final, images, on_curve, boundary, triangles, max_steps, progress)
    if triangles is None:
        return images, composite_certificate(steps, curve)
    return _unfolded(as_points(points, "points"), images, triangles, ~on_curve, final, steps, curve)


def _composite(
    curve, goal, final, images, on_curve, boundary, triangles, max_steps, progress
) -> tuple[np.ndarray, list[InjectivityCertificate]]:
    """The images (M, 2) of `images` under the continuous composite from `curve` to `final` (its
    control points `goal` (n, 2)), and its steps' certificates: see `fold_free_deform`, whose
    arguments these are (`on_curve` (M,): the rows of `boundary`); ValueError where it stops."""
    start = curve.control_points
    for fraction in np.arange(1, PATH_CHECKS) / PATH_CHECKS:  # a crossing found early saves the proofs
        _path_cage((1.0 - fraction) * start + fraction * goal, fraction)
    s, step, current, steps, certificate = 0.0, 1.0, curve, [], None
    basis = None  # G of the current cage at the images off the curve: the same for every step size tried
    while s < 1.0:
        following = min(1.0, s + step)
        cage = (
            final if following == 1.0 else _path_cage((1.0 - following) * start + following * goal, following)
        )
        moved, accepted, discs = None, True, []
        check_mesh = triangles is not None and step > SMALLEST_MESH_STEP
        if check_mesh:  # the mesh first (outside the corner discs, radial there): it costs less than a proof
            basis = _basis(current, images[~on_curve]) if basis is None else basis
            moved = _moved(basis, cage, images, on_curve, boundary)
            accepted = not _turns_over(triangles, images, moved, _in_corner_discs(current, images))
        if accepted:
            certificate = certify_injective(current, cage)
            discs = radial_discs(current, cage.control_points, certificate)
            accepted = (certificate.injective or certificate.away_from_corners) and discs is not None
        if accepted:
            moved, basis = _step_images(current, cage, images, on_curve, boundary, basis, moved, discs)
            accepted = not (discs and check_mesh and _turns_over(triangles, images, moved))
        if accepted:
            images, basis = moved, None
            steps.append(_with_discs(certificate, discs))
            s, current = following, cage
            step *= 2.0
        else:
            step *= 0.5
        if step < SMALLEST_STEP or (len(steps) >= max_steps and s < 1.0):
            raise ValueError(_unproven(s, len(steps), certificate, step < SMALLEST_STEP))
        if progress is not None:
            progress(s)
    images[~on_curve] = _inside(final, images[~on_curve])
    return images, steps


def _checked(curve, target, points) -> tuple[np.ndarray, ClosedBSpline, np.ndarray]:
    """The target's control points (n, 2) and curve, and a copy of the points (M, 2); ValueError,
    said of the argument, where one is not what `fold_free_deform` takes."""
    if not isinstance(curve, ClosedBSpline):
        raise ValueError(f"curve must be a core.ClosedBSpline, got {type(curve).__name__}")
    goal = as_points(target, "target")
    if goal.shape != (shape := curve.control_points.shape):
        raise ValueError(f"target must have shape {shape} like the cage, got {goal.shape}")
    return goal, _target_curve(goal), as_points(points, "points").copy()


def _step_images(
    current, cage, images, on_curve, boundary, basis, moved, discs
) -> tuple[np.ndarray, np.ndarray]:
    """The images (M, 2) after an accepted step of `current` onto `cage` (the harmonic ones `moved`
    if already computed, else from `basis`, computed if None), radial in the corner `discs`
    (`core.injectivity.corner_discs`); and the basis."""
    basis = _basis(current, images[~on_curve]) if basis is None else basis
    moved = _moved(basis, cage, images, on_curve, boundary) if moved is None else moved
    if discs:
        moved[~on_curve] = disc_images(
            current, cage.control_points, images[~on_curve], discs, moved[~on_curve]
        )
    return moved, basis


def _with_discs(certificate: InjectivityCertificate, discs) -> InjectivityCertificate:
    """A step's certificate: proven outside its radial corner discs (if any), not inside them."""
    if not discs:
        return certificate
    return dataclasses.replace(
        certificate,
        injective=False,
        away_from_corners=True,
        where=np.array([disc.point for disc in discs]),
        corner_radius=max(disc.radius for disc in discs),
    )


def _unproven(s: float, taken: int, certificate: InjectivityCertificate, smallest: bool) -> str:
    """The sentence for a composite that stops at s: out of steps, or at a cage that the certificate
    cannot resolve even for a step so small that the map is close to the identity."""
    if not smallest:
        return (
            f"the fold-free composite stops at s = {s:.4g} on the straight path to the target: "
            f"{taken} steps taken, the most allowed"
        )
    near = "" if len(certificate.where) == 0 else " near ({:.4g}, {:.4g})".format(*certificate.where[0])
    return (
        f"no step is proven from s = {s:.4g} on the straight path to the target, not even one of "
        f"{SMALLEST_STEP:g} of the way (a map that close to the identity is not expected to fold), "
        f"a limit of the proof at the cage there{near}: {certificate.reason}"
    )


def _moved(basis: np.ndarray, cage: ClosedBSpline, images: np.ndarray, on_curve: np.ndarray, boundary):
    """The images (M, 2) after the step onto `cage`: the harmonic map's, basis (K, n) of the current
    cage at the K points off the curve (`on_curve` (M,) False) times the cage's control points, and
    the cage at their parameters for the rows of `boundary` (indices (B,), parameters (B,)) or None."""
    moved = images.copy()
    moved[~on_curve] = basis @ cage.control_points
    if boundary is not None:
        moved[boundary[0]] = cage(boundary[1])
    return moved


def _unfolded(
    vertices, images, triangles, free, final, steps, source
) -> tuple[np.ndarray, InjectivityCertificate]:
    """The images (V, 2) with triangles (T, 3) that are still turned over unfolded by moving free
    vertices (V,), and the composite's certificate (of `source`'s map) noting the moves.  First the
    local repair (`unfold_triangles`): a move that leaves the target is undone, and the whole repair
    if it leaves more triangles turned over.  Where triangles stay turned over, the global untangling
    (`untangle_triangles`) from the composite's images, else from the local repair's, kept only if it
    leaves none and every vertex it moved inside the target."""
    repaired, moves = unfold_triangles(vertices, images, triangles, free)
    left = (moves > 0) & ~final.contains(repaired)
    repaired[left] = images[left]
    after, before = (_turned_over_count(vertices, p, triangles) for p in (repaired, images))
    if after > before:
        repaired, after = images, before
    # The composite's own images first: a local repair that stopped short (its moves out of the
    # target undone) can leave a start the untangling does not get out of (a cornered drag at 6k
    # vertices: 48 turned over stayed from there, none from the images).
    starts = [] if after == 0 else [images] if repaired is images else [images, repaired]
    for start in starts:
        untangled, _ = untangle_triangles(vertices, start, triangles, free)
        moved = np.any(untangled != start, axis=1)
        if _turned_over_count(vertices, untangled, triangles) == 0 and final.contains(untangled[moved]).all():
            repaired, after = untangled, 0
            break
    moves = np.linalg.norm(repaired - images, axis=1)
    certificate = composite_certificate(steps, source)
    moved = {
        "moved": int(np.count_nonzero(moves)),
        "largest_move": float(moves.max()) / final.diameter,
        "turned_over": after,
    }
    return repaired, dataclasses.replace(certificate, extra=certificate.extra | moved)


def _turned_over_count(vertices: np.ndarray, images: np.ndarray, triangles: np.ndarray) -> int:
    """How many triangles (T, 3) the images (V, 2) of the vertices (V, 2) fold: turned over or
    collapsed, as `core.folded_triangles` counts them (and both repairs aim for)."""
    areas = triangle_signed_areas(images, triangles)
    return int(np.count_nonzero(areas <= FOLDED_AREA_SHARE * triangle_signed_areas(vertices, triangles)))


def _turns_over(triangles: np.ndarray, before: np.ndarray, after: np.ndarray, skipped=None) -> bool:
    """Whether a step turns over a triangle (T, 3) that was not turned over before it (not counting
    triangles with a vertex where `skipped` (V,) is True)."""
    if skipped is not None:
        triangles = triangles[~np.any(skipped[triangles], axis=1)]
    newly = (triangle_signed_areas(after, triangles) <= 0) & (triangle_signed_areas(before, triangles) > 0)
    return bool(np.any(newly))


def _target_curve(points: np.ndarray) -> ClosedBSpline:
    """The target cage's curve; ValueError, said of the target, if it crosses itself."""
    try:
        return ClosedBSpline(points)
    except ValueError as error:
        raise ValueError(f"the target cannot be reached without folding: {error}") from None


def _path_cage(points: np.ndarray, s: float) -> ClosedBSpline:
    """The cage at s on the path; ValueError if it crosses itself (then no map through it is a bijection)."""
    try:
        return ClosedBSpline(points)
    except ValueError as error:
        raise ValueError(
            f"the straight path from the cage to the target passes through a cage that crosses itself "
            f"(at {s:.3g} of the way): {error}"
        ) from None


def _basis(current: ClosedBSpline, points: np.ndarray) -> np.ndarray:
    """The harmonic basis (M, n) of `current` at points (M, 2), whose products with a cage's control
    points (n, 2) are their images under the harmonic map onto it; points a hair outside `current`
    (rounding of the previous step) go to its closest point first."""
    try:
        return basis_functions(current, points, "poisson")
    except ValueError:  # some points are outside: the test below costs, so only now
        return basis_functions(current, _inside(current, points), "poisson")


def _in_corner_discs(current: ClosedBSpline, points: np.ndarray) -> np.ndarray:
    """Whether each of the points (M, 2) lies in the disc of a sharp corner of `current` (M,)."""
    inside = np.zeros(len(points), dtype=bool)
    for corner in inner_curve.corners(current):
        inside |= np.linalg.norm(points - corner.point, axis=1) < corner.radius
    return inside


def _inside(curve: ClosedBSpline, points: np.ndarray) -> np.ndarray:
    """Points (M, 2) with those outside `curve` (by rounding) moved to their closest point on it."""
    outside = np.flatnonzero(~curve.contains(points))
    if outside.size == 0:
        return points
    parameters, _ = closest_point(curve, points[outside])
    points = points.copy()
    points[outside] = curve(parameters)
    return points


def composite_certificate(
    steps: list[InjectivityCertificate], source: ClosedBSpline | None = None
) -> InjectivityCertificate:
    """The certificate of a composite of certified steps: σ₂ >= Π σ₂_k, and K <= Π K_k for the
    dilatations K = (1 + k) / (1 - k).  Its ``where``: the sharp corners of the `source` cage
    when a step was proven only away from corners (each step's own are points of its cage, which
    the steps before take to the same corners); the steps' points when `source` is None."""
    sigma2 = math.prod(step.sigma2_min for step in steps)
    dilatation = math.prod(
        (1.0 + step.k_max) / (1.0 - step.k_max) if step.k_max < 1.0 else math.inf for step in steps
    )
    k_max = (dilatation - 1.0) / (dilatation + 1.0) if math.isfinite(dilatation) else 1.0
    injective = all(step.injective for step in steps)
    corners = [step.where for step in steps if step.away_from_corners]
    where = np.unique(np.concatenate(corners), axis=0) if corners else np.zeros((0, 2))
    if corners and source is not None:
        where = source(source.corners()[:, 0])
    samples = sum(step.samples for step in steps)
    if injective:
        reason = f"composite of {len(steps)} proven harmonic step(s)"
    else:
        reason = (
            f"a bijection: composite of {len(steps)} step(s), harmonic and proven outside discs around "
            "sharp corners, radial over the arc's image (checked star-shaped) inside them"
        )
    radius = max((step.corner_radius for step in steps), default=0.0)
    return InjectivityCertificate(
        injective, sigma2, k_max, where, reason, samples, not injective, radius, {"steps": len(steps)}
    )


__all__ = ["composite_certificate", "fold_free_deform"]
