"""One frame of a fold-free drag: `drag_step` moves the last fold-free mesh map towards the new plain map.

While a handle moves, the plain map's vertex positions Y = G Q' (V, 2) are known at once and its
boundary vertices lie on the target curve; where the drag is hard, Y turns some triangles over.
Each frame starts from the positions X drawn last, which were fold-free (or from the source mesh,
which is), and returns positions proven fold-free (`core.injectivity.mesh_bijection`):

- Y itself when it is proven (the common case);
- else Y outside a region R of interior vertices around Y's turned-over triangles (`RINGS` rings),
  and inside R positions found by the barrier continuation of Garanzha et al. 2021
  (`core.injectivity.mesh_untangling`, with R's rim and the boundary fixed at Y), started from
  whichever turns fewer triangles over of Y and X plus one composite harmonic step (the harmonic
  extension into R of the rim's move Y - X with the mean-value weights of X: Floater 2003;
  Schneider, Hormann & Floater 2013's composite maps, libigl's
  `bijective_composite_harmonic_mapping`, take such steps on the whole mesh).  A region that
  stalls is doubled in rings.  A frame takes a round only if the last one, setup included, fits
  its budget, or if the caller asks for one at least (`least_rounds`: at rest);
- if the frame's budget runs out first: the nearest fold-free state on the way, X + s (Y - X)
  (s is `SHARE` of the largest step that turns no triangle over, the first positive root of each
  triangle's area, a quadratic in s: Smith & Schaefer 2015's flip-free line search; the composite
  harmonic step's direction instead cost a sparse solve more and went no further in the frames
  tried), its boundary between the last frame's and the target curve (`reached` False), and the
  continuation's state (`Untangling`), which the next frame resumes for the same goal (a new goal
  starts afresh on its region): a hard drag catches up after its release and never draws a fold.

Every answer passes `prove_mesh_bijection` (exact orientation, a simple boundary polygon); should
the last state not, X is returned unchanged.  With the source triangles as the barrier's reference
a region squeezed by the drag untangled in 1 round where the last positions' own shapes (slivers
there) took 10.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from core.injectivity.mesh_bijection import MeshBijection, prove_mesh_bijection
from core.injectivity.mesh_untangling import (
    SMALLEST_DECREASE,
    TINY_EPSILON,
    BarrierProblem,
    reference_shapes,
    regularised_determinant,
)

#: Rings of triangles around Y's turned-over triangles in the first region of the continuation.
RINGS = 3
#: The share of the largest flip-free step taken on the way when the continuation is not done.
SHARE = 0.9
#: Steps on the way shorter than this share of it are not taken.
SHORTEST = 1e-3
#: A triangle's doubled area must stay above this share of its source triangle's (above
#: `core.folded_triangles`' 1e-9, so that no triangle drawn counts as collapsed).
AREA_FLOOR = 1e-6
#: Rounds without fewer triangles at or below their floor after which a region counts as stalled.
STALL_ROUNDS = 30


@dataclass(frozen=True)
class DragMesh:
    """What `drag_step` needs of a mesh, computed once per mesh (`drag_mesh`).

    Attributes
    ----------
    vertices : ndarray of shape (V, 2)
        The source positions (a fold-free start when nothing else is).
    triangles : ndarray of shape (T, 3), int
        Counter-clockwise.
    boundary : ndarray of shape (B,), int
        The boundary loop in order.
    incidence : scipy.sparse.csr_matrix of shape (T, V)
        1 where a triangle has a vertex.
    interior : ndarray of shape (V,), bool
    floors : ndarray of shape (T,)
        `AREA_FLOOR` times the source triangles' doubled areas.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    boundary: np.ndarray
    incidence: scipy.sparse.csr_matrix
    interior: np.ndarray
    floors: np.ndarray


def drag_mesh(vertices: np.ndarray, triangles: np.ndarray, boundary: np.ndarray) -> DragMesh:
    """The `DragMesh` of a triangulated disk: source vertices (V, 2), triangles (T, 3), boundary (B,)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    rows = np.repeat(np.arange(len(triangles)), 3)
    incidence = scipy.sparse.csr_matrix(
        (np.ones(rows.size), (rows, triangles.ravel())), shape=(len(triangles), len(vertices))
    )
    interior = np.ones(len(vertices), dtype=bool)
    interior[np.asarray(boundary)] = False
    floors = AREA_FLOOR * _doubled_areas(vertices, triangles)
    return DragMesh(vertices, triangles, np.asarray(boundary), incidence, interior, floors)


@dataclass(frozen=True)
class Untangling:
    """A barrier continuation in progress, for the next frame to resume.

    Attributes
    ----------
    region : ndarray of shape (V,), bool
        The interior vertices it moves.
    positions : ndarray of shape (V, 2)
        Where they are (some triangles still turned over).
    epsilon, energy : float
        The continuation's ε and its last energy (0: not started).
    rings : int
        Rings of the region around the triangles it was made for.
    fewest, since : int
        The fewest triangles at or below their floor so far, and the rounds since that fell.
    goal : ndarray of shape (V, 2)
        The goal it works towards (a frame with another goal starts afresh on the same region).
    round_seconds : float
        What a round cost in the last frame that took some, with the continuation's setup (whether
        the next fits in a frame's budget).
    """

    region: np.ndarray
    positions: np.ndarray
    epsilon: float
    energy: float
    rings: int
    fewest: int
    since: int
    goal: np.ndarray
    round_seconds: float


@dataclass(frozen=True)
class DragStep:
    """The answer of `drag_step`.

    Attributes
    ----------
    positions : ndarray of shape (V, 2)
        Proven fold-free (`proof`).
    reached : bool
        The boundary vertices are the goal's (on the target curve); False: still on the way.
    plain : bool
        The positions are the goal itself (the plain map is fold-free).
    proof : MeshBijection
    rounds : int
        Rounds of the continuation taken in this frame.
    untangling : Untangling or None
        The continuation to resume next frame (when not `reached`).
    """

    positions: np.ndarray
    reached: bool
    plain: bool
    proof: MeshBijection
    rounds: int
    untangling: Untangling | None


def drag_step(
    mesh: DragMesh,
    start: np.ndarray | None,
    goal: np.ndarray,
    budget: float,
    untangling: Untangling | None = None,
    least_rounds: int = 1,
) -> DragStep:
    """Fold-free positions for this frame, as close to `goal` as the budget allows.

    Parameters
    ----------
    mesh : DragMesh
    start : ndarray of shape (V, 2) or None
        The positions drawn last, fold-free; None: the source vertices.
    goal : ndarray of shape (V, 2)
        The plain map's positions, boundary vertices on the target curve.
    budget : float
        Seconds the continuation may take (the proofs come on top: about a millisecond each).
    untangling : Untangling, optional
        The last frame's continuation (`DragStep.untangling`): resumed for the same goal, else its
        region (with the rings around the goal's turned-over triangles) is started on afresh.
    least_rounds : int
        Rounds of the continuation taken even past the budget (a round of a wide region may take
        longer than a frame: 0 while a handle moves, so that a frame keeps its time and shows the
        nearest fold-free state instead; 1 at rest, so that the drawing catches up).

    Returns
    -------
    DragStep

    Raises
    ------
    ValueError
        If `start` turns a triangle over.
    """
    deadline = time.perf_counter() + budget
    goal = np.asarray(goal, dtype=np.float64)
    goal_edges = _edges(goal, mesh.triangles)
    turned = _cross(*goal_edges) <= mesh.floors
    if not turned.any():
        proof = prove_mesh_bijection(goal, mesh.triangles, mesh.boundary)
        if proof.proven:
            return DragStep(goal, True, True, proof, 0, None)
    origin = mesh.vertices if start is None else np.asarray(start, dtype=np.float64)
    rounds, positions = 0, None
    estimate = 0.0 if untangling is None else untangling.round_seconds
    started = time.perf_counter()
    if least_rounds > 0 or started + estimate < deadline:
        positions, untangling, rounds = _continued(
            mesh, origin, goal, turned, untangling, deadline, least_rounds
        )
        # What a frame's first round costs, with the continuation's setup (a fresh start's harmonic
        # step and barrier problem took longer than its round): whether the next frame can afford one.
        seconds = (time.perf_counter() - started) / max(rounds, 1)
        untangling = dataclasses.replace(untangling, round_seconds=seconds)
    if positions is not None:
        positions[mesh.boundary] = goal[mesh.boundary]  # the same floats as the goal's, on its curve
        proof = prove_mesh_bijection(positions, mesh.triangles, mesh.boundary)
        if proof.proven:
            return DragStep(positions, True, False, proof, rounds, None)
    # Out of time: the nearest fold-free state on the straight way to the goal.
    coefficients = _area_polynomial(_edges(origin, mesh.triangles), goal_edges)
    if not np.all(coefficients[0] > 0.0):
        raise ValueError("start turns triangles over: a drag step starts from fold-free positions")
    length = SHARE * min(_first_root(*coefficients), 1.0)
    positions = origin + _checked_length(mesh, coefficients, length) * (goal - origin)
    proof = prove_mesh_bijection(positions, mesh.triangles, mesh.boundary)
    if not proof.proven:
        positions = origin
        proof = prove_mesh_bijection(origin, mesh.triangles, mesh.boundary)
    return DragStep(positions, False, False, proof, rounds, untangling)


def _continued(
    mesh: DragMesh, origin, goal, turned, untangling: Untangling | None, deadline: float, least: int
):
    """The continuation towards `goal` (V, 2) from `origin` (V, 2), its goal's turned-over triangles
    (T,) bool, resumed or started afresh (`drag_step`), widened where it stalls: (positions (V, 2)
    with nothing at or below its floor, or None; its state; rounds taken)."""
    if untangling is None or not np.array_equal(untangling.goal, goal):
        # A new goal: a fresh start, one composite harmonic step from the last positions (resumed
        # positions made for the last goal, its rim moved since, turned hundreds of triangles over
        # where a drag's frames were 40 ms apart), on the last region if it still covers the folds.
        rings = RINGS if untangling is None else untangling.rings
        seconds = 0.0 if untangling is None else untangling.round_seconds
        region = _rings(mesh, turned, rings)
        if untangling is not None:
            region |= untangling.region
        moved = _start(mesh, origin, goal, region)
        untangling = Untangling(region, moved, 0.0, 0.0, rings, len(mesh.triangles), 0, goal, seconds)
    rounds, positions = 0, None
    # A turned-over triangle with no interior vertex cannot be unfolded by moving the interior.
    while np.all(np.any(untangling.region[mesh.triangles[turned]], axis=1)):
        positions, untangling, taken = _untangled(mesh, goal, untangling, deadline, least - rounds)
        rounds += taken
        out_of_time = time.perf_counter() + untangling.round_seconds > deadline
        if positions is not None or (rounds >= least and out_of_time):
            break
        if untangling.since > STALL_ROUNDS:  # a wider region
            rings = 2 * untangling.rings
            region = _rings(mesh, turned, rings) | untangling.region
            if np.array_equal(region, untangling.region):
                break  # it holds every vertex it can: the continuation is given up on this goal
            moved = np.where(region[:, None], untangling.positions, goal)
            seconds = untangling.round_seconds
            untangling = Untangling(region, moved, 0.0, 0.0, rings, len(mesh.triangles), 0, goal, seconds)
    return positions, untangling, rounds


def _start(mesh: DragMesh, origin: np.ndarray, goal: np.ndarray, region: np.ndarray) -> np.ndarray:
    """Where a continuation starts (V, 2): of one composite harmonic step from the last positions
    (`_direction`) and the goal itself, the one that turns fewer triangles over."""
    stepped = origin + _direction(mesh, origin, goal - origin, region)
    folds = [
        np.count_nonzero(_doubled_areas(start, mesh.triangles) <= mesh.floors) for start in (stepped, goal)
    ]
    return stepped if folds[0] <= folds[1] else goal.copy()


def _untangled(mesh: DragMesh, goal: np.ndarray, untangling: Untangling, deadline: float, least: int):
    """Garanzha et al.'s barrier continuation (`core.injectivity.mesh_untangling`) of the region's
    vertices, every other vertex at the goal (V, 2), resumed from `untangling`, until no triangle is
    at or below its floor, it stalls (`STALL_ROUNDS`) or, `least` rounds taken, the next round (as
    long as the last) would end past the deadline (`time.perf_counter`).
    The reference shapes are the source triangles' (the last positions' own, slivers where a drag
    squeezes, took 10 rounds where these took 1).  Returns (positions (V, 2) or None, the
    continuation's state, rounds taken)."""
    region = untangling.region
    active = np.any(region[mesh.triangles], axis=1)
    triangles = mesh.triangles[active]
    start = np.where(region[:, None], untangling.positions, goal)
    if _doubled_areas(start, triangles).sum() <= 0.0:  # positive triangles cannot tile the region
        stalled = Untangling(region, start, 0.0, 0.0, untangling.rings, 0, STALL_ROUNDS + 1, goal, 0.0)
        return None, stalled, 0
    gradients, areas = reference_shapes(mesh.vertices, start, triangles, own_shapes=False)
    problem = BarrierProblem(start, triangles, region, gradients, areas)
    lowest = mesh.floors[active] / (2.0 * areas)  # the floors as det J
    flat = start[region].ravel()
    determinants = problem.determinants(flat)
    epsilon = untangling.epsilon or max(
        np.sqrt(1e-12 + 0.04 * min(determinants.min(), 0.0) ** 2), TINY_EPSILON
    )
    previous, fewest, since, taken = problem.energy(flat, epsilon), untangling.fewest, untangling.since, 0
    seconds = untangling.round_seconds
    while not np.all(determinants > lowest):
        started = time.perf_counter()
        if (taken >= least and started + seconds > deadline) or since > STALL_ROUNDS:
            start[region] = flat.reshape(-1, 2)
            state = Untangling(
                region, start, epsilon, previous, untangling.rings, fewest, since, goal, seconds
            )
            return None, state, taken
        flat = problem.newton_step(flat, epsilon)
        energy, determinants, taken = problem.energy(flat, epsilon), problem.determinants(flat), taken + 1
        smallest, turned = determinants.min(), np.count_nonzero(determinants <= lowest)
        fewest, since = (turned, 0) if turned < fewest else (fewest, since + 1)
        decrease = max(1.0 - energy / previous, SMALLEST_DECREASE)
        mu = (1.0 - decrease) * regularised_determinant(smallest, epsilon)
        epsilon = 2.0 * np.sqrt(mu * (mu - smallest)) if smallest < mu else TINY_EPSILON
        previous, seconds = energy, time.perf_counter() - started
    start[region] = flat.reshape(-1, 2)
    return start, untangling, taken


def _checked_length(mesh: DragMesh, coefficients: tuple, length: float) -> float:
    """`length`, halved until every triangle's doubled area, c0 + c1 s + c2 s² (`coefficients`, each
    (T,)) at s = length, stays above its floor; 0 once it is shorter than `SHORTEST`."""
    c0, c1, c2 = coefficients
    while length >= SHORTEST:
        if np.all(c0 + length * (c1 + length * c2) > mesh.floors):
            return length
        length *= 0.5
    return 0.0


def _edges(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges b - a and c - a (each (T, 2)) of each triangle (a, b, c)."""
    a = points[triangles[:, 0]]
    return points[triangles[:, 1]] - a, points[triangles[:, 2]] - a


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u × v (K,) of vectors (K, 2)."""
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _area_polynomial(start: tuple, end: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(c0, c1, c2), each (T,): each triangle's doubled area c0 + c1 s + c2 s² on the straight way
    from the positions of edges `start` to those of edges `end` (`_edges`), s from 0 to 1."""
    (e1, e2), (g1, g2) = start, end
    f1, f2 = g1 - e1, g2 - e2
    return _cross(e1, e2), _cross(e1, f2) + _cross(f1, e2), _cross(f1, f2)


def _first_root(c0: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> float:
    """The smallest s in (0, 1] at which some c0 + c1 s + c2 s² (c0 > 0, each (T,)) reaches zero, or inf
    (Smith & Schaefer 2015's flip-free step).  Only triangles whose area can reach zero by s = 1 are
    solved for: negative at s = 1, or a convex quadratic whose lowest point, in (0, 1), is not above 0."""
    maybe = (c0 + c1 + c2 <= 0.0) | ((c2 > 0.0) & (c1 < 0.0) & (-c1 < 2.0 * c2) & (c1 * c1 >= 4.0 * c0 * c2))
    if not maybe.any():
        return np.inf
    c0, c1, c2 = c0[maybe], c1[maybe], c2[maybe]
    discriminant = c1 * c1 - 4.0 * c2 * c0
    root = np.sqrt(np.maximum(discriminant, 0.0))
    # Stable roots: q = -(c1 + sign(c1) √Δ) / 2, roots q / c2 and c0 / q.
    q = -0.5 * (c1 + np.where(c1 >= 0.0, root, -root))
    with np.errstate(divide="ignore", invalid="ignore"):
        candidates = np.stack([q / c2, c0 / q])
    real = (discriminant >= 0.0) & np.isfinite(candidates)
    return float(np.where(real & (candidates > 0.0), candidates, np.inf).min())


def _doubled_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(b - a) × (c - a) of each triangle (T,)."""
    a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _rings(mesh: DragMesh, triangles: np.ndarray, rings: int) -> np.ndarray:
    """Interior vertices (V,) bool within `rings` rings of the marked triangles (T,) bool."""
    marked = triangles.astype(np.float64)
    vertices = np.zeros(mesh.incidence.shape[1], dtype=bool)
    for _ in range(rings):
        vertices = (mesh.incidence.T @ marked) > 0
        marked = (mesh.incidence @ vertices.astype(np.float64)) > 0
    return vertices & mesh.interior


def _direction(mesh: DragMesh, positions: np.ndarray, straight: np.ndarray, region: np.ndarray) -> np.ndarray:
    """`straight` (V, 2) outside the region (V,) bool; inside, the harmonic extension of its values
    on the region's rim with the mean-value weights of `positions` (V, 2)."""
    if not region.any():
        return straight
    touching = np.any(region[mesh.triangles], axis=1)
    triangles = mesh.triangles[touching]
    rows, columns, weights = _mean_value_weights(positions, triangles)
    keep = region[rows]
    rows, columns, weights = rows[keep], columns[keep], weights[keep]
    index = np.full(len(positions), -1, dtype=np.int64)
    inside = np.flatnonzero(region)
    index[inside] = np.arange(len(inside))
    local = index[rows]
    diagonal = np.bincount(local, weights, minlength=len(inside))
    free = region[columns]
    matrix = scipy.sparse.csc_matrix(
        (
            np.concatenate([diagonal, -weights[free]]),
            (
                np.concatenate([np.arange(len(inside)), local[free]]),
                np.concatenate([np.arange(len(inside)), index[columns[free]]]),
            ),
        ),
        shape=(len(inside),) * 2,
    )
    rim = ~free
    right = np.zeros((len(inside), 2))
    np.add.at(right, local[rim], weights[rim, None] * straight[columns[rim]])
    direction = straight.copy()
    direction[inside] = scipy.sparse.linalg.splu(matrix).solve(right)
    return direction


def _mean_value_weights(positions: np.ndarray, triangles: np.ndarray):
    """Floater's mean-value weights of the triangles' (K, 3) corners as directed edges: rows (3 K · 2),
    columns, weights w_ij = tan(θ / 2) / |x_j - x_i| summed over the two triangles at edge ij (each
    triangle gives its corner i's angle θ to both edges from i)."""
    rows, columns, weights = [], [], []
    for k in range(3):
        i, j, m = triangles[:, k], triangles[:, (k + 1) % 3], triangles[:, (k + 2) % 3]
        u, v = positions[j] - positions[i], positions[m] - positions[i]
        lu, lv = np.hypot(u[:, 0], u[:, 1]), np.hypot(v[:, 0], v[:, 1])
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        half_tangent = (lu * lv - (u * v).sum(axis=1)) / cross  # tan(θ / 2) = (1 - cos θ) / sin θ
        rows += [i, i]
        columns += [j, m]
        weights += [half_tangent / lu, half_tangent / lv]
    return np.concatenate(rows), np.concatenate(columns), np.concatenate(weights)


__all__ = ["DragMesh", "DragStep", "drag_mesh", "drag_step"]
