"""core.injectivity.drag_step: every frame of a hard drag is proven fold-free with its boundary on the
target curve, the plain map is kept where it is fold-free, and a drag that falls behind catches up."""

from __future__ import annotations

import time

import numpy as np
import pytest

import core
from core.curves import examples
from core.injectivity.drag_step import drag_mesh, drag_step
from core.injectivity.mesh_bijection import prove_mesh_bijection
from core.injectivity.simple_curve import first_crossing

#: Hard drags of the fixture's starfish (point, offset): their plain maps turn 152-367 of its 3,780
#: triangles over at the end (the target curves stay simple).
HARD_DRAGS = [(9, (-56.3, -101.2)), (5, (54.7, 80.3)), (9, (-107.3, -112.1)), (5, (-38.1, 111.1))]
#: Frames of each drag, and frames at most to catch up in after a jump.
FRAMES = 30
CATCH_UP = 400


@pytest.fixture(scope="module")
def starfish():
    """(cage (10, 2), mesh of ~2,000 vertices, its Poisson basis G (V, 10))."""
    cage = 200.0 * examples.starfish()
    curve = core.ClosedBSpline(cage)
    mesh = core.triangulate(curve, max_edge=curve.diameter / 60)
    return cage, mesh, np.asarray(core.mesh_basis_functions(curve, mesh, "poisson"))


def _check_frame(mesh, step, goal):
    """A frame's positions: proven, nothing folded by `core.folded_triangles`; when reached, the
    boundary vertices exactly the goal's."""
    assert step.proof.proven
    assert prove_mesh_bijection(step.positions, mesh.triangles, mesh.boundary).proven
    assert np.count_nonzero(core.folded_triangles(mesh, step.positions)) == 0
    if step.reached:
        np.testing.assert_array_equal(step.positions[mesh.boundary], goal[mesh.boundary])


def _inside(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Whether each point (M, 2) is inside the polygon (B, 2), by crossing counts."""
    start, end = polygon, np.roll(polygon, -1, axis=0)
    x, y = points[:, :1], points[:, 1:]
    spans = (start[:, 1] > y) != (end[:, 1] > y)
    rise = np.where(spans, end[:, 1] - start[:, 1], 1.0)
    crossing_x = start[:, 0] + (y - start[:, 1]) * (end[:, 0] - start[:, 0]) / rise
    return np.count_nonzero(spans & (x < crossing_x), axis=1) % 2 == 1


def test_a_fold_free_plain_map_is_drawn_as_it_is(starfish):
    cage, mesh, basis = starfish
    moved = cage.copy()
    moved[0] += (10.0, -5.0)
    goal = basis @ moved
    step = drag_step(drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary), None, goal, 0.0)
    assert step.plain and step.reached and step.positions is goal and step.way is goal and step.substeps == 0


@pytest.mark.parametrize(("point", "offset"), HARD_DRAGS)
def test_every_frame_of_a_hard_drag_is_fold_free_on_the_target_curve(starfish, point, offset):
    """The drag in `FRAMES` frames, each given the time it needs (5 s at most: ~0.1 s here): every
    frame proven with nothing folded and its boundary on the target curve, in 1 to 3 substeps (the
    barrier's tangent in the squeezed region), the interior vertices inside the boundary polygon."""
    cage, mesh, basis = starfish
    frames = drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary)
    moved = cage.copy()
    positions, way, substeps = None, None, []
    for frame in range(1, FRAMES + 1):
        moved[point] = cage[point] + np.array(offset) * frame / FRAMES
        assert first_crossing(moved) is None
        goal = basis @ moved
        step = drag_step(frames, positions, goal, 5.0, way)
        _check_frame(mesh, step, goal)
        assert step.reached
        positions, way = step.positions, step.way
        substeps.append(step.substeps)
    assert prove_mesh_bijection(goal, mesh.triangles, mesh.boundary).turned_over > 100
    assert not step.plain and max(substeps) <= 3
    assert _inside(step.positions[mesh.interior], step.positions[mesh.boundary]).all()


def test_with_one_substep_a_frame_is_fold_free_and_the_drag_catches_up(starfish):
    """No time: one substep a frame.  A jump of the hardest drag in 3 frames draws fold-free states
    on the way (the boundary behind the target curve), and frames at the last target catch up."""
    cage, mesh, basis = starfish
    frames = drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary)
    point, offset = HARD_DRAGS[2]
    moved = cage.copy()
    positions, way, behind = None, None, 0
    for frame in range(1, 4):
        moved[point] = cage[point] + np.array(offset) * frame / 3
        goal = basis @ moved
        step = drag_step(frames, positions, goal, 0.0, way)
        _check_frame(mesh, step, goal)
        assert step.plain or step.substeps == 1
        positions, way, behind = step.positions, step.way, behind + (not step.reached)
    assert behind >= 1
    for _ in range(CATCH_UP):
        if step.reached:
            break
        step = drag_step(frames, positions, goal, 0.0, way)
        _check_frame(mesh, step, goal)
        positions, way = step.positions, step.way
    assert step.reached and not step.plain


def test_without_a_substep_the_start_is_drawn_again(starfish):
    cage, mesh, basis = starfish
    point, offset = HARD_DRAGS[2]
    moved = cage.copy()
    moved[point] += offset
    goal = basis @ moved
    step = drag_step(drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary), None, goal, 0.0, least=0)
    _check_frame(mesh, step, goal)
    assert not step.reached and step.substeps == 0
    np.testing.assert_array_equal(step.positions, mesh.vertices)


def test_a_hard_drag_from_the_source_is_mapped_in_one_call_given_the_time(starfish):
    """The hardest drag (367 triangles turned over) from the source mesh, in one call of 5 s at most
    (~0.1 s on a quiet machine)."""
    cage, mesh, basis = starfish
    point, offset = HARD_DRAGS[2]
    moved = cage.copy()
    moved[point] += offset
    goal = basis @ moved
    started = time.perf_counter()
    step = drag_step(drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary), None, goal, 5.0)
    assert time.perf_counter() - started < 10.0
    _check_frame(mesh, step, goal)
    assert step.reached


def test_a_folded_start_is_refused(starfish):
    cage, mesh, basis = starfish
    start = mesh.vertices.copy()
    start[mesh.interior[0]] = start[mesh.boundary[0]] * 3.0
    point, offset = HARD_DRAGS[0]
    moved = cage.copy()
    moved[point] += offset
    with pytest.raises(ValueError, match="start turns triangles over"):
        drag_step(drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary), start, basis @ moved, 0.0, least=0)
