"""The pins rows of ``bench``: `core.pin_deform` with a distortion bound, per cage size.

A wavy cage of n control points (an ellipse with a three-fold wave, 400 pixels wide) and four pins
dragged along a straight path, K = 2: the first solve (the cage's gradients at the samples
included), then two bounded solves, both medians after that first solve on the same cage: the
drag-rate solve (``certify=False``: the bound held at the samples of Γ, as the viewer solves while a
pin is dragged) and the certified solve (certificate and re-solves until the bound is proven), with
the bound the last one proves and the largest pin error.  The last column names the solves whose
median is within issue 47's 0.1 s (`BUDGET`).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from core import ClosedBSpline, PinDeformation, pin_deform

#: Control points of the rows.
CONTROL_POINTS = (16, 40, 100)
#: The bound of the rows, and how many drag steps and certified solves each row times.
MAX_DISTORTION = 2.0
DRAG_STEPS = 10
CERTIFIED = 3
#: The bounded solve's time budget, in seconds.
BUDGET = 0.1
PINS = np.array([[300.0, 300.0], [380.0, 320.0], [230.0, 280.0], [300.0, 400.0]])
PULL = np.array([[0.0, 0.0], [60.0, -40.0], [-20.0, 0.0], [0.0, 30.0]])


def wavy_cage(count: int) -> ClosedBSpline:
    """The rows' cage of `count` control points."""
    angle = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    points = np.stack([np.cos(angle) * (1.0 + 0.2 * np.cos(3.0 * angle)), 0.8 * np.sin(angle)], axis=1)
    return ClosedBSpline(points * 200.0 + 300.0)


def pin_rows(control_points=CONTROL_POINTS, steps: int = DRAG_STEPS, certified: int = CERTIFIED) -> None:
    """Print the pins table for cages of each count of `control_points`: wall-clock medians, and the
    process's CPU-time medians beside them (all its threads: steadier than the wall clock on a
    shared machine, and above it where the certificate runs on both cores)."""
    print(f"\npins: core.pin_deform, four pins dragged, max_distortion = {MAX_DISTORTION:g}")
    header = (
        f"{'control points':>15} {'first s':>8} {'drag median ms':>15} {'certified median ms':>20} "
        f"{'proven K':>9} {'max pin error px':>17} {'within 0.1 s':>13} {'drag CPU ms':>12} "
        f"{'certified CPU ms':>17}"
    )
    print(header)
    print("-" * len(header))
    for count in control_points:
        curve = wavy_cage(count)
        first = _timed(curve, 0.1, certify=False)[0]
        drag = [_timed(curve, fraction, certify=False) for fraction in np.linspace(0.1, 1.0, steps + 1)[1:]]
        proofs = [_timed(curve, fraction, certify=True) for fraction in np.linspace(0.4, 1.0, certified)]
        result = proofs[-1][2]
        (drag_median, drag_cpu), (proof_median, proof_cpu) = (
            [statistics.median(row[column] for row in rows) for column in (0, 1)] for rows in (drag, proofs)
        )
        within = (
            "+".join(
                name
                for name, median in (("drag", drag_median), ("certified", proof_median))
                if median <= BUDGET
            )
            or "none"
        )
        print(
            f"{count:>15} {first:>8.2f} {1000 * drag_median:>15.0f} {1000 * proof_median:>20.0f} "
            f"{result.proven_distortion:>9.3f} {result.pin_error.max():>17.2g} {within:>13} "
            f"{1000 * drag_cpu:>12.0f} {1000 * proof_cpu:>17.0f}",
            flush=True,
        )


def _timed(curve: ClosedBSpline, fraction: float, certify: bool) -> tuple[float, float, PinDeformation]:
    """Wall-clock and CPU seconds of one bounded solve with the pins `fraction` of the way along, and
    its result."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = pin_deform(curve, PINS, PINS + fraction * PULL, max_distortion=MAX_DISTORTION, certify=certify)
    return time.perf_counter() - wall, time.process_time() - cpu, result
