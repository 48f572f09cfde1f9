"""The house's second step (issue 49): `app` in rooms (at most 12 modules at its top level),
`app` through `core`'s front door only (`from core import X`, never `core.x.y`), and tests that
mirror the code (`tests/<core|app>/<package>/test_<module>.py` beside a module of that name,
unique basenames, the long files marked `slow`).  Each rule is checked on a bad case first."""

from __future__ import annotations

import ast
from pathlib import Path

import tomllib
from support.paths import ROOT

import core

MAX_APP_TOP_MODULES = 12
#: Test files that test a flow across modules rather than one module, each with its reason.
ACROSS_MODULES = {
    "tests/app/commands/test_bad_inputs.py": "bad input at every command",
    "tests/app/commands/test_parameterization.py": "the boundary parameterization through every command",
    "tests/app/bench/test_bench.py": "the bench's rows, from app.bench.table and its row modules",
    "tests/app/io/images/test_images.py": "the photograph package app.io.images as a whole",
    "tests/app/viewer/test_window.py": "the viewer's real window under Xvfb",
    "tests/app/viewer/test_window_fold_free.py": "the window in fold-free mode",
    "tests/app/viewer/test_window_daily.py": "the window as a daily tool: layout, undo, frames, SVG cages",
    "tests/app/viewer/test_window_pins.py": "the window's pin tool: pins added, dragged, undone, removed",
}
#: Where a file's tests are slow (a real window, the bench, compiling from a cold cache, a wheel).
SLOW = [
    "tests/app/viewer/test_window.py",
    "tests/app/viewer/test_window_fit.py",
    "tests/app/viewer/test_window_fold_free.py",
    "tests/app/viewer/test_window_daily.py",
    "tests/app/viewer/test_window_pins.py",
    "tests/app/bench/test_bench.py",
    "tests/core/newton/test_compilation.py",
    "tests/packaging/test_wheel.py",
    "tests/packaging/test_sdist.py",
]


def top_level_modules(folder: Path) -> list[str]:
    """The modules at the top of a package folder (packages not counted)."""
    return sorted(path.name for path in folder.glob("*.py"))


def deep_core_imports(source: str) -> list[str]:
    """The modules below `core` that `source` imports (function-level imports included)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("core."):
            found.append(node.module)
        elif isinstance(node, ast.Import):
            found += [alias.name for alias in node.names if alias.name.startswith("core.")]
    return found


def unmirrored(test_files: list[str], modules: set[str]) -> list[str]:
    """Test files `tests/<top>/<folders>/test_<name>.py` with no module `<top>/<folders>/<name>.py`
    (nor a package `<top>/<folders>/<name>/`) among `modules` (paths relative to the root)."""
    missing = []
    for test in test_files:
        parts = Path(test).parts[1:]
        name = parts[-1].removeprefix("test_").removesuffix(".py")
        module = "/".join([*parts[:-1], name])
        if f"{module}.py" not in modules and f"{module}/__init__.py" not in modules:
            missing.append(test)
    return missing


def marked_slow(source: str) -> bool:
    """Whether a test module marks all its tests slow (``pytestmark = pytest.mark.slow``)."""
    return any(
        isinstance(node, ast.Assign)
        and any(isinstance(t, ast.Name) and t.id == "pytestmark" for t in node.targets)
        and "slow" in ast.unparse(node.value)
        for node in ast.parse(source).body
    )


def test_the_helpers_catch_bad_cases(tmp_path):
    for name in [f"m{k}.py" for k in range(13)]:
        (tmp_path / name).write_text("")
    assert len(top_level_modules(tmp_path)) == 13
    snippet = "import core\nfrom core import deform\ndef f():\n    from core.meshes.mesh import Mesh\n"
    assert sorted(deep_core_imports(snippet + "import core.curves.bspline\n")) == [
        "core.curves.bspline",
        "core.meshes.mesh",
    ]
    modules = {"app/warp/job.py", "app/io/images/__init__.py"}
    tests = ["tests/app/warp/test_job.py", "tests/app/io/test_images.py", "tests/app/warp/test_gone.py"]
    assert unmirrored(tests, modules) == ["tests/app/warp/test_gone.py"]
    assert marked_slow("import pytest\npytestmark = pytest.mark.slow\n")
    assert not marked_slow("import pytest\n@pytest.mark.slow\ndef test_x(): pass\n")


def test_app_has_at_most_12_modules_at_its_top():
    assert len(top_level_modules(ROOT / "app")) <= MAX_APP_TOP_MODULES, top_level_modules(ROOT / "app")


def test_app_imports_only_cores_front_door():
    offenders = {
        str(path.relative_to(ROOT)): deep
        for path in sorted((ROOT / "app").rglob("*.py"))
        if (deep := deep_core_imports(path.read_text()))
    }
    assert offenders == {}
    assert all(hasattr(core, name) for name in core.__all__)


def test_tests_mirror_the_code():
    tests = sorted(
        str(p.relative_to(ROOT)) for top in ("core", "app") for p in (ROOT / "tests" / top).rglob("test_*.py")
    )
    modules = {str(p.relative_to(ROOT)) for top in ("core", "app") for p in (ROOT / top).rglob("*.py")}
    assert set(ACROSS_MODULES) <= set(tests), "an exception names a test file that is gone"
    assert unmirrored([t for t in tests if t not in ACROSS_MODULES], modules) == []
    names = [p.name for p in (ROOT / "tests").rglob("test_*.py")]
    assert len(names) == len(set(names)), "test file names are unique across tests/"


def test_the_slow_marker_is_registered_and_marks_the_long_files():
    markers = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["markers"]
    assert any(marker.startswith("slow:") for marker in markers)
    assert [path for path in SLOW if not marked_slow((ROOT / path).read_text())] == []
