"""A fold-free map of a mesh onto a target cage, proven on the mesh: `mesh_fold_free_map`.

What is drawn is the mesh's piecewise-linear map, and `core.injectivity.mesh_bijection` proves it a
bijection onto its boundary polygon when every triangle keeps its orientation and that polygon is
simple: no certificate of a continuous map is needed for a fold-free *mesh* map.  The map is the
composite of discrete harmonic steps of `core.injectivity.mesh_composite`, with the boundary
vertices on the cages of a path at their parameters, tried on the paths below in turn until one
reaches the target (unless the plain harmonic map G P', where the caller gives it, is a bijection
on the mesh: then it is the answer, what the plain warp draws; next, where the caller gives it, the
continuous composite's images, kept if they are a bijection on the mesh):

1. the straight path of cages, P(s) = (1 - s) P + s P';
2. the similarity (rotation and scale about the centroid, and the centroid's move) that best fits
   the control points, taken exactly (it keeps every triangle's orientation), then the straight path
   from the similar cage to the target: a rotation up to 180°, whose straight path collapses the
   cage at its middle, and a shrink to any scale are one step.

A path through a cage whose control polygon has no area (a rotation by 180°) is skipped; a path on
which cages cross themselves is tried all the same (positive triangles can overlap on the way, as
long as they do not at the end) for `FIRST_SOLVES` solves, then given up (such paths stalled on
every drag tried), and the refusal says where it crosses; a later path whose cages cross themselves
too is not followed (on the held-out star drags both paths crossed and stalled, and the untangling
of the first one's furthest images mapped each, 0.4-0.8 s sooner).  When no path
reaches the target, the furthest images are carried to it by one harmonic step and the triangles
that step turns over are untangled (`core.injectivity.mesh_untangling`); if that fails too, the
refusal names every path tried.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from core.curves.bspline import ClosedBSpline
from core.injectivity.certificate import InjectivityCertificate
from core.injectivity.mesh_bijection import mesh_bijection
from core.injectivity.mesh_composite import MAX_SOLVES, MeshPath, composite_on_mesh, harmonic_images
from core.injectivity.mesh_untangling import untangle_triangles
from core.meshes.distortion import signed_singular_values, triangle_jacobians

#: Cages at s = 1/PATH_CHECKS, 2/PATH_CHECKS, ... of a path are checked for crossings before any step.
PATH_CHECKS = 16
#: Solves on a path before it is checked for cages that cross themselves, if it has not ended.
FIRST_SOLVES = 16
#: Rings around the turned-over triangles in the untangling's first region: a stalled path's tangle
#: is wide (star drags across a neighbouring arm: 3 and 6 rings failed, 100 rounds each, before 12
#: untangled, 2.7 of 3.5 s).
UNTANGLING_RINGS = 12
#: A control polygon whose area falls to this share of the larger end's on the way counts as collapsed
#: (a half turn's is 0 at the middle, up to rounding).
COLLAPSED = 1e-6
#: The name of the plain harmonic map G P' where it is the answer (no path taken).
PLAIN_HARMONIC_MAP = "the plain harmonic map"
#: The name of the continuous composite (harmonic maps between the cages of the straight path,
#: each step certified), tried first on large meshes where the caller gives it.
CONTINUOUS_COMPOSITE = "the continuous composite"
#: The paths tried, by name, in order.
PATHS = ("the straight path", "rotation and scale about the centroid, then the straight path")


def mesh_fold_free_map(
    curve: ClosedBSpline,
    final: ClosedBSpline,
    vertices: np.ndarray,
    triangles: np.ndarray,
    boundary: tuple[np.ndarray, np.ndarray],
    progress: Callable[[float], None] | None = None,
    plain: np.ndarray | None = None,
    continuous: Callable[[], tuple[np.ndarray, int] | None] | None = None,
) -> tuple[np.ndarray, InjectivityCertificate]:
    """Images of the mesh's vertices under a fold-free piecewise-linear map onto the target's polygon.

    Parameters
    ----------
    curve : ClosedBSpline
        The source cage, n control points.
    final : ClosedBSpline
        The target cage, n control points.
    vertices : ndarray of shape (V, 2)
        The mesh's vertices (a mesh of `curve`: one boundary loop on it).
    triangles : ndarray of shape (T, 3), int
        Counter-clockwise.
    boundary : (indices, parameters)
        The boundary vertices, int (B,), and their parameters on the curve (B,): their images are
        the target curve at those parameters exactly.
    progress : callable, optional
        Called after every harmonic step with how far along the current path the images are (a
        path tried after another starts again from 0).
    plain : ndarray of shape (V, 2), optional
        The plain harmonic map's images (G P'): the answer if they are a bijection on the mesh.
    continuous : callable, optional
        Tried next (before the paths): (images (V, 2), steps) of the continuous composite
        (`CONTINUOUS_COMPOSITE`), or None where it stops; the answer if a bijection on the mesh.

    Returns
    -------
    images : ndarray of shape (V, 2)
    certificate : InjectivityCertificate
        ``on_mesh``: the piecewise-linear map proven a bijection onto its boundary polygon; σ₂ and k
        of its triangles' Jacobians; ``extra``: ``"steps"`` (harmonic solves), ``"path"``,
        ``"moved"``, ``"largest_move"``, ``"turned_over"`` (0).

    Raises
    ------
    ValueError
        The target runs the other way round, or no path reaches it without folding (the sentence
        names the paths tried).
    """
    target = final.control_points
    if (_polygon_area(target) > 0.0) != (_polygon_area(curve.control_points) > 0.0):
        raise ValueError("the target runs the other way round than the cage: every triangle would turn over")
    indices, parameters = boundary
    loop = indices[np.argsort(parameters, kind="stable")]
    end_values = final(parameters)
    if plain is not None:
        plain = plain.copy()
        plain[indices] = end_values  # G interpolates the curve: the same up to rounding
        if mesh_bijection(vertices, plain, triangles, loop).proven:
            return plain, _certificate(vertices, plain, triangles, PLAIN_HARMONIC_MAP, 0)
    tried, solves, furthest, crossed = [], 0, None, False
    if continuous is not None:
        mapped = _continuous_end(vertices, triangles, indices, loop, end_values, continuous, tried)
        if mapped is not None:
            return mapped
    for name, start_cage, start in _paths(curve, target, vertices):
        collapse = _collapse(start_cage, target)
        if collapse is not None:
            tried.append(f"{name} (the cage's control polygon collapses at {collapse:.3g} of the way)")
            continue
        crossing = _crossing(start_cage, target) if crossed else None
        if crossing is not None:  # the untangling takes the furthest images of the first such path
            tried.append(f"{name} (not followed after a path that crosses itself stalled; {crossing})")
            continue
        reached, crossing = _followed(
            vertices, triangles, indices, (start_cage, start), target, end_values, progress
        )
        crossed |= crossing is not None
        solves += reached.solves
        if reached.reached == 1.0:
            proof = mesh_bijection(vertices, reached.images, triangles, loop)
            if proof.proven:
                return reached.images, _certificate(vertices, reached.images, triangles, name, solves)
            tried.append(f"{name} (its end is not a bijection: {proof.reason()})")
            continue
        why = crossing or "no cage on it crosses itself"
        tried.append(f"{name} (its steps stall at {reached.reached:.3g} of the way; {why})")
        if furthest is None or reached.reached > furthest[1].reached:
            furthest = (name, reached)
    if furthest is not None:
        untangled = _untangled_end(vertices, triangles, indices, loop, end_values, furthest[1])
        if untangled is not None:
            images, moves = untangled
            return images, _certificate(vertices, images, triangles, furthest[0], solves + 1, moves)
    raise ValueError(
        "no fold-free map of the mesh onto the target was found; paths tried: " + "; ".join(tried)
    )


def _continuous_end(vertices, triangles, indices, loop, end_values, continuous, tried):
    """(images, certificate) of the `continuous` composite (see `mesh_fold_free_map`) if its mesh
    map is a bijection, else None with the reason appended to `tried`."""
    composite = continuous()
    if composite is None:
        tried.append(f"{CONTINUOUS_COMPOSITE} (not proven within its steps)")
        return None
    images, steps = composite
    images[indices] = end_values
    proof = mesh_bijection(vertices, images, triangles, loop)
    if proof.proven:
        return images, _certificate(vertices, images, triangles, CONTINUOUS_COMPOSITE, steps)
    tried.append(f"{CONTINUOUS_COMPOSITE} (its mesh map is not a bijection: {proof.reason()})")
    return None


def _followed(
    vertices, triangles, indices, start, target, end_values, progress
) -> tuple[MeshPath, str | None]:
    """The composite on the path from `start` (its cage (n, 2), images (V, 2)) to `target` (n, 2),
    and where a cage on it crosses itself (None if none does).  `FIRST_SOLVES` solves first; a path
    not ended by then is followed on, from where it got to, only if no cage on it crosses itself:
    such paths stalled on every drag tried (a star's tip dragged across its neighbour's arm)."""
    start_cage, images = start
    first = composite_on_mesh(vertices, triangles, indices, images, end_values, progress, FIRST_SOLVES)
    if first.reached == 1.0:
        return first, None
    crossing = _crossing(start_cage, target)
    if crossing is not None:
        return first, crossing
    done = first.reached  # the rest of the path is the straight path from there: Y is linear in s
    rest = composite_on_mesh(
        vertices, triangles, indices, first.images, end_values,
        None if progress is None else lambda s: progress(done + (1.0 - done) * s),
        MAX_SOLVES - first.solves,
    )  # fmt: skip
    reached = 1.0 if rest.reached == 1.0 else done + (1.0 - done) * rest.reached
    return MeshPath(rest.images, reached, first.solves + rest.solves), None


def _paths(curve: ClosedBSpline, target: np.ndarray, vertices: np.ndarray):
    """(name, start cage (n, 2), start images (V, 2)) of each path of `PATHS` that can be built."""
    source = curve.control_points
    yield PATHS[0], source, vertices
    similarity = _best_similarity(source, target)
    if similarity is not None:
        scale_rotation, shift = similarity
        yield PATHS[1], _similar(source, scale_rotation, shift), _similar(vertices, scale_rotation, shift)


def _collapse(start: np.ndarray, target: np.ndarray) -> float | None:
    """Where on the straight path of cages from `start` to `target` (n, 2) the control polygon's
    signed area (a quadratic in s, checked at `PATH_CHECKS` points and the vertex of the parabola)
    falls to `COLLAPSED` of the ends' or changes sign, or None: no mesh follows a boundary through
    that."""
    fractions = np.arange(1, PATH_CHECKS) / PATH_CHECKS
    first, last, middle = (_polygon_area(points) for points in (start, target, 0.5 * (start + target)))
    # A(s) = first (1 - s)² + 2 c s (1 - s) + last s², with c from A(1/2).
    cross_term = 2.0 * middle - 0.5 * (first + last)
    curvature = first + last - 2.0 * cross_term
    if curvature > 0.0:
        vertex = (first - cross_term) / curvature
        fractions = np.append(fractions, vertex) if 0.0 < vertex < 1.0 else fractions
    areas = first * (1 - fractions) ** 2 + 2 * cross_term * fractions * (1 - fractions) + last * fractions**2
    collapsed = np.flatnonzero(areas * np.sign(first) <= COLLAPSED * max(abs(first), abs(last)))
    return None if collapsed.size == 0 else float(np.min(fractions[collapsed]))


def _polygon_area(points: np.ndarray) -> float:
    """The signed area of the closed polygon (n, 2) (the shoelace formula)."""
    following = np.roll(points, -1, axis=0)
    return 0.5 * float(np.sum(points[:, 0] * following[:, 1] - points[:, 1] * following[:, 0]))


def _crossing(start: np.ndarray, target: np.ndarray) -> str | None:
    """Where a cage on the straight path from `start` to `target` (n, 2) crosses itself, or None."""
    for fraction in np.arange(1, PATH_CHECKS) / PATH_CHECKS:
        try:
            ClosedBSpline((1.0 - fraction) * start + fraction * target)
        except ValueError as error:
            return f"a cage on it crosses itself at {fraction:.3g} of the way: {error}"
    return None


def _best_similarity(source: np.ndarray, target: np.ndarray) -> tuple[complex, complex] | None:
    """(a, b) minimising Σ |a z_i + b - w_i|² over the control points as complex numbers: the
    rotation and scale a about the centroid, and the shift; None when a vanishes."""
    z = source[:, 0] + 1j * source[:, 1]
    w = target[:, 0] + 1j * target[:, 1]
    zc, wc = z - z.mean(), w - w.mean()
    a = complex(np.vdot(zc, wc) / np.vdot(zc, zc).real)
    if not abs(a) > 0.0:
        return None
    return a, complex(w.mean() - a * z.mean())


def _similar(points: np.ndarray, scale_rotation: complex, shift: complex) -> np.ndarray:
    """The points (M, 2) under z -> a z + b."""
    moved = scale_rotation * (points[:, 0] + 1j * points[:, 1]) + shift
    return np.stack([moved.real, moved.imag], axis=1)


def _untangled_end(vertices, triangles, indices, loop, end_values, furthest: MeshPath):
    """(images, moves) carried from a stalled path's furthest images to the target by one harmonic
    step and untangled (`untangle_triangles`), if that ends a bijection; else None."""
    images = harmonic_images(triangles, indices, furthest.images, end_values)
    free = np.ones(len(vertices), dtype=bool)
    free[indices] = False
    untangled, moves = untangle_triangles(vertices, images, triangles, free, UNTANGLING_RINGS)
    if not mesh_bijection(vertices, untangled, triangles, loop).proven:
        return None
    return untangled, moves


def _certificate(vertices, images, triangles, path: str, solves: int, moves=None) -> InjectivityCertificate:
    """The certificate of a piecewise-linear map proven a bijection on the mesh."""
    sigma = signed_singular_values(triangle_jacobians(vertices, images, triangles))
    k = float(np.max((sigma[:, 0] - sigma[:, 1]) / (sigma[:, 0] + sigma[:, 1])))
    moved = 0 if moves is None else int(np.count_nonzero(moves))
    largest = 0.0 if moves is None else float(moves.max()) / float(np.ptp(images, axis=0).max())
    extra = {"steps": solves, "path": path, "moved": moved, "largest_move": largest, "turned_over": 0}
    steps = "" if path == PLAIN_HARMONIC_MAP else f", {solves} harmonic steps"
    reason = (
        f"the mesh's piecewise-linear map: every triangle keeps its orientation and the boundary "
        f"polygon is simple ({path}{steps})"
    )
    return InjectivityCertificate(
        True, float(sigma[:, 1].min()), k, np.zeros((0, 2)), reason, 0, False, 0.0, extra, on_mesh=True
    )


__all__ = ["CONTINUOUS_COMPOSITE", "PATHS", "PLAIN_HARMONIC_MAP", "mesh_fold_free_map"]
