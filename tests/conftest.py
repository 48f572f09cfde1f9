"""Shared fixtures: example domains and deterministic interior points; the order of the test files."""

from __future__ import annotations

import pytest

import core
from core.curves import examples

#: The viewer-window harness's `display` fixture (a private Xvfb server), for every window test.
pytest_plugins = ("support.viewer_harness",)

#: The test files that take longest, longest first (their wall time in one serial run of the suite,
#: core compiled beforehand, 2026-12-07: 60 s down to 4 s, 390 s for all). `.ci/run` hands whole
#: files to its three workers in collection order (``--dist loadfile --no-loadscope-reorder``):
#: started first, the long files end with the short ones instead of one worker finishing a long
#: file alone. Files not named follow, in path order.
LONGEST_FIRST = (
    "test_window.py",
    "test_bench.py",
    "test_subject.py",
    "test_window_daily.py",
    "test_cli.py",
    "test_poisson.py",
    "test_bad_inputs.py",
    "test_window_fold_free.py",
    "test_compiled_integrals.py",
    "test_certificate.py",
    "test_bspline.py",
    "test_compilation.py",
    "test_animation.py",
    "test_window_fit.py",
    "test_mesh_fold_free.py",
    "test_pipeline.py",
    "test_library_threads.py",
    "test_documents.py",
    "test_parameterization.py",
    "test_window_pins.py",
    "test_compositing.py",
)


def pytest_collection_modifyitems(items: list) -> None:
    """Puts the files of `LONGEST_FIRST` first, in its order; tests keep their order within a file."""
    rank = {name: index for index, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


@pytest.fixture(scope="module")
def ctx():
    """A headless EGL OpenGL context; without EGL the tests using it fail, never skip."""
    from app.render.renderer import create_headless_context

    context = create_headless_context()
    yield context
    context.release()


@pytest.fixture
def renderer(ctx):
    """An `app.render.renderer.WarpRenderer` on the headless context, released afterwards."""
    from app.render.renderer import WarpRenderer

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
