"""The fold-free rows of ``bench``: `core.fold_free_deform` against libigl on the same mesh.

libigl's ``bijective_composite_harmonic_mapping`` composes discrete (finite-element) harmonic maps
between morphs of the boundary values, doubling its number of uniform steps and starting again
while a step flips a triangle; ours composes the same kind of steps, each cut before a triangle
turns over and the step size adaptive, and proves the end a bijection on the mesh
(`core.injectivity.mesh_fold_free`).  Both get the same mesh (`core.triangulate`) and the same
boundary values (the target curve at the boundary vertices' parameters), in this process.  libigl
is imported here and in `app.bench.fold_free_held_out` only (the ``bench`` extra); without it the
rows say so and time ours alone.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import numpy as np

import core
from app.bench.timing import edge_for_vertices, median_time

#: Vertices of the fold-free rows: the default mesh's size, and a large one.
VERTICES = (10_000, 50_000)
#: The deformation: control point `HANDLE` of the bench's blob dragged by `DRAG` of its diameter
#: in the direction `DRAG_ANGLE` (degrees; the plain harmonic map folds there).
HANDLE = 1
DRAG = 0.3
DRAG_ANGLE = 90.0
#: The large cage's row: its control points (on a five-lobed circle, radius ~150 px), the one dragged
#: upwards, and the drags in pixels: (one the certificate proves, one whose harmonic map folds).
LARGE_CAGE, LARGE_HANDLE, LARGE_DRAGS = 200, 10, (5.0, 45.0)


def bench_target(curve: core.ClosedBSpline) -> np.ndarray:
    """The target control points (n, 2) of the fold-free rows."""
    target = curve.control_points.copy()
    angle = math.radians(DRAG_ANGLE)
    target[HANDLE] += DRAG * curve.diameter * np.array([math.cos(angle), math.sin(angle)])
    return target


def fold_free_rows(
    curve: core.ClosedBSpline, repeats: int, forget: Callable[[], None], vertices=None
) -> None:
    """Print the fold-free table: ours (its density solves included: `forget` empties their cache) and
    libigl's on the same meshes (`VERTICES` if `vertices` is None), medians of `repeats` runs."""
    vertices = VERTICES if vertices is None else vertices
    try:
        import igl
    except ImportError:
        igl = None
    target = bench_target(curve)
    print(
        "fold-free warp: core.fold_free_deform (composite harmonic steps proven on the mesh, no basis given)"
    )
    if igl is None:
        print("  libigl is not installed (pip install libigl, or the package's 'bench' extra): ours alone")
    header = f"{'vertices V':>11} {'ours s':>8} {'steps':>6} {'flips':>6} {'proven':>7} {'plain flips':>12}"
    header += f" {'libigl s':>9} {'flips':>6} {'ours / libigl':>14}"
    print(header)
    print("-" * len(header))
    for count in vertices:
        max_edge = edge_for_vertices(curve.area, count)
        mesh = core.triangulate(curve, max_edge=max_edge)
        boundary = (mesh.boundary, mesh.boundary_parameters)

        def ours(mesh=mesh, boundary=boundary):
            forget()
            return core.fold_free_deform(
                curve, target, mesh.vertices, boundary=boundary, triangles=mesh.triangles
            )

        seconds, (images, certificate) = median_time(ours, repeats)
        plain = core.deform(core.mesh_basis_functions(curve, mesh, "poisson", cache=False), target)
        row = f"{len(mesh.vertices):>11,} {seconds:>8.3f} {certificate.extra['steps']:>6} "
        proven = "yes" if certificate.injective else "no"
        row += f"{_flips(mesh, images):>6} {proven:>7} {_flips(mesh, plain):>12}"
        if igl is not None:
            values = target_curve_values(target, mesh)

            def theirs(mesh=mesh, values=values):
                return igl.bijective_composite_harmonic_mapping(
                    mesh.vertices, mesh.triangles, mesh.boundary, values
                )

            igl_seconds, mapped = median_time(theirs, repeats)
            row += f" {igl_seconds:>9.3f} {_flips(mesh, mapped):>6} {seconds / igl_seconds:>14.2f}"
        print(row)
    print()


def large_cage_row(repeats: int, count: int = LARGE_CAGE) -> None:
    """Print the large cage's row (issue 46: ≤ 1 s and ≤ 5 s): `core.certify_injective` from cold, each
    run a new cage (the lobed circle scaled by 1 + k/1000: its densities not solved, as in a fresh
    process once the compiled code is read), wall clock and the process's CPU time (both threads); and
    `core.fold_free_deform` of the folding drag at the cage's default mesh.  Medians of `repeats` runs."""
    base = core.examples.lobed_circle(count) * 150.0 + 300.0
    print(f"{count}-point cage (a five-lobed circle, radius ~150 px); medians of {repeats}")
    header = f"{'certificate s':>14} {'cpu s':>6} {'proven':>7} {'samples':>8} {'vertices V':>11}"
    header += f" {f'{LARGE_DRAGS[1]:.0f}-px drag map s':>17} {'flips':>6} {'proven':>7}"
    print(header)
    print("-" * len(header))
    walls, cpus = [], []
    for run in range(1, repeats + 1):
        points = base * (1.0 + 1e-3 * run)
        target = points.copy()
        target[LARGE_HANDLE, 1] += LARGE_DRAGS[0]
        started, cpu = time.perf_counter(), time.process_time()
        proof = core.certify_injective(core.ClosedBSpline(points), target)
        walls.append(time.perf_counter() - started)
        cpus.append(time.process_time() - cpu)
    curve = core.ClosedBSpline(base)
    mesh = core.triangulate(curve)
    target = base.copy()
    target[LARGE_HANDLE, 1] += LARGE_DRAGS[1]

    def mapped():
        return core.fold_free_deform(
            curve, target, mesh.vertices, boundary=(mesh.boundary, mesh.boundary_parameters),
            triangles=mesh.triangles,
        )  # fmt: skip

    seconds, (images, certificate) = median_time(mapped, repeats)
    row = f"{statistics.median(walls):>14.3f} {statistics.median(cpus):>6.3f} "
    row += f"{'yes' if proof.injective else 'no':>7} {proof.samples:>8} {len(mesh.vertices):>11,}"
    row += f" {seconds:>17.3f} {_flips(mesh, images):>6} {'yes' if certificate.injective else 'no':>7}"
    print(row)
    print()


def target_curve_values(target: np.ndarray, mesh: core.Mesh) -> np.ndarray:
    """The target curve at the boundary vertices' parameters, (B, 2)."""
    return core.ClosedBSpline(target)(mesh.boundary_parameters)


def _flips(mesh: core.Mesh, images: np.ndarray) -> int:
    return int(np.count_nonzero(core.folded_triangles(mesh, images)))
