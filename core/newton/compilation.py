"""The first-run compilation of `core.newton.solver`, with progress (`core.compile_solver`).

numba compiles the solver to machine code on its first use and keeps the result
in its on-disk cache: ``__pycache__`` beside the sources, or, where that is not
writable (a read-only install), numba's user-wide cache under
``$XDG_CACHE_HOME/numba`` (``~/.cache/numba``); ``NUMBA_CACHE_DIR`` overrides
both.  Later runs load it in a fraction of a second.  The first compilation
takes tens of seconds of one core, so callers run it up front, through this
module, to say what is happening and how far it has got instead of leaving a
progress bar at 0 %.

Progress is the share of the solver's source lines whose functions numba has
finished compiling (each function of `core.newton.solver` is compiled once, with its
callees first; the work per function grows with its length).
"""

from __future__ import annotations

import inspect
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numba.core import event
from numba.core.registry import CPUDispatcher

from core.curves import arc_length_compiled, closest_parameter, crossing_slabs
from core.newton import (
    gradient_solver,
    kernel_weights,
    minimisation,
    output_rows,
    quadrature_nodes,
    solver,
    solver_state,
)

#: The modules compiled on first use, with progress: the solver, the parts it calls, and its
#: inside test.
SOLVER_MODULES = (
    solver, solver_state, quadrature_nodes, kernel_weights, minimisation, output_rows,
    arc_length_compiled, closest_parameter, crossing_slabs,
)  # fmt: skip
#: Compiled on the first use of gradients (`core.basis_gradients`), after the solver.
GRADIENT_MODULES = (gradient_solver,)

#: Seconds of a cold compilation on a 2-core machine (README, "First run"): what callers announce.
SOLVER_SECONDS = 15
GRADIENT_SECONDS = 8
#: What waiting callers show.
MESSAGE = f"compiling the solver (first use, ~{SOLVER_SECONDS} s)"
GRADIENT_MESSAGE = f"compiling the gradient solver (first use, ~{GRADIENT_SECONDS} s)"
GRADIENTS_MESSAGE = (
    f"compiling the solver and its gradients (first use, ~{SOLVER_SECONDS + GRADIENT_SECONDS} s)"
)
# Set once the solver (the gradient solver) is compiled or loaded in this process: later
# calls cost nothing (reading the solver's source for the progress weights took tens of
# milliseconds a call).
_loaded = threading.Event()
_gradients_loaded = threading.Event()


def compile_solver(progress: Callable[[float], None] | None = None, gradients: bool = False) -> bool:
    """Compile the solver, or load it from numba's cache, before the first solve.

    One small basis-function evaluation of a Newton kernel in the arc-length
    parameterisation types every function of `core.newton.solver` (the default kernel,
    ``poisson``, is not compiled, so it names one): the kernel, the output mode and the
    parameterisation are run-time values, so every kernel of `core.KERNELS`,
    `core.kernel` and `core.basis_functions` share the one specialisation it
    compiles.

    Parameters
    ----------
    progress : callable, optional
        Called with the fraction compiled in [0, 1], first with 0 when a real
        compilation starts, last with 1; never called when every function comes
        from the cache.
    gradients : bool
        Also the gradient solver (`core.newton.gradient_solver`, the first use of
        `core.basis_gradients`), in the same progress.

    Returns
    -------
    bool
        True if anything was compiled (a first run), False if all came from the
        cache, or at once if it is already loaded in this process.
    """
    gradients = gradients and not _gradients_loaded.is_set()
    if _loaded.is_set() and not gradients:
        return False
    from core.basis import basis_functions
    from core.curves.bspline import ClosedBSpline
    from core.gradients import basis_gradients

    modules = (() if _loaded.is_set() else SOLVER_MODULES) + (GRADIENT_MODULES if gradients else ())
    listener = _Progress(progress, modules)
    square = ClosedBSpline(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    x = np.array([[0.5, 0.5]])
    with event.install_listener("numba:compile", listener):
        if not _loaded.is_set():
            basis_functions(
                square, x, "maximum-likelihood", samples_per_segment=4, parameterization="arc-length"
            )
            _loaded.set()
        if gradients:
            basis_gradients(square, x, "maximum-likelihood", samples_per_segment=4)
            _gradients_loaded.set()
    if listener.compiled and progress is not None:
        progress(1.0)
    return listener.compiled


def compile_all() -> None:
    """Compile every compiled function of `core` into numba's disk cache: the boundary integrals
    and the curve tests (`compile_integrals`) and the mesher (`compile_mesher`) in a child
    process, and meanwhile the solver with its gradients (`compile_solver`) and the positive
    Gordon-Wixom rows (`compile_pgw`) in this one.

    The package's build runs it (``.packaging/backend.py``), so that an installed
    package starts every kernel from the cache.  The two halves share no compiled function's
    work that matters (a few small curve tests, which either writes to the cache whole) and cost
    ~35 s of one core each (66-73 CPU-s in all), so on two cores they take about half the time.

    Raises
    ------
    RuntimeError
        If the child process fails (its error is on stderr, which it shares).
    """
    package_root = str(Path(__file__).resolve().parents[2])
    environment = dict(os.environ)
    environment["PYTHONPATH"] = os.pathsep.join(filter(None, [package_root, environment.get("PYTHONPATH")]))
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from core.newton import compilation; "
            "compilation.compile_integrals(); compilation.compile_mesher()",
        ],
        env=environment,
    )
    try:
        compile_solver(gradients=True)
        compile_pgw()
    finally:
        returned = child.wait()
    if returned != 0:
        raise RuntimeError(f"compiling the boundary integrals and the mesher failed (exit status {returned})")


def compile_integrals() -> None:
    """Compile (or load) the closest-point and winding-number tests (`core.curves.closest_point`)
    and the boundary integrals of the default kernel (`core.boundary_integrals.compiled_integrals`)."""
    from core.boundary_integrals import compiled_integrals
    from core.boundary_integrals.panels import curve_panels
    from core.boundary_integrals.poisson import exercise_near_field, poisson_basis, solved_densities
    from core.curves.closest_point import distance_to_curve

    square = _square()
    x = np.array([[0.5, 0.5]])
    square.contains(x)
    distance_to_curve(square.piecewise_polynomial(), x)
    mode, compiled_integrals.mode = compiled_integrals.mode, "compiled"
    try:
        solved_densities.cache_clear()  # the density solve runs the knot blocks: not from the cache
        poisson_basis(square, x)
        exercise_near_field(square, curve_panels(square))
    finally:
        compiled_integrals.mode = mode


def compile_pgw() -> None:
    """Compile (or load) the positive Gordon-Wixom rows (`core.meshes.pgw`)."""
    from core.meshes.pgw import pgw_basis

    pgw_basis(_square(), np.array([[0.5, 0.5]]))


def compile_mesher() -> None:
    """Compile (or load) the mesher's loops (`core.meshes.delaunay`, `band_regions`, `point_grid`
    and the rest: one `core.triangulate` of the starfish, whose arms make every part run)."""
    from core.curves import examples
    from core.curves.bspline import ClosedBSpline
    from core.meshes.triangulation import triangulate

    triangulate(ClosedBSpline(examples.starfish()))


def _square():
    """The unit square as a cage of 4 control points (a ClosedBSpline)."""
    from core.curves.bspline import ClosedBSpline

    return ClosedBSpline(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))


def solver_weights(modules: tuple = SOLVER_MODULES, qualified: bool = False) -> dict[str, int]:
    """Source lines of every separately compiled function of `modules`, by name
    (``module.name`` if `qualified`: the gradient solver reuses some of the solver's names).

    A function that numba inlines (``inline="always"``) is compiled as part of its
    callers and reports no compilation of its own: its lines count for the functions
    that call it.
    """
    functions = {
        f"{module.__name__}.{name}" if qualified else name: function
        for module in modules
        for name, function in vars(module).items()
        if isinstance(function, CPUDispatcher) and function.py_func.__module__ == module.__name__
    }
    sources = {name: inspect.getsource(function.py_func) for name, function in functions.items()}
    inlined = {name for name, f in functions.items() if f.targetoptions.get("inline") == "always"}
    weights = {name: source.count("\n") for name, source in sources.items() if name not in inlined}
    for name in inlined:
        call = f"{functions[name].py_func.__name__}("
        callers = [caller for caller in weights if call in sources[caller]]
        for caller in callers:
            weights[caller] += sources[name].count("\n") // len(callers)
    return weights


class _Progress(event.Listener):
    """Turns numba's compile events for `modules` into a compiled fraction."""

    def __init__(self, progress: Callable[[float], None] | None, modules: tuple):
        self.progress = progress
        self.modules = {module.__name__ for module in modules}
        self.weights = solver_weights(modules, qualified=True) if modules else {}
        self.total = sum(self.weights.values())
        self.done = 0
        self.compiled = False
        self.thread = threading.get_ident()

    def _name(self, data) -> str | None:
        function = data["dispatcher"].py_func
        if function.__module__ not in self.modules or threading.get_ident() != self.thread:
            return None  # another module's function, or another thread's compilation
        return f"{function.__module__}.{function.__name__}"

    def on_start(self, ev: event.Event) -> None:
        if self._name(ev.data) is not None and not self.compiled:
            self.compiled = True
            if self.progress is not None:
                self.progress(0.0)

    def on_end(self, ev: event.Event) -> None:
        name = self._name(ev.data)
        if name is not None:
            self.done += self.weights.get(name, 0)
            if self.progress is not None:
                self.progress(min(self.done / self.total, 1.0))
