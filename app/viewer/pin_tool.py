"""The pin tool: pins in the picture that the warp follows (Puppet Warp's pins), with a bound K on
its distortion, solved by `core.pin_deform` into the cage's target.

A click in pins mode pins the picture where it is: the pin's ``at`` is the source point the drawn
map takes to the click (the click itself while the target is the cage), its ``to`` the click.
Dragging a pin moves its ``to``; every frame of the drag solves the pins once (``certify=False``,
`follow`: the bound then holds at the samples) and the scene draws the plain map G @ Q of that
target, as for a dragged control point; the release solves again, certified, and commits that
target as one undo step whose status line says what is proven (`settled`).  Right-click or Delete
removes a pin; the K slider (1 rigid ... inf free) re-solves.  A control point moved by hand while
there are pins becomes ``fixed``: later solves hold it where it is.

Nothing here touches GL: the controller, the commands and the panel call it, and the controller
commits the edits it returns (`Edit`) as undo steps.
"""

from __future__ import annotations

import math

import numpy as np

from app.viewer import editing
from app.viewer.state import AppState, Snapshot

#: An edit of the pins for `app.viewer.controller.commit`: the new snapshot and what the status line
#: says, or None (refused: the status line says why).
Edit = tuple[Snapshot, str] | None

#: Window pixels within which a press picks a pin (its ``to``).
PICK_RADIUS = 10.0
#: Image pixels: a pin dropped closer than this to another pin's ``to`` is refused.
SAME_PLACE = 2.0
#: The K slider's position s in [0, 1] is 1 - 1/K: 0 rigid (K = 1), 1/2 at K = 2, 1 free (no bound).
FREE_FROM = 0.995

#: Overlay colours (straight RGB): a pin's ``to``, its ``at``, the selected pin, fixed control points.
PIN_COLOUR = (0.95, 0.30, 0.85)
SELECTED_PIN_COLOUR = (1.00, 0.86, 0.20)
FIXED_COLOUR = (1.00, 0.45, 0.10)


def pin_points(snapshot: Snapshot) -> tuple[np.ndarray, np.ndarray]:
    """The pins' ``at`` and ``to``, each ndarray of shape (m, 2), image pixels."""
    at = np.array([pin[0] for pin in snapshot.pins.points], dtype=np.float64).reshape(-1, 2)
    to = np.array([pin[1] for pin in snapshot.pins.points], dtype=np.float64).reshape(-1, 2)
    return at, to


def pick_pin(state: AppState, x: float, y: float) -> int | None:
    """The pin whose ``to`` is under window position (x, y), or None."""
    _, to = pin_points(state.document.live)
    if not len(to):
        return None
    return editing.nearest_handle(editing.to_window(state.display.viewport, to), (x, y), PICK_RADIUS)


def source_point(state: AppState, point) -> np.ndarray | None:
    """The source point (2,) that the drawn map takes to `point` (image pixels), or None outside it.

    The map is the mesh's: the triangle of the deformed mesh (G @ Q at the vertices) holding
    `point` and the same barycentric combination of its source vertices.  The identity (target =
    cage) gives `point` itself, exactly (`core.pin_deform` says whether it is inside the cage); another
    target needs the live cage's basis: None until it is drawn.
    """
    live, basis = state.document.live, state.compute.basis
    point = np.asarray(point, dtype=np.float64)
    if np.array_equal(live.cage, live.target):
        return point.copy()
    if basis is None or not np.array_equal(basis.cage, live.cage):
        return None
    from core import deform

    deformed = deform(basis.basis, live.target)
    triangles = basis.mesh.triangles
    a, b, c = (deformed[triangles[:, k]] for k in range(3))
    u, v, w = b - a, c - a, point - a
    det = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        beta = (w[:, 0] * v[:, 1] - w[:, 1] * v[:, 0]) / det
        gamma = (u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]) / det
    slack = 1e-9
    inside = np.flatnonzero((det != 0) & (beta >= -slack) & (gamma >= -slack) & (beta + gamma <= 1 + slack))
    if not len(inside):
        return None
    t = inside[0]
    corners = basis.mesh.vertices[triangles[t]]
    return (1 - beta[t] - gamma[t]) * corners[0] + beta[t] * corners[1] + gamma[t] * corners[2]


def solve(snapshot: Snapshot, certify: bool):
    """`core.pin_deform` of `snapshot`'s pins, bound and fixed points (held at their targets) on
    its cage, with its kernel; `ValueError` (one line) where it refuses."""
    from core import ClosedBSpline, pin_deform

    at, to = pin_points(snapshot)
    fixed = {i: snapshot.target[i] for i in snapshot.pins.fixed} or None
    return pin_deform(
        ClosedBSpline(snapshot.cage), at, to, max_distortion=snapshot.pins.bound, fixed=fixed,
        kernel=snapshot.kernel, certify=certify,
    )  # fmt: skip


def proven_words(result) -> str:
    """The status line's words of a certified solve: the bound proven (or why not), the pins that miss."""
    asked = "no bound" if result.max_distortion is None else f"bound {result.max_distortion:g}"
    proven = result.proven_distortion
    if math.isfinite(proven):
        words = f"pins: K ≤ {proven:.3g} proven ({asked}), fold-free"
    else:
        words = f"pins: nothing proven ({asked}): {result.certificate}"
    misses = [f"pin {j} misses by {result.pin_error[j]:.2g} px" for j in result.missed]
    return "; ".join([words, *misses])


def added(state: AppState, x: float, y: float) -> Edit:
    """The picture pinned at window position (x, y): the edit (the target does not move), or None
    and one line saying why not."""
    from core import PIN_KERNELS

    live = state.document.live
    if live.kernel not in PIN_KERNELS:
        kernels = " or ".join(PIN_KERNELS)
        state.say(
            f"pins need the {kernels} kernel, not {live.kernel}: choose one in the Kernel section", error=True
        )
        return None
    click = editing.to_image(state.display.viewport, (x, y))
    at = source_point(state, click)
    basis = state.compute.basis
    if at is None and (basis is None or not np.array_equal(basis.cage, live.cage)):
        state.say("cannot pin yet: the warp of this cage is being computed; click again once it is drawn")
        return None
    if at is None:
        state.say("cannot pin there: click inside the cage's picture", error=True)
        return None
    pins_at, _ = pin_points(live)
    if len(pins_at) and np.min(np.linalg.norm(pins_at - at, axis=1)) < SAME_PLACE:
        state.say("a pin is there already: drag it, or right-click it to remove it", error=True)
        return None
    points = (*live.pins.points, (tuple(at), tuple(click)))
    snapshot = live.replace(pins=live.pins.replace(points=points))
    try:  # a point the pins' solve refuses (outside the cage's curve) is refused here, at once
        solve(snapshot, certify=False)
    except ValueError as error:
        state.say(f"cannot pin there: {error}", error=True)
        return None
    return snapshot, f"pin {len(points) - 1} added at {click[0]:.0f}, {click[1]:.0f}: drag it"


def follow(state: AppState) -> None:
    """Once a frame, while a pin is dragged: the live target by the drag-rate solve of the live pins
    (``certify=False``), when they moved since the last solve."""
    drag, live = state.selection.drag, state.document.live
    if drag is None or drag.kind != "pin" or drag.solved == live.pins.points:
        return
    drag.solved = live.pins.points
    try:
        result = solve(live, certify=False)
    except ValueError as error:
        state.say(f"pins: {error}", error=True)
        return
    state.document.live = live.replace(target=result.target)


def move(state: AppState, index: int, position) -> None:
    """Pin `index`'s ``to`` at `position` (image pixels), in the live snapshot (a drag)."""
    live = state.document.live
    points = list(live.pins.points)
    points[index] = (points[index][0], tuple(float(v) for v in position))
    state.document.live = live.replace(pins=live.pins.replace(points=tuple(points)))


def released(state: AppState, index: int, before: Snapshot) -> Edit:
    """The end of pin `index`'s drag: its `settled` edit; refused onto another pin, or where the
    solve refuses (then the drag is undone and one line says why)."""
    live = state.document.live
    _, to = pin_points(live)
    others = np.delete(to, index, axis=0)
    if len(others) and np.min(np.linalg.norm(others - to[index], axis=1)) < SAME_PLACE:
        state.document.live = before
        state.say(f"pin {index} cannot go onto another pin: drop it elsewhere", error=True)
        return None
    edit = settled(state, live, f"moved pin {index}")
    if edit is None:
        state.document.live = before
    return edit


def settled(state: AppState, snapshot: Snapshot, what: str) -> Edit:
    """`snapshot` with the certified solve's target of its pins (itself without pins), and `what`
    with what is proven; None, and one line saying why, where the solve refuses."""
    if not snapshot.pins.points:
        return snapshot, what
    try:
        result = solve(snapshot, certify=True)
    except ValueError as error:
        state.say(f"{what}: not done: {error}", error=True)
        return None
    return snapshot.replace(target=result.target), f"{what}; {proven_words(result)}"


def removed(state: AppState, index: int | None = None) -> Edit:
    """Pin `index` (default: the selected one) removed, the others solved again."""
    live = state.document.live
    points = live.pins.points
    index = state.selection.pin if index is None else index
    if index is None or not 0 <= index < len(points):
        state.say("click a pin first (pins mode), or right-click one to remove it", error=True)
        return None
    state.selection.pin = None
    pins = live.pins.replace(points=points[:index] + points[index + 1 :])
    return settled(state, live.replace(pins=pins), f"removed pin {index}")


def bound_of(position: float) -> float | None:
    """K of the slider's `position` in [0, 1] (1 - 1/K), rounded to 2 decimals; None (free) at the end."""
    if position >= FREE_FROM:
        return None
    return round(1.0 / (1.0 - max(position, 0.0)), 2)


def position_of(bound: float | None) -> float:
    """The K slider's position of `bound` (None: free, 1)."""
    return 1.0 if bound is None else 1.0 - 1.0 / bound


def bound_words(bound: float | None) -> str:
    """K as the slider shows it."""
    return "K = ∞ (free)" if bound is None else f"K = {bound:.2f}"


def bounded(state: AppState, bound) -> Edit:
    """The pins' bound K (None or inf: none), the pins solved again within it; None if it is the
    bound already, or not one (one line says so)."""
    bound = None if bound is None or bound == math.inf else float(bound)
    if bound is not None and not bound >= 1.0:
        state.say(f"K must be 1 (rigid) or more, got {bound:g}", error=True)
        return None
    live = state.document.live
    if bound == live.pins.bound:
        return None
    return settled(state, live.replace(pins=live.pins.replace(bound=bound)), f"pins: {bound_words(bound)}")


def held(snapshot: Snapshot, moved) -> Snapshot:
    """`snapshot` with the control points `moved` by hand fixed, while it has pins."""
    if not snapshot.pins.points:
        return snapshot
    return snapshot.replace(pins=snapshot.pins.replace(fixed=(*snapshot.pins.fixed, *moved)))


def overlay(state: AppState) -> tuple[np.ndarray, np.ndarray]:
    """The pins' marks: segments (S, 2, 7) from each moved pin's ``at`` to its ``to`` and handles (2 m, 7), a
    small faint one at ``at``, a larger one at ``to`` (the selected pin's yellow): rows of
    `app.viewer.scene.overlay_arrays`."""
    at, to = pin_points(state.document.live)
    moved = np.any(at != to, axis=1)  # a line of no length would be drawn as a blot
    segments = np.zeros((int(moved.sum()), 2, 7))
    segments[:, 0, :2], segments[:, 1, :2] = at[moved], to[moved]
    segments[:, :, 2:5] = PIN_COLOUR
    segments[:, :, 5] = 0.7
    segments[:, :, 6] = 1.5
    marks = np.zeros((2 * len(at), 7))
    marks[:, :2] = np.vstack([at, to])
    marks[:, 2:5] = PIN_COLOUR
    marks[:, 5] = np.repeat([0.6, 1.0], len(at))
    marks[:, 6] = np.repeat([6.0, 10.0], len(at))
    if state.selection.pin is not None and state.selection.pin < len(at):
        marks[len(at) + state.selection.pin, 2:5] = SELECTED_PIN_COLOUR
    return segments, marks


def fixed_marks(state: AppState) -> np.ndarray:
    """Handles (k, 7): an orange ring under each fixed control point of the target (drawn before
    the target's handles, larger, so that it shows around them)."""
    live = state.document.live
    marks = np.zeros((len(live.pins.fixed), 7))
    marks[:, :2] = live.target[list(live.pins.fixed)]
    marks[:, 2:5], marks[:, 5], marks[:, 6] = FIXED_COLOUR, 1.0, 17.0
    return marks
