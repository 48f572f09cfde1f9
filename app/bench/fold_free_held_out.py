"""The held-out fold-free rows of ``bench``: `core.fold_free_deform` beside libigl on six cages.

Six cages that the fold-free map was not tuned on (smooth, thin, a 1:8 ellipse, a 40-point star, a
cross with four reflex corners, a keyhole with two convex corners), each at its default mesh, and
`DEFORMATIONS` targets of each drawn with a fixed seed: a rotation of the whole cage by 90° and by
180°, and drags of one handle by 10 to 45 % of the diameter (on the cornered cages one of them moves
one point of a doubled corner, so that the target has no corner there).  Both maps get the same mesh
and boundary values; ours with the density solve included (`forget` empties its cache), no basis.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import numpy as np

import core

#: Targets a cage (2 rotations, the rest drags), and their seed.
DEFORMATIONS = 13
SEED = 46
#: Drags as a share of the cage's diameter.
DRAGS = (0.1, 0.2, 0.3, 0.45)


def held_out_cages() -> dict[str, np.ndarray]:
    """The six cages by name, control points (n, 2) in pixels, counter-clockwise (y up)."""
    turns = 2.0 * np.pi * np.arange(16) / 16
    twelve = 2.0 * np.pi * np.arange(12) / 12
    arc = np.radians(np.linspace(-60.0, 240.0, 11))
    circle = np.stack([np.cos(arc), np.sin(arc)], axis=1) * 100.0 + [150.0, 200.0]
    cross = [[1, 0], [2, 0], [2, 1], [3, 1], [3, 2], [2, 2], [2, 3], [1, 3], [1, 2], [0, 2], [0, 1], [1, 1]]
    return {
        "smooth": core.examples.blob() * 300.0,
        "thin": np.stack([150 * np.cos(twelve), 25 * np.sin(twelve) + 8 * np.sin(2 * twelve)], axis=1) + 150,
        "ellipse 1:8": np.stack([160.0 * np.cos(turns), 20.0 * np.sin(turns)], axis=1) + 160.0,
        "star 40": core.examples.starfish(arms=20, inner=0.6) * 150.0 + 150.0,
        "cross": np.repeat(np.array(cross, dtype=np.float64), 2, axis=0) * 100.0,
        "keyhole": np.concatenate([[[200.0, 0.0]] * 2, circle, [[100.0, 0.0]] * 2]),
    }


def held_out_targets(points: np.ndarray, rng: np.random.Generator) -> list[tuple[str, np.ndarray]]:
    """(label, target (n, 2)) of a cage: the two rotations about the centroid, then drags until
    `DEFORMATIONS`, each a simple curve."""
    centroid = points.mean(axis=0)
    diameter = float(np.max(np.linalg.norm(points[:, None] - points[None], axis=2)))
    targets = []
    for degrees in (90.0, 180.0):
        turn = math.radians(degrees)
        rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
        targets.append((f"rotate {degrees:.0f}", (points - centroid) @ rotation.T + centroid))
    doubled = np.flatnonzero(np.all(points == np.roll(points, 1, axis=0), axis=1))
    while len(targets) < DEFORMATIONS:
        handle, angle = int(rng.integers(len(points))), rng.uniform(0.0, 2.0 * math.pi)
        share = float(rng.choice(DRAGS))
        moved = np.all(points == points[handle], axis=1)
        if doubled.size and len(targets) == 2:  # one point of a doubled corner
            moved = np.arange(len(points)) == doubled[0]
            label = f"corner point {doubled[0]} {share:.2f}"
        else:
            label = f"drag {handle} {share:.2f}"
        target = points.copy()
        target[moved] += share * diameter * np.array([math.cos(angle), math.sin(angle)])
        try:
            core.ClosedBSpline(target)
        except ValueError:
            continue
        targets.append((label, target))
    return targets


def held_out_rows(forget: Callable[[], None], quick: bool = False) -> None:
    """Print, cage by cage and in all, the time of ours and of libigl's composite on the held-out
    targets (`quick`: the first of each): total, median, slowest, the ratio of the totals,
    how many each mapped and the most triangles a map of ours turned over."""
    try:
        import igl
    except ImportError:
        print("held-out fold-free cages: libigl is not installed (pip install libigl): not run\n")
        return
    print("held-out fold-free cages (default meshes; seconds; mapped = a map with no triangle turned over)")
    header = f"{'cage':>12} {'V':>6} {'maps':>5} {'ours total':>11} {'median':>7} {'slowest':>8}"
    header += f" {'libigl total':>13} {'median':>7} {'slowest':>8} {'ours / libigl':>14}"
    header += f" {'mapped ours':>12} {'libigl':>7} {'turned over':>12}"
    print(header)
    print("-" * len(header))
    rng = np.random.default_rng(SEED)
    everything = ([], [], 0, 0, 0, 0)
    for name, points in held_out_cages().items():
        curve = core.ClosedBSpline(points)
        mesh = core.triangulate(curve)
        targets = held_out_targets(points, rng)[: 1 if quick else None]
        ours, theirs, mapped, igl_mapped, turned = [], [], 0, 0, 0
        for _, target in targets:
            values = core.ClosedBSpline(target)(mesh.boundary_parameters)
            started = time.perf_counter()
            try:
                images = igl.bijective_composite_harmonic_mapping(
                    mesh.vertices, mesh.triangles, mesh.boundary, values
                )
                igl_mapped += int(not core.folded_triangles(mesh, images).any())
            except RuntimeError:  # libigl's "failed"
                pass
            theirs.append(time.perf_counter() - started)
            forget()
            started = time.perf_counter()
            try:
                images, _ = core.fold_free_deform(
                    curve, target, mesh.vertices,
                    boundary=(mesh.boundary, mesh.boundary_parameters), triangles=mesh.triangles,
                )  # fmt: skip
                folded = int(np.count_nonzero(core.folded_triangles(mesh, images)))
                mapped, turned = mapped + int(folded == 0), max(turned, folded)
            except ValueError:  # refused, in one line
                pass
            ours.append(time.perf_counter() - started)
        print(_row(name, len(mesh.vertices), ours, theirs, mapped, igl_mapped, turned))
        everything = (
            everything[0] + ours, everything[1] + theirs, everything[2] + mapped,
            everything[3] + igl_mapped, max(everything[4], turned), everything[5] + len(mesh.vertices),
        )  # fmt: skip
    ours, theirs, mapped, igl_mapped, turned, _ = everything
    print(_row("all", 0, ours, theirs, mapped, igl_mapped, turned))
    print()


def _row(name: str, vertices: int, ours: list, theirs: list, mapped: int, igl_mapped: int, turned: int):
    count = f"{vertices:>6,}" if vertices else f"{'':>6}"
    row = f"{name:>12} {count} {len(ours):>5} {sum(ours):>11.3f} {statistics.median(ours):>7.3f}"
    row += f" {max(ours):>8.3f} {sum(theirs):>13.3f} {statistics.median(theirs):>7.3f} {max(theirs):>8.3f}"
    row += f" {sum(ours) / sum(theirs):>14.2f} {mapped:>12} {igl_mapped:>7} {turned:>12}"
    return row
