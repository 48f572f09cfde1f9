"""One BLAS thread for the boundary-integral kernels' many small matrix products.

`core.poisson` and `core.cauchy_green` spend their time in thousands of products of a
few hundred rows each.  OpenBLAS threads those, and on a machine whose cores are busy
(the viewer draws while its worker computes; other programs run) its threads wait for
each other: on the 2-core development machine under load, the default kernel's basis
at 10,000 mesh vertices took 4.8 s with two BLAS threads and 0.36 s with one, at
100,000 vertices 3.3-5.9 s against 1.0-1.3 s.  On a quiet machine one thread is as
fast.  The limit holds only while these functions run (threadpoolctl), so the rest
of a program keeps its BLAS threads.
"""

from __future__ import annotations

import functools

from threadpoolctl import ThreadpoolController


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
