"""Untangling a mesh's images globally: `untangle_triangles`, where the local repair leaves folds.

The local repair (`core.injectivity.mesh_unfolding`) moves one vertex at a time; where a proven
bijection is so anisotropic that rows of a straight-edged mesh's triangles turn over together (a
shaft squeezed into a fan of slivers near a sharp corner), no single vertex can unfold its ring.
Here all free vertices of a region around the turned-over triangles move at once, by the barrier
method of Garanzha, Kaporin, Kudryavtseva, Protais, Ray & Sokolov ("Foldover-free maps in 50 lines
of code", SIGGRAPH 2021).  With J_t the Jacobian of the affine map from a reference triangle of area
a_t onto triangle t's image, the energy

    E_ε = Σ_t a_t [(1 - θ) tr(J_tᵀ J_t) + θ (det² J_t + 1)] / χ(det J_t, ε),
    χ(D, ε) = (D + √(ε² + D²)) / 2,

is finite for every ε > 0, and as ε → 0 it tends to +∞ wherever det J_t ≤ 0, so that (when some
placement of the free vertices turns nothing over) its minimisers' smallest determinant turns
positive as ε shrinks.  ε follows their continuation: after a round with energy E (E_prev before
it) and smallest determinant D_min, σ = max(1 - E / E_prev, 0.1), μ = (1 - σ) χ(D_min, ε), and
ε = 2 √(μ (μ - D_min)) if D_min < μ, else a tiny one (`TINY_EPSILON`).  A round here is
one Newton step on E_ε (each triangle's 4 × 4 Hessian in J projected onto the positive semi-definite
matrices, so that the step descends, and a backtracking line search) rather than a full
minimisation: ε shrinks by ~5 % a round while the smallest determinant is negative, whatever the
inner iterations (with all 1535 interior vertices of a cornered drag free, 1 Newton step a round
untangled in 2.9 s, 2 in 3.8 s, 8 had not after 60 rounds, 15 s).

The reference triangles, all scaled so that their total area is the images' (invariant under moves
of free vertices), are tried in two ways on each region: first the images themselves where they are
not turned over (the energy then holds the proven map's shape there) and the source triangles where
they are; then the source triangles throughout.  The first moves vertices less (on the images of
three cornered drags that both untangle, the largest move fell from 4.6-8.2 % of the diameter to
1.3-6.2 %); the second untangles some regions that the first does not, where the images are
slivers a million times thinner than their source triangles (a radial corner map's fan).  A region
that neither untangles (the turned-over
count stops falling for `STALL_ROUNDS` rounds, or `MAX_ROUNDS` pass) is doubled in rings, from
`RINGS` around the turned-over triangles, until it holds every free vertex, `REGION_TRIES` failed
or the `WORK` is spent.

Why it is sound: if every triangle ends positively oriented and the boundary vertices, which never
move, form a simple polygon, the piecewise-linear map is a bijection onto that polygon (a degree
argument), so the untangled mesh covers it once.  What it does not guarantee: success (a triangle
whose three vertices are all fixed cannot be unfolded), and that a free vertex stays inside a
curved target (the polygon of the boundary's images is not the curve): the caller checks both.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from core.meshes.mesh import FOLDED_AREA_SHARE, triangle_signed_areas

#: The weight of the area term (det² + 1) / χ against the shape term tr(JᵀJ) / χ.
THETA = 0.5
#: Rounds (Newton steps, each followed by an ε update) at most in one region, and rounds without
#: fewer turned-over triangles after which a region is given up.
MAX_ROUNDS = 400
STALL_ROUNDS = 100
#: Newton steps times vertices moved, over all regions and references tried, before giving up on
#: growing the region (the first region is always tried): a bound on the cost of a tangle that
#: cannot be undone (~7 s on a busy 2-core machine; the three cornered drags that needed
#: untangling used 13,000 to 76,000).
WORK = 500_000
#: σ's floor in the ε update (Garanzha et al.'s 0.1).
SMALLEST_DECREASE = 0.1
#: The ε once the smallest determinant is above μ (Garanzha et al.'s "tiny"), relative to det J = 1.
TINY_EPSILON = 1e-10
#: Rings of triangles around the turned-over ones in the first region; each failure doubles them,
#: up to `REGION_TRIES` regions (the last of 96 rings: most meshes' whole interior, while the cost
#: stays bounded on a fine mesh with a small tangle).
RINGS = 3
REGION_TRIES = 6
#: A triangle counts as turned over when its image's signed area is at most this share of its own
#: (as `core.folded_triangles`).
TOLERANCE = FOLDED_AREA_SHARE


def untangle_triangles(
    vertices: np.ndarray,
    images: np.ndarray,
    triangles: np.ndarray,
    free: np.ndarray,
    rings: int = RINGS,
) -> tuple[np.ndarray, np.ndarray]:
    """Images with free vertices near turned-over triangles moved together so that none turns over.

    Parameters
    ----------
    vertices : ndarray of shape (V, 2)
        The mesh's vertices, its triangles counter-clockwise.
    images : ndarray of shape (V, 2)
        Their images; for the result to be a bijection onto the polygon of the fixed (not free)
        vertices' images, that polygon must be simple.
    triangles : ndarray of shape (T, 3), int
    free : ndarray of shape (V,), bool
        Vertices that may move (the interior ones).
    rings : int
        Rings of triangles around the turned-over ones in the first region (doubled after each
        region that fails): more where the tangle is known to be wide.

    Returns
    -------
    images : ndarray of shape (V, 2)
        A copy: with no triangle turned over, or unchanged if no region tried untangles them or a
        turned-over triangle has no free vertex (then they are left for the caller to see, with
        `core.folded_triangles`).  Vertices that are not free never move.
    moves : ndarray of shape (V,)
        How far each vertex moved.
    """
    images = np.asarray(images, dtype=np.float64)
    source_areas = triangle_signed_areas(vertices, triangles)
    turned = triangle_signed_areas(images, triangles) <= TOLERANCE * source_areas
    if np.any(turned & ~np.any(free[triangles], axis=1)):  # no move can unfold these
        return images.copy(), np.zeros(len(images))
    tried, budget = np.zeros(len(images), dtype=bool), WORK
    for attempt in range(REGION_TRIES if np.any(turned) else 0):
        movable = free & _rings_around(triangles, turned, len(images), rings * 2**attempt)
        if np.array_equal(movable, tried):  # no new vertex: the region holds every free one (or none)
            break
        closest, fewest = None, np.count_nonzero(turned)
        for own_shapes, warm in _TRIES:  # the first region is always tried in full
            if warm and closest is None:
                break
            rounds = MAX_ROUNDS if attempt == 0 else min(MAX_ROUNDS, budget // np.count_nonzero(movable))
            if rounds <= STALL_ROUNDS:  # too little work left to tell
                return images.copy(), np.zeros(len(images))
            start = closest if warm else images
            untangled, taken = _untangled(vertices, images, start, triangles, movable, own_shapes, rounds)
            left = np.count_nonzero(triangle_signed_areas(untangled, triangles) <= TOLERANCE * source_areas)
            if left == 0:
                return untangled, np.linalg.norm(untangled - images, axis=1)
            if left < fewest:
                closest, fewest = untangled, left
            budget -= taken * np.count_nonzero(movable)
        tried = movable
    return images.copy(), np.zeros(len(images))


def relaxed(
    vertices: np.ndarray, images: np.ndarray, triangles: np.ndarray, movable: np.ndarray, rounds: int
) -> np.ndarray:
    """Images (V, 2) with the `movable` (V,) vertices moved by `rounds` Newton steps on the barrier
    energy E_ε (ε tiny) against the source triangles' shapes: from images that turn nothing over, a
    step that would turn a triangle over raises E_ε past any bound and is cut back by the line
    search, so triangles about to collapse open up and none turns over (the caller checks)."""
    active = triangles[np.any(movable[triangles], axis=1)]
    gradients, areas = reference_shapes(vertices, images, active, own_shapes=False)
    problem = BarrierProblem(images, active, movable, gradients, areas)
    positions = images[movable].ravel()
    for _ in range(rounds):
        positions = problem.newton_step(positions, TINY_EPSILON)
    result = images.copy()
    result[movable] = positions.reshape(-1, 2)
    return result


#: The tries on each region: (reference of the images' own shapes, start from the closest try so far
#: on the region instead of the images).  A try that stalls with a few triangles turned over often
#: leaves a start from which the source shapes untangle at once (a cornered drag at 6.5k vertices:
#: 194 turned over, the two cold tries stalled at 10 and 4, the warm one untangled in 111 rounds).
_TRIES = ((True, False), (False, False), (False, True))


def _rings_around(triangles: np.ndarray, turned: np.ndarray, count: int, rings: int) -> np.ndarray:
    """Vertices (count,) bool within `rings` rings of triangles of the `turned` ones (T,)."""
    region = np.zeros(count, dtype=bool)
    region[triangles[turned].ravel()] = True
    for _ in range(rings):
        region[triangles[np.any(region[triangles], axis=1)].ravel()] = True
    return region


def _untangled(
    vertices, images, start, triangles, movable, own_shapes: bool, rounds: int
) -> tuple[np.ndarray, int]:
    """Images (V, 2) with the `movable` (V,) ones moved by the barrier continuation (at most `rounds`
    rounds) on the triangles that have a movable vertex, against references of their `own_shapes`
    or not (`reference_shapes`): the last positions tried, whether or not they untangle; and the rounds
    taken."""
    active = triangles[np.any(movable[triangles], axis=1)]
    if triangle_signed_areas(start, active).sum() <= 0.0:
        # The region's boundary image does not enclose a positive area: positive triangles cannot tile it.
        return start.copy(), 0
    gradients, areas = reference_shapes(vertices, images, active, own_shapes)
    problem = BarrierProblem(start, active, movable, gradients, areas)
    # det J at which a triangle counts as turned over: TOLERANCE of its source area, in its image.
    floors = TOLERANCE * triangle_signed_areas(vertices, active) / areas
    positions = start[movable].ravel()
    determinants = problem.determinants(positions)
    epsilon = max(np.sqrt(1e-12 + 0.04 * min(determinants.min(), 0.0) ** 2), TINY_EPSILON)
    previous = problem.energy(positions, epsilon)
    fewest, since, taken = len(active) + 1, 0, 0
    while taken < rounds:
        taken += 1
        positions = problem.newton_step(positions, epsilon)
        energy, determinants = problem.energy(positions, epsilon), problem.determinants(positions)
        smallest, turned = determinants.min(), np.count_nonzero(determinants <= floors)
        fewest, since = (turned, 0) if turned < fewest else (fewest, since + 1)
        if turned == 0 or since > STALL_ROUNDS:
            break
        decrease = max(1.0 - energy / previous, SMALLEST_DECREASE)
        mu = (1.0 - decrease) * regularised_determinant(smallest, epsilon)
        epsilon = 2.0 * np.sqrt(mu * (mu - smallest)) if smallest < mu else TINY_EPSILON
        previous = energy
    untangled = start.copy()
    untangled[movable] = positions.reshape(-1, 2)
    return untangled, taken


def regularised_determinant(determinant, epsilon):
    """χ(D, ε) = (D + √(ε² + D²)) / 2, the regularised determinant, positive for ε > 0 (for D < 0
    written as ε² / (2 (√(ε² + D²) - D)), which does not round to 0)."""
    root = np.sqrt(epsilon * epsilon + determinant * determinant)
    negative = np.minimum(determinant, 0.0)
    return np.where(
        determinant >= 0.0, 0.5 * (determinant + root), epsilon * epsilon / (2.0 * (root - negative))
    )


def reference_shapes(vertices, images, active, own_shapes: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per active triangle (K, 3) the gradients (K, 3, 2) of its barycentric coordinates on its
    reference triangle (J = Xᵀ G for the images X (3, 2) of its corners) and the reference areas
    (K,).  The reference is the triangle's own image where that is not turned over and `own_shapes`,
    its source triangle otherwise; all scaled together so that their areas add up to the images'
    signed area (so that det J = 1 on average is reachable)."""
    source_areas = triangle_signed_areas(vertices, active)
    image_areas = triangle_signed_areas(images, active)
    kept = image_areas > 0.0 if own_shapes else np.zeros(len(active), dtype=bool)
    image_scale = np.sqrt(image_areas.sum() / source_areas.sum())  # of the source triangles
    corners = np.where(kept[:, None, None], images[active], image_scale * vertices[active])
    areas = np.where(kept, image_areas, image_scale**2 * source_areas)
    scale = np.sqrt(image_areas.sum() / areas.sum())
    edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=2) * scale
    inverse = np.linalg.inv(edges)  # rows: gradients of the 2nd and 3rd barycentric coordinates
    gradients = np.concatenate([-inverse.sum(axis=1, keepdims=True), inverse], axis=1)
    return gradients, areas * scale**2


class BarrierProblem:
    """The barrier energy of the active triangles (K, 3) as a function of the movable vertices'
    positions, flattened (2 F,) in vertex order, with its gradient and projected Newton steps."""

    def __init__(self, images, active, movable, gradients, weights):
        self.images, self.active, self.movable = images, active, movable
        self.gradients, self.weights = gradients, weights
        index = np.full(len(images), -1, dtype=np.int64)
        index[movable] = np.arange(np.count_nonzero(movable))
        # Degrees of freedom of each triangle's 6 coordinates (corner m, component i at 2 m + i); -1 if fixed.
        corner_index = index[active]
        self.dofs = np.where(
            corner_index[:, :, None] >= 0, 2 * corner_index[:, :, None] + np.arange(2), -1
        ).reshape(-1, 6)
        rows = np.broadcast_to(self.dofs[:, :, None], (len(active), 6, 6))
        columns = np.broadcast_to(self.dofs[:, None, :], (len(active), 6, 6))
        self.kept = (rows >= 0) & (columns >= 0)
        self.rows, self.columns = rows[self.kept], columns[self.kept]
        self.size = 2 * np.count_nonzero(movable)
        # d vec(J) / d x (K, 4, 6): J[i, j] = Σ_m X[m, i] G[m, j], vec(J) = (J00, J01, J10, J11).
        jacobian = np.zeros((len(active), 2, 2, 3, 2))
        for component in range(2):
            jacobian[:, component, :, :, component] = np.transpose(gradients, (0, 2, 1))
        self.jacobian = jacobian.reshape(-1, 4, 6)
        self.transposed = np.ascontiguousarray(np.transpose(self.jacobian, (0, 2, 1)))

    def _jacobians(self, positions) -> np.ndarray:
        """J (K, 2, 2) of every active triangle."""
        points = self.images.copy()
        points[self.movable] = positions.reshape(-1, 2)
        return np.einsum("kmi,kmj->kij", points[self.active], self.gradients)

    def determinants(self, positions) -> np.ndarray:
        """det J (K,)."""
        jacobians = self._jacobians(positions)
        return jacobians[:, 0, 0] * jacobians[:, 1, 1] - jacobians[:, 0, 1] * jacobians[:, 1, 0]

    def energy(self, positions, epsilon) -> float:
        """E_ε at the positions (2 F,)."""
        jacobians = self._jacobians(positions)
        determinant = jacobians[:, 0, 0] * jacobians[:, 1, 1] - jacobians[:, 0, 1] * jacobians[:, 1, 0]
        trace = np.einsum("kij,kij->k", jacobians, jacobians)
        chi = regularised_determinant(determinant, epsilon)
        return float(np.dot(self.weights, ((1.0 - THETA) * trace + THETA * (determinant**2 + 1.0)) / chi))

    def _derivatives(self, positions, epsilon) -> tuple[np.ndarray, np.ndarray]:
        """The gradient (2 F,) of E_ε and the per-triangle Hessians in J (K, 4, 4), projected onto
        the positive semi-definite matrices, already mapped to the triangles' coordinates (K, 6, 6)."""
        vector = self._jacobians(positions).reshape(-1, 4)
        a, b, c, d = vector.T
        determinant = a * d - b * c
        trace = np.einsum("ki,ki->k", vector, vector)
        root = np.sqrt(epsilon * epsilon + determinant * determinant)
        chi = regularised_determinant(determinant, epsilon)
        chi1 = chi / root  # χ' = (1 + D / r) / 2
        chi2 = epsilon * epsilon / (2.0 * root**3)
        # E per triangle = A(D) tr + B(D), A = (1 - θ) / χ, B = θ (D² + 1) / χ.
        shape = 1.0 - THETA
        a0 = shape / chi
        a1 = -shape * chi1 / chi**2
        a2 = shape * (2.0 * chi1**2 / chi**3 - chi2 / chi**2)
        square = determinant**2 + 1.0
        b1 = THETA * (2.0 * determinant / chi - square * chi1 / chi**2)
        b2 = THETA * (
            2.0 / chi - 4.0 * determinant * chi1 / chi**2 + square * (2.0 * chi1**2 / chi**3 - chi2 / chi**2)
        )
        by_determinant = a1 * trace + b1
        cofactor = np.stack([d, -c, -b, a], axis=1)  # ∂D / ∂vec(J)
        gradient_j = 2.0 * a0[:, None] * vector + by_determinant[:, None] * cofactor
        hessian = (
            2.0 * a0[:, None, None] * np.eye(4)
            + 2.0
            * a1[:, None, None]
            * (vector[:, :, None] * cofactor[:, None, :] + cofactor[:, :, None] * vector[:, None, :])
            + (a2 * trace + b2)[:, None, None] * cofactor[:, :, None] * cofactor[:, None, :]
            + by_determinant[:, None, None] * _DETERMINANT_HESSIAN
        )
        values, vectors = np.linalg.eigh(hessian)
        hessian = (vectors * np.maximum(values, 0.0)[:, None, :]) @ np.transpose(vectors, (0, 2, 1))
        weights = self.weights[:, None]
        gradient_x = (gradient_j[:, None, :] @ self.jacobian)[:, 0, :] * weights
        hessian_x = self.transposed @ hessian @ self.jacobian * weights[:, :, None]
        gradient = np.zeros(self.size)
        kept = self.dofs >= 0
        gradient += np.bincount(self.dofs[kept], gradient_x[kept], minlength=self.size)
        return gradient, hessian_x

    def _assembled(self, hessian_x) -> scipy.sparse.csc_matrix:
        """The sparse (2 F, 2 F) sum of the triangles' Hessians in their coordinates (K, 6, 6)."""
        return scipy.sparse.csc_matrix(
            (hessian_x[self.kept], (self.rows, self.columns)), shape=(self.size,) * 2
        )

    def responses(self, positions, epsilon, moves) -> tuple[np.ndarray, np.ndarray]:
        """How the movable vertices (2 F,) follow moves (V, 2) of the others, with H the Hessian of
        E_ε at the positions (2 F,) (each triangle's projected, `_derivatives`), factored once:
        to first order, H_FF d_F = -H_F,rest d_rest (a continuation's predictor), and with E_ε's
        gradient too, H_FF d_F = -g_F - H_F,rest d_rest (a Newton step of E_ε with the others moved:
        towards its minimiser as well, which opens up squeezed triangles)."""
        gradient, hessian_x = self._derivatives(positions, epsilon)
        fixed = np.asarray(moves, dtype=np.float64)[self.active].reshape(-1, 6) * (self.dofs < 0)
        pushed = np.einsum("kij,kj->ki", hessian_x, fixed)
        kept = self.dofs >= 0
        right = -np.bincount(self.dofs[kept], pushed[kept], minlength=self.size)
        solve = _definite_factors(self._assembled(hessian_x)).solve
        return solve(right), solve(right - gradient)

    def newton_step(self, positions, epsilon) -> np.ndarray:
        """Positions (2 F,) after one projected Newton step on E_ε with a backtracking line search
        (Armijo); the same positions if no step descends."""
        gradient, hessian_x = self._derivatives(positions, epsilon)
        step = -_definite_factors(self._assembled(hessian_x)).solve(gradient)
        slope, energy, length = float(gradient @ step), self.energy(positions, epsilon), 1.0
        while slope < 0.0 and length > 1e-12:
            trial = positions + length * step
            if self.energy(trial, epsilon) <= energy + 1e-4 * length * slope:
                return trial
            length *= 0.5
        return positions


def _definite_factors(matrix: scipy.sparse.csc_matrix):
    """The factors (`scipy.sparse.linalg.SuperLU`) of a barrier Hessian (N, N).  The shape term's
    2 (1 - θ) / χ I makes the matrix definite wherever the free vertices connect to a fixed one; the
    shift only guards a region with an isolated part.  Symmetric positive definite: factored without
    pivoting (SuperLU's symmetric mode), ~2x faster than a pivoting LU."""
    shift = 1e-12 * matrix.diagonal().max() * scipy.sparse.identity(matrix.shape[0], format="csc")
    return scipy.sparse.linalg.splu(
        (matrix + shift).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )  # fmt: skip


#: The Hessian of det J in vec(J) = (J00, J01, J10, J11).
_DETERMINANT_HESSIAN = np.array([[0, 0, 0, 1], [0, 0, -1, 0], [0, -1, 0, 0], [1, 0, 0, 0]], dtype=np.float64)


__all__ = ["BarrierProblem", "reference_shapes", "regularised_determinant", "relaxed", "untangle_triangles"]
