"""The layout rules of the project: core/ is pure numerics, GLSL lives in shaders/, and the
wheel ships every package and the bundled folders."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parent.parent
FORBIDDEN = ("app", "moderngl", "glfw", "imgui_bundle", "OpenGL")


def test_core_imports_no_gui_or_gl_module():
    offenders = []
    for path in sorted((ROOT / "core").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            offenders += [f"{path.name}: {name}" for name in names if name.split(".")[0] in FORBIDDEN]
    assert offenders == []


def test_importing_core_loads_no_gui_or_gl_module():
    code = f"import sys, core; print(sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r}))"
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    assert result.stdout.strip() == "[]"


def test_top_level_holds_only_the_agreed_entries():
    allowed = {"pyproject.toml", "app", "core", "shaders", "assets", "tests", "README.md"}
    tracked = subprocess.run(["git", "ls-files"], capture_output=True, text=True, cwd=ROOT, check=True)
    top = {line.split("/")[0] for line in tracked.stdout.splitlines()}
    assert {entry for entry in top if not entry.startswith(".")} <= allowed


def test_bench_runs(tmp_path):
    # A smoke test of `python -m app bench` at tiny sizes, so that the table never rots;
    # speed itself is measured by the bench, not by tests.
    result = subprocess.run(
        [sys.executable, "-m", "app", "bench", "--quick", "--repeats", "1", "--skip-memory", "--skip-warp"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    assert "harmonic-like" in result.stdout and "FEM / transfinite" in result.stdout


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
