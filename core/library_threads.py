"""The threads of the libraries core calls and of its own loops: one BLAS thread for the
boundary-integral kernels' many small matrix products; idle BLAS threads that sleep soon; the
compiled loops' shares on a pool of threads (`in_shares`).

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

core's own loops run on threads too, a strided share each (`in_shares`): each compiled loop
takes its share of the items (``first``, ``first + shares``, ...) and releases the GIL, and
Python threads run the shares side by side.  numba's parallel loops (``prange``) did the same
on its OpenMP pool, but their passes cost ~20 of the ~100 CPU-seconds of compiling `core` from a
cold cache (the boundary integrals' half: 43-51 CPU-s against 25-28 serial), and libgomp's idle
threads spun after every loop unless ``OMP_WAIT_POLICY`` said otherwise.  The pool's threads
here wait on a queue: an idle pool costs nothing.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from threadpoolctl import ThreadpoolController

#: log2 of the cycles OpenBLAS's idle threads spin before they sleep (its default: 28).
IDLE_SPIN = 20

os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", str(IDLE_SPIN))


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


def thread_count(items: int) -> int:
    """Threads for a loop over `items`: numba's thread count (`configured_threads`), at most one
    an item, at least one."""
    return max(1, min(configured_threads(), items))


def configured_threads() -> int:
    """numba's thread count, ``NUMBA_NUM_THREADS`` (the cores by default)."""
    import numba  # here: this module sets OpenBLAS's variable before numpy (numba's import) loads

    return numba.config.NUMBA_NUM_THREADS


def in_shares(loop: Callable, items: int, *arguments) -> None:
    """``loop(*arguments, first, shares)`` for every `first` below ``shares = thread_count(items)``,
    side by side: the calling thread runs the first share, `pool`'s threads the others.

    `loop` is a compiled function that releases the GIL (``nogil=True``) and takes its share of
    the items (those at first, first + shares, ..., or the first-th of `shares` equal runs),
    writing only their outputs.  Every share has ended when this returns, or raises the first
    share's error.
    """
    shares = thread_count(items)
    workers = pool(configured_threads() - 1) if shares > 1 else None
    others = [workers.submit(loop, *arguments, first, shares) for first in range(1, shares)]
    try:
        loop(*arguments, 0, shares)
    finally:
        for share in others:
            share.exception()  # waits: no share writes after a return
    for share in others:
        share.result()


@functools.cache
def pool(threads: int) -> ThreadPoolExecutor:
    """The worker threads of `in_shares`, one fewer than numba's thread count (the caller's thread
    takes a share too): made once per process, each thread at its first use."""
    return ThreadPoolExecutor(threads, thread_name_prefix="transfinite")


if hasattr(os, "register_at_fork"):
    # A forked child (the viewer's workers) has none of its parent's threads: new pools there.
    os.register_at_fork(after_in_child=pool.cache_clear)
