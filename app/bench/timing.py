"""What every row of ``bench`` shares: the median time of repeated runs, the mesh edge that
gives a vertex count (and the meshes of a curve at given counts), a table's head."""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable


def median_time(function: Callable[[], object], repeats: int) -> tuple[float, object]:
    """(median seconds of `repeats` calls of `function`, the last call's result)."""
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def edge_for_vertices(area: float, count: int) -> float:
    """The edge length h of a triangle mesh with about `count` vertices on `area`:
    2 A / (sqrt(3) h^2) vertices."""
    return math.sqrt(2.0 * abs(area) / (math.sqrt(3.0) * count))


def meshes_with_vertices(curve, counts):
    """(count, max_edge, mesh) for each count of `counts`: `curve` (a `core.ClosedBSpline`) meshed by
    `core.triangulate` at the edge length that gives about that many vertices."""
    from core import triangulate

    for count in counts:
        max_edge = edge_for_vertices(curve.area, count)
        yield count, max_edge, triangulate(curve, max_edge=max_edge)


def print_head(header: str) -> None:
    """Print a table's column names and a rule under them."""
    print(header)
    print("-" * len(header))
