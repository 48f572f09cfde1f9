"""A fold-free map of a mesh: composite discrete harmonic steps with a flip-free line search.

The map that is drawn is the mesh's piecewise-linear one, so the composite of Schneider, Hormann &
Floater (SGP 2013) is taken on the mesh itself, as libigl's ``bijective_composite_harmonic_mapping``
does: the boundary vertices move along a straight path of boundary values, Y(s) = (1 - s) Y₀ + s Y₁,
and a step from s to s' is the discrete harmonic map (P1 finite elements, the cotangent stiffness of
the *current* images: the step is harmonic on the current domain, and the identity is its solution
for s' = s, so that short steps are close to it) with the boundary at Y(s').  Where libigl doubles
its number of uniform steps and starts again when a step turns a triangle over, here each step is
cut where the first triangle would turn over (Smith & Schaefer, "Bijective parameterization with
free boundaries", 2015: along the straight segment from the current images to the step's, triangle
t's doubled signed area is a quadratic a τ² + b τ + c in the step's fraction τ, and the smallest
positive root over the triangles is the largest flip-free fraction); a fraction `SAFETY` of it is
taken, and since Y is linear in s the boundary is then exactly Y at the matching s.  Left alone, the
next steps squeeze the same triangles again (a 1:8 ellipse's drag: their areas fell 5× a step and
the path stalled at 0.78), so after a cut step the free vertices around the triangles that limited
it take a few Newton steps of the barrier energy of `core.injectivity.mesh_untangling` (`relaxed`:
it grows without bound as a triangle collapses, so they open up; then the same drag took 10 steps).
Every image on the way is fold-free, the step size adapts (doubling after a whole step, halving
after a poor one, which also relaxes a wider region), the path is given up when its pace says it
would not end within `MAX_SOLVES`, and the end is proven a bijection by
`core.injectivity.mesh_bijection` (all triangles positive, the boundary polygon simple).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from core.injectivity.mesh_untangling import relaxed
from core.meshes.mesh import folded_limits, triangle_signed_areas

#: The share of the largest flip-free fraction of a step that is taken.
SAFETY = 0.8
#: A step cut below this fraction of the way asked for is not taken: the step is halved instead.
POOR_FRACTION = 0.1
#: Harmonic solves at most, and the smallest step in s, before the path is given up.
MAX_SOLVES = 200
SMALLEST_STEP = 1.0 / 4096
#: The path is given up when, at the pace of the last this many solves, the rest of it would take
#: more than `MAX_SOLVES` in all.
STALL_SOLVES = 12
#: After a cut step, the free vertices within this many rings of the triangles that limited it are
#: moved by this many Newton steps of a barrier energy; after a poor one, within more, by more.
RINGS = 3
RELAX_ROUNDS = 3
POOR_RINGS = 8
POOR_ROUNDS = 10


@dataclass(frozen=True)
class MeshPath:
    """The end of a composite on a mesh.

    Attributes
    ----------
    images : ndarray of shape (V, 2)
        The images reached: at s = `reached`, every triangle kept positive.
    reached : float
        How far along the path (1: the boundary is on Y₁).
    solves : int
        Harmonic solves made.
    """

    images: np.ndarray
    reached: float
    solves: int


def composite_on_mesh(
    vertices: np.ndarray,
    triangles: np.ndarray,
    boundary: np.ndarray,
    start: np.ndarray,
    end_values: np.ndarray,
    progress: Callable[[float], None] | None = None,
    max_solves: int = MAX_SOLVES,
) -> MeshPath:
    """Move the mesh's images from `start` to boundary values `end_values` by fold-free harmonic steps.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
        The mesh, triangles counter-clockwise.
    triangles : ndarray of shape (T, 3), int
    boundary : ndarray of shape (B,), int
        The boundary vertices (fixed to the path's values).
    start : ndarray of shape (V, 2)
        Images with every triangle positive (the identity, or a similarity of it).
    end_values : ndarray of shape (B, 2)
        The boundary vertices' images at the end of the path.
    progress : callable, optional
        Called after every solve with how far along the path the images are (0 to 1).
    max_solves : int

    Returns
    -------
    MeshPath
        Reached 1 when the whole path was taken; less when the steps stalled (then the images at
        the last s reached).
    """
    free = np.ones(len(vertices), dtype=bool)
    free[boundary] = False
    solver = _HarmonicSolver(triangles, free)
    source_areas = triangle_signed_areas(vertices, triangles)
    first = start[boundary]
    images, s, step, solves, history = start.copy(), 0.0, 1.0, 0, [0.0]
    while s < 1.0 and solves < max_solves and step >= SMALLEST_STEP and not _stalled(history, max_solves):
        following = min(1.0, s + step)
        values = end_values if following == 1.0 else (1.0 - following) * first + following * end_values
        proposed = solver.solve(images, boundary, values)
        solves += 1
        fraction, limiting = _kept_fraction(images, proposed, triangles, source_areas)
        if fraction >= POOR_FRACTION:
            images = proposed if fraction == 1.0 else images + fraction * (proposed - images)
            if fraction < 1.0:
                images = _opened(vertices, images, triangles, free, limiting, source_areas)
            s = following if fraction == 1.0 else s + fraction * (following - s)
            step = min(1.0, 2.0 * step) if fraction == 1.0 else step
        else:  # the same triangles would collapse again: ease a wider region open
            images = _opened(
                vertices, images, triangles, free, limiting, source_areas, POOR_RINGS, POOR_ROUNDS
            )
            step *= 0.5
        history.append(s)
        if progress is not None:
            progress(s)
    if s == 1.0:
        images[boundary] = end_values
    return MeshPath(images, s, solves)


def harmonic_images(triangles: np.ndarray, boundary: np.ndarray, metric: np.ndarray, values: np.ndarray):
    """The discrete harmonic map (V, 2) in the metric of the images `metric` (V, 2) with the
    `boundary` (B,) rows at `values` (B, 2): one step of `composite_on_mesh`, whatever it folds."""
    free = np.ones(len(metric), dtype=bool)
    free[boundary] = False
    return _HarmonicSolver(triangles, free).solve(metric, boundary, values)


def _stalled(history: list[float], max_solves: int) -> bool:
    """Whether, at the pace of the last `STALL_SOLVES` solves (s after each in `history`), the rest
    of the path would take more than `max_solves` solves in all."""
    if len(history) <= STALL_SOLVES:
        return False
    pace = (history[-1] - history[-1 - STALL_SOLVES]) / STALL_SOLVES
    return not pace * (max_solves - len(history)) >= 1.0 - history[-1]


def _kept_fraction(images, proposed, triangles, source_areas) -> float:
    """The fraction τ in (0, 1] of the move from `images` to `proposed` (V, 2) to take: 1 if every
    triangle stays kept all the way, else `SAFETY` times the first τ at which one collapses (halved
    while the images there still count a triangle folded); 0 if none is left."""
    i, j, k = triangles.T
    u1, u2 = images[j] - images[i], images[k] - images[i]
    moves = proposed - images
    d1, d2 = moves[j] - moves[i], moves[k] - moves[i]
    a = _cross(d1, d2)
    b = _cross(u1, d2) + _cross(d1, u2)
    c = _cross(u1, u2)
    roots = _first_positive_roots(a, b, c)
    limiting = roots <= 1.0
    first = float(roots.min(initial=np.inf))
    fraction = 1.0 if first > 1.0 else SAFETY * first
    for _ in range(8):
        taken = proposed if fraction == 1.0 else images + fraction * moves
        areas = triangle_signed_areas(taken, triangles)
        kept = areas > folded_limits(source_areas, areas)
        if kept.all():
            return fraction, limiting
        limiting |= ~kept
        fraction = 0.5 * (SAFETY if fraction == 1.0 else fraction)
    return 0.0, limiting


def _opened(vertices, images, triangles, free, limiting, source_areas, rings=None, rounds=None) -> np.ndarray:
    """The images (V, 2) with the free vertices within `RINGS` rings of the `limiting` triangles (T,)
    (those that would have turned over) moved by `RELAX_ROUNDS` Newton steps of a barrier energy
    (`core.injectivity.mesh_untangling.relaxed`), so that the next steps do not squeeze the same
    triangles again; unchanged if that folds a triangle."""
    region = np.zeros(len(images), dtype=bool)
    region[triangles[limiting].ravel()] = True
    for _ in range(RINGS if rings is None else rings):
        region[triangles[np.any(region[triangles], axis=1)].ravel()] = True
    movable = region & free
    if not movable.any():
        return images
    moved = relaxed(vertices, images, triangles, movable, RELAX_ROUNDS if rounds is None else rounds)
    areas = triangle_signed_areas(moved, triangles)
    return moved if np.all(areas > folded_limits(source_areas, areas)) else images


def _first_positive_roots(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Per triangle the smallest τ > 0 at which a τ² + b τ + c (each (T,), c > 0) vanishes; inf if none."""
    roots = np.full(a.shape, np.inf)
    linear = np.abs(a) <= 1e-14 * (np.abs(b) + np.abs(c))
    falling = linear & (b < 0)
    roots[falling] = -c[falling] / b[falling]
    quadratic = ~linear
    disc = b * b - 4.0 * a * c
    real = quadratic & (disc >= 0)
    root_of_disc = np.sqrt(np.where(real, disc, 0.0))
    q = -0.5 * (b + np.where(b >= 0, root_of_disc, -root_of_disc))
    with np.errstate(divide="ignore", invalid="ignore"):
        one, other = q / a, c / q
    for candidate in (one, other):
        positive = real & np.isfinite(candidate) & (candidate > 0)
        roots[positive] = np.minimum(roots[positive], candidate[positive])
    return roots


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


class _HarmonicSolver:
    """The discrete harmonic map of a mesh with fixed boundary values, in the metric of given images:
    the P1 stiffness K (the cotangent weights) of the image triangles, K_FF x_F = -K_FB x_B for the
    free vertices F.  The sparsity pattern is built once; each solve fills in the values.  K_FF is
    symmetric positive definite (the image triangles are all positive), so it is factored without
    pivoting, in SuperLU's symmetric mode: half the time of a pivoting LU at 50k vertices."""

    def __init__(self, triangles: np.ndarray, free: np.ndarray):
        self.triangles = triangles
        rows = np.repeat(triangles, 3, axis=1).ravel()
        cols = np.tile(triangles, (1, 3)).ravel()
        self.numbering = np.cumsum(free) - 1  # a free vertex's row in K_FF
        self.inner = free[rows] & free[cols]
        self.coupled = free[rows] & ~free[cols]
        self.rows, self.cols, self.count = rows, cols, int(free.sum())
        self.free = free

    def solve(self, metric: np.ndarray, boundary: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Images (V, 2): `values` (B, 2) at the `boundary` rows, harmonic in `metric`'s (V, 2) elsewhere."""
        corners = metric[self.triangles]
        opposite = np.roll(corners, -1, axis=1) - np.roll(corners, 1, axis=1)  # edge opposite each corner
        area4 = 2.0 * _cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        stiffness = (np.einsum("tid,tjd->tij", opposite, opposite) / area4[:, None, None]).ravel()
        fixed = np.zeros_like(metric)
        fixed[boundary] = values
        rows, cols = self.numbering[self.rows], self.numbering[self.cols]
        matrix = scipy.sparse.csc_matrix(
            (stiffness[self.inner], (rows[self.inner], cols[self.inner])), shape=(self.count, self.count)
        )
        weights = stiffness[self.coupled]
        right = np.zeros((self.count, 2))
        for axis in range(2):
            right[:, axis] = -np.bincount(
                rows[self.coupled], weights * fixed[self.cols[self.coupled], axis], minlength=self.count
            )
        images = fixed
        images[self.free] = scipy.sparse.linalg.splu(
            matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        ).solve(right)
        return images


__all__ = ["MeshPath", "composite_on_mesh", "harmonic_images"]
