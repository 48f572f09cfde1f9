"""Scratch arrays kept per thread between calls, for the dense solve's largest temporaries.

Memory fresh from the system costs a page fault a 4 KiB page, ~2.5 µs on the development
machine, and after another computation frees its arrays (the finite-element solve of the
bench's table) the C library gives their memory back: the next 2.5 MB array of the bench
blob's density solve took ~1 ms of faults, a tenth of the solve.  A kept array is faulted in
once.  Arrays over `KEPT` bytes are not kept (their solves are long enough not to mind).
"""

from __future__ import annotations

import threading

import numpy as np

#: Bytes at most a kept array holds.
KEPT = 8 << 20

_kept = threading.local()


def scratch(name: str, shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised float64 array of `shape`, this thread's array `name` (kept for its next
    call, which overwrites it: a caller keeps no reference past its own use), or a fresh one
    where it would hold over `KEPT` bytes."""
    count = int(np.prod(shape))
    if 8 * count > KEPT:
        return np.empty(shape)
    arrays = getattr(_kept, "arrays", None)
    if arrays is None:
        arrays = _kept.arrays = {}
    kept = arrays.get(name)
    if kept is None or kept.size < count:
        kept = arrays[name] = np.empty(count)
    return kept[:count].reshape(shape)
