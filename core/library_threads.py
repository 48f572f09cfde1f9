"""The threads of the libraries core calls: one BLAS thread for the boundary-integral kernels'
many small matrix products; idle BLAS and OpenMP threads that sleep soon.

`poisson` and `cauchy_green` spend their time in thousands of products of a
few hundred rows each.  OpenBLAS threads those, and on a machine whose cores are busy
(the viewer draws while its worker computes; other programs run) its threads wait for
each other: on the 2-core development machine under load, the default kernel's basis
at 10,000 mesh vertices took 4.8 s with two BLAS threads and 0.36 s with one, at
100,000 vertices 3.3-5.9 s against 1.0-1.3 s.  On a quiet machine one thread is as
fast.  The limit holds only while these functions run (threadpoolctl), so the rest
of a program keeps its BLAS threads.

OpenBLAS's worker threads also busy-wait after each threaded call, ~0.1 s by default,
before they sleep: on 2 cores they took a core from the numba threads of whatever ran
next (the default kernel's basis at 10,000 mesh vertices right after a finite-element
solve: 62 ms instead of 37).  ``OPENBLAS_THREAD_TIMEOUT``, read when OpenBLAS loads, lets them
spin 2^`IDLE_SPIN` cycles (~0.4 ms) instead: the finite-element solve keeps its speed
(0.057 s at 10,000 vertices, 1.27 s at 100,000, 6.4 s at 300,000, as before), the next
call its own.  Importing this module sets it, unless the user did; `core` imports it first,
before numpy, and it has no effect once numpy has loaded OpenBLAS.

numba runs the ``prange`` loops of `core` on its OpenMP thread pool (GNU libgomp, numba's
threading layer where TBB is not installed).  After each parallel loop libgomp's threads
busy-wait for the next one (~300,000 spins by default) before they sleep, the same theft as
OpenBLAS's, and the viewer runs its drawing, its precompute worker and its fold-free check
worker side by side.  A caller idling 2 ms after each of 100 small parallel loops kept 0.49-0.66
of a core busy with the pool's spinning; with ``OMP_WAIT_POLICY=passive`` (sleep at once) 0.02.
On the 2-core development machine under load, the tests of the kernels
(`tests/core/boundary_integrals/test_poisson.py`, `test_kernels.py`, `test_gradients.py`) took 35-37
CPU-seconds instead of 44-52. Importing this module sets `WAIT_POLICY`, unless the user set a
policy; numba starts its pool at the first parallel loop, after `core` is imported, and libgomp
reads the variable then.
"""

from __future__ import annotations

import functools
import os

from threadpoolctl import ThreadpoolController

#: log2 of the cycles OpenBLAS's idle threads spin before they sleep (its default: 28).
IDLE_SPIN = 20

os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", str(IDLE_SPIN))

#: libgomp's policy for the idle threads of numba's pool (its default: spin, then sleep).
WAIT_POLICY = "passive"

os.environ.setdefault("OMP_WAIT_POLICY", WAIT_POLICY)


def one_blas_thread(function):
    """Decorator: run `function` with BLAS limited to one thread."""

    @functools.wraps(function)
    def limited(*args, **kwargs):
        with _controller().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return limited


@functools.cache
def _controller() -> ThreadpoolController:
    """The process's thread pools, found once: finding them reads the list of loaded libraries,
    ~1.5 ms a call (threadpoolctl's `threadpool_limits` does it at every call). Made at the
    first call, after numpy and scipy have loaded their BLAS."""
    return ThreadpoolController()
