"""core.library_threads: OpenBLAS's idle threads spin briefly, set before numpy loads OpenBLAS;
the OpenMP pool of numba's parallel loops sleeps when idle."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from support.paths import ROOT

from core.library_threads import IDLE_SPIN, WAIT_POLICY


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


# A caller that idles 2 ms after each of 100 small parallel loops (core's own: the winding numbers
# of `ClosedBSpline.contains`, read from numba's cache): the CPU time of the process over its wall
# time, printed with the wait policy libgomp read.  It then ends at once: an "active" pool spins on
# through the interpreter's shutdown.
IDLE_CALLER = """
import os, time, core, numpy as np
from core.curves import examples
from core.curves.closest_point import winding_numbers

pieces = core.ClosedBSpline(examples.blob()).piecewise_polynomial()
points = np.zeros((16, 2))
winding_numbers(pieces, points)
start, cpu = time.perf_counter(), time.process_time()
for _ in range(100):
    winding_numbers(pieces, points)
    time.sleep(0.002)
share = (time.process_time() - cpu) / (time.perf_counter() - start)
print(os.environ.get("OMP_WAIT_POLICY", "unset"), share, flush=True)
os._exit(0)
"""


def idle_share(environment: dict) -> tuple[str, float]:
    """(the wait policy, the process's CPU time over its wall time) of `IDLE_CALLER`."""
    result = subprocess.run(
        [sys.executable, "-c", IDLE_CALLER], capture_output=True, text=True, env=environment, cwd=ROOT
    )
    assert result.returncode == 0, result.stderr
    policy, share = result.stdout.split()
    return policy, float(share)


def test_the_pools_threads_sleep_between_loops_unless_the_user_says_otherwise():
    environment = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    environment["NUMBA_NUM_THREADS"] = "2"
    policy, sleeping = idle_share(environment)
    # The user's own policy stays: "active" spins for ever, a core's worth while the caller sleeps.
    user_policy, spinning = idle_share({**environment, "OMP_WAIT_POLICY": "active"})
    assert sleeping < 0.2 and sleeping < spinning / 3, (sleeping, spinning)
    assert (policy, user_policy) == (WAIT_POLICY, "active") == ("passive", "active")
