"""The mesher rows of ``bench``: `core.triangulate` against Triangle at the same vertex count.

Triangle (J. R. Shewchuk's mesher, through the ``triangle`` package) meshes the polygon of our
mesh's boundary vertices with a minimum angle of 20.7 degrees (ours: `RADIUS_EDGE_RATIO`) and a
maximum triangle area calibrated, before the timing, to give about as many vertices as ours.
Both run in this process, in turn.  ``triangle`` is imported here only (the ``bench`` extra: it is
never needed at run time, nor shipped); without it the rows say so and time ours alone.
"""

from __future__ import annotations

import math

import numpy as np

import core
from app.bench.timing import median_time, meshes_with_vertices, print_head
from core import RADIUS_EDGE_RATIO

#: Vertices of the mesher rows.
VERTICES = (10_000, 100_000, 300_000)
#: Rounds of the area calibration of Triangle's switches (the count scales as 1 / area).
CALIBRATION_ROUNDS = 3
#: Fewest runs of ours and of Triangle's (a row of 0.02 s runs moves by 10 % over 3 runs on a busy machine).
LEAST_REPEATS = 5


def mesher_rows(curve: core.ClosedBSpline, repeats: int, vertices=None) -> None:
    """Print the mesher table: medians of `repeats` runs of `core.triangulate` and of Triangle, in turn,
    at each count of `vertices` (`VERTICES` if None)."""
    vertices = VERTICES if vertices is None else vertices
    try:
        import triangle
    except ImportError:
        triangle = None
    print("mesher: core.triangulate against Triangle (quality 20.7 degrees, area calibrated to the count)")
    if triangle is None:
        print(
            "  triangle is not installed (pip install triangle, or the package's 'bench' extra): ours alone"
        )
    header = f"{'target V':>9} {'ours V':>8} {'ours s':>8}"
    header += f" {'Triangle V':>11} {'Triangle s':>11} {'ours / Triangle':>16}"
    print_head(header)
    for count, max_edge, mesh in meshes_with_vertices(curve, vertices):
        row = f"{count:>9,} {len(mesh.vertices):>8,}"

        def ours(max_edge=max_edge):
            return core.triangulate(curve, max_edge=max_edge)

        if triangle is None:
            print(row + f" {median_time(ours, repeats)[0]:>8.3f}")
            continue
        polygon = triangle_input(mesh)
        switches = calibrated_switches(triangle, polygon, len(mesh.vertices), max_edge)

        def theirs(polygon=polygon, switches=switches):
            return triangle.triangulate(polygon, switches)

        times = np.zeros((repeats, 2))
        for turn in range(repeats):  # in turn: the machine's drifts fall on both
            times[turn, 0] = median_time(ours, 1)[0]
            times[turn, 1], result = median_time(theirs, 1)
        ours_seconds, their_seconds = np.median(times, axis=0)
        row += f" {ours_seconds:>8.3f} {len(result['vertices']):>11,} {their_seconds:>11.3f}"
        print(row + f" {ours_seconds / their_seconds:>16.2f}")
    print()


def triangle_input(mesh: core.Mesh) -> dict:
    """Triangle's planar straight-line graph: the closed polygon of `mesh`'s boundary vertices."""
    count = mesh.boundary.size
    segments = np.stack([np.arange(count), (np.arange(count) + 1) % count], axis=1)
    return {"vertices": mesh.vertices[mesh.boundary], "segments": segments}


def calibrated_switches(triangle, polygon: dict, count: int, max_edge: float) -> str:
    """Triangle's switches (PSLG, quiet, minimum angle, maximum area) giving about `count` vertices.

    The area starts at an equilateral triangle of edge `max_edge` and is scaled by the ratio of the
    interior vertex counts, `CALIBRATION_ROUNDS` times.
    """
    angle = math.degrees(math.asin(0.5 / RADIUS_EDGE_RATIO))
    boundary = polygon["vertices"].shape[0]
    area = math.sqrt(3.0) / 4.0 * max_edge**2
    for _ in range(CALIBRATION_ROUNDS):
        found = len(triangle.triangulate(polygon, f"pQq{angle:.2f}a{area:.6g}")["vertices"])
        area *= max(found - boundary, 1) / max(count - boundary, 1)
    return f"pQq{angle:.2f}a{area:.6g}"
