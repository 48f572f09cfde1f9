"""The standard suite of the quality study (`app.studies.quality`): cages and strong deformations of them.

Domains: the bundled demos (``assets/*.cage.json``) and built-in non-convex shapes: a
C, a U, a hook, a six-armed star and an F-shaped polygon (sharp corners, a thin arm).
Deformations of each domain, drawn with a fixed seed: two single handles dragged by
`DRAG` of the cage's diameter, two moves of three handles by `MULTI_DRAG` each, and
two bends that rotate the half of the cage on one side of a line through its centroid
by `BEND_DEGREES` (once each way).  A handle is what the viewer shows as one point:
control points repeated in a row (a sharp corner) move together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.io.bundled import bundled_directory
from app.io.files import read_cage

#: Seed of the deformations' random handles and directions.
SEED = 14
#: Drag of a single handle, and of each of three handles, as a fraction of the cage's diameter.
DRAG = 0.25
MULTI_DRAG = 0.15
#: Rotation of half the cage in a bend.
BEND_DEGREES = 30.0
#: The bundled demos in the suite (``assets/NAME.cage.json``).
DEMOS = ("starfish", "character", "pattern")


@dataclass(frozen=True)
class Deformation:
    """One target cage of a domain.

    Attributes
    ----------
    label : str
        What was done, e.g. ``"drag 7"`` or ``"bend +30"``.
    target : ndarray of shape (n, 2)
        Target control points.
    """

    label: str
    target: np.ndarray


@dataclass(frozen=True)
class Domain:
    """A source cage and its deformations.

    Attributes
    ----------
    name : str
    control_points : ndarray of shape (n, 2)
    deformations : list of Deformation
    """

    name: str
    control_points: np.ndarray
    deformations: list[Deformation]


def standard_suite(seed: int = SEED, demos: tuple[str, ...] = DEMOS) -> list[Domain]:
    """Every domain of the suite with its six deformations, the same for the same `seed`.

    Parameters
    ----------
    seed : int
        Seed of the random handles, directions and bend axes.
    demos : tuple of str
        Bundled demos to include before the built-in shapes.
    """
    rng = np.random.default_rng(seed)
    assets = bundled_directory("assets")
    shapes = [(name, read_cage(assets / f"{name}.cage.json")) for name in demos]
    shapes += list(built_in_shapes().items())
    return [Domain(name, points, deformations(points, rng)) for name, points in shapes]


def built_in_shapes() -> dict[str, np.ndarray]:
    """The non-convex built-in domains by name, control points of shape (n, 2) each (y up)."""
    arc = np.radians(np.linspace(30.0, 330.0, 9))
    hook_arc = np.radians(np.linspace(0.0, -200.0, 6))
    # A straight stem into a curl of radius 1 around (-1, 0).
    hook = np.concatenate(
        [[[0.0, 2.2], [0.0, 1.5], [0.0, 0.8]], np.stack([np.cos(hook_arc) - 1.0, np.sin(hook_arc)], 1)]
    )
    return {
        "C-shape": thick_path(np.stack([np.cos(arc), np.sin(arc)], axis=1), 0.3),
        "U-shape": thick_path(
            np.array(
                [[-1.0, 1.2], [-1.0, 0.4], [-1.0, -0.4], [0.0, -0.8], [1.0, -0.4], [1.0, 0.4], [1.0, 1.2]]
            ),
            0.4,
        ),
        "hook": thick_path(hook, 0.35),
        "star": star(arms=6, inner=0.3),
        "F polygon": polygon(
            [
                [0.0, 0.0],
                [2.0, 0.0],
                [2.0, 0.4],
                [0.5, 0.4],
                [0.5, 0.55],
                [1.8, 0.55],
                [1.8, 0.68],
                [0.5, 0.68],
                [0.5, 1.5],
                [0.0, 1.5],
            ]
        ),
    }


def thick_path(centreline: np.ndarray, width: float) -> np.ndarray:
    """A band of `width` around a polyline (m, 2): its left side forwards, then its right side
    backwards, control points of shape (2m, 2), counter-clockwise."""
    tangents = np.gradient(centreline, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    normals = np.stack([-tangents[:, 1], tangents[:, 0]], axis=1)
    return np.concatenate([centreline - 0.5 * width * normals, (centreline + 0.5 * width * normals)[::-1]])


def star(arms: int, inner: float) -> np.ndarray:
    """A star of `arms` thin limbs: tips at radius 1, armpits at `inner`, shape (2 arms, 2)."""
    angles = np.pi / 2 + np.pi * np.arange(2 * arms) / arms
    radii = np.where(np.arange(2 * arms) % 2 == 0, 1.0, inner)
    return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)


def polygon(corners) -> np.ndarray:
    """A polygon as a B-spline cage: every corner doubled (a sharp corner), shape (2m, 2)."""
    return np.repeat(np.asarray(corners, dtype=np.float64), 2, axis=0)


def handles(control_points: np.ndarray) -> list[np.ndarray]:
    """Indices of the control points that move together: runs of equal consecutive points
    (cyclically), one array per handle, in order."""
    n = len(control_points)
    same_as_previous = np.all(control_points == np.roll(control_points, 1, axis=0), axis=1)
    if same_as_previous.all():
        return [np.arange(n)]
    start = int(np.flatnonzero(~same_as_previous)[0])
    groups: list[list[int]] = []
    for offset in range(n):
        index = (start + offset) % n
        if same_as_previous[index] and groups:
            groups[-1].append(index)
        else:
            groups.append([index])
    return [np.array(group) for group in groups]


def deformations(control_points: np.ndarray, rng: np.random.Generator) -> list[Deformation]:
    """Two single drags, two three-handle moves and two bends of a cage (n, 2), drawn from `rng`."""
    points = np.asarray(control_points, dtype=np.float64)
    diameter = float(np.max(np.linalg.norm(points[:, None] - points[None], axis=2)))
    groups = handles(points)
    result = []
    for count, fraction in ((1, DRAG), (1, DRAG), (3, MULTI_DRAG), (3, MULTI_DRAG)):
        chosen = sorted(rng.choice(len(groups), size=count, replace=False))
        target = points.copy()
        for handle in chosen:
            angle = rng.uniform(0.0, 2.0 * np.pi)
            target[groups[handle]] += fraction * diameter * np.array([np.cos(angle), np.sin(angle)])
        label = "drag" if count == 1 else "move"
        result.append(Deformation(f"{label} {'+'.join(str(groups[h][0]) for h in chosen)}", target))
    centroid = points.mean(axis=0)
    for sign in (1.0, -1.0):
        axis_angle = rng.uniform(0.0, 2.0 * np.pi)
        axis = np.array([np.cos(axis_angle), np.sin(axis_angle)])
        turn = np.radians(sign * BEND_DEGREES)
        rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
        target = points.copy()
        moving = (points - centroid) @ axis > 0
        target[moving] = (points[moving] - centroid) @ rotation.T + centroid
        result.append(Deformation(f"bend {sign * BEND_DEGREES:+.0f}", target))
    return result
