"""The solver's first-run compilation: honest progress, one specialisation per function."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from support.paths import ROOT

pytestmark = pytest.mark.slow

# Compiles (or loads) the solver, then runs what users run: both output modes, a
# near point, quadrature refinement (unshifted power 8), an explicit and a
# three-point kernel.  All of it must go through the one specialisation made by
# compile_solver; numba loads cached callees inside their callers, so the counts
# are only meaningful on a cold cache.
_CHILD = """
import json, warnings
import numpy as np
from numba.core.registry import CPUDispatcher
import core
from core.curves import examples
from core.newton.compilation import SOLVER_MODULES

warnings.simplefilter("ignore")
fractions = []
compiled = core.compile_solver(fractions.append)
blob = core.ClosedBSpline(examples.blob())
centre = blob.control_points.mean(axis=0)
x = np.array([centre, 0.999 * blob.sample(100).points[0] + 0.001 * centre])
core.basis_functions(blob, x)
core.basis_functions(blob, x, "power", power=8.0)
core.kernel(blob.sample(20), x, "mean-value")
square = core.ClosedBSpline(np.repeat([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], 2, axis=0))
core.basis_functions(square, [[0.3, 0.6]], "wachspress")
signatures = {
    n: len(f.signatures)
    for module in SOLVER_MODULES
    for n, f in vars(module).items()
    if isinstance(f, CPUDispatcher) and f.py_func.__module__ == module.__name__
    and f.targetoptions.get("inline") != "always"  # compiled inside its callers
}
print(json.dumps({"compiled": compiled, "fractions": fractions, "signatures": signatures}))
"""


def _run_child(cache: Path) -> dict:
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    result = subprocess.run(
        [sys.executable, "-c", _CHILD], capture_output=True, text=True, env=environment, cwd=ROOT, check=True
    )
    return json.loads(result.stdout.splitlines()[-1])


def test_a_cold_cache_compiles_once_with_progress_and_the_next_run_loads_it(tmp_path):
    from core.newton.compilation import solver_weights

    cold = _run_child(tmp_path)
    fractions = cold["fractions"]
    assert cold["compiled"] and fractions[0] == 0.0 and fractions[-1] == 1.0
    assert np.all(np.diff(fractions) >= 0.0) and len(fractions) > 10  # it moves, never a frozen 0 %
    assert cold["signatures"] == dict.fromkeys(solver_weights(), 1)
    warm = _run_child(tmp_path)
    assert not warm["compiled"] and warm["fractions"] == []


def test_once_loaded_in_a_process_compile_solver_returns_at_once(monkeypatch):
    # mesh_basis_functions calls it before every solve: a second call must neither read the
    # solver's source for progress weights nor run a trial solve.
    from core.newton import compilation

    compilation.compile_solver()

    def forbidden(*args, **kwargs):
        raise AssertionError("compile_solver did work although the solver is loaded")

    monkeypatch.setattr(compilation, "solver_weights", forbidden)
    monkeypatch.setattr("core.basis.basis_functions", forbidden)
    fractions = []
    assert compilation.compile_solver(fractions.append) is False
    assert fractions == []


def test_without_a_writable_cache_folder_the_solver_compiles_uncached_with_one_note(tmp_path):
    # A copy of the package whose __pycache__ folders cannot be made (a file is in the way), with
    # NUMBA_CACHE_DIR and the home folder where no folder can be created either: numba has no
    # cache locator for it (`cannot cache function '_slab': no locator available`).
    shutil.copytree(ROOT / "core", tmp_path / "core", ignore=shutil.ignore_patterns("__pycache__"))
    for package in (tmp_path / "core").rglob("__init__.py"):
        (package.parent / "__pycache__").write_text("")
    blocked = str(tmp_path / "core" / "__pycache__" / "numba")  # under a file: never creatable
    environment = dict(
        os.environ, PYTHONPATH=str(tmp_path), NUMBA_CACHE_DIR=blocked, XDG_CACHE_HOME=blocked, HOME=blocked
    )
    child = (
        "import numpy as np, core\n"
        "from core.curves.crossing_slabs import crossing_slabs\n"
        "print(crossing_slabs(np.array([0.0, 1.0, 1.0, 0.0]))[0].tolist())\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", child], capture_output=True, text=True, env=environment, cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["[0,", "4]"]  # compiled and ran, uncached
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("note: numba cannot write its cache"), result.stderr


# Two compiled functions in two modules of a copy of `core`, the caller's machine code carrying the
# callee's: the same cache locator and stamp (`core.jit_cache`) as every compiled function of the
# package (`core.curves.closest_point._distances` calling `closest_parameter`, say), compiled in a
# fraction of a second instead of the seconds those take.
_CALLEE = "from numba import njit\n\n\n@njit(cache=True)\ndef step(x):\n    return x + 1.0\n"
_CALLER = (
    "from numba import njit\n\nfrom core.probe_callee import step\n\n\n"
    "@njit(cache=True)\ndef twice(x):\n    return step(step(x))\n"
)


def test_an_edit_of_a_callee_module_recompiles_its_callers_in_other_modules(tmp_path):
    # probe_caller.twice calls probe_callee.step and carries its machine code: numba alone would
    # check only probe_caller.py and keep running the old callee.
    shutil.copytree(ROOT / "core", tmp_path / "core", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "core" / "probe_callee.py").write_text(_CALLEE)
    (tmp_path / "core" / "probe_caller.py").write_text(_CALLER)
    environment = dict(os.environ, PYTHONPATH=str(tmp_path), NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    child = (
        "from core.probe_caller import twice\n"
        "print(twice(0.0), twice.stats.cache_hits.total(), twice.stats.cache_misses.total())\n"
    )

    def value_hits_and_misses() -> list[float]:
        result = subprocess.run(
            [sys.executable, "-c", child], capture_output=True, text=True, env=environment, cwd=tmp_path
        )
        assert result.returncode == 0, result.stderr
        return [float(word) for word in result.stdout.split()]

    assert value_hits_and_misses() == [2.0, 0, 1]  # compiled
    assert value_hits_and_misses() == [2.0, 1, 0]  # loaded
    callee = tmp_path / "core" / "probe_callee.py"
    callee.write_text(callee.read_text().replace("x + 1.0", "x + 2.0"))
    assert value_hits_and_misses() == [4.0, 0, 1]  # compiled again, although probe_caller.py is unchanged


def test_the_cache_stamp_covers_the_modules_compiled_code_reads_constants_from(tmp_path, monkeypatch):
    # compiled_integrals freezes the Gauss nodes of gauss_legendre (ORDER of them) into its machine
    # code: an edit of gauss_legendre.py must change the stamp, or a warm cache runs with the old
    # ORDER past the ends of the new arrays. A module no compiled code imports (the panels, the
    # disk cache of G) must not.
    from core import jit_cache

    copy = tmp_path / "core"
    source = Path(jit_cache.__file__).resolve().parent
    shutil.copytree(source, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(jit_cache, "_FOLDER", copy)
    changed = {}
    stamped = {
        "boundary_integrals/gauss_legendre.py",
        "boundary_integrals/compiled_integrals.py",
        "curves/bspline.py",
    }
    unstamped = ("boundary_integrals/panels.py", "storage/cache.py", "storage/atomic_write.py")
    for name in (*sorted(stamped), *unstamped):
        jit_cache.package_stamp.cache_clear()
        before = jit_cache.package_stamp()
        with open(copy / name, "a") as stream:
            stream.write("\n# edited\n")
        jit_cache.package_stamp.cache_clear()
        changed[name] = jit_cache.package_stamp() != before
    jit_cache.package_stamp.cache_clear()
    assert changed == {name: name in stamped for name in changed}


def test_a_function_that_cannot_be_cached_gets_numbas_warning_not_an_error():
    # numba warns "Cannot cache compiled function ... as it uses dynamic globals" (ctypes
    # pointers, large global arrays: at NUMBA_OPT=0 a compile of the boundary integrals met one)
    # with the file its cache locator names: without it, the compilation failed.
    from types import SimpleNamespace

    from numba.core.errors import NumbaWarning

    from core.curves.crossing_slabs import inside_polygon

    result = SimpleNamespace(
        lifted=(),
        library=SimpleNamespace(has_dynamic_globals=True),
        fndesc=SimpleNamespace(qualname="inside_polygon"),
    )
    with pytest.warns(NumbaWarning, match="Cannot cache compiled function .inside_polygon."):
        assert inside_polygon._cache._impl.check_cachable(result) is False
