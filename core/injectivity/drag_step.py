"""One frame of a fold-free drag: `drag_step` moves the last fold-free mesh map onto the new target.

While a handle moves, the plain map's vertex positions Y = G Q' (V, 2) are known at once and its
boundary vertices lie on the target curve; where the drag is hard, Y turns some triangles over.
Each frame starts from the positions X drawn last, which were fold-free (or from the source mesh,
which is), and the plain positions W they were drawn for (`DragStep.way`), and returns positions
proven fold-free (`core.injectivity.mesh_bijection`):

- Y itself when it is proven (the common case);
- else X moved by d: the boundary vertices onto Y's, on the target curve; the interior ones by the
  plain map's own move Y - W, except in a region R of interior vertices (`RINGS` rings around the
  triangles that this move would squeeze to their floor, or that X already squeezes below
  `SQUEEZED` of their source area), where d is the barrier energy's tangent: with H the Hessian of
  Garanzha et al. 2021's barrier energy at X (`core.injectivity.mesh_untangling`, the source
  triangles as reference; its stiffness grows without bound as a triangle collapses),
  H_RR d_R = -H_R,rest d_rest, a continuation's predictor along the boundary's path (the squeezed
  triangles give way to their neighbours instead of collapsing); and, with the same factors, the
  Newton step of the energy with the rest moved, H_RR d_R = -g_R - H_R,rest d_rest, taken when it
  goes the whole way (it also opens up triangles that earlier frames squeezed: on a drag kept in
  the folded range for 150 frames, the smallest triangle stayed at 1.2e-2 of its source area,
  2.7e-3 without it).
- The step along d is the largest that keeps every triangle's doubled area above its floor (a
  quadratic in the step's length s: the first positive root, Smith & Schaefer 2015's flip-free line
  search), `SHARE` of it when short of 1: a substep; the next predicts again from where it ended,
  until the boundary is on the target curve or the frame's budget is spent (after `least`
  substeps).  Out of budget, the last substep's positions are drawn: fold-free, the boundary
  between the last frame's and the target curve (`reached` False), and the next frame goes on from
  them.

On the viewer's hard drag (6,332 vertices, the plain map turning up to 249 triangles over at the
end) every frame of 54 reached the target curve in one substep; the whole drag from the source
mesh in one call, 5 substeps.  (The barrier continuation itself, from Y's folded positions,
needed several rounds of a wider region, more than a frame's time: 20-30 % of such a drag's
frames had drawn the boundary behind the target curve.)

Every answer passes `prove_mesh_bijection` (exact orientation, a simple boundary polygon); should
the last state not, X is returned unchanged.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from core.injectivity.mesh_bijection import MeshBijection, prove_mesh_bijection
from core.injectivity.mesh_untangling import TINY_EPSILON, BarrierProblem, reference_shapes

#: Rings of triangles around the squeezed ones in the region whose move is the barrier's tangent.
RINGS = 2
#: Triangles the last positions squeeze below this share of their source area are in the region.
SQUEEZED = 0.1
#: The share of the largest flip-free step taken when it is short of the whole move.
SHARE = 0.9
#: Steps shorter than this share of the move are not taken.
SHORTEST = 1e-3
#: A triangle's doubled area must stay above this share of its source triangle's (above
#: `core.folded_triangles`' 1e-9, so that no triangle drawn counts as collapsed).
AREA_FLOOR = 1e-6


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
    corners : ndarray of shape (3, T), int
        `triangles` transposed, each row contiguous (the gathers of a frame's areas and rings).
    interior : ndarray of shape (V,), bool
    areas : ndarray of shape (T,)
        The source triangles' doubled areas.
    floors : ndarray of shape (T,)
        `AREA_FLOOR` times `areas`.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    boundary: np.ndarray
    corners: np.ndarray
    interior: np.ndarray
    areas: np.ndarray
    floors: np.ndarray


def drag_mesh(vertices: np.ndarray, triangles: np.ndarray, boundary: np.ndarray) -> DragMesh:
    """The `DragMesh` of a triangulated disk: source vertices (V, 2), triangles (T, 3), boundary (B,)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    corners = np.ascontiguousarray(triangles.T)
    interior = np.ones(len(vertices), dtype=bool)
    interior[np.asarray(boundary)] = False
    areas = _doubled_areas(vertices, corners)
    return DragMesh(vertices, triangles, np.asarray(boundary), corners, interior, areas, AREA_FLOOR * areas)


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
    substeps : int
        Substeps taken in this frame.
    way : ndarray of shape (V, 2)
        The plain positions these positions were drawn for (the goal once `reached`; on the way, as
        far along from the last frame's as the substeps went): the next frame's W.
    """

    positions: np.ndarray
    reached: bool
    plain: bool
    proof: MeshBijection
    substeps: int
    way: np.ndarray


def drag_step(
    mesh: DragMesh,
    start: np.ndarray | None,
    goal: np.ndarray,
    budget: float,
    way: np.ndarray | None = None,
    least: int = 1,
) -> DragStep:
    """Fold-free positions for this frame, the boundary on the goal's if the budget allows.

    Parameters
    ----------
    mesh : DragMesh
    start : ndarray of shape (V, 2) or None
        The positions drawn last, fold-free; None: the source vertices.
    goal : ndarray of shape (V, 2)
        The plain map's positions, boundary vertices on the target curve.
    budget : float
        Seconds the substeps may take (the proof comes on top: about a millisecond).
    way : ndarray of shape (V, 2), optional
        The plain positions `start` was drawn for (the last frame's `DragStep.way`): the interior
        moves as the plain map does since.  None: `start` itself (the source vertices if it is None).
    least : int
        Substeps taken even past the budget (at least one, so that a frame is drawn on the target
        curve whenever one substep reaches it).

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
    if not np.any(_doubled_areas(goal, mesh.corners) <= mesh.floors):
        proof = prove_mesh_bijection(goal, mesh.triangles, mesh.boundary)
        if proof.proven:
            return DragStep(goal, True, True, proof, 0, goal)
    origin = mesh.vertices if start is None else np.asarray(start, dtype=np.float64)
    way = origin if way is None else np.asarray(way, dtype=np.float64)
    areas = _doubled_areas(origin, mesh.corners)
    if not np.all(areas > 0.0):
        raise ValueError("start turns triangles over: a drag step starts from fold-free positions")
    floors = np.minimum(mesh.floors, 0.5 * areas)  # a start below a floor may not sink further
    move = goal - way
    move[mesh.boundary] = goal[mesh.boundary] - origin[mesh.boundary]
    positions, done, substeps, seconds = origin, 0.0, 0, 0.0
    while done < 1.0:
        started = time.perf_counter()
        if substeps >= least and started + seconds > deadline:
            break
        positions, share = _substep(mesh, positions, (1.0 - done) * move, floors)
        done, substeps = (1.0 if share == 1.0 else done + (1.0 - done) * share), substeps + 1
        seconds = time.perf_counter() - started
        if share == 0.0:  # stalled: no flip-free step on the way
            break
    if done == 1.0:
        positions = positions.copy()
        positions[mesh.boundary] = goal[mesh.boundary]  # the same floats as the goal's, on its curve
        proof = prove_mesh_bijection(positions, mesh.triangles, mesh.boundary)
        if proof.proven:
            return DragStep(positions, True, False, proof, substeps, goal)
    else:
        proof = prove_mesh_bijection(positions, mesh.triangles, mesh.boundary)
        if proof.proven:
            return DragStep(positions, False, False, proof, substeps, way + done * (goal - way))
    proof = prove_mesh_bijection(origin, mesh.triangles, mesh.boundary)
    return DragStep(origin, False, False, proof, substeps, way)


def _substep(mesh: DragMesh, positions: np.ndarray, move: np.ndarray, floors: np.ndarray):
    """One substep from fold-free `positions` (V, 2) along `move` (V, 2), its region's part replaced
    by the barrier's response (`_responses`): the corrected one if it goes the whole way without a
    triangle reaching its floor, else the predictor if that does, else the one that goes further.
    Returns (new positions (V, 2), the share of the move taken: 1, `SHARE` of the largest
    flip-free step, or 0 if that is shorter than `SHORTEST`)."""
    edges = _edges(positions, mesh.corners)
    c0, c1, c2 = _area_polynomial(edges, _edges(positions + move, mesh.corners))
    squeezed = (c0 + c1 + c2 <= floors) | (c0 < SQUEEZED * mesh.areas)
    region = _rings(mesh, squeezed, RINGS)
    moves = _responses(mesh, positions, move, region) if region.any() else (move,)
    best, longest = move, -1.0
    for candidate in moves[::-1]:  # the corrected one first
        if candidate is not move:
            c0, c1, c2 = _area_polynomial(edges, _edges(positions + candidate, mesh.corners))
        coefficients = (c0 - floors, c1, c2)
        root = _first_root(*coefficients)
        if root > 1.0:
            return positions + candidate, 1.0
        share = _checked_length(coefficients, SHARE * root)
        if share > longest:
            best, longest = candidate, share
    return positions + longest * best, longest


def _responses(mesh: DragMesh, positions: np.ndarray, move: np.ndarray, region: np.ndarray) -> tuple:
    """`move` (V, 2) with its part on the region (V,) bool replaced by the barrier energy's response
    to the rest (`BarrierProblem.responses`), H the energy's Hessian at `positions` (V, 2) over the
    triangles with a vertex in the region (source triangles as reference, ε tiny: the positions are
    fold-free): (the predictor, H_RR d_R = -H_R,rest d_rest; the corrected one, with the energy's
    gradient on the right too), each (V, 2)."""
    active = mesh.triangles[np.any(region[mesh.triangles], axis=1)]
    gradients, areas = reference_shapes(mesh.vertices, positions, active, own_shapes=False)
    problem = BarrierProblem(positions, active, region, gradients, areas)
    answers = []
    for response in problem.responses(positions[region].ravel(), TINY_EPSILON, move):
        answers.append(move.copy())
        answers[-1][region] = response.reshape(-1, 2)
    return tuple(answers)


def _checked_length(coefficients: tuple, length: float) -> float:
    """`length`, halved until every triangle's doubled area above its floor, c0 + c1 s + c2 s²
    (`coefficients`, each (T,)) at s = length, stays positive; 0 once it is shorter than `SHORTEST`."""
    c0, c1, c2 = coefficients
    while length >= SHORTEST:
        if np.all(c0 + length * (c1 + length * c2) > 0.0):
            return length
        length *= 0.5
    return 0.0


def _edges(points: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, ...]:
    """The edges b - a and c - a of each triangle (a, b, c) (`DragMesh.corners` (3, T)), by component:
    (bx - ax, by - ay, cx - ax, cy - ay), each (T,)."""
    x, y = points[:, 0], points[:, 1]
    ax, ay = x[corners[0]], y[corners[0]]
    return x[corners[1]] - ax, y[corners[1]] - ay, x[corners[2]] - ax, y[corners[2]] - ay


def _cross(ux: np.ndarray, uy: np.ndarray, vx: np.ndarray, vy: np.ndarray) -> np.ndarray:
    """u × v (K,) of vectors given by components (each (K,))."""
    return ux * vy - uy * vx


def _area_polynomial(start: tuple, end: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(c0, c1, c2), each (T,): each triangle's doubled area c0 + c1 s + c2 s² on the straight way
    from the positions of edges `start` to those of edges `end` (`_edges`), s from 0 to 1."""
    ux, uy, vx, vy = start
    fx, fy, gx, gy = (e - s for e, s in zip(end, start, strict=True))
    return _cross(ux, uy, vx, vy), _cross(ux, uy, gx, gy) + _cross(fx, fy, vx, vy), _cross(fx, fy, gx, gy)


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


def _doubled_areas(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(b - a) × (c - a) (T,) of each triangle (a, b, c) (`DragMesh.corners` (3, T))."""
    return _cross(*_edges(points, corners))


def _rings(mesh: DragMesh, triangles: np.ndarray, rings: int) -> np.ndarray:
    """Interior vertices (V,) bool within `rings` rings of the marked triangles (T,) bool."""
    vertices, corners = np.zeros(len(mesh.vertices), dtype=bool), mesh.corners
    for _ in range(rings):
        vertices[corners[:, triangles].ravel()] = True
        triangles = vertices[corners[0]] | vertices[corners[1]] | vertices[corners[2]]
    return vertices & mesh.interior


__all__ = ["DragMesh", "DragStep", "drag_mesh", "drag_step"]
