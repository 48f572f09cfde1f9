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

# Loads (or, on a cold cache, compiles) the solver, then runs what users run: both output modes,
# a near point, quadrature refinement (unshifted power 8), an explicit and a three-point kernel,
# counting the solver's compilations meanwhile. Then each separately compiled function's entries
# in numba's cache index: the suite and `compile_all` share that cache, so one entry each means
# that no caller, here or in any test run before, ever needed a second specialisation (numba
# loads cached callees inside their callers: counting a warm process's signatures would say
# nothing).
_CHILD = """
import json, warnings
import numpy as np
from numba.core import event
import core
from core.curves import examples
from core.newton.compilation import SOLVER_MODULES, solver_weights

warnings.simplefilter("ignore")
names = {module.__name__ for module in SOLVER_MODULES}
fractions = []
compiled = core.compile_solver(fractions.append)
later = []
class Later(event.Listener):
    def on_start(self, ev):
        function = ev.data["dispatcher"].py_func
        if function.__module__ in names:
            later.append(function.__name__)
    def on_end(self, ev):
        pass
with event.install_listener("numba:compile", Later()):
    blob = core.ClosedBSpline(examples.blob())
    centre = blob.control_points.mean(axis=0)
    x = np.array([centre, 0.999 * blob.sample(100).points[0] + 0.001 * centre])
    core.basis_functions(blob, x)
    core.basis_functions(blob, x, "power", power=8.0)
    core.kernel(blob.sample(20), x, "mean-value")
    square = core.ClosedBSpline(np.repeat([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], 2, axis=0))
    core.basis_functions(square, [[0.3, 0.6]], "wachspress")
weights = solver_weights()
functions = {n: f for module in SOLVER_MODULES for n, f in vars(module).items() if n in weights}
cached = {n: len(f._cache._cache_file._load_index()) for n, f in functions.items()}
print(json.dumps({"compiled": compiled, "fractions": fractions, "later": later, "cached": cached}))
"""


def _run_child() -> dict:
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    result = subprocess.run(
        [sys.executable, "-c", _CHILD], capture_output=True, text=True, env=environment, cwd=ROOT, check=True
    )
    return json.loads(result.stdout.splitlines()[-1])


def test_users_calls_need_the_one_specialisation_compile_solver_makes_and_the_next_run_loads_it():
    from core.newton.compilation import solver_weights

    first = _run_child()
    assert first["later"] == []  # nothing compiled after compile_solver
    assert first["cached"] == dict.fromkeys(solver_weights(), 1)
    if first["compiled"]:  # a cold cache (a run without `compile_all` first): its progress
        fractions = first["fractions"]
        assert fractions[0] == 0.0 and fractions[-1] == 1.0 and np.all(np.diff(fractions) >= 0.0)
        assert len(fractions) > 10  # it moves, never a frozen 0 %
    again = _run_child()
    assert not again["compiled"] and again["fractions"] == [] and again["later"] == []


# A module of four compiled functions: `outer` calls `middle` twice and `inlined` (compiled inside
# its callers), `middle` calls `inner`; `other` is not called.
_PROBE = """from numba import njit


@njit(inline="always")
def inlined(x):
    y = x + 1.0
    return y


@njit
def inner(x):
    return x * 2.0


@njit
def middle(x):
    y = inner(x)
    return y + inner(y)


@njit
def outer(x):
    a = middle(x)
    b = middle(a)
    return inlined(a + b)


@njit
def other(x):
    return x
"""


def test_progress_is_the_share_of_source_lines_compiled_callees_first(tmp_path, monkeypatch):
    # The mechanism of compile_solver's progress (`_Progress`) on a cold compilation of a probe
    # module, where the real solver's would take ~25 s of a core.
    from numba.core import event

    from core.newton.compilation import _Progress, solver_weights

    (tmp_path / "progress_probe.py").write_text(_PROBE)
    monkeypatch.syspath_prepend(str(tmp_path))
    import progress_probe

    weights = solver_weights((progress_probe,))
    # Each function's source lines, its decorator's included; inlined's 4 count for outer.
    assert weights == {"inner": 3, "middle": 4, "outer": 5 + 4, "other": 3}
    fractions = []
    listener = _Progress(fractions.append, (progress_probe,))
    with event.install_listener("numba:compile", listener):
        assert progress_probe.outer(1.0) == 43.0  # middle(1) = 2 + 4, middle(6) = 12 + 24, + 1
    total = sum(weights.values())
    assert listener.compiled
    assert fractions == [0.0, 3 / total, 7 / total, 16 / total]  # started; inner, middle, outer done
    assert _Progress(fractions.append, (progress_probe,)).compiled is False


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
