"""core.library_threads: OpenBLAS's idle threads spin briefly, set before numpy loads OpenBLAS;
the compiled loops run in shares on threads that sleep when idle."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from support.paths import ROOT

from core.library_threads import IDLE_SPIN, in_shares, thread_count


@pytest.mark.parametrize("first", ["core", "app.commands.cli"])
def test_the_idle_spin_is_set_before_numpy_loads(first):
    # app.commands.cli loads numpy before core, so app sets the same value itself; a user's own setting stays.
    script = f"import sys, os, {first}; print(os.environ['OPENBLAS_THREAD_TIMEOUT'])"
    environment = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environment, cwd=ROOT
    )
    assert result.stdout.split() == [str(IDLE_SPIN)], result.stderr
    environment["OPENBLAS_THREAD_TIMEOUT"] = "7"
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environment, cwd=ROOT
    )
    assert result.stdout.split() == ["7"], result.stderr


# A caller that idles 2 ms after each of 100 small threaded loops (core's own: the winding numbers
# of `ClosedBSpline.contains`, read from numba's cache): the CPU time of the process over its wall
# time.  (numba's parallel loops, which these replaced, kept 0.49-0.66 of a core spinning here
# with libgomp's default wait policy.)
IDLE_CALLER = """
import time, core, numpy as np
from core.curves import examples
from core.curves.closest_point import winding_numbers

pieces = core.ClosedBSpline(examples.blob()).piecewise_polynomial()
points = np.zeros((16, 2))
winding_numbers(pieces, points)
start, cpu = time.perf_counter(), time.process_time()
for _ in range(100):
    winding_numbers(pieces, points)
    time.sleep(0.002)
print((time.process_time() - cpu) / (time.perf_counter() - start), flush=True)
"""


def test_the_loops_threads_sleep_between_loops():
    environment = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    result = subprocess.run(
        [sys.executable, "-c", IDLE_CALLER], capture_output=True, text=True, env=environment, cwd=ROOT
    )
    assert result.returncode == 0, result.stderr
    assert float(result.stdout) < 0.2, result.stdout


def test_each_share_takes_its_items_side_by_side(monkeypatch):
    monkeypatch.setattr("numba.config.NUMBA_NUM_THREADS", 3)
    assert [thread_count(items) for items in (0, 1, 2, 3, 10)] == [1, 1, 2, 3, 3]
    taken, threads, barrier = [], set(), threading.Barrier(3, timeout=10)

    def loop(out, first, shares):
        barrier.wait()  # every share runs at once, each on a thread of its own
        threads.add(threading.get_ident())
        taken.append((first, shares))
        out[first::shares] += 1

    out = np.zeros(10, dtype=int)
    in_shares(loop, 10, out)
    assert sorted(taken) == [(0, 3), (1, 3), (2, 3)] and len(threads) == 3
    assert np.array_equal(out, np.ones(10, dtype=int))
    # Fewer items, fewer shares, on the same pool: no thread beyond numba's count in all.
    barrier = threading.Barrier(2, timeout=10)
    in_shares(loop, 2, out)
    assert sorted(taken[3:]) == [(0, 2), (1, 2)] and len(threads) == 3


def test_a_failed_share_is_raised_once_every_share_has_ended(monkeypatch):
    monkeypatch.setattr("numba.config.NUMBA_NUM_THREADS", 2)
    ended = []

    def loop(first, shares):
        if first == 0:
            raise ValueError("share 0 failed")
        time.sleep(0.2)
        ended.append(first)

    with pytest.raises(ValueError, match="share 0 failed"):
        in_shares(loop, 2)
    assert ended == [1]
