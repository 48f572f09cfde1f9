"""The address space left under a limit (``ulimit -v``, ``prlimit --as``), checked before the steps
that cannot fail cleanly for lack of it.

numpy and OpenCV report a failed allocation (`MemoryError`, the command line's
exit 1); the libraries below them do not: OpenBLAS spins or aborts when it cannot
map its buffers as a library loads, and llvmpipe, Mesa's software OpenGL, crashes
compiling shaders or says that libEGL is missing.  Under a limit, the program
therefore refuses to start below `MIN_ADDRESS_SPACE`, and the GL steps check their
estimated need first (`require_address_space`), so that lack of memory reads as
lack of memory, in one line.  Without a limit nothing is checked: the system's
own accounting then decides, and numpy reports it.

Only the standard library is imported here: `app.__main__` checks the limit
before anything large is loaded.
"""

from __future__ import annotations

import os
import resource

#: Address space below which the program does not start: its libraries (numpy, OpenCV, scipy,
#: numba, moderngl) take about 0.85 GiB, and OpenBLAS spins as it loads when it cannot map its
#: buffers (0.75 GiB).
MIN_ADDRESS_SPACE = 1 << 30
#: Address space an OpenGL context takes: llvmpipe, with a thread per CPU, took 0.37 to 0.55 GiB
#: on 2 CPUs, and crashed (SIGSEGV) compiling shaders when it did not find enough.
GL_CONTEXT_BYTES = (512 + 64 * (os.cpu_count() or 1)) << 20
#: Address space the renderer's programs take when llvmpipe compiles them (measured: 13 to 79 MiB).
PROGRAM_BYTES = 96 << 20
#: Address space per byte of an RGBA image given to the renderer (the texture, its mipmaps and a
#: premultiplied copy; measured ~3.3).
IMAGE_FACTOR = 4
#: Address space per output pixel of a render: the output (RGBA), its copies and its PNG encoding.
OUTPUT_FACTOR = 12


def address_space_limit() -> int | None:
    """The soft limit of the address space in bytes, or None if there is none."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def address_space_left() -> int | None:
    """Bytes of address space left under the limit now, or None without a limit."""
    limit = address_space_limit()
    if limit is None:
        return None
    with open("/proc/self/statm") as statm:
        mapped = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    return limit - mapped


def startup_problem() -> str | None:
    """Why the program cannot start under this address-space limit, or None."""
    limit = address_space_limit()
    if limit is not None and limit < MIN_ADDRESS_SPACE:
        return (
            f"out of memory: the address space is limited to {_gib(limit)} (ulimit -v); the program needs "
            f"at least {_gib(MIN_ADDRESS_SPACE)}"
        )
    return None


def require_address_space(needed: int, what: str) -> None:
    """Raise `MemoryError` if fewer than `needed` bytes of address space are left for `what`."""
    left = address_space_left()
    if left is not None and left < needed:
        raise MemoryError(
            f"{what} needs about {_gib(needed)} of address space, but the limit of "
            f"{_gib(address_space_limit())} (ulimit -v) leaves {_gib(max(left, 0))}"
        )


def render_bytes(image_size: tuple[int, int], output_size: tuple[int, int], tile: int) -> int:
    """Estimated address space for the renderer to hold an image (width, height) and draw an output
    (width, height) in tiles of at most `tile` pixels a side (multisampled: 20 bytes a pixel)."""
    tile = min(output_size[0], tile) * min(output_size[1], tile)
    return (
        IMAGE_FACTOR * 4 * image_size[0] * image_size[1]
        + 20 * tile
        + OUTPUT_FACTOR * output_size[0] * output_size[1]
    )


def _gib(size: int) -> str:
    return f"{size / 2**30:.2f} GiB"
