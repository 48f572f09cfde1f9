"""What every row of ``bench`` shares: the median time of repeated runs, and the mesh edge that
gives a vertex count."""

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
