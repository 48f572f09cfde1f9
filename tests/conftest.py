"""Shared fixtures: example domains and deterministic interior points; the order of the test files."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

import core
from core.curves import examples

#: The test files that take longest, longest first (their wall time in one `.ci/run` on a shared
#: machine, with core compiled beforehand: 431 s down to 22 s, 16 min for all). `.ci/run` hands
#: whole files to its two workers in collection order (``--dist loadfile --no-loadscope-reorder``):
#: started first, the long files end with the short ones instead of one worker finishing a long
#: file alone. Files not named follow, in path order.
LONGEST_FIRST = (
    "test_viewer_window.py",
    "test_compilation.py",
    "test_layout.py",
    "test_fit.py",
    "test_poisson.py",
    "test_injectivity_certificate.py",
    "test_viewer_window_fit.py",
    "test_injectivity_composite.py",
    "test_cli.py",
    "test_viewer_fold_free.py",
    "test_viewer_precompute.py",
    "test_viewer_window_fold_free.py",
    "test_quality.py",
    "test_compiled_integrals.py",
    "test_bad_inputs.py",
    "test_animate.py",
    "test_parameterization_app.py",
    "test_bspline.py",
    "test_fill.py",
)


def pytest_collection_modifyitems(items: list) -> None:
    """Puts the files of `LONGEST_FIRST` first, in its order; tests keep their order within a file."""
    rank = {name: index for index, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def interior_points(curve: core.ClosedBSpline, count: int, seed: int, margin: float = 0.0) -> np.ndarray:
    """`count` uniformly random points inside `curve`, shape (count, 2), fixed seed.

    With margin > 0, only points farther than margin * diameter from the curve.
    """
    from core.curves.closest_point import distance_to_curve

    rng = np.random.default_rng(seed)
    low = curve.control_points.min(axis=0)
    high = curve.control_points.max(axis=0)
    found = []
    while sum(len(f) for f in found) < count:
        x = rng.uniform(low, high, size=(4 * count, 2))
        x = x[curve.contains(x)]
        if margin > 0:
            x = x[distance_to_curve(curve.piecewise_polynomial(), x) > margin * curve.diameter]
        found.append(x)
    return np.concatenate(found)[:count]


@pytest.fixture(scope="module")
def ctx():
    """A headless EGL OpenGL context; without EGL the tests using it fail, never skip."""
    from app.render import create_headless_context

    context = create_headless_context()
    yield context
    context.release()


@pytest.fixture
def renderer(ctx):
    """An `app.render.WarpRenderer` on the headless context, released afterwards."""
    from app.render import WarpRenderer

    with WarpRenderer(ctx) as instance:
        yield instance


@pytest.fixture(scope="session")
def blob() -> core.ClosedBSpline:
    """The non-convex 12-point domain (like the paper's Fig. 1)."""
    return core.ClosedBSpline(examples.blob())


@pytest.fixture(scope="session")
def starfish() -> core.ClosedBSpline:
    """A five-armed star: non-convex, with limbs."""
    return core.ClosedBSpline(examples.starfish())


@pytest.fixture(scope="session")
def ellipse() -> core.ClosedBSpline:
    """A convex domain."""
    return core.ClosedBSpline(examples.ellipse())


def pixel_blob(n: int = 10) -> np.ndarray:
    """A smooth cage about 360 px across in image coordinates (x right, y down), shape (n, 2)."""
    angle = 2 * np.pi * np.arange(n) / n
    radius = 150 * (1 + 0.2 * np.cos(3 * angle))
    return np.stack([300 + radius * np.cos(angle), 300 - radius * np.sin(angle)], axis=1)


def near_cusp(gap: float, turn_degrees: float, k: int = 3) -> np.ndarray:
    """`pixel_blob` with a point inserted `gap` px after point k, towards the cage's tangent
    at k turned by `turn_degrees`: a near-cusp.  From about 150 degrees the cage turns back
    over the two points and the curve crosses itself in a loop around their knot."""
    points = pixel_blob()
    tangent = points[k + 1] - points[k - 1]
    turn = np.radians(turn_degrees)
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    direction = rotation @ tangent / np.linalg.norm(tangent)
    return np.insert(points, k + 1, points[k] + gap * direction, axis=0)


def wavy_star(n: int = 15, arms: int = 5, depth: float = 0.5) -> np.ndarray:
    """Control points (n, 2) on r = 1 + depth cos(arms angle): a non-convex star."""
    angle = 2 * np.pi * np.arange(n) / n
    radius = 1.0 + depth * np.cos(arms * angle)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def l_polygon() -> np.ndarray:
    """An L-shaped polygon, every corner doubled (sharp corners), shape (12, 2)."""
    polygon = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
    return np.repeat(np.array(polygon, dtype=float), 2, axis=0)


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def declared_png(width: int, height: int) -> bytes:
    """A PNG header declaring width x height RGB pixels, and no pixel data (65 bytes)."""
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + _png_chunk(b"IDAT", zlib.compress(b""))
        + _png_chunk(b"IEND", b"")
    )


def blank_png(width: int, height: int, channels: int = 1) -> bytes:
    """A real, valid, all-zero PNG of width x height pixels: big in pixels, small in bytes."""
    colour = {1: 0, 3: 2, 4: 6}[channels]
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour, 0, 0, 0))
        + _png_chunk(b"IDAT", _zeros_zlib(height * (1 + width * channels)))  # filter byte 0 and 0s a row
        + _png_chunk(b"IEND", b"")
    )


def _zeros_zlib(count: int, block: int = 1 << 24) -> bytes:
    """A zlib stream of `count` zero bytes, deflating only one `block` of them: a full flush ends
    the blocks so far on a byte boundary with nothing referred back past it, so the deflated
    block repeats; Adler-32 of n zero bytes is (n mod 65521) << 16 | 1."""
    whole, rest = divmod(count, block)
    repeated = zlib.compressobj(1, zlib.DEFLATED, -15)
    piece = repeated.compress(bytes(block)) + repeated.flush(zlib.Z_FULL_FLUSH) if whole else b""
    last = zlib.compressobj(1, zlib.DEFLATED, -15)
    tail = last.compress(bytes(rest)) + last.flush()
    checksum = struct.pack(">I", (count % 65521) << 16 | 1)
    return b"\x78\x01" + piece * whole + tail + checksum
