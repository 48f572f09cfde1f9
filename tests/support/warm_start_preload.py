"""What the warm server of `support.warm_start` loads once, at its import: every module of `core` and
of the app's packages that a viewer runs (the window, its precompute and check workers, the
renderer, files and warps), the libraries they load, and numba's machinery for compiled code (its
first cached function).  Nothing here starts a thread, opens a display or initialises OpenGL: the
viewers forked from it do that."""

import importlib
import pkgutil

import glfw  # noqa: F401  (imported, not initialised: each viewer initialises it on its display)
import imgui_bundle  # noqa: F401
import moderngl  # noqa: F401
import numpy as np

import app
import core

for package in (core, app):
    for module in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        if not module.name.startswith(("app.bench", "app.studies")):
            importlib.import_module(module.name)

from core.curves.crossing_slabs import crossing_slabs  # noqa: E402

crossing_slabs(np.array([0.0, 1.0, 1.0, 0.0]))  # numba's typing and lowering registries, loaded once
