"""Fold-free frames: with the document's "Fold-free" on, every mesh the viewer draws is proven fold-free.

What the canvas shows is the mesh's piecewise-linear map.  Each frame, while a handle moves and
after, its positions come from `core.drag_step`: the plain map G P' itself when it is proven a
bijection onto its boundary polygon (`core.prove_mesh_bijection`: every triangle positive, exactly,
and the polygon simple), else positions reached from the last frame's without turning a triangle
over, the boundary on the target curve.  A frame whose budget (`DRAG_BUDGET`) does not reach that
(a jump of many pixels at once on a slow machine) draws the fold-free state it reached on the way,
its boundary behind the target curve by `MeshProof.lag`, and catches up in the frames after
(`FoldFreeFrames.catching_up`: the window keeps drawing until it has).  The background
check's certified continuous map (`app.viewer.fold_free`) replaces these positions once it
arrives, if it too is a bijection on the mesh; else the mesh keeps them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import core

#: Seconds of a frame in which the drag step starts substeps while a handle moves (one is always
#: taken: on the bench's hard drag one reached the target curve in every frame, 3-8 ms on a quiet
#: machine; a jump of many pixels in one frame takes more), and at rest (catching up after a
#: release, or fold-free switched on: nothing else moves then).
DRAG_BUDGET = 0.04
REST_BUDGET = 0.1


@dataclass(frozen=True)
class MeshProof:
    """What is proven of the mesh drawn for one target.

    Attributes
    ----------
    target : bytes
        The target control points' bytes the positions were drawn for.
    reached : bool
        The boundary is on the target curve (False: the drawing is catching up with the drag).
    turned_over : int
        Turned-over triangles drawn, counted exactly (0: the PL map is proven a bijection).
    lag : float
        How far (image px) the boundary vertices drawn are from their places on the target curve, at
        most (0 when `reached`).
    """

    target: bytes
    reached: bool
    turned_over: int
    lag: float = 0.0

    def proves(self, target: np.ndarray) -> bool:
        """Whether this is the proof of a bijection onto `target`'s (n, 2) curve polygon."""
        return self.reached and self.turned_over == 0 and self.target == np.asarray(target).tobytes()


@dataclass(frozen=True)
class PreviewBasis:
    """A dense mesh's preview mesh as `FoldFreeFrames` takes a basis (`app.viewer.state.BasisResult`):
    fold-free frames drawn on it while a handle moves.

    Attributes
    ----------
    key : str
    mesh : app.viewer.state.PreviewMesh
        Its vertices, triangles and boundary loop.
    basis : ndarray of shape (V', n)
        Its G.
    """

    key: str
    mesh: object
    basis: np.ndarray


def plain_positions(basis: np.ndarray, target: np.ndarray) -> np.ndarray:
    """G P' (V, 2) in float64, one column of G at a time: a BLAS product leaves OpenBLAS's threads
    spinning, and on two cores they slow the software rasteriser's next frame
    (`app.viewer.scene.combined_columns`)."""
    target = np.asarray(target, dtype=np.float64)
    positions = np.zeros((2, basis.shape[0]))
    for column in range(basis.shape[1]):
        positions[0] += basis[:, column] * target[column, 0]
        positions[1] += basis[:, column] * target[column, 1]
    return positions.T


class FoldFreeFrames:
    """The fold-free positions drawn last, and the drag step's work carried from frame to frame."""

    def __init__(self):
        self._basis_key: str | None = None
        self._mesh: core.DragMesh | None = None
        self._positions: np.ndarray | None = None  # the last fold-free positions drawn (V, 2)
        self._way: np.ndarray | None = None  # the plain positions they were drawn for (V, 2)
        #: The last frame's boundary is not yet on the target curve: draw again.
        self.catching_up = False
        self.proof: MeshProof | None = None
        #: The last certified map `adopt` refused (its mesh map folds: the mesh is too coarse for it).
        self.refused: np.ndarray | None = None

    def _use(self, basis) -> None:
        """Start over on a new mesh (`basis`: `app.viewer.state.BasisResult`)."""
        if basis.key == self._basis_key:
            return
        mesh = basis.mesh
        self._basis_key = basis.key
        self._mesh = core.drag_mesh(mesh.vertices, mesh.triangles, mesh.boundary)
        self._positions = self._way = None

    def positions(self, basis, target: np.ndarray, moving: bool) -> np.ndarray:
        """This frame's fold-free positions (V, 2) for `target` (n, 2) on the mesh of `basis`: one
        substep of `core.drag_step` at least, more within `DRAG_BUDGET` while a handle is `moving`,
        else `REST_BUDGET`."""
        self._use(basis)
        goal = plain_positions(basis.basis, target)
        budget = DRAG_BUDGET if moving else REST_BUDGET
        try:
            step = core.drag_step(self._mesh, self._positions, goal, budget, self._way)
        except ValueError:  # a start that is not fold-free (none is kept): from the source mesh then
            step = core.drag_step(self._mesh, None, goal, budget)
        self._positions, self._way = step.positions, step.way
        self.catching_up = not step.reached
        boundary = self._mesh.boundary
        lag = np.hypot(*(step.positions[boundary] - goal[boundary]).T).max(initial=0.0)
        self.proof = MeshProof(np.asarray(target).tobytes(), step.reached, step.proof.turned_over, float(lag))
        return step.positions

    def adopt(self, basis, target: np.ndarray, positions: np.ndarray) -> bool:
        """Draw `positions` (V, 2), the certified continuous map of `target`, if they are a bijection
        on the mesh too (then later frames start from them); False if not."""
        self._use(basis)
        mesh = self._mesh
        proof = core.prove_mesh_bijection(positions, mesh.triangles, mesh.boundary)
        if not proof.proven or np.any(core.folded_triangles(basis.mesh, positions)):
            self.refused = positions
            return False
        self._positions, self._way, self.catching_up = positions, plain_positions(basis.basis, target), False
        self.proof = MeshProof(np.asarray(target).tobytes(), True, 0)
        return True

    def forget(self) -> None:
        """Nothing fold-free is drawn any more (the switch is off).  The last positions stay: fold-free
        on the same mesh, they are a start for the next frames as good as any."""
        self.proof = None
        self.catching_up = False
