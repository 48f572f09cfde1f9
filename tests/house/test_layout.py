"""The layout rules of the project: core/ is pure numerics, GLSL lives in shaders/, the imports
within app/ run one way, and the wheel ships every package and the bundled folders."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib
from support.imports import find_cycle, import_graph  # noqa: F401
from support.paths import ROOT

FORBIDDEN = ("app", "moderngl", "glfw", "imgui_bundle", "OpenGL")


def test_core_imports_no_gui_or_gl_module():
    offenders = []
    for path in sorted((ROOT / "core").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            offenders += [
                f"{path.relative_to(ROOT)}: {name}" for name in names if name.split(".")[0] in FORBIDDEN
            ]
    assert offenders == []


def test_importing_core_loads_no_gui_or_gl_module():
    # Every name of `core`, each imported at its first use (`core.__getattr__`).
    code = (
        "import sys, core; [getattr(core, name) for name in core.__all__]; "
        f"print(sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r}))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    assert result.stdout.strip() == "[]"


def test_the_geometry_of_framing_and_editing_loads_no_gl_module():
    # The viewer's document, editing and framing are plain geometry (app.render.viewport):
    # testable without GL.
    modules = (
        "app.warp.framing, app.viewer.state, app.viewer.editing, app.viewer.controller, app.viewer.documents"
    )
    loaded = f"sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN[1:]!r})"
    code = f"import sys, {modules}; print({loaded})"
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    assert result.stdout.strip() == "[]"


def test_top_level_holds_only_the_agreed_entries():
    allowed = {"pyproject.toml", "app", "core", "shaders", "assets", "tests", "README.md"}
    tracked = subprocess.run(["git", "ls-files"], capture_output=True, text=True, cwd=ROOT, check=True)
    top = {line.split("/")[0] for line in tracked.stdout.splitlines()}
    assert {entry for entry in top if not entry.startswith(".")} <= allowed


@pytest.mark.slow
def test_find_cycle_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) == []


def test_imports_within_app_have_no_cycle():
    assert find_cycle(import_graph("app")) == []


def test_only_the_entry_point_imports_the_command_line():
    # __main__ -> cli -> commands -> core: a command that needs a helper of the command line
    # takes it from app.console (or app.io.files), never from app.commands.cli.
    importers = sorted(
        name for name, imported in import_graph("app").items() if "app.commands.cli" in imported
    )
    assert importers == ["app.__main__"]


def test_the_wheel_lists_every_package_and_the_bundled_folders():
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = {
        ".".join(path.parent.relative_to(ROOT).parts)
        for top in ("app", "core")
        for path in (ROOT / top).rglob("__init__.py")
    }
    assert packages <= set(setuptools["packages"])
    assert setuptools["package-dir"] == {"app.data.shaders": "shaders", "app.data.assets": "assets"}
    for package, folder in setuptools["package-dir"].items():
        shipped = {
            path.name
            for pattern in setuptools["package-data"][package]
            for path in (ROOT / folder).glob(pattern)
        }
        tracked = subprocess.run(
            ["git", "ls-files", folder], capture_output=True, text=True, cwd=ROOT, check=True
        ).stdout.split()
        assert shipped == {Path(name).name for name in tracked}, f"every file of {folder}/ is shipped"


def test_the_wheel_ships_numbas_cache_of_every_package_with_compiled_functions():
    # .packaging/backend.py compiles core into the __pycache__ beside each compiled module; the
    # wheel carries those files only for the packages that pyproject.toml lists.
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    compiled = {
        ".".join(path.parent.relative_to(ROOT).parts)
        for path in (ROOT / "core").rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.ImportFrom)
        and node.module == "numba"
        and "njit" in {a.name for a in node.names}
    }
    shipped = {package for package, patterns in package_data.items() if "__pycache__/*.nbi" in patterns}
    assert compiled and compiled == shipped
    assert all("__pycache__/*.nbc" in package_data[package] for package in shipped)


def test_documents_cited_in_the_project_are_in_the_repository():
    tracked = subprocess.run(["git", "ls-files"], capture_output=True, text=True, cwd=ROOT, check=True)
    cited, outside = set(), []
    for name in tracked.stdout.splitlines():
        path = ROOT / name
        if path.suffix not in (".py", ".md", ".toml", ".glsl") or path == Path(__file__).resolve():
            continue
        text = path.read_text()
        outside += [name for marker in ("DESIGN.md", "../shared") if marker in text]
        cited |= set(re.findall(r"\.docs/[\w./-]+\.md", text))
    assert outside == []
    assert cited and all((ROOT / document).is_file() for document in cited), cited
